// SPDX-License-Identifier: Apache-2.0
#include "nebula/volume/block_walk.h"

#include <algorithm>
#include <cmath>

namespace nebula {

void blockMaxima(const SparseVolume& v, std::array<int, 3>& blocks,
                 std::vector<std::array<float, 2>>& maxima)
{
    const int B = OCCUPANCY_BLOCK;
    for (int a = 0; a < 3; ++a)
        blocks[a] = (v.dims()[a] + B - 1) / B;
    maxima.assign(std::size_t(blocks[0]) * blocks[1] * blocks[2], {0.0f, 0.0f});
    const auto& lo = v.lo();
    const auto& d = v.dims();
    // The stored bricks' lattice points only: every other point is zero.
    v.forEachStoredBrick([&](std::size_t b) {
        const auto p0 = v.point(b);
        for (int z = 0; z < SparseVolume::BRICK; ++z)
            for (int y = 0; y < SparseVolume::BRICK; ++y)
                for (int x = 0; x < SparseVolume::BRICK; ++x) {
                    // Relative to lo.
                    const int i = p0[0] + x - lo[0], j = p0[1] + y - lo[1], k = p0[2] + z - lo[2];
                    if (i < 0 || j < 0 || k < 0 || i >= d[0] || j >= d[1] || k >= d[2]) continue;
                    const float* q = v.voxel(
                        b + std::size_t((z * SparseVolume::BRICK + y) * SparseVolume::BRICK + x));
                    if (q[0] <= 0.0f && q[1] <= 0.0f) continue;
                    // Point (i,j,k) is a corner of cells i-1..i per axis: block i/B, and also
                    // block i/B - 1 where i starts a block (cell i-1 ends the one before).
                    const int bi = i / B, bj = j / B, bk = k / B;
                    const int fi = (i % B == 0 && i > 0) ? 1 : 0,
                              fj = (j % B == 0 && j > 0) ? 1 : 0,
                              fk = (k % B == 0 && k > 0) ? 1 : 0;
                    for (int ck = bk - fk; ck <= bk; ++ck)
                        for (int cj = bj - fj; cj <= bj; ++cj)
                            for (int ci = bi - fi; ci <= bi; ++ci) {
                                if (ci >= blocks[0] || cj >= blocks[1] || ck >= blocks[2]) continue;
                                auto& m =
                                    maxima[(std::size_t(ck) * blocks[1] + cj) * blocks[0] + ci];
                                m[0] = std::max(m[0], q[0]);
                                m[1] = std::max(m[1], q[1]);
                            }
                }
    });
}

double voxelSize(const Affine& indexToWorld)
{
    const auto& m = indexToWorld.m;
    const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                       m[2] * (m[3] * m[7] - m[4] * m[6]);
    return std::cbrt(std::abs(det));
}

} // namespace nebula
