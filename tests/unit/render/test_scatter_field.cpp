// SPDX-License-Identifier: Apache-2.0
// The scattered-light field (DESIGN §5b, nebscatter) against an energy balance, a brute-force
// single-scattering integral, the reference path tracer and published slab radiances, and
// its determinism.
#include "nebula/core/error.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/scatter_field.h"
#include "nebula/render/spectral.h"

#include "render_scenes.h"

#include <tbb/task_arena.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace nebula;
using namespace nebula::test;

namespace {

const double Y00 = 0.5 / std::sqrt(PI);

/// A lattice of @p n^3 voxels of size H whose density is @p density(world point).
template <class Density> RenderScene ball(int n, const std::vector<Star>& stars, Density&& density)
{
    RenderScene scene;
    scene.fields = SparseVolume({0, 0, 0}, {n, n, n}, 2 + int(stars.size()));
    scene.fields.indexToWorld.m = {H, 0, 0, 0, H, 0, 0, 0, H};
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                scene.fields.writable(scene.fields.index(i, j, k))[0] =
                    float(density(Vec3(i * H, j * H, k * H)));
    scene.stars = stars;
    for (const auto& s : stars)
        scene.starColor.push_back({s.luminosity, s.luminosity, s.luminosity});
    scene.dust.kappa_V = KAPPA;
    scene.dust.r = {0.75, 1.0, 1.33};
    fillStarTau(scene);
    scene.buildOccupancy();
    return scene;
}

Star starAt(const Vec3& p, double luminosity = 1.0)
{
    Star s;
    s.name = "s";
    s.position = {p.x, p.y, p.z};
    s.luminosity = luminosity;
    return s;
}

} // namespace

// Energy balance in a uniform cube of dust (dust up to the lattice's faces, so k is the same
// in every field cell) lit face-on by a far star (irradiance 1; its tau is linear, so
// trilinear tau is exact): the first-scattered power sampled from the tau grids matches
// a E A (1 - e^-k_c 3.2 pc); the collided light's absorption, computed from the field's J
// as (1 - a) k integral of 4 pi J dV, matches the absorption counted by the packets, and
// plus the collided power that escapes (counted where packets leave the grid) it equals the
// first-scattered power. Coloured dust: the three channels share one walk. Tolerances 1 %
// and 1.5 % (Monte Carlo noise about 0.3 %).
// The thick cube (tau_V 30 across) has most of its flights' walks in their tails, where the
// tail roulette stops 3 in 4 of them (weights, energy sums).
TEST(ScatterField, EnergyBalanceInAUniformCube)
{
    const int n = 33;
    // n_H 800: k_V = 1.2 / pc, tau_V = 3.8 across the cube; 6400: tau_V 30.
    for (const double n0 : {800.0, 6400.0}) {
        Star far = farStar(Vec3(-1, 0, 0));
        const Vec3 pos = Vec3(1.6, 1.6, 1.6) + Vec3(-1e5, 0, 0);
        far.position = {pos.x, pos.y, pos.z};
        auto scene = ball(n, {far}, [&](const Vec3&) { return n0; });
        scene.dust.albedo = 0.7;
        RenderOptions ropts;
        ScatterOptions so;
        so.packets = n0 > 1000.0 ? 100000 : 200000;
        so.fieldLevel = 1;
        so.order = 1;
        for (const double refineTau : {0.0, 1.0}) { // uniform cells, adaptive cells
            // The thick cube refines every block: adaptive cells are uniform cells there.
            if (n0 > 1000.0 && refineTau == 0.0) continue;
            SCOPED_TRACE("n_H " + std::to_string(n0) + ", refineTau " + std::to_string(refineTau));
            so.refineTau = refineTau;
            const ScatterField field = computeScatterField(scene, ropts, so, nullptr);
            ASSERT_EQ(field.sources.size(), 1u);
            const ScatterSourceField& f = field.sources[0];
            for (int c = 0; c < 3; ++c) {
                const double k = KAPPA * scene.dust.r[c] * n0;
                const double power = scene.dust.albedo * 3.2 * 3.2 * (1 - std::exp(-k * 3.2));
                EXPECT_NEAR(f.power[c], power, 0.01 * power) << "channel " << c;
                // Absorbed according to the field: (1 - a) k sum over cells of 4 pi J V.
                double absorbed = 0.0;
                const auto& m = f.moments;
                const double cell = 8.0 * H * H * H;
                for (int K = m.lo()[2] + 1; K < m.lo()[2] + m.dims()[2] - 1; ++K)
                    for (int J = m.lo()[1] + 1; J < m.lo()[1] + m.dims()[1] - 1; ++J)
                        for (int I = m.lo()[0] + 1; I < m.lo()[0] + m.dims()[0] - 1; ++I) {
                            // the cell's overlap with the lattice box [0, 32]^3 (index units)
                            double vol = cell;
                            for (const int X : {I, J, K}) {
                                const double a0 = std::max(0.0, 2.0 * X - 0.5);
                                const double a1 = std::min(32.0, 2.0 * X + 1.5);
                                vol *= (a1 - a0) / 2.0;
                            }
                            const double c00 = m.voxel(m.index(I, J, K))[c];
                            absorbed += (1 - scene.dust.albedo) * k * (c00 / Y00) * vol;
                        }
                EXPECT_NEAR(absorbed, f.absorbed[c], 0.01 * f.absorbed[c]) << "channel " << c;
                EXPECT_NEAR(absorbed + f.escaped[c], power, 0.015 * power) << "channel " << c;
                EXPECT_GT(f.escaped[c], 0.1 * power);
                EXPECT_GT(absorbed, 0.1 * power);
                if (c == 1) {
                    std::printf("n_H %g, refine-tau %g: absorbed (field) %.4g, (packets) %.4g, + "
                                "escaped %.4g against power %.4g\n",
                                n0, refineTau, absorbed, f.absorbed[c], absorbed + f.escaped[c],
                                power);
                }
            }
        }
    }
}

