// SPDX-License-Identifier: Apache-2.0
// nebscatter's adaptive cells turned back into cells (render/scatter_reconstruct.h, DESIGN §5b
// "Adaptive cells"): a cell of a block tallied whole is its block's value plus limited slopes
// times its offset. Checked against closed forms on small block lattices: a linear field is
// reproduced exactly, the eight cells keep their block's mean, extremes and blocks without a
// neighbour stay flat, and a steep side limits the slope to twice the gentle one.
#include "scatter_reconstruct.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

using namespace nebula::detail;

namespace {

/// Blocks on a lattice of @p dims blocks from absolute block @p lo, every block with active
/// cells, @p per values each: value(B, q) for B relative to lo.
FieldBlocks blockLattice(const std::array<int, 3>& lo, const std::array<int, 3>& dims,
                         std::size_t per,
                         const std::function<double(const std::array<int, 3>&, std::size_t)>& value)
{
    FieldBlocks b;
    b.lo = lo;
    b.dims = dims;
    b.per = per;
    for (int z = 0; z < dims[2]; ++z)
        for (int y = 0; y < dims[1]; ++y)
            for (int x = 0; x < dims[0]; ++x) {
                b.index.push_back(std::int32_t(b.index.size()));
                for (std::size_t q = 0; q < per; ++q)
                    b.value.push_back(value({x, y, z}, q));
            }
    return b;
}

/// The eight cells of block @p B (relative to the lattice's lo), reconstructed: cell
/// (dx, dy, dz) in {0, 1}^3 at [dx + 2 dy + 4 dz], @p per values each.
std::vector<std::vector<float>> cellsOf(const FieldBlocks& b, const std::array<int, 3>& B)
{
    std::vector<std::vector<float>> cells(8, std::vector<float>(b.per));
    for (int c = 0; c < 8; ++c) {
        const int X[3] = {2 * (B[0] + b.lo[0]) + (c & 1), 2 * (B[1] + b.lo[1]) + (c >> 1 & 1),
                          2 * (B[2] + b.lo[2]) + (c >> 2)};
        reconstructCell(b, X, cells[std::size_t(c)].data());
    }
    return cells;
}

} // namespace

TEST(ScatterReconstruct, LinearFieldIsExactInsideTheLattice)
{
    // v = a_q + g_q . B with integer a and g: every value and offset is exact in binary, so
    // the central difference is g and a cell at B + (+-1/4) is a_q + g_q . (B +- 1/4) exactly.
    // The lattice starts at a negative block (cells -2 and -1 are block -1).
    const std::array<int, 3> lo = {-1, 0, 3}, dims = {4, 4, 4};
    const double a[2] = {40.0, -7.0};
    const double g[2][3] = {{1.0, -2.0, 3.0}, {-4.0, 0.5, 2.0}};
    const auto linear = [&](const std::array<double, 3>& p, std::size_t q) {
        return a[q] + g[q][0] * p[0] + g[q][1] * p[1] + g[q][2] * p[2];
    };
    const FieldBlocks b =
        blockLattice(lo, dims, 2, [&](const std::array<int, 3>& B, std::size_t q) {
            return linear({double(B[0]), double(B[1]), double(B[2])}, q);
        });
    int checked = 0;
    for (int z = 1; z <= 2; ++z)
        for (int y = 1; y <= 2; ++y)
            for (int x = 1; x <= 2; ++x) {
                const auto cells = cellsOf(b, {x, y, z});
                for (int c = 0; c < 8; ++c) {
                    const std::array<double, 3> p = {x + ((c & 1) ? 0.25 : -0.25),
                                                     y + ((c >> 1 & 1) ? 0.25 : -0.25),
                                                     z + ((c >> 2) ? 0.25 : -0.25)};
                    for (std::size_t q = 0; q < 2; ++q) {
                        EXPECT_EQ(cells[std::size_t(c)][q], float(linear(p, q)))
                            << "block " << x << "," << y << "," << z << " cell " << c;
                        ++checked;
                    }
                }
            }
    EXPECT_EQ(checked, 8 * 8 * 2);
}

