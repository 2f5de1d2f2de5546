// SPDX-License-Identifier: Apache-2.0
// Optical depth (nebillum) against closed forms and brute force (DESIGN §2-3).
#include "nebula/physics/optical_depth.h"

#include "nebula/core/error.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

using namespace nebula;

namespace {

constexpr double KAPPA = 1.5e-3;

/// A cube lattice of edge @p n with lower corner @p lo, voxel size @p h [pc], filled by f.
template <typename F> SparseVolume makeVolume(int n, int lo, double h, F f)
{
    SparseVolume v({lo, lo, lo}, {n, n, n}, 1);
    v.indexToWorld.m = {h, 0, 0, 0, h, 0, 0, 0, h};
    for (int k = lo; k < lo + n; ++k)
        for (int j = lo; j < lo + n; ++j)
            for (int i = lo; i < lo + n; ++i)
                v.writable(v.index(i, j, k))[0] = float(f(i, j, k));
    return v;
}

double fieldAt(const SparseVolume& v, const std::vector<float>& field, int i, int j, int k)
{
    return field[v.index(i, j, k)];
}

/// Production tau (opticalDepthAt) at every lattice point.
std::vector<float> productionTau(const SparseVolume& v, const Vec3& star)
{
    std::vector<std::uint32_t> all(v.voxelCount());
    for (std::size_t i = 0; i < all.size(); ++i)
        all[i] = std::uint32_t(i);
    return opticalDepthAt(v, star, KAPPA, all);
}

/// Chord length from point s (inside) along unit u to the sphere |x| = R.
double chordToSphere(const Vec3& s, const Vec3& u, double R)
{
    const double b = s.dot(u);
    return -b + std::sqrt(b * b - s.dot(s) + R * R);
}

} // namespace

// Uniform sphere, star at the centre: inside the sphere (all cell corners inside) the
// trilinear density is exactly n0, so tau = kappa n0 r to rounding. Outside, tau is the
// radius times kappa n0, up to the one-voxel linear ramp of the trilinear edge.
TEST(OpticalDepth, UniformSphereStarAtCentre)
{
    const int n = 41, lo = -20;
    const double h = 0.1, R = 15.0, n0 = 1000.0; // R in voxels
    const auto vol = makeVolume(
        n, lo, h, [&](int i, int j, int k) { return i * i + j * j + k * k <= R * R ? n0 : 0.0; });
    const Vec3 star(0, 0, 0);
    const auto ref = productionTau(vol, star);
    int inside = 0, outside = 0;
    for (int k = lo; k < lo + n; ++k)
        for (int j = lo; j < lo + n; ++j)
            for (int i = lo; i < lo + n; ++i) {
                const double r = std::sqrt(double(i * i + j * j + k * k));
                const double tau = fieldAt(vol, ref, i, j, k);
                if (r <= R - 2.0) {
                    EXPECT_NEAR(tau, KAPPA * n0 * r * h, 1e-5 * KAPPA * n0 * R * h);
                    ++inside;
                } else if (r >= R + 2.0) {
                    EXPECT_NEAR(tau, KAPPA * n0 * R * h, KAPPA * n0 * 1.0 * h);
                    ++outside;
                }
            }
    EXPECT_GT(inside, 1000);
    EXPECT_GT(outside, 1000);
    // Along an axis the ramp from the last inside lattice point (15) to 16 adds half a voxel.
    EXPECT_NEAR(fieldAt(vol, ref, 19, 0, 0), KAPPA * n0 * 15.5 * h, 1e-6);
}

