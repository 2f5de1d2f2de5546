// SPDX-License-Identifier: Apache-2.0
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
void blockMaxima(const SparseVolume& v, std::array<int, 3>& blocks,
                 std::vector<std::array<float, 2>>& maxima);

/// The edge of a cube of a voxel's volume: cbrt |det M| of the index-to-world map [pc].
double voxelSize(const Affine& indexToWorld);

/// A ray through the occupancy blocks of a lattice, in index space, with world distance t
/// as its parameter: the renderers' block walk. It clips the ray to the lattice box, finds
/// the block holding a point of the ray and the distance at which the ray leaves that block.
/// The fast integrators step along it and skip empty blocks (Marcher); the path tracer
/// draws free flights against each block's majorant (path_tracer.cpp); nebscatter's flight
/// walk clips its rays with it and steps over half-voxel cells itself (DESIGN §9).
struct BlockRay
{
    Vec3 oI, dI;       ///< origin and direction in index space (dI: index units per pc)
    Vec3 boxLo, boxHi; ///< the lattice box [index]
    std::array<int, 3> blocks{0, 0, 0};
    double t0 = 0.0, t1 = -1.0; ///< the ray's part inside the box, t0 >= 0 [pc]

    /// The ray from world point @p oW along unit world direction @p dW, up to world distance
    /// @p tMax, through lattice @p v (world -> index map @p w2i) cut into @p blockCounts
    /// blocks of OCCUPANCY_BLOCK^3 cells.
    BlockRay(const SparseVolume& v, const Affine& w2i, const std::array<int, 3>& blockCounts,
             const Vec3& oW, const Vec3& dW, double tMax = std::numeric_limits<double>::infinity())
        : BlockRay(v, blockCounts, w2i.apply(oW), w2i.applyLinear(dW), tMax)
    {}

