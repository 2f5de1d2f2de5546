// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file framing.h
/// --frame-nebula (nebrender, nebview): the dust's framing target from the density grid, and
/// the camera framed on it (render/camera_framing.h holds the geometry and the rule).

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/render/camera_framing.h"

#include <string>

namespace nebula {

/// The dust of grid @p densityGrid of @p grids as a framing target: the centroid of its
/// positive active values weighted by value (mass: the voxels are equal), the radius about
/// it that holds FRAMING_MASS_FRACTION of the mass (to 1/8192 of the extent), the distance
/// to the farthest dusty voxel (an active tile counts as its value times its voxels at its
/// centre). Throws Error naming the file and the grid if it is missing, and UsageError
/// naming --frame-nebula, the file and the grid if no value in it is above 0 (no dust).
FramingTarget dustFramingTarget(const GridSet& grids, const std::string& densityGrid);

/// @p camera framed on dustFramingTarget() (frameCamera()); with -v a line with the target
/// and the camera chosen.
Camera frameNebula(const GridSet& grids, const std::string& densityGrid, const Camera& camera,
                   const FramingChoice& keep, const Run& run);

} // namespace nebula
