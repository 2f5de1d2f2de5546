// SPDX-License-Identifier: Apache-2.0
/// @file test_block_walk.cpp
/// volume/block_walk.h: occupancy blocks (blockMaxima() against brute force), voxelSize()
/// of any affine map, and the Marcher's walk along a ray, whose steps cover the occupied
/// blocks of the lattice box and nothing else (against the chord lengths found by splitting
/// the ray at every block face).

#include "nebula/volume/block_walk.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

using nebula::Affine;
using nebula::OCCUPANCY_BLOCK;
using nebula::SparseVolume;
using nebula::Vec3;

namespace {

constexpr int B = OCCUPANCY_BLOCK;

/// A 2-channel volume with non-negative random values in a random subset of its lattice
/// points (the rest zero), so that some blocks are empty.
SparseVolume randomVolume(std::array<int, 3> lo, std::array<int, 3> dims, double fill,
                          unsigned seed)
{
    SparseVolume v(lo, dims, 2);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) {
        if (u(rng) < fill) v.writable(i)[0] = float(u(rng) * 10.0);
        if (u(rng) < fill) v.writable(i)[1] = float(u(rng) * 3.0);
    }
    return v;
}

/// Brute force: the largest value of each channel over the corners of every cell of each
/// block. Block b holds cells b B .. b B + B - 1 per axis, whose corners are the lattice
/// points b B .. b B + B (clipped to the lattice).
std::vector<std::array<float, 2>> bruteMaxima(const SparseVolume& v, std::array<int, 3>& blocks)
{
    for (int a = 0; a < 3; ++a)
        blocks[a] = (v.dims()[a] + B - 1) / B;
    std::vector<std::array<float, 2>> m(std::size_t(blocks[0]) * blocks[1] * blocks[2],
                                        {0.0f, 0.0f});
    const auto& lo = v.lo();
    for (int bk = 0; bk < blocks[2]; ++bk)
        for (int bj = 0; bj < blocks[1]; ++bj)
            for (int bi = 0; bi < blocks[0]; ++bi) {
                auto& out = m[(std::size_t(bk) * blocks[1] + bj) * blocks[0] + bi];
                for (int k = bk * B; k <= std::min(bk * B + B, v.dims()[2] - 1); ++k)
                    for (int j = bj * B; j <= std::min(bj * B + B, v.dims()[1] - 1); ++j)
                        for (int i = bi * B; i <= std::min(bi * B + B, v.dims()[0] - 1); ++i) {
                            const float* q = v.voxel(v.index(lo[0] + i, lo[1] + j, lo[2] + k));
                            out[0] = std::max(out[0], q[0]);
                            out[1] = std::max(out[1], q[1]);
                        }
            }
    return m;
}

std::vector<std::uint8_t> occupancy(const SparseVolume& v, std::array<int, 3>& blocks)
{
    std::vector<std::array<float, 2>> maxima;
    nebula::blockMaxima(v, blocks, maxima);
    std::vector<std::uint8_t> occ(maxima.size());
    for (std::size_t i = 0; i < maxima.size(); ++i) {
        occ[i] = maxima[i][0] > 0.0f || maxima[i][1] > 0.0f;
    }
    return occ;
}

Affine scaledRotated(double s, double angle, const Vec3& t)
{
    // Rotation about (1, 1, 1)/sqrt(3) by angle (Rodrigues), times s.
    const double c = std::cos(angle), sn = std::sin(angle), k = 1.0 / std::sqrt(3.0);
    const double x = k, y = k, z = k, C = 1 - c;
    Affine a;
    a.m = {s * (c + x * x * C),      s * (x * y * C - z * sn), s * (x * z * C + y * sn),
           s * (y * x * C + z * sn), s * (c + y * y * C),      s * (y * z * C - x * sn),
           s * (z * x * C - y * sn), s * (z * y * C + x * sn), s * (c + z * z * C)};
    a.t = t;
    return a;
}

// ---- blockMaxima --------------------------------------------------------------------------

