#pragma once
/// @file illumination.h
/// nebillum's entry point: a tau.<star> grid per star (DESIGN §2).

#include "nebula/cli.h"
#include "nebula/grid_io.h"
#include "nebula/optical_depth.h"

namespace nebula {

struct IllumOptions
{
    std::vector<Star> stars;    ///< replaces the input's nebula:stars when not empty
    DustParams dust;            ///< kappa_V converts column density to tau_V
};

/// Name of the optical-depth grid of star @p star.
inline std::string tauGridName(const std::string& star) { return "tau." + star; }

/// Adds (or replaces) tau.<star> for every star to @p grids, active on the density's active
/// voxels and their 26 neighbours (so every dusty lattice cell has tau at all 8 corners),
/// with the density's transform; exact (optical_depth.h); records stars and dust in the metadata. With --only-new, the
/// input grids are dropped. Throws Error on a missing or bad density grid or no stars.
void illuminate(GridSet& grids, const CommonOptions& common, const IllumOptions& opts,
                const Run& run);

} // namespace nebula
