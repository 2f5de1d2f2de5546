// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file star_depth.h
/// The optical depth from a star to any point, exact where trilinear interpolation of the
/// tau grid is not (DESIGN §3.3). nebillum's tau.<star> is exact at the lattice points; between
/// them the renderers interpolate it trilinearly, which is right where tau is close to linear
/// across a cell but not where it bends: at the lit face of a cloud whose voxels are optically
/// thick, tau grows as the square of the depth inside the first cell while the interpolation
/// makes it grow linearly, too deep and too dark (a voxel of optical depth 5 at the face loses
/// 30-46 % of its once-scattered light), and across the edge of a dense filament's shadow.
/// StarDepth marks, per star, the lattice cells where tau bends (a second difference of the
/// tau grid at one of the cell's corners of at least CURVED), integrates the trilinear density
/// exactly (physics/optical_depth.h) from a point in such a cell towards the star, one voxel at
/// a time, until it reaches a cell where tau does not bend (or the star, or the edge of the
/// grid, or an optical depth past which no light is left), and adds the interpolated tau there:
/// a short characteristic. The same test starts and stops the march, so the optical depth is
/// continuous across the cells' boundaries. The march never stops where the tau grids hold
/// no value (nebillum writes them on the dust and one voxel round it; elsewhere the dense
/// fields read 0): it crosses such gaps to the next cell with values, or leaves the grid.

#include "nebula/physics/optical_depth.h"
#include "nebula/render/scene.h"

#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

namespace nebula {

class StarDepth
{
public:
    /// A lattice cell is "curved" for a star when the tau grid's second difference along an
    /// axis, |tau(i-1) - 2 tau(i) + tau(i+1)|, is at least this at one of its corners:
    /// trilinear tau is then off by up to about an eighth of it inside the cell.
    static constexpr double CURVED = 0.1;
    /// Past this V optical depth from the point the march stops (e^-12: no light left).
    static constexpr double TAU_STOP = 12.0;
    /// At most this many voxels are marched (then the interpolated tau is taken).
    static constexpr int MAX_STEPS = 32;

    /// For @p scene's density (channel 0 of its fields), kappa_V and stars, whose tau grids
    /// are channels 2 + s.
    explicit StarDepth(const RenderScene& scene);

    /// tau_V of star @p s at index point @p pI, where the trilinear tau grid gives
    /// @p tauInterp: @p tauInterp itself unless @p pI lies in a curved cell.
    double operator()(std::size_t s, const Vec3& pI, double tauInterp) const
    {
        return curved(s, pI) ? march(s, pI) : tauInterp;
    }

    /// Whether index point @p pI lies in a lattice cell where star @p s's tau bends.
    bool curved(std::size_t s, const Vec3& pI) const
    {
        const std::size_t c = cellOf(pI);
        return c != NONE && (ensure(c), mCurved[s][c]);
    }

    /// Whether any star's tau bends in the cell of @p pI (the renderers' quick test).
    bool anyCurved(const Vec3& pI) const
    {
        const std::size_t c = cellOf(pI);
        return c != NONE && (ensure(c), mAny[c]);
    }

    /// The exact march from @p pI (see the file comment).
    double march(std::size_t s, const Vec3& pI) const;

    /// The fraction of lattice cells curved for star @p s (builds every brick's bits).
    double curvedFraction(std::size_t s) const;

private:
    static constexpr std::size_t NONE = ~std::size_t(0);
    /// Builds the bits of the cells of brick @p b (of the scene's fields) unless built: the
    /// first thread to ask builds them, any other waits for it.
    void build(std::size_t b) const;
    /// The bits of the brick of cell @p c, built.
    void ensure(std::size_t c) const
    {
        const std::size_t b = c / SparseVolume::BRICK_VOXELS;
        if (mBuilt[b].load(std::memory_order_acquire) != 2) build(b);
    }
    /// The voxel index (SparseVolume::index()) of the lower corner of the lattice cell
    /// holding @p pI, NONE outside.
    std::size_t cellOf(const Vec3& pI) const
    {
        const double x = std::floor(pI.x), y = std::floor(pI.y), z = std::floor(pI.z);
        if (!(x >= mLo[0] && y >= mLo[1] && z >= mLo[2] && x + 1 < mLo[0] + mDims[0] &&
              y + 1 < mLo[1] + mDims[1] && z + 1 < mLo[2] + mDims[2]))
            return NONE;
        return mScene.fields.index(int(x), int(y), int(z));
    }

    const RenderScene& mScene;
    const ColumnIntegrator& mColumn; ///< the scene's (RenderScene::column)
    // The bits are built brick by brick when a ray first asks for one of its cells (build()):
    // a frame pays only for the bricks its rays reach. Each brick's bits are 8 words of its
    // own, written once by the thread that builds it.
    /// Per brick: 0 not built, 1 being built, 2 built.
    std::unique_ptr<std::atomic<std::uint8_t>[]> mBuilt;
    std::size_t mBricks = 0;
    /// Per star: a bit per lattice cell (at the voxel index of its lower corner).
    mutable std::vector<VoxelBits> mCurved;
    mutable VoxelBits mAny; ///< a bit per lattice cell: any star
    /// A bit per lattice cell: its 8 corners lie within one voxel of dust (the tau grids
    /// hold values there).
    mutable VoxelBits mValid;
    std::vector<Vec3> mStarI; ///< star positions in index space
    std::array<int, 3> mLo{}, mDims{};
    double mKappa = 0.0;
};

} // namespace nebula
