// SPDX-License-Identifier: Apache-2.0
/// @file test_volume.cpp
/// volume/volume.h: Vec3, the affine maps (apply, inverse) and SparseVolume (lattice
/// indexing, interleaved channels, trilinear sampling: exact for fields that are linear in
/// each coordinate, zero outside the lattice).

#include "nebula/volume/volume.h"

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <cmath>
#include <random>
#include <vector>

using nebula::Affine;
using nebula::SparseVolume;
using nebula::Vec3;

namespace {

Affine randomAffine(std::mt19937_64& rng)
{
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    Affine a;
    for (;;) {
        for (auto& m : a.m)
            m = u(rng);
        const auto& m = a.m;
        const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                           m[2] * (m[3] * m[7] - m[4] * m[6]);
        if (std::abs(det) > 0.2) break; // well conditioned
    }
    a.t = Vec3(u(rng) * 5, u(rng) * 5, u(rng) * 5);
    return a;
}

void expectNear(const Vec3& a, const Vec3& b, double tol)
{
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

// ---- Vec3 ---------------------------------------------------------------------------------

TEST(Vec3, Arithmetic)
{
    const Vec3 a(1, 2, 3), b(-4, 0.5, 2);
    const Vec3 s = a + b, d = a - b, m = a * 2.0, n = -a;
    EXPECT_EQ(s.x, -3.0);
    EXPECT_EQ(s.y, 2.5);
    EXPECT_EQ(s.z, 5.0);
    EXPECT_EQ(d.x, 5.0);
    EXPECT_EQ(m.z, 6.0);
    EXPECT_EQ(n.y, -2.0);
    EXPECT_EQ(a.dot(b), -4.0 + 1.0 + 6.0);
    EXPECT_EQ(a[0], 1.0);
    EXPECT_EQ(a[1], 2.0);
    EXPECT_EQ(a[2], 3.0);
    Vec3 c = a;
    c[1] = 7.0;
    EXPECT_EQ(c.y, 7.0);
    EXPECT_DOUBLE_EQ(Vec3(3, 4, 12).length(), 13.0);
    expectNear(Vec3(0, 3, 4).normalized(), Vec3(0, 0.6, 0.8), 1e-15);
    EXPECT_EQ(Vec3().length(), 0.0);
}

TEST(Vec3, CrossIsRightHandedAndPerpendicular)
{
    const Vec3 x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
    expectNear(x.cross(y), z, 0.0);
    expectNear(y.cross(z), x, 0.0);
    expectNear(z.cross(x), y, 0.0);
    expectNear(y.cross(x), -z, 0.0);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-3, 3);
    for (int i = 0; i < 100; ++i) {
        const Vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
        const Vec3 c = a.cross(b);
        EXPECT_NEAR(c.dot(a), 0.0, 1e-12);
        EXPECT_NEAR(c.dot(b), 0.0, 1e-12);
        // |a x b|^2 = |a|^2 |b|^2 - (a.b)^2 (Lagrange).
        EXPECT_NEAR(c.dot(c), a.dot(a) * b.dot(b) - a.dot(b) * a.dot(b), 1e-10);
    }
}

// ---- Affine -------------------------------------------------------------------------------

TEST(Affine, ApplyIsMatrixTimesPointPlusTranslation)
{
    Affine a;
    a.m = {1, 2, 3, 4, 5, 6, 7, 8, 10}; // row-major
    a.t = Vec3(-1, 0.5, 2);
    expectNear(a.applyLinear(Vec3(1, 0, 0)), Vec3(1, 4, 7), 0.0); // first column
    expectNear(a.applyLinear(Vec3(0, 0, 1)), Vec3(3, 6, 10), 0.0);
    expectNear(a.apply(Vec3(1, 1, 1)), Vec3(6 - 1, 15 + 0.5, 25 + 2), 0.0);
    // The default is the identity.
    const Affine id;
    expectNear(id.apply(Vec3(3, -2, 9)), Vec3(3, -2, 9), 0.0);
}

TEST(Affine, InverseUndoesApply)
{
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> u(-50, 50);
    for (int i = 0; i < 200; ++i) {
        const Affine a = randomAffine(rng);
        const Affine inv = a.inverse();
        for (int k = 0; k < 5; ++k) {
            const Vec3 p(u(rng), u(rng), u(rng));
            expectNear(inv.apply(a.apply(p)), p, 1e-9 * (1 + p.length()));
            expectNear(a.apply(inv.apply(p)), p, 1e-9 * (1 + p.length()));
            expectNear(inv.applyLinear(a.applyLinear(p)), p, 1e-9 * (1 + p.length()));
        }
    }
    // A scale-and-shift map has the obvious inverse.
    Affine s;
    s.m = {0.5, 0, 0, 0, 0.25, 0, 0, 0, 2};
    s.t = Vec3(1, 2, 3);
    const Affine si = s.inverse();
    EXPECT_DOUBLE_EQ(si.m[0], 2.0);
    EXPECT_DOUBLE_EQ(si.m[4], 4.0);
    EXPECT_DOUBLE_EQ(si.m[8], 0.5);
    expectNear(si.t, Vec3(-2, -8, -1.5), 1e-15);
}

TEST(Affine, SingularMapHasNoInverse)
{
    Affine flat;
    flat.m = {1, 0, 0, 0, 1, 0, 0, 0, 0};
    EXPECT_THROW(flat.inverse(), nebula::Error);
    Affine rank1;
    rank1.m = {1, 2, 3, 2, 4, 6, 3, 6, 9};
    EXPECT_THROW(rank1.inverse(), nebula::Error);
    Affine notANumber;
    notANumber.m[0] = NAN;
    EXPECT_THROW(notANumber.inverse(), nebula::Error);
}

// ---- SparseVolume --------------------------------------------------------------------------

TEST(SparseVolume, LatticeIndexingAndChannels)
{
    const SparseVolume empty;
    EXPECT_EQ(empty.voxelCount(), 0u);
    EXPECT_EQ(empty.channels(), 0);

    // x: -2..1 (bricks from -8 and 0), y: 3..7 (one brick), z: 10..15 (the brick from 8).
    SparseVolume v({-2, 3, 10}, {4, 5, 6}, 3);
    EXPECT_EQ(v.voxelCount(), 2u * SparseVolume::BRICK_VOXELS);
    EXPECT_EQ(v.channels(), 3);
    EXPECT_EQ(v.storedBricks(), 0u);
    // Every lattice point has its own index, point() inverts index(), and all read zero.
    std::vector<int> seen(v.voxelCount(), 0);
    for (int k = 10; k < 16; ++k)
        for (int j = 3; j < 8; ++j)
            for (int i = -2; i < 2; ++i) {
                const std::size_t idx = v.index(i, j, k);
                ASSERT_LT(idx, v.voxelCount());
                EXPECT_EQ(seen[idx]++, 0);
                EXPECT_EQ(v.point(idx), (std::array<int, 3>{i, j, k}));
                for (int c = 0; c < 3; ++c)
                    EXPECT_EQ(v.voxel(idx)[c], 0.0f);
            }
    // Brick-major: the bricks are aligned to multiples of 8 in index space, x fastest inside.
    EXPECT_EQ(v.index(-2, 3, 10), 6u + 3u * 8u + 2u * 64u);
    EXPECT_EQ(v.index(-1, 3, 10), v.index(-2, 3, 10) + 1u);
    EXPECT_EQ(v.index(0, 0 + 3, 10), SparseVolume::BRICK_VOXELS + 3u * 8u + 2u * 64u);
    // contains(): exactly the lattice [lo, lo + dims - 1].
    EXPECT_TRUE(v.contains(-2, 3, 10));
    EXPECT_TRUE(v.contains(1, 7, 15));
    EXPECT_FALSE(v.contains(-3, 3, 10));
    EXPECT_FALSE(v.contains(2, 3, 10));
    EXPECT_FALSE(v.contains(0, 8, 12));
    EXPECT_FALSE(v.contains(0, 5, 9));
    EXPECT_FALSE(v.contains(0, 5, 16));
    // A voxel's channels are adjacent; writing stores its brick only.
    float* q = v.writable(v.index(0, 5, 12));
    q[0] = 1.0f;
    q[1] = 2.0f;
    q[2] = 3.0f;
    EXPECT_EQ(v.storedBricks(), 1u);
    EXPECT_TRUE(v.stored(v.index(1, 7, 15)));
    EXPECT_FALSE(v.stored(v.index(-1, 5, 12)));
    EXPECT_EQ(v.voxel(v.index(-1, 5, 12))[0], 0.0f);
    const SparseVolume& cv = v;
    EXPECT_EQ(cv.voxel(v.index(0, 5, 12))[2], 3.0f);
    EXPECT_EQ(cv.voxel(v.index(1, 5, 12))[0], 0.0f);
    // Copies and channels keep the values and the sparsity.
    const SparseVolume copy = v;
    EXPECT_EQ(copy.storedBricks(), 1u);
    EXPECT_EQ(copy.voxel(copy.index(0, 5, 12))[1], 2.0f);
    const SparseVolume second = v.channel(1);
    EXPECT_EQ(second.channels(), 1);
    EXPECT_EQ(second.storedBricks(), 1u);
    EXPECT_EQ(second.voxel(second.index(0, 5, 12))[0], 2.0f);
    v.setZero();
    EXPECT_EQ(v.voxel(v.index(0, 5, 12))[1], 0.0f);
    EXPECT_EQ(copy.voxel(copy.index(0, 5, 12))[1], 2.0f);

    EXPECT_THROW(SparseVolume({0, 0, 0}, {0, 4, 4}, 1), nebula::Error);
    EXPECT_THROW(SparseVolume({0, 0, 0}, {4, 4, 4}, 0), nebula::Error);
    EXPECT_THROW(SparseVolume({0, 0, 0}, {4, -1, 4}, 1), nebula::Error);
    // More bricks than a volume can index: an error, nothing allocated.
    EXPECT_THROW(SparseVolume({0, 0, 0}, {1 << 30, 1 << 30, 1 << 30}, 1), nebula::Error);
}

TEST(SparseVolume, CellCornersAcrossBricksMatchTheVoxels)
{
    // Every cell, inside a brick or straddling up to 8 of them: the 8 corners' values.
    SparseVolume v({-9, -1, 5}, {20, 11, 13}, 2);
    for (int k = 5; k < 18; ++k)
        for (int j = -1; j < 10; ++j)
            for (int i = -9; i < 11; ++i) {
                if ((i * 7 + j * 3 + k) % 5 == 0) continue; // some bricks stay unstored
                float* q = v.writable(v.index(i, j, k));
                q[0] = float(i + 100 * j + 10000 * k);
                q[1] = -q[0];
            }
    for (int k = 5; k < 17; ++k)
        for (int j = -1; j < 9; ++j)
            for (int i = -9; i < 10; ++i) {
                const float* q[8];
                v.cellCorners(i, j, k, q);
                for (int c = 0; c < 8; ++c) {
                    const float* want =
                        v.voxel(v.index(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2)));
                    ASSERT_EQ(q[c][0], want[0]) << i << "," << j << "," << k << " corner " << c;
                    ASSERT_EQ(q[c][1], want[1]);
                }
            }
}