// Empty space is skipped (the walk's blocks with nothing to do): a small cloud lit by a
// star beside it, in a box that just holds both and in one 4^3 times larger, the cloud at
// the same place in the field cells. The packets' energy sums and the field's integral of
// J agree within 2 % (their noise is about 0.5 %).
TEST(ScatterField, CloudInAHugeEmptyBoxGivesTheTightBoxsField)
{
    struct Result
    {
        ScatterSourceField f;
        double jVolume[3] = {0, 0, 0};
    };
    const auto run = [](int n) {
        const Vec3 centre = Vec3(1, 1, 1) * (H * (n / 2));
        const Vec3 star = centre + Vec3(0.7, 0, 0);
        auto scene = ball(n, {starAt(star, 10.0)}, [&](const Vec3& x) {
            return (x - centre).length() < 0.6 ? 2000.0 : 0.0;
        });
        RenderOptions ropts;
        ScatterOptions so;
        so.packets = 100000;
        so.fieldLevel = 1;
        so.order = 1;
        Result r;
        r.f = computeScatterField(scene, ropts, so, nullptr).sources.at(0);
        const auto& m = r.f.moments;
        m.forEachStoredBrick([&](std::size_t first) {
            for (std::size_t v = first; v < first + SparseVolume::BRICK_VOXELS; ++v) {
                const auto p = m.point(v);
                if (!m.contains(p[0], p[1], p[2])) continue;
                for (int c = 0; c < 3; ++c)
                    r.jVolume[c] += m.voxel(v)[c];
            }
        });
        return r;
    };
    const Result tight = run(21), huge = run(85); // centres 10 and 42: both even
    for (int c = 0; c < 3; ++c) {
        SCOPED_TRACE("channel " + std::to_string(c));
        EXPECT_NEAR(huge.f.power[c], tight.f.power[c], 0.02 * tight.f.power[c]);
        EXPECT_NEAR(huge.f.escaped[c], tight.f.escaped[c], 0.02 * tight.f.escaped[c]);
        EXPECT_NEAR(huge.f.absorbed[c], tight.f.absorbed[c], 0.02 * tight.f.absorbed[c]);
        EXPECT_NEAR(huge.jVolume[c], tight.jVolume[c], 0.02 * tight.jVolume[c]);
        EXPECT_GT(tight.jVolume[c], 0.0);
    }
    std::printf("huge box against tight box: escaped %+.2f %%, absorbed %+.2f %%, sum of J %+.2f "
                "%% (green)\n",
                100 * (huge.f.escaped[1] / tight.f.escaped[1] - 1),
                100 * (huge.f.absorbed[1] / tight.f.absorbed[1] - 1),
                100 * (huge.jVolume[1] / tight.jVolume[1] - 1));
}

// An optically thin shell (tau 0.02) around a star: the field's J inside the shell matches
// the single-scattering integral brute-forced over directions through the same trilinear
// density (second order adds ~1 %; the brute force itself is checked against the sharp
// shell's closed form at the centre, J = k a p(-1) L (1/R1 - 1/R2) / (4 pi)). Tolerance 3 %:
// over seeds 1-4 the band averages came out -0.1 to +1.9 %.
TEST(ScatterField, ThinShellMatchesTheSingleScatteringIntegral)
{
    const int n = 41;
    const Vec3 centre(2.05, 2.05, 2.05);        // a field cell's centre
    const double R1 = 1.0, R2 = 1.8, n0 = 15.0; // tau_V = 0.018 across the shell
    const auto density = [&](const Vec3& x) {
        const double r = (x - centre).length();
        return r >= R1 && r <= R2 ? n0 : 0.0;
    };
    auto scene = ball(n, {starAt(centre, 4.0 * PI)}, density);
    scene.dust.g = 0.6;
    RenderOptions ropts;
    ScatterOptions so;
    so.packets = 400000;
    so.fieldLevel = 1;
    so.order = 2;

    // Brute force at point y: J = (1/4 pi) sum over directions of the light arriving from
    // along -w: integral of k(x) a p(mu) E(x) ds, x = y - s w, marched in steps of H/20 over
    // the trilinear density (SparseVolume::sample), E with the exact optical depth.
    const SparseVolume& v = scene.fields;
    const Affine w2i = v.indexToWorld.inverse();
    const auto brute = [&](const Vec3& y, int c) {
        const int M = 3000;
        double sum = 0.0;
        const double k0 = KAPPA * scene.dust.r[c];
        for (int q = 0; q < M; ++q) {
            const double z = 1.0 - (2.0 * q + 1.0) / M;
            const double phi = q * PI * (3.0 - std::sqrt(5.0));
            const double s = std::sqrt(1 - z * z);
            const Vec3 w(s * std::cos(phi), s * std::sin(phi), z); // light travel direction
            double tauBack = 0.0;
            const double ds = H / 20;
            for (double t = 0.5 * ds; t < 3.0; t += ds) {
                const Vec3 x = y - w * t;
                float fv[3];
                v.sample(w2i.apply(x), fv);
                if (!(fv[0] > 0)) continue;
                const Vec3 fromStar = x - centre;
                const double r = fromStar.length();
                const double mu = fromStar.dot(w) / r;
                const double E = 1.0 / (r * r) * std::exp(-scene.dust.r[c] * fv[2]); // L=4pi
                const double kk = k0 * fv[0];
                sum += kk * scene.dust.albedo * henyeyGreenstein(mu, 0.6) * E * std::exp(-tauBack) *
                       ds;
                tauBack += kk * ds;
            }
        }
        return sum / M; // (1/4pi) * 4 pi / M
    };
    for (const double refineTau : {0.0, 1.0}) { // uniform cells, adaptive cells
        SCOPED_TRACE("refineTau " + std::to_string(refineTau));
        so.refineTau = refineTau;
        const ScatterField field = computeScatterField(scene, ropts, so, nullptr);
        const ScatterSourceField& f = field.sources[0];
        // The shell is symmetric about the star, so J depends on the radius only: the field's J
        // is averaged over the cells whose centres lie within 0.05 pc of a radius inside the
        // shell (200-300 cells, which averages the per-cell noise of about 5 % down to well
        // under 1 %) and compared with the brute-force J at that radius on an axis. The l = 1
        // moments (proportional to y, z, x) give the net flux: along the radius it points
        // outwards (more light travels away from the star), across it it averages to zero.
        const auto& m = f.moments;
        for (const double R : {1.2, 1.4, 1.6}) {
            for (int c = 0; c < 3; ++c) {
                double sumJ = 0.0, radial = 0.0, across = 0.0;
                int cells = 0;
                for (int K = m.lo()[2]; K < m.lo()[2] + m.dims()[2]; ++K)
                    for (int J = m.lo()[1]; J < m.lo()[1] + m.dims()[1]; ++J)
                        for (int I = m.lo()[0]; I < m.lo()[0] + m.dims()[0]; ++I) {
                            const Vec3 v = m.indexToWorld.apply(Vec3(I, J, K)) - centre;
                            const double r = v.length();
                            if (std::abs(r - R) > 0.05) continue;
                            const float* q = m.voxel(m.index(I, J, K));
                            sumJ += q[c] / (4 * PI * Y00); // c_00 = 4 pi Y_00 J
                            const Vec3 flux(q[shIndex(1, 1) * 3 + c], q[shIndex(1, -1) * 3 + c],
                                            q[shIndex(1, 0) * 3 + c]); // (x, y, z)
                            radial += flux.dot(v) / r;
                            // a tangential direction that changes sign round the shell
                            across += flux.dot(Vec3(-v.y, v.x, 0)) / r;
                            ++cells;
                        }
                ASSERT_GT(cells, 150) << R;
                const double J = sumJ / cells;
                const double ref = brute(centre + Vec3(R, 0, 0), c);
                EXPECT_NEAR(J, ref, 0.03 * ref) << "R " << R << " channel " << c;
                EXPECT_GT(radial, 0.05 * std::abs(sumJ) * 4 * PI * Y00) << "R " << R;
                EXPECT_LT(std::abs(across), 0.2 * radial) << "R " << R;
                std::printf("shell R %.2f c %d: J %.5g ref %.5g (%+.2f %%), %d cells\n", R, c, J,
                            ref, 100 * (J / ref - 1), cells);
            }
        }
    }
    // The sharp-shell closed form is near (the voxelised shell's edges are ramps).
    const double closed =
        KAPPA * n0 * scene.dust.albedo * henyeyGreenstein(-1.0, 0.6) * (1 / R1 - 1 / R2);
    EXPECT_NEAR(brute(Vec3(2.05, 2.05, 2.05), 1), closed, 0.05 * closed);
}