    /// The same with the origin and direction already in index space; the ray is clipped to
    /// the box grown by @p margin voxels every way (a level of detail reaches past the
    /// lattice), the blocks stay the lattice's.
    BlockRay(const SparseVolume& v, const std::array<int, 3>& blockCounts, const Vec3& originI,
             const Vec3& dirI, double tMax, double margin = 0.0)
        : oI(originI), dI(dirI), boxLo(v.lo()[0], v.lo()[1], v.lo()[2]),
          boxHi(v.lo()[0] + v.dims()[0] - 1, v.lo()[1] + v.dims()[1] - 1,
                v.lo()[2] + v.dims()[2] - 1),
          blocks(blockCounts)
    {
        t0 = 0.0;
        t1 = tMax;
        for (int a = 0; a < 3; ++a) {
            const double lo = boxLo[a] - margin, hi = boxHi[a] + margin;
            if (std::abs(dI[a]) < 1e-300) {
                if (oI[a] < lo || oI[a] > hi) t1 = -1.0;
                continue;
            }
            double ta = (lo - oI[a]) / dI[a], tb = (hi - oI[a]) / dI[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
    }

    /// Whether the ray meets the box.
    bool hits() const { return t0 < t1; }

    /// The block (linear index @p b) holding index point @p p; false outside the block grid.
    bool blockAt(const Vec3& p, int& b, int bb[3]) const
    {
        for (int a = 0; a < 3; ++a) {
            bb[a] = static_cast<int>(std::floor((p[a] - boxLo[a]) / OCCUPANCY_BLOCK));
            if (bb[a] < 0 || bb[a] >= blocks[a]) return false;
        }
        b = (bb[2] * blocks[1] + bb[1]) * blocks[0] + bb[0];
        return true;
    }
    /// The block-sized cell @p bb holding index point @p p (off the block grid too), the
    /// block of the grid nearest it, @p nearest (bb itself when it is on the grid), and
    /// that block's linear index (returned).
    int nearestBlock(const Vec3& p, int bb[3], int nearest[3]) const
    {
        for (int a = 0; a < 3; ++a) {
            bb[a] = static_cast<int>(std::floor((p[a] - boxLo[a]) / OCCUPANCY_BLOCK));
            nearest[a] = std::clamp(bb[a], 0, blocks[a] - 1);
        }
        return (nearest[2] * blocks[1] + nearest[1]) * blocks[0] + nearest[0];
    }

    /// World distance at which the ray leaves block @p bb (at most t1).
    double blockExit(const int bb[3]) const
    {
        double tExit = t1;
        for (int a = 0; a < 3; ++a) {
            if (std::abs(dI[a]) < 1e-300) continue;
            const double face = boxLo[a] + OCCUPANCY_BLOCK * (bb[a] + (dI[a] > 0 ? 1 : 0));
            tExit = std::min(tExit, (face - oI[a]) / dI[a]);
        }
        return tExit;
    }
};

/// Front-to-back stepping of one volume (level 0 or a pyramid level) along camera rays:
/// walks a BlockRay, skips empty occupancy blocks, and hands each step's midpoint (index
/// space), world distance and length to a callback.
struct Marcher
{
    const SparseVolume& vol;
    const std::array<int, 3>& blocks;
    const std::vector<std::uint8_t>& occupied;
    Affine w2i;
    Vec3 eyeI;
    Vec3 boxLo, boxHi; ///< the lattice box [index]
    double voxelWorld;

    Marcher(const SparseVolume& v, const std::array<int, 3>& b, const std::vector<std::uint8_t>& o,
            const Vec3& eye)
        : vol(v), blocks(b), occupied(o), w2i(v.indexToWorld.inverse()), eyeI(w2i.apply(eye)),
          boxLo(v.lo()[0], v.lo()[1], v.lo()[2]),
          boxHi(v.lo()[0] + v.dims()[0] - 1, v.lo()[1] + v.dims()[1] - 1,
                v.lo()[2] + v.dims()[2] - 1),
          voxelWorld(voxelSize(v.indexToWorld))
    {}

    /// Calls @p step(pI, tm, seg) for steps of @p stepVoxels voxels along world direction
    /// @p dW until it returns false; returns whether the ray met the box. (marchDetail() at
    /// level 0 does the same; this loop is kept apart because the level bookkeeping costs
    /// the default frame a few per cent.)
    template <class Step> bool march(const Vec3& dW, double stepVoxels, Step&& step) const
    {
        return marchFrom(eyeI, dW, stepVoxels, step);
    }
    /// march() from index-space point @p oI instead of the eye (the orthographic camera's
    /// parallel rays, each from its pixel on the eye's plane).
    template <class Step>
    bool marchFrom(const Vec3& oI, const Vec3& dW, double stepVoxels, Step&& step) const
    {
        const BlockRay ray(vol, blocks, oI, w2i.applyLinear(dW),
                           std::numeric_limits<double>::infinity());
        const double dt = stepVoxels / ray.dI.length();
        for (double t = ray.t0; t < ray.t1;) {
            const double seg = std::min(dt, ray.t1 - t);
            const double tm = t + 0.5 * seg;
            const Vec3 pI = ray.oI + ray.dI * tm;
            // Empty-space skipping: jump to the exit of an empty occupancy block.
            int b, bb[3];
            if (ray.blockAt(pI, b, bb) && !occupied[std::size_t(b)]) {
                t = std::max(ray.blockExit(bb), t + 1e-6 * dt);
                continue;
            }
            if (!step(pI, tm, seg)) break;
            t += seg;
        }
        return ray.hits();
    }
    /// march() with a level of detail: at ray distance t a pixel spans @p footprint * t
    /// [pc]; the step there is @p stepVoxels level-L voxels (2^L voxels), L the largest level
    /// up to @p maxLevel whose voxel spans at most @p lod pixels there and at most
    /// @p cap(t) (the caller's limit there, e.g. near a star), and @p step(pI, tm, seg, L)
    /// is told L. Empty space is skipped by `occupied` at level 0 and by @p reach (per block,
    /// the lowest level that may be non-zero there) above it. @p coarsest (per block; empty:
    /// no limit) caps L in the block holding the step's midpoint (the nearest block off the
    /// grid).
    template <class Cap, class Step>
    bool marchDetail(const Vec3& dW, double stepVoxels, double footprint, double lod, int maxLevel,
                     const std::vector<std::uint8_t>& reach,
                     const std::vector<std::uint8_t>& coarsest, Cap&& cap, Step&& step) const
    {
        // Level L spreads the dust by up to 1.5 x 2^L voxels, past the lattice too.
        const BlockRay ray(vol, blocks, eyeI, w2i.applyLinear(dW),
                           std::numeric_limits<double>::infinity(),
                           maxLevel > 0 ? 1.5 * double(1 << maxLevel) : 0.0);
        const double dt = stepVoxels / ray.dI.length();
        // The distance from which level L is used: where 2^L voxels span lod pixels.
        const double inf = std::numeric_limits<double>::infinity();
        const double perLevel = lod > 0.0 && footprint > 0.0 ? voxelWorld / (lod * footprint) : inf;
        int level = 0;
        double tNext = maxLevel > 0 ? 2.0 * perLevel : inf;
        for (double t = ray.t0; t < ray.t1;) {
            while (t >= tNext) {
                ++level;
                tNext = level < maxLevel ? perLevel * double(2 << level) : inf;
            }
            const int wanted = level ? std::min(level, int(cap(t))) : 0;
            int use = wanted;
            double seg = std::min(dt * double(1 << use), ray.t1 - t);
            Vec3 pI = ray.oI + ray.dI * (t + 0.5 * seg);
            int b, bb[3] = {0, 0, 0}, nearest[3];
            std::size_t near = use ? std::size_t(ray.nearestBlock(pI, bb, nearest)) : 0;
            while (use && !coarsest.empty() && coarsest[near] < use) {
                // Too coarse for this block's dust: the finer step, midpoint and block.
                use = coarsest[near];
                seg = std::min(dt * double(1 << use), ray.t1 - t);
                pI = ray.oI + ray.dI * (t + 0.5 * seg);
                near = std::size_t(ray.nearestBlock(pI, bb, nearest));
            }
            const double tm = t + 0.5 * seg;
            // Empty-space skipping: jump to the exit of an empty block. In the margin past the
            // lattice a level L > 0 is as empty as the nearest block (whose reach counts from
            // inside the lattice, so this errs towards sampling). Level 0 is zero off the
            // block grid; it is skipped there where `coarsest` refused a coarser level (the
            // block-sized cell bb: blockAt() writes the same cell as nearestBlock() did), and
            // not where the ray starts at level 0 (as before that limit, step for step).
            bool empty;
            if (use)
                empty = reach[near] > use;
            else if (ray.blockAt(pI, b, bb))
                empty = !occupied[std::size_t(b)];
            else
                empty = use < wanted;
            if (empty) {
                t = std::max(ray.blockExit(bb), t + 1e-6 * dt);
                continue;
            }
            if (!step(pI, tm, seg, use)) break;
            t += seg;
        }
        return ray.hits();
    }
};

} // namespace nebula
