#pragma once
/// @file star_depth.h
/// The optical depth from a star to any point, exact where trilinear interpolation of the
/// tau grid is not (DESIGN §3.3). nebillum's tau.<star> is exact at the lattice points; between
/// them the renderers interpolate it trilinearly, which is exact where the density is the same
/// at a cell's 8 corners but not where it changes within the cell: at the lit face of a cloud
/// whose voxels are optically thick, tau grows as the square of the depth inside the first
/// cell while the interpolation makes it grow linearly, too deep and too dark (a voxel of
/// optical depth 5 at the face loses 40 % of its once-scattered light). StarDepth integrates
/// the trilinear density exactly (physics/optical_depth.h) from the point towards the star
/// through such cells, one voxel at a time, until it reaches a cell where the interpolation is
/// right again (or the star, or the edge of the grid, or an optical depth past which no light
/// is left), and adds the interpolated tau there: a short characteristic.

#include "nebula/physics/optical_depth.h"
#include "nebula/render/scene.h"

#include <cstdint>
#include <vector>

namespace nebula {

class StarDepth
{
public:
    /// A lattice cell is "rough" when the V optical depth across one voxel changes by at least
    /// this much between its corners (kappa_V h (n_max - n_min)): trilinear tau is then off by
    /// up to about an eighth of it inside the cell.
    static constexpr double ROUGH = 0.05;
    /// Past this V optical depth from the point the march stops (e^-12: no light left).
    static constexpr double TAU_STOP = 12.0;
    /// At most this many voxels are marched (then the interpolated tau is taken).
    static constexpr int MAX_STEPS = 24;
    /// The march stops in a cell that is not rough and whose tau grid varies by less than
    /// this between its corners (where trilinear tau is right both along and across the
    /// star's light).
    static constexpr double SMOOTH_TAU = 0.1;

    /// For @p scene's density (channel 0 of its fields), kappa_V and stars, whose tau grids
    /// are channels 2 + s.
    explicit StarDepth(const RenderScene& scene);

    /// tau_V of star @p s at index point @p pI, where the trilinear tau grid gives
    /// @p tauInterp: @p tauInterp itself unless @p pI lies in a rough cell.
    double operator()(std::size_t s, const Vec3& pI, double tauInterp) const
    {
        return rough(pI) ? march(s, pI) : tauInterp;
    }

    /// Whether index point @p pI lies in a rough lattice cell.
    bool rough(const Vec3& pI) const
    {
        const int i = int(std::floor(pI.x)) - mLo[0], j = int(std::floor(pI.y)) - mLo[1],
                  k = int(std::floor(pI.z)) - mLo[2];
        if (i < 0 || j < 0 || k < 0 || i + 1 >= mDims[0] || j + 1 >= mDims[1] || k + 1 >= mDims[2])
            return false;
        return mRough[(std::size_t(k) * std::size_t(mDims[1]) + std::size_t(j)) *
                          std::size_t(mDims[0]) +
                      std::size_t(i)] != 0;
    }

    /// The exact march from @p pI (see the file comment).
    double march(std::size_t s, const Vec3& pI) const;

    /// The largest difference of star @p s's tau grid between the corners of the lattice cell
    /// holding @p pI (0 outside the grid).
    double tauSpread(std::size_t s, const Vec3& pI) const;

    /// The fraction of lattice cells that are rough.
    double roughFraction() const;

private:
    const RenderScene& mScene;
    DenseVolume mDensity; ///< channel 0 of the scene's fields (ColumnIntegrator's input)
    ColumnIntegrator mColumn;
    std::vector<std::uint8_t> mRough; ///< per lattice cell (lower corner's index)
    std::vector<Vec3> mStarI;         ///< star positions in index space
    std::array<int, 3> mLo{}, mDims{};
    double mKappa = 0.0;
};

} // namespace nebula