TEST(SparseVolume, MemoryFollowsTheBricksWritten)
{
    // A 512^3 lattice of 4 channels is 2 GiB dense; 64 bricks written cost 64 x 8 KiB and
    // the table (256 KiB), whatever the bounding box.
    rusage before{};
    ::getrusage(RUSAGE_SELF, &before);
    SparseVolume v({0, 0, 0}, {512, 512, 512}, 4);
    for (int b = 0; b < 64; ++b) {
        const int at = 8 * (b * 7 % 64);
        for (int k = 0; k < 8; ++k)
            for (int j = 0; j < 8; ++j)
                for (int i = 0; i < 8; ++i)
                    v.writable(v.index(at + i, 8 * b + j, 504 - 8 * (b % 3) + k))[0] = 1.0f;
    }
    EXPECT_EQ(v.storedBricks(), 64u);
    EXPECT_EQ(v.storedBytes(), 64u * 512u * 4u * 4u + 64u * 64u * 64u * 4u);
    // Reading every voxel, stored or not, costs no memory either.
    double sum = 0.0;
    for (int k = 0; k < 512; k += 3)
        for (int j = 0; j < 512; j += 5)
            for (int i = 0; i < 512; ++i)
                sum += v.voxel(v.index(i, j, k))[0];
    EXPECT_GT(sum, 0.0);
    rusage after{};
    ::getrusage(RUSAGE_SELF, &after);
    const double grownMiB = double(after.ru_maxrss - before.ru_maxrss) / 1024.0; // KiB -> MiB
    // Generous: huge pages round the bricks up to 2 MiB, and the process's peak may move with
    // other allocations; dense storage would add 2048 MiB.
    EXPECT_LT(grownMiB, 64.0);
}

