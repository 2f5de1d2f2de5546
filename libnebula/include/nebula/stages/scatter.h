// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter.h
/// nebscatter's entry point: the scattered-light field (DESIGN §5b) as grids.

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/render/scatter_field.h"

#include <array>
#include <string>

namespace nebula {

/// nebscatter's field defaults: order L = 4 and the field level chosen from the grid
/// (autoFieldLevel()). The dense error-table scenes need both (README, "Accuracy").
inline ScatterOptions defaultStageFieldOptions()
{
    ScatterOptions o;
    o.order = 4;
    o.fieldLevel = AUTO_FIELD_LEVEL;
    o.refineTau = 1.0; // adaptive cells
    return o;
}

/// nebscatter's default --precision: every stored moment within 2^-8 (0.39 %) of its cell's
/// c_00, about a tenth of the noise of J at the default packets (DESIGN §5b "Stored
/// precision").
inline constexpr int DEFAULT_FIELD_BITS = 8;

/// nebscatter's options: the field's (ScatterOptions) and the scene's it is made from and
/// for (recorded in its metadata, ScatterFieldMeta).
struct ScatterStageOptions
{
    ScatterOptions field = defaultStageFieldOptions();
    ScatterSceneSettings scene;
    /// R, G, B wavelengths [nm]: the channels' extinction (nebrender's --wavelengths).
    std::array<double, 3> wavelengths{700.0, 546.1, 435.8};
    bool onlyNew = false; ///< write only the field grids
    /// The significant bits the stored moments keep (ScatterFieldMeta::storedBits,
    /// --precision): FIELD_FLOAT_BITS keeps the floats as computed.
    int storedBits = DEFAULT_FIELD_BITS;
    /// > 0: the starlight's field for nebrender --spectral at this many wavelengths
    /// (spectralFieldWavelengths()) instead of the R, G, B field.
    int spectral = 0;
};

/// Computes the field of @p grids (density, emission, tau.<star>, nebula:stars, nebula:dust)
/// and adds its grids, replacing any earlier field: per source ("stars", or "star_<name>"
/// with perStar, and "emission" when the input emits) and RGB channel, the FloatGrid
/// scatter.<source>.J.<c> (mean intensity of the collided light [L_sun pc^-2 sr^-1]) and,
/// for l = 1..L, scatter.<source>.c<l>_<m>.<c> (c_lm [L_sun pc^-2]), on field level k's
/// transform (nebpyramid's levelTransform()), active on the cells holding dust and their
/// neighbours; and the file metadata nebula:scatter (what the field was made for). With
/// opts.spectral = N: the stars' field at N wavelengths (computeSpectralScatterField()),
/// grids spectralScatterGridName() and metadata nebula:scatter_spectral, replacing only an
/// earlier spectral field (one file may hold both; an R, G, B field replaces only its own
/// grids too). Throws
/// Error on input nebrender would refuse (no stars, a tau grid missing) and UsageError on
/// bad options (validateScatterOptions()). A field level AUTO_FIELD_LEVEL is resolved by
/// autoFieldLevel() first (reported with -v); the result records the level used. Under
/// MPI (opts.field.ranks), only rank 0 adds the grids; the other ranks leave @p grids as
/// they are.
ScatterField scatter(GridSet& grids, const ScatterStageOptions& opts, const Run& run);

} // namespace nebula