TEST(ScatterReconstruct, EightCellsKeepTheirBlocksMean)
{
    // Arbitrary values (a fixed pseudo-random pattern): the offsets +-1/4 cancel over the
    // eight cells whatever the limited slopes are, so their mean is the block's value.
    const FieldBlocks b =
        blockLattice({0, 0, 0}, {3, 3, 3}, 3, [](const std::array<int, 3>& B, std::size_t q) {
            const unsigned h = unsigned(B[0] * 73856093) ^ unsigned(B[1] * 19349663) ^
                               unsigned(B[2] * 83492791) ^ unsigned(q * 2654435761u);
            return double(h % 1000u) / 10.0 + 1.0;
        });
    for (int z = 0; z < 3; ++z)
        for (int y = 0; y < 3; ++y)
            for (int x = 0; x < 3; ++x) {
                const auto cells = cellsOf(b, {x, y, z});
                const std::size_t row = std::size_t(b.row(std::array<int, 3>{x, y, z}.data()));
                for (std::size_t q = 0; q < 3; ++q) {
                    double mean = 0.0;
                    for (const auto& c : cells)
                        mean += double(c[q]) / 8.0;
                    const double v = b.value[row * 3 + q];
                    EXPECT_NEAR(mean, v, 1e-6 * v) << x << "," << y << "," << z << " q " << q;
                }
            }
}

TEST(ScatterReconstruct, ExtremesEdgesAndMissingNeighboursStayFlat)
{
    // Along x: 1, 5, 2 (the middle block is a maximum); along y and z constant.
    FieldBlocks b =
        blockLattice({0, 0, 0}, {3, 3, 3}, 1, [](const std::array<int, 3>& B, std::size_t) {
            const double vx[3] = {1.0, 5.0, 2.0};
            return vx[B[0]];
        });
    for (const auto& c : cellsOf(b, {1, 1, 1}))
        EXPECT_EQ(c[0], 5.0f); // an extreme: no slope; y and z: no difference
    // A block on the lattice's edge has one neighbour along x: flat along x.
    for (const auto& c : cellsOf(b, {0, 1, 1}))
        EXPECT_EQ(c[0], 1.0f);
    // A neighbour without active cells (row -1) makes the axis flat too: with x values
    // 1, 2, 3 the middle block has slope 1 along x, and none once a neighbour is missing.
    b = blockLattice({0, 0, 0}, {3, 3, 3}, 1,
                     [](const std::array<int, 3>& B, std::size_t) { return 1.0 + B[0]; });
    const auto sloped = cellsOf(b, {1, 1, 1});
    EXPECT_EQ(sloped[0][0], 1.75f);                 // x - 1/4
    EXPECT_EQ(sloped[1][0], 2.25f);                 // x + 1/4
    b.index[(std::size_t(1) * 3 + 1) * 3 + 2] = -1; // block (2, 1, 1)
    for (const auto& c : cellsOf(b, {1, 1, 1}))
        EXPECT_EQ(c[0], 2.0f);
}

TEST(ScatterReconstruct, SteepSideLimitsTheSlopeToTwiceTheGentleOne)
{
    // Along z: 0, 1, 10. Central difference 5, but the monotonised limiter takes
    // min(5, 2 * 1, 2 * 9) = 2: the cells are 1 -+ 2/4, within [0, 10] and no new extreme.
    // Decreasing (10, 1, 0) gives the mirror image.
    for (const bool up : {true, false}) {
        const FieldBlocks b =
            blockLattice({5, -3, 0}, {3, 3, 3}, 1, [&](const std::array<int, 3>& B, std::size_t) {
                const double v[3] = {0.0, 1.0, 10.0};
                return up ? v[B[2]] : v[2 - B[2]];
            });
        const auto cells = cellsOf(b, {1, 1, 1});
        for (int c = 0; c < 8; ++c) {
            const bool upper = (c >> 2) != 0;
            const float expected = (upper == up) ? 1.5f : 0.5f;
            EXPECT_EQ(cells[std::size_t(c)][0], expected) << "cell " << c << " up " << up;
        }
    }
}