// Same seed, same field whatever the thread count and whether the tallies go to per-thread
// buffers or to one shared buffer (integer sums), and another seed gives another field.
TEST(ScatterField, SameSeedSameFieldWhateverTheThreadCount)
{
    auto scene = ball(17, {starAt(Vec3(0.8, 0.8, 0.8), 10.0)}, [](const Vec3&) { return 900.0; });
    for (std::size_t i = 0; i < scene.fields.voxelCount(); ++i)
        scene.fields.writable(i)[1] = 0.5f; // emission too
    RenderOptions ropts;
    ScatterOptions so;
    so.packets = 20000;
    so.fieldLevel = 0;
    ScatterField one, two;
    tbb::task_arena(1).execute([&] { one = computeScatterField(scene, ropts, so, nullptr); });
    tbb::task_arena(2).execute([&] { two = computeScatterField(scene, ropts, so, nullptr); });
    ASSERT_EQ(one.sources.size(), 2u); // stars and emission
    for (std::size_t s = 0; s < 2; ++s) {
        EXPECT_EQ(latticeValues(one.sources[s].moments), latticeValues(two.sources[s].moments));
        EXPECT_EQ(one.sources[s].escaped, two.sources[s].escaped);
    }
    // One shared buffer with atomic additions (what large grids use) gives the same sums.
    ScatterOptions shared = so;
    shared.perThreadTallyBytes = 0.0;
    ScatterField atomic;
    tbb::task_arena(2).execute(
        [&] { atomic = computeScatterField(scene, ropts, shared, nullptr); });
    for (std::size_t s = 0; s < 2; ++s)
        EXPECT_EQ(latticeValues(one.sources[s].moments), latticeValues(atomic.sources[s].moments));
    so.seed = 2;
    EXPECT_NE(latticeValues(computeScatterField(scene, ropts, so, nullptr).sources[0].moments),
              latticeValues(one.sources[0].moments));
}

// Half-voxel cells (level -1) split each voxel's cell in 8. The packets and their flights
// are the same at both levels (the walk's pieces end at every half-voxel face either way),
// so the 8 cells' mean is the full-resolution cell's value up to rounding (float storage,
// fixed-point sums), moment for moment and channel for channel: with uniform cells, and
// with adaptive cells, whose unrefined blocks (voxels) are tallied whole and whose slopes
// keep each block's mean. The energy sums are the same too. A voxel 50 times denser than
// the rest (tau_V 7.5 across) is refined in the adaptive field, the thin ones are not.
TEST(ScatterField, HalfVoxelCellsAverageToFullResolutionCells)
{
    auto scene = ball(13, {starAt(Vec3(0.45, 0.6, 0.6), 5.0)}, [](const Vec3& x) {
        const bool core =
            std::abs(x.x - 0.7) < 0.01 && std::abs(x.y - 0.6) < 0.01 && std::abs(x.z - 0.6) < 0.01;
        return core ? 50000.0 : 1000.0;
    });
    RenderOptions ropts;
    ScatterOptions so;
    so.packets = 20000;
    so.order = 2;
    so.fieldLevel = 0;
    so.refineTau = 0.0;
    const ScatterField full = computeScatterField(scene, ropts, so, nullptr);
    so.fieldLevel = -1;
    for (const double refineTau : {0.0, 1.0}) {
        SCOPED_TRACE("refineTau " + std::to_string(refineTau));
        so.refineTau = refineTau;
        const ScatterField half = computeScatterField(scene, ropts, so, nullptr);
        ASSERT_EQ(half.level, -1);
        ASSERT_EQ(half.sources.size(), 1u);
        const ScatterSourceField &a = full.sources[0], &b = half.sources[0];
        EXPECT_EQ(a.flights, b.flights);
        for (int c = 0; c < 3; ++c) { // fixed-point sums, their quanta 2^level apart
            EXPECT_NEAR(a.escaped[c], b.escaped[c], 1e-9 * a.escaped[c]);
            EXPECT_NEAR(a.absorbed[c], b.absorbed[c], 1e-9 * a.absorbed[c]);
        }
        const SparseVolume &fm = a.moments, &hm = b.moments;
        ASSERT_EQ(hm.channels(), fm.channels());
        // A half-voxel cell's centre: 1/2 a voxel's index units apart, the first 1/4 below.
        const Vec3 c0 = hm.indexToWorld.apply(Vec3(0, 0, 0)),
                   c1 = hm.indexToWorld.apply(Vec3(1, 0, 0));
        EXPECT_NEAR(c1.x - c0.x, 0.5 * H, 1e-12);
        EXPECT_NEAR(c0.x, -0.25 * H, 1e-12);
        std::vector<double> peak(std::size_t(fm.channels()), 0.0);
        for (std::size_t i = 0; i < fm.voxelCount(); ++i)
            for (int q = 0; q < fm.channels(); ++q)
                peak[std::size_t(q)] =
                    std::max(peak[std::size_t(q)], std::abs(double(fm.voxel(i)[q])));
        int compared = 0;
        double worst = 0.0;
        // The voxels with dust away from the lattice's faces (all 8 of their cells inside).
        for (int k = 1; k < 12; ++k)
            for (int j = 1; j < 12; ++j)
                for (int i = 1; i < 12; ++i) {
                    if (!(scene.fields.voxel(scene.fields.index(i, j, k))[0] > 0.0f)) continue;
                    const float* parent = fm.voxel(fm.index(i, j, k));
                    for (int q = 0; q < fm.channels(); ++q) {
                        double mean = 0.0;
                        for (int c = 0; c < 8; ++c)
                            mean += double(hm.voxel(hm.index(2 * i + c % 2, 2 * j + (c / 2) % 2,
                                                             2 * k + c / 4))[q]) /
                                    8.0;
                        const double err =
                            std::abs(mean - double(parent[q])) / peak[std::size_t(q)];
                        worst = std::max(worst, err);
                        EXPECT_LT(err, 1e-5)
                            << "voxel " << i << "," << j << "," << k << " channel " << q;
                    }
                    ++compared;
                }
        EXPECT_GT(compared, 1000);
        std::printf("half-voxel cells, refine-tau %g: largest difference of the 8 cells' mean "
                    "%.2g of the channel's peak over %d voxels\n",
                    refineTau, worst, compared);
    }
}