TEST(BlockMaxima, MaxOfCornerValuesPerBlock)
{
    struct Case
    {
        std::array<int, 3> lo, dims;
        double fill;
    };
    // Block counts that divide the lattice evenly and not, dims - 1 a multiple of B (a last
    // block of corner points only), one block, sparse and dense.
    const Case cases[] = {
        {{0, 0, 0}, {19, 12, 26}, 0.02}, {{-5, 7, 100}, {17, 9, 8}, 0.05},
        {{3, -4, -9}, {8, 8, 8}, 0.3},   {{0, 0, 0}, {33, 5, 16}, 0.005},
        {{1, 1, 1}, {2, 2, 2}, 1.0},     {{0, 0, 0}, {24, 24, 24}, 0.0005},
    };
    unsigned seed = 10;
    for (const Case& c : cases) {
        const SparseVolume v = randomVolume(c.lo, c.dims, c.fill, seed++);
        std::array<int, 3> blocks{}, expectedBlocks{};
        std::vector<std::array<float, 2>> maxima;
        nebula::blockMaxima(v, blocks, maxima);
        const auto expected = bruteMaxima(v, expectedBlocks);
        EXPECT_EQ(blocks, expectedBlocks);
        ASSERT_EQ(maxima.size(), expected.size());
        for (std::size_t b = 0; b < maxima.size(); ++b) {
            EXPECT_EQ(maxima[b][0], expected[b][0]) << "block " << b << ", dims " << c.dims[0];
            EXPECT_EQ(maxima[b][1], expected[b][1]) << "block " << b << ", dims " << c.dims[0];
        }
    }
}

TEST(BlockMaxima, ALatticePointOnABlockFaceCountsForBothBlocks)
{
    // Point 8 is the corner shared by cell 7 (block 0) and cell 8 (block 1).
    SparseVolume v({0, 0, 0}, {20, 4, 4}, 2);
    v.writable(v.index(8, 1, 1))[0] = 4.0f;
    v.writable(v.index(3, 2, 2))[1] = 2.0f;
    std::array<int, 3> blocks{};
    std::vector<std::array<float, 2>> maxima;
    nebula::blockMaxima(v, blocks, maxima);
    EXPECT_EQ(blocks, (std::array<int, 3>{3, 1, 1}));
    ASSERT_EQ(maxima.size(), 3u);
    EXPECT_EQ(maxima[0][0], 4.0f);
    EXPECT_EQ(maxima[1][0], 4.0f);
    EXPECT_EQ(maxima[2][0], 0.0f);
    EXPECT_EQ(maxima[0][1], 2.0f);
    EXPECT_EQ(maxima[1][1], 0.0f);
}

// ---- voxelSize ----------------------------------------------------------------------------

TEST(VoxelSize, CubeRootOfTheDeterminant)
{
    Affine a;
    EXPECT_DOUBLE_EQ(nebula::voxelSize(a), 1.0);
    a.m = {0.25, 0, 0, 0, 0.25, 0, 0, 0, 0.25};
    a.t = Vec3(100, -3, 7); // the translation does not matter
    EXPECT_DOUBLE_EQ(nebula::voxelSize(a), 0.25);
    a.m = {0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.4}; // anisotropic: cbrt(0.008) = 0.2
    EXPECT_NEAR(nebula::voxelSize(a), 0.2, 1e-15);
    a.m = {-0.5, 0, 0, 0, 0.5, 0, 0, 0, 0.5}; // mirrored: negative determinant
    EXPECT_NEAR(nebula::voxelSize(a), 0.5, 1e-15);
    // Rotation does not change the volume of a voxel.
    for (double angle : {0.1, 0.7, 2.0, -1.3}) {
        EXPECT_NEAR(nebula::voxelSize(scaledRotated(0.37, angle, Vec3(1, 2, 3))), 0.37, 1e-14)
            << angle;
    }
    // A sheared map: det = product of the diagonal.
    a.m = {0.2, 0.5, -0.3, 0, 0.2, 0.9, 0, 0, 0.2};
    EXPECT_NEAR(nebula::voxelSize(a), 0.2, 1e-15);
}

// ---- Marcher ------------------------------------------------------------------------------

struct Step
{
    Vec3 pI;
    double tm, seg;
};

