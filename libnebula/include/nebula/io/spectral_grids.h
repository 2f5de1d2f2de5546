// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file spectral_grids.h
/// Reading the spectral grids (DESIGN §2, §7): an emission grid's lines, an absorption grid's
/// lines, the temperature grid and the velocity grid, with errors that name the file and grid.

#include "nebula/io/grid_io.h"
#include "nebula/physics/lines.h"

#include <string>
#include <vector>

namespace nebula {

/// The lines of the emission grid @p grid: its `nebula:lines` metadata parsed, or
/// @p fallback if it has none. Throws Error naming @p source and the grid if the metadata
/// is not a string or does not parse.
std::vector<SpectralLine> gridLines(const openvdb::GridBase& grid, const std::string& source,
                                    const std::vector<SpectralLine>& fallback);

/// The absorption lines of the absorption grid @p grid (its `nebula:absorption-lines`
/// metadata parsed, DESIGN §7.6). Throws Error naming @p source and the grid if it has no
/// such metadata, if it is not a string, or if it does not parse.
std::vector<SpectralLine> gridAbsorptionLines(const openvdb::GridBase& grid,
                                              const std::string& source);

/// The names of @p grids' absorption grids (isAbsorptionGridName()), in the file's order.
std::vector<std::string> absorptionGridNames(const GridSet& grids);

/// Throws Error naming @p source and the grid if any active temperature value is negative,
/// NaN or infinite.
void requireValidTemperature(const openvdb::FloatGrid& grid, const std::string& source);

/// The Vec3fGrid @p name of @p grids (a velocity [km/s] in world axes). Throws Error naming
/// the source and grid (and @p option, e.g. "--velocity-grid") if it is missing, of another
/// type (saying which, and that a Vec3fGrid [km/s] is expected), has a non-affine
/// transform, or has a non-finite active value or background.
openvdb::Vec3fGrid::Ptr velocityGrid(const GridSet& grids, const std::string& name,
                                     const std::string& option);

} // namespace nebula