namespace {

/// Rank r of s in one process: ranks 1..s-1 run first and leave their arrays in a mailbox
/// (one per sumToRoot() call, in call order); rank 0 then adds them, as MPI_Reduce would.
class MailboxRanks final : public Ranks
{
public:
    MailboxRanks(int r, int s, std::vector<std::vector<std::int64_t>>& box)
        : mRank(r), mSize(s), mBox(box)
    {}
    int rank() const override { return mRank; }
    int size() const override { return mSize; }
    void sumToRoot(std::int64_t* data, std::size_t n) const override
    {
        if (mRank != 0) {
            mBox.emplace_back(data, data + n);
            return;
        }
        // Rank 0's call k sums call k of every other rank.
        const std::size_t others = std::size_t(mSize - 1), calls = mBox.size() / others;
        for (std::size_t r = 0; r < others; ++r) {
            const auto& v = mBox[r * calls + mCall];
            EXPECT_EQ(v.size(), n);
            for (std::size_t i = 0; i < n; ++i)
                data[i] += v[i];
        }
        ++mCall;
    }
    void sumToRoot(std::uint64_t* data, std::size_t n) const override
    {
        std::vector<std::int64_t> v(data, data + n);
        sumToRoot(v.data(), n);
        for (std::size_t i = 0; i < n; ++i)
            data[i] = std::uint64_t(v[i]);
    }

private:
    int mRank, mSize;
    std::vector<std::vector<std::int64_t>>& mBox;
    mutable std::size_t mCall = 0;
};

} // namespace

TEST(ScatterField, RanksSharingThePacketsGiveOneProcesssField)
{
    auto scene = ball(17, {starAt(Vec3(0.8, 0.8, 0.8), 10.0)}, [](const Vec3&) { return 900.0; });
    for (std::size_t i = 0; i < scene.fields.voxelCount(); ++i)
        scene.fields.writable(i)[1] = 0.5f; // emission too: two sources, two rounds of sums
    RenderOptions ropts;
    ScatterOptions so;
    so.packets = 20001; // not a multiple of the ranks
    so.fieldLevel = 0;
    const ScatterField one = computeScatterField(scene, ropts, so, nullptr);
    ASSERT_EQ(one.sources.size(), 2u);
    for (const int size : {2, 3}) {
        std::vector<std::vector<std::int64_t>> box;
        for (int r = size - 1; r >= 1; --r) {
            MailboxRanks ranks(r, size, box);
            so.ranks = &ranks;
            const ScatterField other = computeScatterField(scene, ropts, so, nullptr);
            ASSERT_EQ(other.sources.size(), 2u);
            EXPECT_EQ(other.sources[0].moments.storedBricks(), 0u) << "only rank 0 holds the field";
        }
        MailboxRanks root(0, size, box);
        so.ranks = &root;
        const ScatterField sum = computeScatterField(scene, ropts, so, nullptr);
        for (std::size_t s = 0; s < 2; ++s) {
            EXPECT_EQ(latticeValues(sum.sources[s].moments), latticeValues(one.sources[s].moments))
                << size << " ranks, source " << s;
            EXPECT_EQ(sum.sources[s].escaped, one.sources[s].escaped);
            EXPECT_EQ(sum.sources[s].flights, one.sources[s].flights);
            EXPECT_EQ(sum.sources[s].relativeError, one.sources[s].relativeError);
        }
    }
    // More ranks than packets: refused, naming --packets.
    std::vector<std::vector<std::int64_t>> box;
    MailboxRanks many(0, 3, box);
    so.ranks = &many;
    so.packets = 2;
    try {
        validateScatterOptions(scene, so);
        ADD_FAILURE() << "3 ranks, 2 packets accepted";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("--packets 2 is fewer than the 3 MPI ranks"),
                  std::string::npos)
            << e.what();
    }
}

TEST(ScatterField, RefusesBadOptions)
{
    auto scene = ball(9, {starAt(Vec3(0.4, 0.4, 0.4))}, [](const Vec3&) { return 100.0; });
    ScatterOptions so;
    so.order = 5;
    EXPECT_THROW(validateScatterOptions(scene, so), UsageError);
    so.order = 2;
    so.packets = 0;
    EXPECT_THROW(validateScatterOptions(scene, so), UsageError);
    so.packets = 10;
    // Field level @p level is refused with a message holding @p text.
    const auto refused = [&](int level, const std::string& text) {
        so.fieldLevel = level;
        try {
            validateScatterOptions(scene, so);
            ADD_FAILURE() << "level " << level << " accepted";
        } catch (const UsageError& e) {
            EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
        }
    };
    refused(3, "--field-level 3"); // cells of 8 voxels: the grid is 7 voxels across
    so.fieldLevel = 2;
    EXPECT_NO_THROW(validateScatterOptions(scene, so));
    so.fieldLevel = -1; // half-voxel cells
    EXPECT_NO_THROW(validateScatterOptions(scene, so));
    refused(-2, "--field-level -2: use a level in -1..2");
}