// Smooth sphere n = n0 (1 - r^2/R^2), star off-centre: the column along any chord has a
// closed form (integral of a quadratic in the path length); trilinear interpolation of a
// smooth field differs from it by O(h^2), here < 0.2 %.
TEST(OpticalDepth, SmoothSphereStarOffCentreChords)
{
    const int n = 61, lo = -30;
    const double h = 0.05, R = 26.0, n0 = 800.0;
    const auto vol = makeVolume(n, lo, h, [&](int i, int j, int k) {
        return std::max(0.0, n0 * (1.0 - (i * i + j * j + k * k) / (R * R)));
    });
    const Vec3 star(6.3, -4.1, 2.7);
    const auto ref = productionTau(vol, star);
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> pick(lo, lo + n - 1);
    int checked = 0;
    while (checked < 300) {
        const Vec3 x(pick(rng), pick(rng), pick(rng));
        const Vec3 d = x - star;
        const double len = d.length();
        if (len < 1.0) continue;
        const Vec3 u = d * (1.0 / len);
        // r^2(l) = |s|^2 + 2 l (s.u) + l^2 for l in [0, min(len, exit)].
        const double lEnd = std::min(len, chordToSphere(star, u, R));
        const double a = star.dot(star), b = star.dot(u);
        const double integral =
            lEnd - (a * lEnd + b * lEnd * lEnd + lEnd * lEnd * lEnd / 3) / (R * R);
        const double expected = KAPPA * n0 * integral * h;
        const double tau = fieldAt(vol, ref, int(x.x), int(x.y), int(x.z));
        EXPECT_NEAR(tau, expected, 2e-3 * expected + 1e-9)
            << "voxel " << x.x << "," << x.y << "," << x.z;
        ++checked;
    }
}

// Uniform slab of lattice planes k in [k0, k1]: the trilinear field depends on z only and is
// n0 on [k0, k1] with linear ramps over one voxel each side, so its effective thickness is
// (k1 - k0 + 1) voxels and a ray crossing it at angle theta to the normal has
// tau = kappa n0 (k1 - k0 + 1) h / cos(theta), exactly. The transform is anisotropic,
// rotated and mirrored to check world lengths.
TEST(OpticalDepth, UniformSlabObliqueRaysAnyAffine)
{
    const int nx = 64, nz = 24;
    const double n0 = 500.0;
    const int k0 = 9, k1 = 13;
    SparseVolume vol({0, 0, 0}, {nx, nx, nz}, 1);
    for (int k = k0; k <= k1; ++k)
        for (int j = 0; j < nx; ++j)
            for (int i = 0; i < nx; ++i)
                vol.writable(vol.index(i, j, k))[0] = float(n0);
    // World = R * diag(0.2, 0.2, 0.5) * index, with R a rotation about y plus a mirror in x.
    const double c = std::cos(0.7), s = std::sin(0.7);
    const double sx = 0.2, sz = 0.5;
    vol.indexToWorld.m = {-c * sx, 0, s * sz, 0, sx, 0, s * sx, 0, c * sz};
    vol.indexToWorld.t = Vec3(3, -2, 1);
    const Vec3 star(31.5, 30.2, 2.0); // index space, below the slab
    const auto ref = productionTau(vol, star);
    const Affine& M = vol.indexToWorld;
    for (int k = 20; k < nz; ++k)
        for (int j = 20; j < 44; j += 3)
            for (int i = 20; i < 44; i += 3) {
                const Vec3 d = Vec3(i, j, k) - star;
                // Index z-thickness (k1-k0+1) scaled along the ray: the fraction of the
                // segment inside the slab is thickness / dz; times its world length.
                const double worldLen = M.applyLinear(d).length();
                const double expected = KAPPA * n0 * worldLen * (k1 - k0 + 1) / d.z;
                EXPECT_NEAR(fieldAt(vol, ref, i, j, k), expected, 1e-5 * expected);
            }
}