/// Lengths (world units) of the ray eye + t dW, t >= 0, inside the lattice box and inside
/// occupied blocks, found by splitting the ray at every block face and the box: the
/// reference for the Marcher. Also counts the occupied -> empty transitions (where a walk of
/// finite steps may over- or undershoot by half a step).
double occupiedChord(const nebula::Marcher& m, const Vec3& dW, int& exits, double& tFirst)
{
    const Vec3 dI = m.w2i.applyLinear(dW);
    std::vector<double> ts = {0.0};
    for (int a = 0; a < 3; ++a) {
        if (dI[a] == 0.0) continue;
        for (int f = 0; f <= m.blocks[a]; ++f) {
            const double plane = std::min(m.boxLo[a] + B * f, m.boxHi[a]);
            const double t = (plane - m.eyeI[a]) / dI[a];
            if (t > 0.0) ts.push_back(t);
        }
    }
    std::sort(ts.begin(), ts.end());
    double total = 0.0;
    bool previous = false;
    exits = 0;
    tFirst = -1.0;
    for (std::size_t i = 0; i + 1 < ts.size(); ++i) {
        const double a = ts[i], b = ts[i + 1];
        if (b - a < 1e-12) continue;
        const Vec3 p = m.eyeI + dI * (0.5 * (a + b));
        bool occ = false;
        bool inside = true;
        for (int k = 0; k < 3; ++k)
            inside = inside && p[k] >= m.boxLo[k] && p[k] <= m.boxHi[k];
        if (inside) {
            const int bi = int(std::floor(p.x - m.boxLo.x)) / B,
                      bj = int(std::floor(p.y - m.boxLo.y)) / B,
                      bk = int(std::floor(p.z - m.boxLo.z)) / B;
            occ = m.occupied[(std::size_t(bk) * m.blocks[1] + bj) * m.blocks[0] + bi] != 0;
        }
        if (occ) {
            total += b - a;
            if (tFirst < 0) tFirst = a;
        }
        if (previous && !occ) ++exits;
        previous = occ;
    }
    if (previous) ++exits;
    return total;
}

bool inOccupiedBlock(const nebula::Marcher& m, const Vec3& p)
{
    const int bi = int(std::floor(p.x - m.boxLo.x)) / B, bj = int(std::floor(p.y - m.boxLo.y)) / B,
              bk = int(std::floor(p.z - m.boxLo.z)) / B;
    if (bi < 0 || bj < 0 || bk < 0 || bi >= m.blocks[0] || bj >= m.blocks[1] || bk >= m.blocks[2]) {
        return false;
    }
    return m.occupied[(std::size_t(bk) * m.blocks[1] + bj) * m.blocks[0] + bi] != 0;
}