// The automatic field level: about 64 cells across the grid (45 to 90), finer where cells
// of the densest 1 % of the dust are optically thick, within the tallies' memory budget.
TEST(ScatterField, AutoFieldLevelFollowsGridSizeOpticalThicknessAndMemory)
{
    // A box of n - 2 voxels of dust nH (voxel tau_V = KAPPA nH H = 1.5e-4 nH), optionally
    // with a dense core of fewer than 1 % of the voxels.
    const auto box = [](int n, double nH, double core = 0.0) {
        RenderScene s;
        s.fields = SparseVolume({0, 0, 0}, {n, n, n}, 2);
        s.fields.indexToWorld.m = {H, 0, 0, 0, H, 0, 0, 0, H};
        for (int k = 1; k < n - 1; ++k)
            for (int j = 1; j < n - 1; ++j)
                for (int i = 1; i < n - 1; ++i) {
                    const bool inCore = std::abs(i - n / 2) < 4 && std::abs(j - n / 2) < 4 &&
                                        std::abs(k - n / 2) < 4;
                    s.fields.writable(s.fields.index(i, j, k))[0] =
                        float(inCore && core > 0.0 ? core : nH);
                }
        s.dust.kappa_V = KAPPA;
        return s;
    };
    // Grid size alone (thin dust): 64 -> 0, 128 -> 1 (64 cells), 90 -> 0, 92 -> 1.
    EXPECT_EQ(autoFieldLevel(box(66, 100.0), 4, 3).level, 0);
    const RenderScene thin128 = box(130, 100.0);
    const FieldLevelChoice c = autoFieldLevel(thin128, 4, 3);
    EXPECT_EQ(c.level, 1);
    EXPECT_EQ(c.gridLevel, 1);
    EXPECT_NEAR(c.voxelTau, KAPPA * 100.0 * H, 1e-9);
    EXPECT_NEAR(c.cellTau, 2.0 * KAPPA * 100.0 * H, 1e-9);
    EXPECT_EQ(autoFieldLevel(box(92, 100.0), 4, 3).level, 0);
    EXPECT_EQ(autoFieldLevel(box(94, 100.0), 4, 3).level, 1);
    // A dense core under 1 % of the voxels does not decide the level.
    EXPECT_EQ(autoFieldLevel(box(130, 100.0, 1e6), 4, 3).level, 1);
    // Thick dust (voxel tau 0.75, cells of level 1: 1.5): level 0 where its tallies fit in
    // the budget (order 2: 130^3 x 9 x 3 x 8 bytes = 0.44 GiB), not where they do not
    // (order 4: 1.2 GiB).
    const RenderScene thick = box(130, 5000.0);
    EXPECT_EQ(autoFieldLevel(thick, 2, 3).level, 0);
    EXPECT_EQ(autoFieldLevel(thick, 4, 3).level, 1);
    EXPECT_LE(autoFieldLevel(thick, 4, 3).tallyBytes, AUTO_FIELD_MAX_TALLY_BYTES);
    // Optically thick voxels (tau_V 3 across, cells of level 0 too): half-voxel cells where
    // their tallies fit (a small grid), with adaptive cells or without.
    const RenderScene dense = box(34, 20000.0);
    for (const double refineTau : {0.0, 1.0}) {
        const FieldLevelChoice h = autoFieldLevel(dense, 4, 3, refineTau);
        EXPECT_EQ(h.level, MIN_FIELD_LEVEL);
        EXPECT_NEAR(h.cellTau, 0.5 * KAPPA * 20000.0 * H, 1e-9);
        EXPECT_LE(h.tallyBytes, AUTO_FIELD_MAX_TALLY_BYTES);
    }
    // At 88^3 the half-voxel field itself (177^3 cells x 75 moments x 4 bytes = 1.5 GiB)
    // does not fit: full resolution.
    EXPECT_EQ(autoFieldLevel(box(90, 20000.0), 4, 3, 1.0).level, 0);
    // Many channels (a spectral field of 64 wavelengths at order 4): coarser than 64 cells.
    const FieldLevelChoice spectral = autoFieldLevel(thin128, 4, 64);
    EXPECT_EQ(spectral.level, 2);
    EXPECT_LE(spectral.tallyBytes, AUTO_FIELD_MAX_TALLY_BYTES);
}