// The exact integrator against brute-force fine-step midpoint integration on a random grid,
// for stars inside and outside the lattice.
TEST(OpticalDepth, ExactMatchesBruteForceOnRandomGrid)
{
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    // Random interior, zero border: the library always pads the lattice with zeros.
    const auto vol = makeVolume(12, -3, 0.3, [&](int i, int j, int k) {
        const bool border = i == -3 || j == -3 || k == -3 || i == 8 || j == 8 || k == 8;
        return border ? 0.0 : 100.0 * U(rng);
    });
    const Vec3 stars[] = {Vec3(2.3, 1.7, 4.1), Vec3(-9.0, 14.2, 3.3)};
    for (const auto& star : stars) {
        for (int trial = 0; trial < 40; ++trial) {
            const Vec3 x(-3 + 11 * U(rng), -3 + 11 * U(rng), -3 + 11 * U(rng));
            const double exact = columnDensity(vol, star, x);
            const double reference = columnDensityReference(vol, star, x);
            const int steps = 20000;
            double brute = 0.0;
            for (int q = 0; q < steps; ++q) {
                brute += vol.sample0(star + (x - star) * ((q + 0.5) / steps));
            }
            brute *= vol.indexToWorld.applyLinear(x - star).length() / steps;
            EXPECT_NEAR(exact, brute, 2e-5 * brute + 1e-6);
            EXPECT_NEAR(reference, brute, 2e-5 * brute + 1e-6);
        }
    }
}

// The renderers integrate the density in place, as channel 0 of their multi-channel fields:
// the same column as on a one-channel copy, bit for bit, whatever the other channels hold.
TEST(OpticalDepth, ChannelZeroOfAnyVolumeIsIntegratedInPlace)
{
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    const auto one = makeVolume(14, -4, 0.25, [&](int i, int j, int k) {
        const bool border = i == -4 || j == -4 || k == -4 || i == 9 || j == 9 || k == 9;
        return border || U(rng) < 0.3 ? 0.0 : 50.0 * U(rng);
    });
    SparseVolume four(one.lo(), one.dims(), 4);
    four.indexToWorld = one.indexToWorld;
    for (std::size_t v = 0; v < one.voxelCount(); ++v) {
        four.writable(v)[0] = one.voxel(v)[0];
        for (int c = 1; c < 4; ++c)
            four.writable(v)[c] = float(1e3 * U(rng)); // never read
    }
    const ColumnIntegrator a(one), b(four);
    for (int trial = 0; trial < 200; ++trial) {
        const Vec3 p(-6 + 17 * U(rng), -6 + 17 * U(rng), -6 + 17 * U(rng));
        const Vec3 q(-6 + 17 * U(rng), -6 + 17 * U(rng), -6 + 17 * U(rng));
        EXPECT_EQ(a(p, q), b(p, q)) << trial;
        EXPECT_EQ(columnDensity(one, p, q), columnDensity(four, p, q)) << trial;
    }
}

