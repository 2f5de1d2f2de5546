// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file pyramid.h
/// nebpyramid (DESIGN §5): multi-resolution levels of the density and the optical depths.
/// Level k averages 2^k x 2^k x 2^k voxels of level 0 (the box average, not OpenVDB's
/// MultiResGrid filter), so mass, the sum of n_H x voxel volume, is conserved exactly:
///     n_k(I) = 8^-k * sum over the block 2^k I .. 2^k I + 2^k - 1 of n_0   (inactive = 0)
/// and the coarse voxel I sits at the centre of its block: its centre is the level-0 index
/// point 2^k I + (2^k - 1)/2, mapped by the level-0 transform (any affine one).

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/physics/optical_depth.h"

#include <openvdb/openvdb.h>

#include <string>

namespace nebula {

/// How nebpyramid makes tau.<star>.L<k>.
enum class TauMethod {
    Recompute, ///< the exact integrator (as nebillum) through the coarse density
    Average    ///< the mean of the level-0 tau.<star> over each block
};

/// "recompute" / "average" <-> TauMethod. Throws UsageError naming --tau on anything else.
TauMethod tauMethodFromString(const std::string& name);
std::string toString(TauMethod method);

/// Every nebpyramid default.
struct PyramidOptions
{
    int levels = 3; ///< levels 1 .. levels are built (level 0 = input)
    TauMethod tau = TauMethod::Recompute;
    std::string densityGrid = "density"; ///< the dust density grid (n_H [cm^-3])
    bool onlyNew = false;                ///< write only the levels, not the input passed through
};

/// The transform of level @p level: the level-0 transform @p fine preceded by the index map
/// I -> 2^level I + (2^level - 1)/2, so a coarse voxel centre is the centre of its block of
/// level-0 voxels, for any affine @p fine (scaled, rotated, mirrored, anisotropic).
openvdb::math::Transform::Ptr levelTransform(const openvdb::math::Transform& fine, int level);

/// Floor division of index @p i by 2^@p level (the coarse voxel holding level-0 voxel i,
/// also for negative i).
inline openvdb::Int32 coarseIndex(openvdb::Int32 i, int level)
{
    return i >= 0 ? i / (1 << level) : -((-(i + 1)) / (1 << level)) - 1;
}

/// The box average of @p grid at level @p level >= 0 (the formula in this file's comment):
/// each coarse voxel is the sum of the level-0 active values (voxels and tiles) of its block
/// divided by 8^level, inactive voxels counting as 0; active where its block holds an active
/// voxel; transform levelTransform(); same name and grid class as @p grid, plus the metadata
/// level (int32), scale (int32 2^level) and source_grid (@p grid's name). Sums are in double
/// in a fixed order, so the result is the same whatever the thread count, and
/// sum n_k * 8^k equals sum n_0 up to float rounding.
openvdb::FloatGrid::Ptr boxAverage(const openvdb::FloatGrid& grid, int level);

/// Like boxAverage(), but each coarse voxel is the mean of the *active* level-0 values of
/// its block (for fields such as tau, whose inactive voxels are not zero but unknown).
openvdb::FloatGrid::Ptr activeMean(const openvdb::FloatGrid& grid, int level);

/// tau.<star>.L<level> by averaging: activeMean() of @p tau0 (the level-0 tau.<star>), made
/// active on the voxels where the recomputed one is (@p coarse's active voxels and their 26
/// neighbours, tauSupport() in stages/illuminate.h), so every dusty lattice cell has tau at its 8
/// corners. A voxel there whose block holds no level-0 tau (no dust within a voxel of it)
/// gets the exact tau of the level-0 density at its centre: kappa_V times @p column0 (over
/// the level-0 dense density) from @p star0 (level-0 index coordinates).
openvdb::FloatGrid::Ptr averageOpticalDepth(const openvdb::FloatGrid& tau0,
                                            const openvdb::FloatGrid& coarse, int level,
                                            const ColumnIntegrator& column0, const Vec3& star0,
                                            double kappa_V);

/// Mass of @p grid: the sum of its active values (voxels and tiles) times the voxel volume
/// |det| of its affine transform [value x pc^3; cm^-3 pc^3 for n_H], summed in double.
double gridMass(const openvdb::FloatGrid& grid);

/// The largest level at which @p bounds (a density's active bounding box) is still at least
/// 2 coarse voxels across its longest axis: 2^(level+1) <= longest extent. -1 if @p bounds
/// is empty or 1 voxel across.
int maxPyramidLevel(const openvdb::CoordBBox& bounds);

/// Adds (or replaces) <density>.L<k> and tau.<star>.L<k> for k = 1 .. opts.levels to
/// @p grids, for every star of the file's nebula:stars, with the dust (kappa_V) of its
/// nebula:dust. The density is opts.densityGrid. tau.<star>.L<k> by opts.tau: Recompute
/// runs addOpticalDepths() (stages/illuminate.h) on <density>.L<k>; Average is
/// averageOpticalDepth() of the level-0 tau.<star>; either way active on the coarse
/// density's active voxels and their 26 neighbours. Each tau grid carries the metadata star,
/// kappa_V, level, scale and method. With opts.onlyNew the input grids are dropped.
/// Throws UsageError for opts.levels < 1 or too large (maxPyramidLevel()); Error for a
/// missing, non-FloatGrid, non-affine, empty, NaN or negative density, no stars, a bad
/// nebula:dust, or (Average) a missing or unusable level-0 tau grid.
void buildPyramid(GridSet& grids, const PyramidOptions& opts, const Run& run);

} // namespace nebula