namespace {

/// A cloud of optical depth ~3 through its centre: a ball of radius 1.1 pc (k_V = 1.36 /pc)
/// with an empty cavity round the star and a filament of 4x the density that shadows part
/// of it; the star is inside the cavity, off centre.
RenderScene thickCloud(double albedo, PhaseModel phase, double g, bool grey)
{
    const Vec3 c(1.2, 1.2, 1.2), star(1.0, 1.3, 1.2);
    auto scene = ball(25, {starAt(star, 4.0 * PI)}, [&](const Vec3& x) {
        const double r = (x - c).length();
        if (r > 1.1 || (x - star).length() < 0.35) return 0.0;
        const double dx = x.x - 1.55, dz = x.z - 1.0;
        return dx * dx + dz * dz < 0.15 * 0.15 ? 3600.0 : 909.0;
    });
    scene.dust.albedo = albedo;
    scene.dust.phase = phase;
    scene.dust.g = g;
    if (grey) scene.dust.r = {1, 1, 1};
    return scene;
}

/// Fast integrator with the field against the path tracer, in 2x2-pixel blocks of an 8x8
/// image and in total: within 3 standard errors (the path tracer's, from its variance layer,
/// and the field's, from the spread of four fields of independent seeds) plus 2 %. Blocks
/// below 1 % of the brightest one (the cloud's limb at the image corners, 0.01 % of the
/// flux; bench/error_table.sh's threshold) are printed, not asserted. With @p blocks false
/// only the total is asserted.
void compareWithPathTracer(const RenderScene& base, const std::string& what, int order = 3,
                           bool blocks = true, double totalTolerance = 0.02)
{
    RenderOptions o;
    o.lod = 0.0; // the path tracer samples pixel centres at full resolution
    o.camera.eye = Vec3(1.2, 1.2, -8.0);
    o.camera.lookAt = Vec3(1.2, 1.2, 1.2);
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = 8;
    o.camera.fovDeg = 16.0;
    o.drawStars = false;
    o.step = 0.25;
    ScatterOptions so;
    so.packets = 100000;
    so.fieldLevel = 0;
    so.order = order;
    so.refineTau = 1.0; // nebscatter's default: adaptive cells
    const int seeds = 4;
    std::vector<Image> fast;
    for (int s = 0; s < seeds; ++s) {
        so.seed = std::uint64_t(s + 1);
        RenderScene scene = base;
        scene.scatter = sceneScatterField(computeScatterField(scene, o, so, nullptr), o);
        fast.push_back(renderFrame(scene, o));
    }
    const Image single = renderFrame(base, o);
    RenderOptions po = o;
    po.integrator = Integrator::Path;
    po.spp = 2000;
    const Image path = renderPathTraced(base, po);
    const ImageLayer* var = nullptr;
    for (const auto& l : path.layers)
        if (l.name == "variance") var = &l;
    ASSERT_NE(var, nullptr);
    for (int c = 0; c < 3; ++c) {
        double tp = 0, tv = 0, ts = 0, brightest = 0;
        std::vector<double> tf(seeds, 0.0);
        for (int b = 0; b < 16; ++b) {
            double p = 0;
            for (int q = 0; q < 4; ++q)
                p +=
                    path.rgba[(std::size_t(2 * (b / 4) + q / 2) * 8 + 2 * (b % 4) + q % 2) * 4 + c];
            brightest = std::max(brightest, p);
        }
        for (int by = 0; by < 4; ++by)
            for (int bx = 0; bx < 4; ++bx) {
                double p = 0, v = 0;
                std::vector<double> f(seeds, 0.0);
                for (int q = 0; q < 4; ++q) {
                    const std::size_t pix = std::size_t(2 * by + q / 2) * 8 + 2 * bx + q % 2;
                    for (int s = 0; s < seeds; ++s)
                        f[std::size_t(s)] += fast[std::size_t(s)].rgba[pix * 4 + c];
                    p += path.rgba[pix * 4 + c];
                    v += var->rgb[pix * 3 + c];
                    ts += single.rgba[pix * 4 + c];
                }
                double mean = 0, spread = 0;
                for (int s = 0; s < seeds; ++s) {
                    mean += f[std::size_t(s)] / seeds;
                    tf[std::size_t(s)] += f[std::size_t(s)];
                }
                for (int s = 0; s < seeds; ++s)
                    spread += std::pow(f[std::size_t(s)] - mean, 2) / (seeds - 1);
                const double sigma = std::sqrt(v + spread / seeds);
                if (blocks && p >= 0.01 * brightest) {
                    EXPECT_NEAR(mean, p, 3 * sigma + 0.02 * p)
                        << what << " block " << bx << "," << by << " channel " << c;
                }
                std::printf("  %s block %d,%d c %d: path %.4g field %.4g +- %.2g (%+.1f %%)\n",
                            what.c_str(), bx, by, c, p, mean, sigma, 100 * (mean / p - 1));
                tp += p;
                tv += v;
            }
        double mean = 0, spread = 0;
        for (int s = 0; s < seeds; ++s)
            mean += tf[std::size_t(s)] / seeds;
        for (int s = 0; s < seeds; ++s)
            spread += std::pow(tf[std::size_t(s)] - mean, 2) / (seeds - 1);
        const double sigma = std::sqrt(tv + spread / seeds);
        EXPECT_NEAR(mean, tp, 3 * sigma + totalTolerance * tp) << what << " total, channel " << c;
        // Multiple scattering matters here: single scattering alone is clearly short.
        EXPECT_LT(ts, 0.9 * tp) << what << " channel " << c;
        std::printf("%s channel %d: path %.5g, field %.5g +- %.2g (%+.2f %%), single %.5g "
                    "(%+.1f %%)\n",
                    what.c_str(), c, tp, mean, sigma, 100 * (mean / tp - 1), ts,
                    100 * (ts / tp - 1));
    }
}

} // namespace

TEST(ScatterField, MatchesThePathTracerHG06ColouredDust)
{
    compareWithPathTracer(thickCloud(0.6, PhaseModel::HenyeyGreenstein, 0.6, false), "HG 0.6");
}

TEST(ScatterField, MatchesThePathTracerIsotropic)
{
    compareWithPathTracer(thickCloud(0.7, PhaseModel::HenyeyGreenstein, 0.0, true), "HG 0");
}

// Strongly forward scattering (g = 0.9) is where truncated harmonics fall short: the light
// scattered once near the star is a narrow cone, and at L = 3 the blocks are off by up to
// tens of per cent both ways (printed; at L = 4 no better). Only the total is asserted,
// within 3 standard errors plus 4 %; it comes out about -2 % (single scattering: -29 %).
TEST(ScatterField, MatchesThePathTracerHG09InTotal)
{
    compareWithPathTracer(thickCloud(0.7, PhaseModel::HenyeyGreenstein, 0.9, true), "HG 0.9", 3,
                          false, 0.04);
}

TEST(ScatterField, MatchesThePathTracerRayleigh)
{
    compareWithPathTracer(thickCloud(0.7, PhaseModel::Rayleigh, 0.0, true), "Rayleigh");
}

// The published slab radiances the path tracer is tested against (van de Hulst: isotropic,
// a = 0.8, b = 2: R(0.5, 1) = 0.28616, T(0.5, 1) = 0.14864; DISORT test problem 3A: HG
// g = 0.75, a = 1, b = 1: 0.101103 up, 0.266648 down at mu 0.5, for incident flux pi),
// reproduced by single scattering + the field (order 4, full resolution). The slab is
// uniform sideways, so the radiance is averaged over a 16x16 view of its middle (+-6 pc,
// seen from 400 pc: the exit cosine varies by 0.01), which averages the field's noise over
// many cells. Isotropic scattering needs only J (p_l = 0 for l > 0); HG 0.75 is truncated
// at l = 4. Tolerance: 4 % (the slab's finite width: 1 %; the field's noise at 160,000
// packets: under 1 %), except the HG slab's transmitted radiance, 7 %: with 400,000 packets
// the field gives -3.8 to -4.8 % there whatever the seed (the truncation at l = 4 of a
// forward-peaked phase function), and 160,000 packets add about 1 % of noise.
TEST(ScatterField, WideSlabMatchesPublishedRadiances)
{
    struct Case
    {
        double tau, albedo, g, up, down; // radiance per unit irradiance at mu = 0.5
    };
    const auto wideView = [](double tau, bool reflected) {
        RenderOptions o = slabCamera(0.5, reflected, tau);
        const Vec3 d = o.camera.eye - o.camera.lookAt;
        o.camera.eye = o.camera.lookAt + d * 10.0; // 400 pc away
        o.camera.width = o.camera.height = 16;
        o.camera.fovDeg = 1.7;
        return o;
    };
    const auto mean = [](const Image& img, int c) {
        double m = 0.0;
        for (std::size_t p = 0; p < img.rgba.size() / 4; ++p)
            m += img.rgba[p * 4 + std::size_t(c)];
        return m / double(img.rgba.size() / 4);
    };
    for (const Case& k : {Case{2.0, 0.8, 0.0, 0.28616 / PI, 0.14864 / PI},
                          Case{1.0, 1.0, 0.75, 0.101103 / PI, 0.266648 / PI}}) {
        RenderScene scene = slab(k.tau, k.albedo, k.g);
        fillStarTau(scene); // the ray caster's starlight needs tau.<star>
        const RenderOptions upView = wideView(k.tau, true), downView = wideView(k.tau, false);
        ScatterOptions so;
        so.packets = 160000;
        so.fieldLevel = 0;
        so.order = 4;
        scene.scatter = sceneScatterField(computeScatterField(scene, upView, so, nullptr), upView);
        const Image up = renderFrame(scene, upView);
        const Image down = renderFrame(scene, downView);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(mean(up, c), k.up, 0.04 * k.up)
                << "reflected, a " << k.albedo << " g " << k.g << " c " << c;
            EXPECT_NEAR(mean(down, c), k.down, (k.g > 0.0 ? 0.07 : 0.04) * k.down)
                << "transmitted, a " << k.albedo << " g " << k.g << " c " << c;
        }
        std::printf("slab a %g g %g: up %.5g (published %.5g, %+.2f %%), down %.5g (%.5g, "
                    "%+.2f %%)\n",
                    k.albedo, k.g, mean(up, 1), k.up, 100 * (mean(up, 1) / k.up - 1), mean(down, 1),
                    k.down, 100 * (mean(down, 1) / k.down - 1));
    }
}

