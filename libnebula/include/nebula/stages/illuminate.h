// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file illuminate.h
/// nebillum's entry point: a tau.<star> grid per star (DESIGN §2).

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/physics/optical_depth.h"

namespace nebula {

struct IllumOptions
{
    std::vector<Star> stars;             ///< replaces the input's nebula:stars when not empty
    DustParams dust;                     ///< kappa_V converts column density to tau_V
    std::string densityGrid = "density"; ///< the dust density grid (n_H [cm^-3])
    bool onlyNew = false;                ///< write only the tau grids, not the input passed through
};

/// Where tau.<star> is written: the density's active voxels and their 26 neighbours, so every
/// lattice cell that touches dust has tau at all 8 corners and nebrender's trilinear tau is
/// exact there. The returned grid holds that topology (its values are the density's).
openvdb::FloatGrid::Ptr tauSupport(const openvdb::FloatGrid& density);

/// The active voxels of @p support on @p n's lattice as voxel indices (SparseVolume::index()),
/// for opticalDepthAt() (benchmarks and tests; nebillum writes tau straight into the grid).
std::vector<std::uint32_t> tauSupportPoints(const openvdb::FloatGrid& support,
                                            const SparseVolume& n);

/// Adds (or replaces) in @p products a FloatGrid tau.<star><suffix> per star: the exact
/// V-band optical depth (optical_depth.h, kappa_V from @p dust) of the trilinear @p density
/// from the star to each voxel of tauSupport(), with the density's transform, and the
/// metadata star, kappa_V, density_grid (@p density's name) and units. The tau computation
/// of illuminate(), for any density grid (nebpyramid runs it on the coarse levels with
/// @p suffix ".L<k>"). @p density must be affine with finite values >= 0; @p products'
/// source names it in errors. The progress bar is labelled "<tool> <star><suffix>".
void addOpticalDepths(GridSet& products, const openvdb::FloatGrid& density,
                      const std::vector<Star>& stars, const DustParams& dust,
                      const std::string& suffix, const Run& run);

/// Adds (or replaces) tau.<star> for every star to @p grids, active on the density's active
/// voxels and their 26 neighbours (so every dusty lattice cell has tau at all 8 corners),
/// with the density's transform; exact (optical_depth.h); records stars and dust in the metadata.
/// With opts.onlyNew, the input grids are dropped. Throws Error on a missing or bad density grid or
/// no stars.
void illuminate(GridSet& grids, const IllumOptions& opts, const Run& run);

} // namespace nebula