// The empty-cell skipping sees every dusty cell: single voxels on the faces, edges and corners
// of the 8^3 bricks and on the lattice's own faces (a lattice not aligned to the bricks, only
// the bricks that hold them stored, the density in channel 0 of 3), each reached by segments
// that end in the cells round it. The cell walk matches the reference, which skips nothing.
TEST(OpticalDepth, EmptyCellSkippingSeesDustAtBrickAndLatticeFaces)
{
    SparseVolume vol({-5, -6, -7}, {23, 20, 21}, 3);
    vol.indexToWorld.m = {0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1};
    const std::vector<std::array<int, 3>> dust = {
        {7, 7, 7},    {8, 8, 8},  {0, 0, 0},  {-1, 7, 8}, {15, 0, -1},  // brick corners
        {7, 3, 4},    {3, 8, 2},  {2, 3, -7}, {-5, 2, 3}, {17, 13, 13}, // faces
        {-5, -6, -7}, {17, 13, 4}};                                     // lattice corners
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> U(-1.5, 1.5);
    for (const auto& d : dust) {
        ASSERT_TRUE(vol.contains(d[0], d[1], d[2]));
        float* v = vol.writable(vol.index(d[0], d[1], d[2]));
        v[0] = 800.0f;
        v[1] = v[2] = 5.0f; // other channels: never read
    }
    ASSERT_LT(vol.storedBricks(), 20u);
    // The bits against their definition, cell by cell (cells: lower corners lo .. lo + dims - 2).
    const VoxelBits dusty = dustyCells(vol);
    std::size_t set = 0;
    for (int k = -7; k < -7 + 21 - 1; ++k)
        for (int j = -6; j < -6 + 20 - 1; ++j)
            for (int i = -5; i < -5 + 23 - 1; ++i) {
                const float* q[8];
                vol.cellCorners(i, j, k, q);
                bool any = false;
                for (int c = 0; c < 8; ++c)
                    any = any || q[c][0] != 0.0f;
                ASSERT_EQ(dusty[vol.index(i, j, k)], any) << "cell " << i << "," << j << "," << k;
                set += any;
            }
    EXPECT_EQ(dusty.count(), set); // and no bit outside the lattice's cells
    EXPECT_GT(set, 40u);
    const ColumnIntegrator column(vol);
    int hits = 0;
    for (const auto& d : dust) {
        const Vec3 c(d[0], d[1], d[2]);
        for (int trial = 0; trial < 60; ++trial) {
            const Vec3 a = c + Vec3(U(rng), U(rng), U(rng)), b = c + Vec3(U(rng), U(rng), U(rng));
            const double ref = columnDensityReference(vol, a, b);
            ASSERT_NEAR(column(a, b), ref, 1e-5 * ref + 1e-9)
                << "voxel " << d[0] << "," << d[1] << "," << d[2] << " trial " << trial;
            hits += ref > 1.0;
        }
    }
    EXPECT_GT(hits, 300); // most segments cross the dust
    // A segment that leaves the lattice through the dusty voxel on its face: the field jumps
    // to zero there; both integrals agree with fine midpoint sums.
    const Vec3 a(2.5076, 3.0228, -8.1273), b(1.5218, 3.0013, -6.5460);
    const int steps = 400000;
    double brute = 0.0;
    for (int q = 0; q < steps; ++q)
        brute += vol.sample0(a + (b - a) * ((q + 0.5) / steps));
    brute *= vol.indexToWorld.applyLinear(b - a).length() / steps;
    EXPECT_NEAR(column(a, b), brute, 1e-4 * brute);
    EXPECT_NEAR(columnDensityReference(vol, a, b), brute, 1e-4 * brute);
}

// The production path (cell walk with empty-cell skipping) against the independent simple
// reference, on a random clumpy cloud with empty regions, for a star inside and one outside
// the lattice: the same exact integral, so they agree to float rounding.
TEST(OpticalDepth, ProductionMatchesReference)
{
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    const int n = 32;
    const auto vol = makeVolume(n, 0, 0.25, [&](int i, int j, int k) {
        const double r =
            std::sqrt((i - 16.0) * (i - 16.0) + (j - 16.0) * (j - 16.0) + (k - 16.0) * (k - 16.0));
        const double v = U(rng);
        return r < 14 && v > 0.4 ? 2000.0 * v : 0.0; // 40 % of the voxels empty
    });
    for (const Vec3 star : {Vec3(13.3, 17.6, 15.2), Vec3(-15.0, 8.0, 30.0)}) {
        const auto ref = opticalDepthReference(vol, star, KAPPA);
        const auto prod = productionTau(vol, star);
        double maxTau = 0.0;
        for (std::size_t q = 0; q < ref.size(); ++q) {
            maxTau = std::max(maxTau, double(ref[q]));
            ASSERT_NEAR(prod[q], ref[q], 1e-5 * ref[q] + 1e-7) << "lattice point " << q;
        }
        EXPECT_GT(maxTau, 3.0); // thick enough to matter
    }
}

// Same result whatever the thread count: each point is one independent ray.
TEST(OpticalDepth, DeterministicAcrossThreadCounts)
{
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    const auto vol = makeVolume(20, 0, 0.5, [&](int, int, int) { return 500.0 * U(rng); });
    const auto many = productionTau(vol, Vec3(9.5, 3.2, 11.1));
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const auto single = productionTau(vol, Vec3(9.5, 3.2, 11.1));
    EXPECT_EQ(many, single);
}