// ---------------------------------------------------------------------------------------
// The spectral field (nebscatter --spectral) and the spectral renderer.

namespace {

/// @p scene as the spectral renderer sees it (no emission grids).
SpectralScene spectralOf(const RenderScene& scene)
{
    SpectralScene s;
    s.base = scene;
    s.dust = scene.dust;
    return s;
}

RenderOptions cloudCamera(int res)
{
    RenderOptions o;
    o.lod = 0.0; // compared with the path tracer and the spectral renderer, at full resolution
    o.camera.eye = Vec3(1.2, 1.2, -8.0);
    o.camera.lookAt = Vec3(1.2, 1.2, 1.2);
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = res;
    o.camera.fovDeg = 16.0;
    o.drawStars = false;
    o.step = 0.25;
    return o;
}

/// The largest CIEDE2000 difference between two images' pixels (L*a*b* relative to a D65
/// white of the reference's largest luminance; pixels below 1e-3 of it left out).
double maxDeltaE(const Image& ref, const Image& test)
{
    const std::size_t n = std::size_t(ref.width) * ref.height;
    double Yw = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        Yw = std::max(
            Yw, linearSRGBToXYZ({ref.rgba[i * 4], ref.rgba[i * 4 + 1], ref.rgba[i * 4 + 2]})[1]);
    const XYZ white = linearSRGBToXYZ({Yw, Yw, Yw});
    double worst = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const XYZ a = linearSRGBToXYZ({ref.rgba[i * 4], ref.rgba[i * 4 + 1], ref.rgba[i * 4 + 2]});
        if (!(a[1] > 1e-3 * Yw)) continue;
        const XYZ b =
            linearSRGBToXYZ({test.rgba[i * 4], test.rgba[i * 4 + 1], test.rgba[i * 4 + 2]});
        worst = std::max(worst, deltaE2000(xyzToLab(a, white), xyzToLab(b, white)));
    }
    return worst;
}

} // namespace

// Adaptive cells against uniform cells, on a scene made hard for them: a dense core (its
// blocks refined) in a thin envelope (tallied by blocks of 2x2x2 cells), a star in the
// envelope, and a dense wall whose shadow's sharp edge crosses the envelope's blocks. Same
// flux within 1 %, and the same image within noise: the RMS difference of the adaptive and
// a uniform image over 4x4-pixel blocks, over two realisations, is below 1.5 times that of
// two uniform images of other seeds. Without a bias the first is the smaller in expectation
// (the adaptive field has less noise), but one realisation's ratio ranges over 0.6-1.4; a
// bias such as the shadow's leak this test was written for (its shadow 14-29 % too bright)
// puts it far above.
TEST(ScatterField, AdaptiveCellsMatchUniformCellsWithinNoise)
{
    const Vec3 centre(1.6, 1.6, 1.6);
    auto scene = ball(33, {starAt(Vec3(0.5, 1.6, 1.6), 30.0)}, [&](const Vec3& x) {
        const double r = (x - centre).length();
        if (r > 1.5) return 0.0;
        if (r < 0.35) return 12000.0; // tau_V 3.6 across a block: refined
        if (x.x > 1.0 && x.x < 1.15 && x.y > 1.6) return 20000.0; // the wall, tau_V 4.5
        return 400.0;                                             // 0.12 across a block
    });
    RenderOptions o = cloudCamera(32);
    o.camera.eye = Vec3(1.6, 1.6, -8.0);
    o.camera.lookAt = centre;
    o.camera.fovDeg = 22.0;
    ScatterOptions so;
    so.packets = 100000;
    so.fieldLevel = 0;
    so.order = 4;
    const auto render = [&](double refineTau, std::uint64_t seed) {
        so.refineTau = refineTau;
        so.seed = seed;
        RenderScene sc = scene;
        const ScatterField field = computeScatterField(sc, o, so, nullptr);
        sc.scatter = sceneScatterField(field, o);
        return renderFrame(sc, o);
    };
    const Image single = renderFrame(scene, o);
    const auto flux = [](const Image& img) {
        double f = 0.0;
        for (std::size_t p = 0; p < img.rgba.size() / 4; ++p)
            f += img.rgba[p * 4 + 1];
        return f;
    };
    double uu = 0.0, au = 0.0;
    int n = 0;
    for (const std::uint64_t seed : {1, 11}) {
        const Image u1 = render(0.0, seed), u2 = render(0.0, seed + 1), a = render(1.0, seed + 2);
        // The field's share of the light, the part that differs.
        const double scattered = flux(u1) - flux(single);
        ASSERT_GT(scattered, 0.2 * flux(u1));
        EXPECT_NEAR(flux(a), flux(u1), 0.01 * flux(u1));
        // 4x4-pixel blocks above 0.2 % of the brightest (the star makes its surroundings bright).
        const auto blocks = [](const Image& img) {
            std::vector<double> b(64, 0.0);
            for (int y = 0; y < 32; ++y)
                for (int x = 0; x < 32; ++x)
                    b[std::size_t(y / 4 * 8 + x / 4)] +=
                        img.rgba[(std::size_t(y) * 32 + x) * 4 + 1];
            return b;
        };
        const auto bu1 = blocks(u1), bu2 = blocks(u2), ba = blocks(a);
        const double brightest = *std::max_element(bu1.begin(), bu1.end());
        for (std::size_t i = 0; i < bu1.size(); ++i) {
            if (bu1[i] < 0.002 * brightest) continue;
            uu += std::pow((bu2[i] - bu1[i]) / bu1[i], 2);
            au += std::pow((ba[i] - bu1[i]) / bu1[i], 2);
            ++n;
        }
        std::printf("adaptive (seed %d): flux %+.2f %%\n", int(seed + 2),
                    100 * (flux(a) / flux(u1) - 1));
    }
    ASSERT_GT(n, 60);
    uu = std::sqrt(uu / n);
    au = std::sqrt(au / n);
    EXPECT_GT(uu, 0.0);
    EXPECT_LT(au, 1.5 * uu) << "adaptive against uniform " << au << ", uniform against uniform "
                            << uu;
    std::printf("adaptive: block RMS against uniform %.2f %%, uniform against uniform %.2f %% "
                "(%d blocks over two realisations)\n",
                100 * au, 100 * uu, n);
}

