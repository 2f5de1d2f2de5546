#pragma once
/// @file export.h
/// nebexport's entry point: a FloatGrid as a dense float32 cube (FITS, .npy, HDF5) with its
/// geometry and unit, for other programs (DESIGN §10).

#include "nebula/core/run.h"
#include "nebula/io/cube_io.h"
#include "nebula/io/grid_io.h"

#include <optional>
#include <string>

namespace nebula {

struct ExportOptions
{
    std::string grid = "density";     ///< the FloatGrid written
    std::string output;               ///< the file ("-" stdout, with --format)
    std::optional<CubeFormat> format; ///< nullopt: from the output's extension
    /// The index box written: "auto" (the cube the grid was imported from, else "active"),
    /// "active" (the active voxels' bounding box), or "I0,J0,K0,I1,J1,K1" (inclusive).
    std::string bbox = "auto";
    std::string dataset; ///< HDF5 dataset path; "" = "/<grid>"

    /// Throws UsageError naming the option (a bad --bbox, an unknown format).
    void validate() const;
};

/// The index box of --bbox @p text for @p grid: min and max (inclusive). Throws UsageError
/// (syntax, min > max) or Error (an empty grid with "active").
std::array<std::array<int, 3>, 2> exportBox(const openvdb::FloatGrid& grid,
                                            const std::string& text);

/// The unit a cube of grid @p grid is in, as FITS BUNIT writes it: density -> "cm-3",
/// tau -> "", temperature -> "K", emission -> "Lsun pc-3 sr-1", else the grid's `units`.
std::string cubeUnit(const openvdb::GridBase& grid);

/// Writes grid opts.grid of @p grids over the box as a dense float32 cube to opts.output:
/// voxel (x, y, z) of the box at array index [x, y, z] (DESIGN §10), its geometry (a FITS
/// WCS equal to the one it was imported with where the transform still matches it, else
/// CTYPE X/Y/Z in pc; HDF5 attributes voxel_size_pc, origin_pc), its unit, the history. A
/// rotated or sheared transform, a missing grid, or a cube the machine cannot hold in memory
/// (FITS, HDF5: checked before allocating) are refused.
void exportCube(const GridSet& grids, const ExportOptions& opts, const Run& run);

} // namespace nebula
