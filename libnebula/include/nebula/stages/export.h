// SPDX-License-Identifier: Apache-2.0
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
    std::string grid = "density";       ///< the FloatGrid written
    std::string output;                 ///< the file ("-" stdout, with --format)
    const CubeFormat* format = nullptr; ///< null: from the output's extension
    /// The index box written: "auto" (the cube the grid was imported from, else "active"),
    /// "active" (the active voxels' bounding box), or "I0,J0,K0,I1,J1,K1" (inclusive).
    std::string bbox = "auto";
    std::string dataset; ///< HDF5 dataset path; "" = "/<grid>"

    /// Throws UsageError naming the option (a bad --bbox, an unknown format).
    void validate() const;
};

/// What writing a cube costs, computed before the first byte (nebexport's bounds).
struct CubeCost
{
    double voxels = 0.0;        ///< dims[0] * dims[1] * dims[2] (a double: no wrap-around)
    double fileBytes = 0.0;     ///< the output's size: 4 bytes a voxel and the header [bytes]
    double memoryBytes = 0.0;   ///< the most the writer holds in memory [bytes]
    const char* memoryUse = ""; ///< what holds it, for the message
};

/// The room a cube's header takes in the file besides its HISTORY lines, at most (FITS
/// keywords padded to 2880-byte blocks, HDF5's attributes and tables, .npy's header) [bytes].
inline constexpr double CUBE_HEADER_BYTES = 1 << 20;

/// The cost of writing a float32 cube of @p dims as @p format with a header of at most
/// @p headerBytes: FITS and HDF5 are built in memory (the whole file; HDF5's is copied out
/// once more), .npy is streamed a z plane at a time.
CubeCost cubeCost(const CubeFormat& format, const std::array<std::int64_t, 3>& dims,
                  double headerBytes = CUBE_HEADER_BYTES);

/// Throws UsageError naming --bbox unless @p text is "auto", "active" or six integers
/// I0,J0,K0,I1,J1,K1 with each minimum <= its maximum (nebexport, nebstats).
void validateBbox(const std::string& text);

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
/// CTYPE X/Y/Z in pc; HDF5 attributes voxel_size_pc, origin_pc), its unit, the history.
/// Refused before the first byte and the first large allocation (Error; UsageError naming
/// --bbox where an explicit box made it so): a rotated or sheared transform, a missing grid,
/// a cube of more than MAX_CUBE_VOXELS, a file larger than its file system's free space
/// (freeDiskSpace(); not for stdout), a writer that would hold more than the machine's memory
/// (cubeCost()), and a NaN or infinite value the cube would hold (requireFinite() over the
/// box: the active values, the background, the inactive values in the box).
void exportCube(const GridSet& grids, const ExportOptions& opts, const Run& run);

} // namespace nebula
