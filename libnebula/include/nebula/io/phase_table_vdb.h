// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file phase_table_vdb.h
/// The phase table as grids (DESIGN §2, §4): `phase` (Phi), `phase.error` (its standard
/// error) and `phase.single` (its single-scattering part), FloatGrids in index space (identity
/// transform) with voxel (i, j, 0) = mu bin i, t row j. The axes, the medium and the Monte Carlo
/// settings are metadata of `phase`.

#include "nebula/io/grid_io.h"
#include "nebula/physics/phase_table.h"

namespace nebula {

inline constexpr const char* PHASE_GRID = "phase";
inline constexpr const char* PHASE_ERROR_GRID = "phase.error";
inline constexpr const char* PHASE_SINGLE_GRID = "phase.single";
/// Value of the `table` metadata that marks a grid as nebphase's table.
inline constexpr const char* PHASE_TABLE_KIND = "nebula effective phase function";

/// Adds (replaces) the two grids of @p table to @p grids.
void addPhaseTable(GridSet& grids, const PhaseTable& table);

/// Reads the table of @p grids. Throws Error naming grids.source and the grid or metadata
/// field on anything missing, mistyped or inconsistent (not a phase table, axes missing,
/// t range reversed, voxels outside the axes, albedo outside [0, 1], |g| >= 1, zero photons,
/// negative or non-finite values).
PhaseTable readPhaseTable(const GridSet& grids);

} // namespace nebula