TEST(Marcher, StepsCoverExactlyTheOccupiedBlocks)
{
    // A lattice with a few occupied blocks, a scaled, rotated and shifted index-to-world map,
    // eyes outside and inside the box, random directions and the axes.
    SparseVolume v({-4, 2, 7}, {37, 29, 45}, 2);
    std::mt19937_64 rng(77);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 12; ++n) {
        // Fill the interior of a random block (away from its faces, so neighbours stay empty).
        const int bi = int(u(rng) * 4), bj = int(u(rng) * 3), bk = int(u(rng) * 5);
        for (int k = bk * B + 2; k < std::min(bk * B + 7, 45); ++k)
            for (int j = bj * B + 2; j < std::min(bj * B + 7, 29); ++j)
                for (int i = bi * B + 2; i < std::min(bi * B + 7, 37); ++i)
                    v.writable(v.index(-4 + i, 2 + j, 7 + k))[0] = 1.0f;
    }
    v.indexToWorld = scaledRotated(0.15, 0.6, Vec3(3, -1, 2));
    std::array<int, 3> blocks{};
    const auto occ = occupancy(v, blocks);
    ASSERT_GT(std::count(occ.begin(), occ.end(), 1), 3);
    ASSERT_LT(std::count(occ.begin(), occ.end(), 1), long(occ.size()));

    const Vec3 centre = v.indexToWorld.apply(Vec3(-4 + 18, 2 + 14, 7 + 22));
    std::vector<std::pair<Vec3, Vec3>> rays; // eye, unit world direction
    std::normal_distribution<double> g(0.0, 1.0);
    for (int n = 0; n < 300; ++n) {
        const Vec3 d = Vec3(g(rng), g(rng), g(rng)).normalized();
        // Outside, aimed near the centre.
        const Vec3 jitter(g(rng), g(rng), g(rng));
        rays.push_back({centre - d * 20.0 + jitter, d});
        // Inside the box.
        const Vec3 inside =
            v.indexToWorld.apply(Vec3(-4 + u(rng) * 36, 2 + u(rng) * 28, 7 + u(rng) * 44));
        rays.push_back({inside, d});
    }
    // Along the world axes (index direction not axis-aligned) and along index axes (world
    // direction of an index axis: one index component exactly 0).
    for (int a = 0; a < 3; ++a) {
        Vec3 e;
        e[a] = 1.0;
        rays.push_back({centre - e * 20.0, e});
        const Vec3 w = v.indexToWorld.applyLinear(e).normalized();
        rays.push_back({centre - w * 20.0, w});
    }

    int met = 0;
    for (const double stepVoxels : {0.25, 1.0}) {
        for (const auto& [eye, dW] : rays) {
            const nebula::Marcher m(v, blocks, occ, eye);
            std::vector<Step> steps;
            const bool hit = m.march(dW, stepVoxels, [&](const Vec3& pI, double tm, double seg) {
                steps.push_back({pI, tm, seg});
                return true;
            });
            int exits = 0;
            double tFirst = 0.0;
            const double chord = occupiedChord(m, dW, exits, tFirst);
            const Vec3 dI = m.w2i.applyLinear(dW);
            const double dt = stepVoxels / dI.length(); // a full step [world]
            double total = 0.0;
            for (std::size_t s = 0; s < steps.size(); ++s) {
                const Step& st = steps[s];
                // The step's midpoint: in the box, in an occupied block, on the ray.
                ASSERT_TRUE(inOccupiedBlock(m, st.pI)) << "step " << s;
                const Vec3 onRay = m.eyeI + dI * st.tm;
                ASSERT_NEAR((onRay - st.pI).length(), 0.0, 1e-9);
                ASSERT_GT(st.seg, 0.0);
                ASSERT_LE(st.seg, dt * (1 + 1e-12));
                ASSERT_GE(st.tm - 0.5 * st.seg, -1e-12);
                // In order, never overlapping.
                if (s > 0) {
                    const Step& p = steps[s - 1];
                    ASSERT_GE(st.tm - 0.5 * st.seg, p.tm + 0.5 * p.seg - 1e-9 * dt) << "step " << s;
                }
                total += st.seg;
            }
            // Total length = the chord through occupied blocks, up to a step where the walk
            // leaves an occupied block: the step straddling a face is kept or skipped by its
            // midpoint, so it may run up to half a step into an empty block, or leave up to
            // half a step of the occupied one out (a sliver of empty block shorter than a
            // step between two occupied ones can be stepped over whole).
            EXPECT_NEAR(total, chord, dt * exits + 1e-9)
                << "step " << stepVoxels << ", exits " << exits;
            if (chord > 0.0) {
                ++met;
                EXPECT_TRUE(hit);
            }
            // A ray that only grazes occupied blocks (slivers shorter than half a step) may
            // take no step; one through more than that takes some, and one through none
            // takes none.
            if (chord > dt * exits) {
                EXPECT_FALSE(steps.empty());
            }
            if (chord == 0.0) {
                EXPECT_TRUE(steps.empty());
            }
            // Every point of the ray that lies in an occupied block, more than half a step
            // from its faces, is inside some step.
            for (int n = 0; n < 50; ++n) {
                const double t = u(rng) * (chord > 0 ? tFirst + chord + 60.0 : 60.0);
                const Vec3 p = m.eyeI + dI * t;
                bool nearFace = false;
                for (int k = 0; k < 3; ++k) {
                    if (p[k] < m.boxLo[k] || p[k] > m.boxHi[k]) nearFace = true; // outside
                    const double r = std::fmod(p[k] - m.boxLo[k], double(B));
                    const double margin = 0.5 * stepVoxels + 1e-6;
                    if (r < margin || r > B - margin) nearFace = true;
                }
                if (nearFace || !inOccupiedBlock(m, p)) continue;
                const bool covered = std::any_of(steps.begin(), steps.end(), [&](const Step& st) {
                    return t >= st.tm - 0.5 * st.seg - 1e-12 && t <= st.tm + 0.5 * st.seg + 1e-12;
                });
                EXPECT_TRUE(covered) << "t = " << t;
            }
        }
    }
    EXPECT_GT(met, 100); // most rays cross an occupied block
}