TEST(SparseVolume, TrilinearSampleIsExactForMultilinearFields)
{
    // f = a + b x + c y + d z + e x y + g x y z (linear in each coordinate), two channels.
    const auto f0 = [](const Vec3& p) { return 2.0 + 0.5 * p.x - 0.25 * p.y + 0.125 * p.z; };
    const auto f1 = [](const Vec3& p) {
        return -1.0 + 0.1 * p.x * p.y + 0.01 * p.x * p.y * p.z + 0.3 * p.z;
    };
    SparseVolume v({-3, 2, -1}, {7, 6, 8}, 2);
    for (int k = -1; k < 7; ++k)
        for (int j = 2; j < 8; ++j)
            for (int i = -3; i < 4; ++i) {
                float* q = v.writable(v.index(i, j, k));
                q[0] = float(f0(Vec3(i, j, k)));
                q[1] = float(f1(Vec3(i, j, k)));
            }
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> ux(-3.0, 3.0 - 1e-9), uy(2.0, 7.0 - 1e-9),
        uz(-1.0, 6.0 - 1e-9);
    for (int n = 0; n < 2000; ++n) {
        const Vec3 p(ux(rng), uy(rng), uz(rng));
        float out[2];
        v.sample(p, out);
        EXPECT_NEAR(out[0], f0(p), 2e-5 * (1 + std::abs(f0(p)))) << p.x << " " << p.y << " " << p.z;
        EXPECT_NEAR(out[1], f1(p), 2e-5 * (1 + std::abs(f1(p)))) << p.x << " " << p.y << " " << p.z;
        EXPECT_EQ(v.sample0(p), out[0]);
        float one;
        v.sampleChannels(p, 1, 1, &one);
        EXPECT_EQ(one, out[1]);
    }
    // At an interior lattice point: the voxel's value itself.
    float out[2];
    v.sample(Vec3(0, 4, 3), out);
    EXPECT_EQ(out[0], v.voxel(v.index(0, 4, 3))[0]);
    EXPECT_EQ(out[1], v.voxel(v.index(0, 4, 3))[1]);
}

