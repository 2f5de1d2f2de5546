#pragma once
/// @file block_walk.h
/// Occupancy blocks over a dense volume and the walk along rays that skips the empty ones,
/// shared by the integrators (DESIGN §9).

#include "nebula/volume/volume.h"

#include <array>
#include <cstdint>
#include <vector>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nebula {

/// Edge of an occupancy block, in lattice cells.
inline constexpr int OCCUPANCY_BLOCK = 8;

/// Per block of OCCUPANCY_BLOCK^3 lattice cells: the largest channel 0 (density) and
/// channel 1 (emission) at the corners of its cells, i.e. the largest values the trilinear
/// fields take in the block (occupancy, and the path tracer's majorant).
void blockMaxima(const DenseVolume& v, std::array<int, 3>& blocks,
                 std::vector<std::array<float, 2>>& maxima);

/// The edge of a cube of a voxel's volume: cbrt |det M| of the index-to-world map [pc].
double voxelSize(const Affine& indexToWorld);

/// Front-to-back stepping of one volume (level 0 or a pyramid level) along camera rays:
/// clips to the lattice box, skips empty occupancy blocks, and hands each step's midpoint
/// (index space), world distance and length to a callback.
struct Marcher
{
    const DenseVolume& vol;
    const std::array<int, 3>& blocks;
    const std::vector<std::uint8_t>& occupied;
    Affine w2i;
    Vec3 eyeI, boxLo, boxHi;
    double voxelWorld;

    Marcher(const DenseVolume& v, const std::array<int, 3>& b, const std::vector<std::uint8_t>& o,
            const Vec3& eye)
        : vol(v), blocks(b), occupied(o), w2i(v.indexToWorld.inverse()), eyeI(w2i.apply(eye)),
          boxLo(v.lo()[0], v.lo()[1], v.lo()[2]),
          boxHi(v.lo()[0] + v.dims()[0] - 1, v.lo()[1] + v.dims()[1] - 1,
                v.lo()[2] + v.dims()[2] - 1),
          voxelWorld(voxelSize(v.indexToWorld))
    {}

    /// Calls @p step(pI, tm, seg) for steps of @p stepVoxels voxels along world direction
    /// @p dW until it returns false; returns whether the ray met the box.
    template <class Step> bool march(const Vec3& dW, double stepVoxels, Step&& step) const
    {
        const int B = OCCUPANCY_BLOCK;
        const Vec3 dI = w2i.applyLinear(dW);
        // Ray parameter t is world distance from the eye; clip to the lattice box.
        double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
            if (std::abs(dI[a]) < 1e-300) {
                if (eyeI[a] < boxLo[a] || eyeI[a] > boxHi[a]) t1 = -1.0;
                continue;
            }
            double ta = (boxLo[a] - eyeI[a]) / dI[a], tb = (boxHi[a] - eyeI[a]) / dI[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        const double dt = stepVoxels / dI.length();
        for (double t = t0; t < t1;) {
            const double seg = std::min(dt, t1 - t);
            const double tm = t + 0.5 * seg;
            const Vec3 pI = eyeI + dI * tm;
            // Empty-space skipping: jump to the exit of an empty occupancy block.
            const int bi = int(std::floor(pI.x - boxLo.x)) / B,
                      bj = int(std::floor(pI.y - boxLo.y)) / B,
                      bk = int(std::floor(pI.z - boxLo.z)) / B;
            if (bi >= 0 && bj >= 0 && bk >= 0 && bi < blocks[0] && bj < blocks[1] &&
                bk < blocks[2] && !occupied[(std::size_t(bk) * blocks[1] + bj) * blocks[0] + bi]) {
                double tExit = t1;
                const int bb[3] = {bi, bj, bk};
                for (int a = 0; a < 3; ++a) {
                    if (std::abs(dI[a]) < 1e-300) continue;
                    const double face = boxLo[a] + B * (bb[a] + (dI[a] > 0 ? 1 : 0));
                    tExit = std::min(tExit, (face - eyeI[a]) / dI[a]);
                }
                t = std::max(tExit, t + 1e-6 * dt);
                continue;
            }
            if (!step(pI, tm, seg)) break;
            t += seg;
        }
        return t0 < t1;
    }
};

} // namespace nebula