TEST(Marcher, FullyOccupiedBoxIsTheClippedChord)
{
    // Every block occupied: the steps cover the whole segment of the ray in the box, exactly,
    // in full steps but the last.
    SparseVolume v({0, 0, 0}, {17, 17, 17}, 2);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        v.writable(i)[1] = 1.0f;
    v.indexToWorld.m = {0.5, 0, 0, 0, 0.5, 0, 0, 0, 0.5};
    std::array<int, 3> blocks{};
    const auto occ = occupancy(v, blocks);
    const nebula::Marcher m(v, blocks, occ, Vec3(-3.0, 4.0, 4.0));
    std::vector<Step> steps;
    EXPECT_TRUE(m.march(Vec3(1, 0, 0), 0.5, [&](const Vec3& pI, double tm, double seg) {
        steps.push_back({pI, tm, seg});
        return true;
    }));
    // Box [0, 8] pc along x, entered at t = 3 pc: 16 voxels of 0.5 pc in steps of 0.25 pc.
    ASSERT_EQ(steps.size(), 32u);
    EXPECT_NEAR(steps.front().tm, 3.125, 1e-12);
    EXPECT_NEAR(steps.back().tm, 10.875, 1e-9);
    double total = 0.0;
    for (const auto& s : steps) {
        EXPECT_NEAR(s.seg, 0.25, 1e-9);
        total += s.seg;
    }
    EXPECT_NEAR(total, 8.0, 1e-9);
    // The index-space midpoints run along the x axis at y = z = 8.
    EXPECT_NEAR(steps[5].pI.x, 2 * (steps[5].tm - 3.0), 1e-9);
    EXPECT_NEAR(steps[5].pI.y, 8.0, 1e-12);
}

TEST(Marcher, MissStopAndEmptyVolume)
{
    SparseVolume v({0, 0, 0}, {17, 17, 17}, 2);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        v.writable(i)[0] = 1.0f;
    std::array<int, 3> blocks{};
    const auto occ = occupancy(v, blocks);
    int calls = 0;
    // A ray that misses the box: no steps, false.
    const nebula::Marcher outside(v, blocks, occ, Vec3(-5, -5, -5));
    EXPECT_FALSE(outside.march(Vec3(-1, 0, 0), 0.5, [&](const Vec3&, double, double) {
        ++calls;
        return true;
    }));
    // Parallel to an axis, outside the box's slab in another axis.
    EXPECT_FALSE(outside.march(Vec3(0, 0, 1), 0.5, [&](const Vec3&, double, double) {
        ++calls;
        return true;
    }));
    EXPECT_EQ(calls, 0);
    // The callback stops the walk by returning false.
    const nebula::Marcher m(v, blocks, occ, Vec3(-5, 8, 8));
    EXPECT_TRUE(m.march(Vec3(1, 0, 0), 0.5, [&](const Vec3&, double, double) {
        ++calls;
        return calls < 7;
    }));
    EXPECT_EQ(calls, 7);
    // No occupied block: the ray meets the box but takes no step.
    SparseVolume empty({0, 0, 0}, {17, 17, 17}, 2);
    std::array<int, 3> emptyBlocks{};
    const auto none = occupancy(empty, emptyBlocks);
    const nebula::Marcher e(empty, emptyBlocks, none, Vec3(-5, 8, 8));
    calls = 0;
    EXPECT_TRUE(e.march(Vec3(1, 0, 0), 0.5, [&](const Vec3&, double, double) {
        ++calls;
        return true;
    }));
    EXPECT_EQ(calls, 0);
}

} // namespace