// Optical depths are never negative, even next to empty cells where Simpson's weights leave
// a rounding residue: the example nebula's shape at 64^3 and density 16000 once produced
// tau = -3e-33 at one voxel, which nebpyramid (rightly) refused to read.
TEST(OpticalDepth, NeverNegative)
{
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    SparseVolume n({0, 0, 0}, {20, 20, 20}, 1);
    n.indexToWorld.m = {0.156, 0, 0, 0, 0.156, 0, 0, 0, 0.156};
    std::vector<std::uint32_t> points;
    for (std::size_t i = 0; i < n.voxelCount(); ++i) {
        // Sparse, spiky, many decades: isolated dense voxels beside empty ones.
        n.writable(i)[0] = u(rng) < 0.3 ? float(std::pow(10.0, 6.0 * u(rng) - 1.0)) : 0.0f;
        points.push_back(std::uint32_t(i));
    }
    for (const Vec3 star : {Vec3(3.3, 17.1, 9.6), Vec3(-30, 4, 50), Vec3(10, 10, 10)}) {
        const auto tau = opticalDepthAt(n, star, 1.5e-3, points);
        for (float t : tau)
            ASSERT_GE(t, 0.0f);
    }
}

// Stars far outside the lattice (10 to 1e12 grid widths): only the chord inside the lattice is
// walked, so the cost does not grow with the distance, and the chord closed forms hold: through
// the uniform slab of UniformSlabObliqueRaysAnyAffine, tau = kappa n0 (k1 - k0 + 1) |M d| / d.z
// for a star below the slab, and exactly 0 for a star above it (an empty path).
TEST(OpticalDepth, FarStarsGiveTheChordClosedForms)
{
    const int nx = 64, nz = 24;
    const double n0 = 500.0, h = 0.2;
    const int k0 = 9, k1 = 13;
    SparseVolume vol({0, 0, 0}, {nx, nx, nz}, 1);
    for (int k = k0; k <= k1; ++k)
        for (int j = 0; j < nx; ++j)
            for (int i = 0; i < nx; ++i)
                vol.writable(vol.index(i, j, k))[0] = float(n0);
    vol.indexToWorld.m = {h, 0, 0, 0, h, 0, 0, 0, h};
    for (const double widths : {10.0, 1e3, 1e6, 1e12}) {
        const double D = widths * nx;
        // Below the slab, 0.3 sideways per unit down, so each ray crosses the slab inside the
        // lattice; and straight above it.
        const Vec3 below(31.5 + 0.3 * D, 30.2, -D), above(31.5, 30.2, nz + D);
        const auto tauBelow = productionTau(vol, below);
        const auto tauAbove = productionTau(vol, above);
        int checked = 0;
        for (int k = k1 + 2; k < nz; ++k)
            for (int j = 20; j < 44; j += 3)
                for (int i = 20; i < 44; i += 3) {
                    const Vec3 d = Vec3(i, j, k) - below;
                    const double expected = KAPPA * n0 * h * d.length() * (k1 - k0 + 1) / d.z;
                    EXPECT_NEAR(fieldAt(vol, tauBelow, i, j, k), expected, 1e-5 * expected)
                        << widths << " grid widths, voxel " << i << "," << j << "," << k;
                    EXPECT_EQ(fieldAt(vol, tauAbove, i, j, k), 0.0f);
                    ++checked;
                }
        EXPECT_GT(checked, 300);
    }
}

// At 1e20 grid widths (the index arithmetic of an unclipped walk overflowed here) and at the
// edge of the double range, tau stays finite and right; a non-finite star is an error.
TEST(OpticalDepth, StarsAtAbsurdDistancesAreFiniteAndNonFiniteOnesRefused)
{
    const auto vol = makeVolume(8, 0, 1.0, [](int, int, int) { return 10.0; });
    for (const double D : {1e20, 1e300}) {
        const auto tau = productionTau(vol, Vec3(-D, 3.5, 3.5));
        // Along x through the whole lattice row: the uniform field n = 10 over 0 .. i.
        EXPECT_NEAR(fieldAt(vol, tau, 5, 3, 3), KAPPA * 10.0 * 5.0, 1e-6) << D;
        for (float t : tau)
            EXPECT_TRUE(std::isfinite(t));
    }
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_THROW(productionTau(vol, Vec3(inf, 0, 0)), Error);
    EXPECT_THROW(productionTau(vol, Vec3(std::nan(""), 0, 0)), Error);
}