TEST(SparseVolume, ZeroOutsideTheLattice)
{
    SparseVolume v({0, 0, 0}, {4, 4, 4}, 3);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        for (int c = 0; c < 3; ++c)
            v.writable(i)[c] = 5.0f;
    for (const Vec3& p : {Vec3(-0.5, 1, 1), Vec3(1, -1e-9, 1), Vec3(1, 1, 3.5), Vec3(4, 1, 1),
                          Vec3(100, 100, 100), Vec3(-1e9, 0, 0)}) {
        float out[3] = {1, 1, 1};
        v.sample(p, out);
        EXPECT_EQ(out[0], 0.0f) << p.x << " " << p.y << " " << p.z;
        EXPECT_EQ(out[1], 0.0f);
        EXPECT_EQ(out[2], 0.0f);
        EXPECT_EQ(v.sample0(p), 0.0f);
    }
    // Inside, a constant field samples to the constant.
    float out[3];
    v.sample(Vec3(1.3, 2.7, 0.1), out);
    EXPECT_EQ(out[0], 5.0f);
    EXPECT_EQ(out[2], 5.0f);
}

TEST(SparseVolume, SampleZeroWithManyChannels)
{
    // More than 16 channels takes sample0()'s other path; same answer.
    SparseVolume v({0, 0, 0}, {3, 3, 3}, 20);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) {
        for (int c = 0; c < 20; ++c)
            v.writable(i)[c] = float(i) + 100.0f * float(c);
    }
    const Vec3 p(0.25, 1.5, 0.75);
    std::vector<float> all(20);
    v.sample(p, all.data());
    EXPECT_EQ(v.sample0(p), all[0]);
    for (int c = 1; c < 20; ++c)
        EXPECT_NEAR(all[std::size_t(c)], all[0] + 100.0f * c, 1e-3);
    float some[3];
    v.sampleChannels(p, 17, 3, some);
    for (int c = 0; c < 3; ++c)
        EXPECT_EQ(some[c], all[std::size_t(17 + c)]);
}

} // namespace