// How many wavelengths the spectral field needs: on the thick cloud (CCM dust, a 12000 K
// star, the blue end extinguished twice as much as the red), the spectral render with the
// field at 6 wavelengths (every 80 nm over 380-780 nm) stays within Delta E 2000 < 1 of the
// one at 41 (every 10 nm) in every pixel; 3 wavelengths do not. The 6 are a subset of the
// 41, so both carry the same Monte Carlo noise and only the wavelength interpolation
// differs. The field itself matters: single scattering alone is far off.
TEST(ScatterField, SpectralFieldOfSixWavelengthsKeepsColoursWithinDeltaE1)
{
    RenderScene scene = thickCloud(0.6, PhaseModel::HenyeyGreenstein, 0.6, false);
    scene.stars[0].temperature = 12000.0;
    ScatterOptions so;
    so.packets = 15000;
    so.fieldLevel = 0;
    const RenderOptions o = cloudCamera(12);
    const ScatterField dense =
        computeSpectralScatterField(scene, o, so, spectralFieldWavelengths(41), nullptr);
    ASSERT_EQ(dense.wavelengths.size(), 41u);
    EXPECT_EQ(dense.sources.size(), 1u); // the stars; no emission in a spectral field
    RenderOptions so2 = o;
    so2.spectral.enabled = true;
    const auto render = [&](const ScatterField* f) {
        SpectralScene s = spectralOf(scene);
        if (f) s.base.scatter = sceneScatterField(*f, so2);
        return renderSpectral(s, so2);
    };
    const Image ref = render(&dense);
    const ScatterField six = spectralFieldSubset(dense, 8), three = spectralFieldSubset(dense, 20);
    ASSERT_EQ(six.wavelengths.size(), 6u);
    ASSERT_EQ(three.wavelengths.size(), 3u);
    const double dE6 = maxDeltaE(ref, render(&six));
    const double dE3 = maxDeltaE(ref, render(&three));
    const double dESingle = maxDeltaE(ref, render(nullptr));
    std::printf("max Delta E 2000 against 41 wavelengths: 6: %.3f, 3: %.3f, no field: %.3f\n", dE6,
                dE3, dESingle);
    EXPECT_LT(dE6, 1.0);
    EXPECT_GT(dE3, 1.0);
    EXPECT_GT(dESingle, 5.0);
}

// In grey dust the collided light has the star's spectrum everywhere, so the spectral
// field's light (spectral render with the field minus without) must equal the R, G, B
// field's (RGB render with minus without) in linear sRGB: the same units, normalisation
// (the star's luminance Y = L) and geometry. Tolerances: 1.5 % in total per channel, 4 %
// per 2x2-pixel block holding at least 5 % of the brightest block's light (the two fields
// are independent Monte Carlo estimates of 100,000 packets: about 1 % noise per block).
TEST(ScatterField, SpectralFieldMatchesTheRgbFieldInGreyDust)
{
    RenderScene scene = thickCloud(0.6, PhaseModel::HenyeyGreenstein, 0.6, true);
    scene.dust.curve = "grey";
    scene.stars[0].temperature = 6500.0;
    const auto rgb = blackbodyLinearSRGB(6500.0);
    for (int c = 0; c < 3; ++c)
        scene.starColor[0][std::size_t(c)] = rgb[std::size_t(c)] * scene.stars[0].luminosity;
    ScatterOptions so;
    so.packets = 100000;
    so.fieldLevel = 0;
    RenderOptions o = cloudCamera(8);
    RenderScene withField = scene;
    withField.scatter = sceneScatterField(computeScatterField(scene, o, so, nullptr), o);
    const Image rgbWith = renderFrame(withField, o), rgbWithout = renderFrame(scene, o);
    RenderOptions os = o;
    os.spectral.enabled = true;
    SpectralScene sw = spectralOf(scene);
    sw.base.scatter = sceneScatterField(
        computeSpectralScatterField(scene, o, so, spectralFieldWavelengths(9), nullptr), os);
    const Image specWith = renderSpectral(sw, os),
                specWithout = renderSpectral(spectralOf(scene), os);
    for (int c = 0; c < 3; ++c) {
        double tr = 0, ts = 0, brightest = 0;
        std::vector<double> br(16, 0.0), bs(16, 0.0);
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x) {
                const std::size_t p = (std::size_t(y) * 8 + x) * 4 + std::size_t(c);
                const double r = rgbWith.rgba[p] - rgbWithout.rgba[p];
                const double s = specWith.rgba[p] - specWithout.rgba[p];
                br[std::size_t(y / 2 * 4 + x / 2)] += r;
                bs[std::size_t(y / 2 * 4 + x / 2)] += s;
                tr += r;
                ts += s;
            }
        for (double b : br)
            brightest = std::max(brightest, b);
        ASSERT_GT(tr, 0.0);
        EXPECT_NEAR(ts, tr, 0.015 * tr) << "channel " << c;
        std::printf("channel %d: field's light RGB %.5g, spectral %.5g (%+.2f %%)\n", c, tr, ts,
                    100 * (ts / tr - 1));
        for (std::size_t b = 0; b < 16; ++b) {
            if (br[b] < 0.05 * brightest) continue;
            EXPECT_NEAR(bs[b], br[b], 0.04 * br[b]) << "block " << b << " channel " << c;
        }
    }
}