// The level of detail's halving: each voxel the mean of the 8 it covers (zeros off the
// lattice), on a lattice with a negative, odd corner and odd sizes, several channels; the
// sum of each channel over voxels times the voxel volume is kept (where the 8 are all on the
// lattice, and here the border is zero); the transform puts the half voxel at the centre of
// its 8; only bricks with data are stored.
TEST(SparseVolume, HalfResolutionIsTheMeanOfTheEightVoxelsItCovers)
{
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    SparseVolume v({-13, 4, -3}, {29, 21, 17}, 3);
    v.indexToWorld.m = {0.2, 0.05, 0, 0, 0.3, 0, 0.01, 0, 0.25};
    v.indexToWorld.t = Vec3(1, -2, 3);
    const auto& lo = v.lo();
    const auto& d = v.dims();
    for (int k = lo[2] + 1; k < lo[2] + d[2] - 1; ++k)
        for (int j = lo[1] + 1; j < lo[1] + 10; ++j) // the upper part of y stays empty
            for (int i = lo[0] + 1; i < lo[0] + d[0] - 1; ++i)
                for (int c = 0; c < 3; ++c)
                    v.writable(v.index(i, j, k))[c] = u(rng) * float(c + 1);
    const SparseVolume h = v.halfResolution();
    EXPECT_EQ(h.lo()[0], -8); // floor(-13 / 2), less a zero border
    EXPECT_EQ(h.lo()[1], 1);
    EXPECT_EQ(h.lo()[2], -3);
    EXPECT_EQ(h.dims()[0], 17); // .. floor(15 / 2) + 1
    double sumV[3] = {}, sumH[3] = {};
    for (int k = lo[2]; k < lo[2] + d[2]; ++k)
        for (int j = lo[1]; j < lo[1] + d[1]; ++j)
            for (int i = lo[0]; i < lo[0] + d[0]; ++i)
                for (int c = 0; c < 3; ++c)
                    sumV[c] += v.voxel(v.index(i, j, k))[c];
    for (int K = h.lo()[2]; K < h.lo()[2] + h.dims()[2]; ++K)
        for (int J = h.lo()[1]; J < h.lo()[1] + h.dims()[1]; ++J)
            for (int I = h.lo()[0]; I < h.lo()[0] + h.dims()[0]; ++I) {
                double mean[3] = {};
                for (int q = 0; q < 8; ++q) {
                    const int i = 2 * I + (q & 1), j = 2 * J + (q >> 1 & 1), k = 2 * K + (q >> 2);
                    if (!v.contains(i, j, k)) continue;
                    for (int c = 0; c < 3; ++c)
                        mean[c] += v.voxel(v.index(i, j, k))[c] / 8.0;
                }
                for (int c = 0; c < 3; ++c) {
                    const float got = h.voxel(h.index(I, J, K))[c];
                    ASSERT_NEAR(got, mean[c], 1e-6) << I << "," << J << "," << K;
                    sumH[c] += got;
                }
            }
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(8.0 * sumH[c], sumV[c], 1e-5 * sumV[c]);
    // Half voxel I sits at the centre of voxels 2I and 2I + 1.
    const Vec3 a = h.indexToWorld.apply(Vec3(3, 5, 1));
    const Vec3 b = v.indexToWorld.apply(Vec3(6.5, 10.5, 2.5));
    EXPECT_NEAR((a - b).length(), 0.0, 1e-12);
    // Of the half lattice's 2 x 2 x 2 bricks, the upper ones in y hold no data: 4 stored.
    EXPECT_EQ(h.storedBricks(), 4u);
    // The trilinear fields hold the same integral: sums of samples on a fine grid of points.
    double intV = 0.0, intH = 0.0;
    for (double z = -6; z < 16; z += 0.25)
        for (double y = 2; y < 26; y += 0.25)
            for (double x = -16; x < 18; x += 0.25) {
                float a[3], b[3];
                v.sample(Vec3(x, y, z), a);
                h.sample(Vec3((x - 0.5) / 2, (y - 0.5) / 2, (z - 0.5) / 2), b);
                intV += a[0];
                intH += b[0];
            }
    EXPECT_NEAR(intH, intV, 1e-4 * intV);
}
