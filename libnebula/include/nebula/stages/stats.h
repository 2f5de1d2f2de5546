// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file stats.h
/// nebstats' entry point: a grid's column density along an axis and the statistics observers
/// measure on real clouds (physics/cloud_statistics.h; DESIGN §2b), with the 3-D PDF of
/// ln n.

#include "nebula/io/grid_io.h"
#include "nebula/physics/cloud_statistics.h"

#include <array>
#include <cstdint>
#include <string>

namespace nebula {

/// The longest edge of a column map nebstats measures [pixels]: its power spectrum is an
/// n x n FFT, its contours n x n labels, so that 8192 bounds the work (an 8192 x 8192 map of
/// four tiles: 46 s on a busy 2-core VM) and the memory (1.8 GB), whatever the file says.
inline constexpr std::int64_t MAX_MAP_EDGE = 8192;
/// The memory measuring a map takes per pixel of the square of its longer edge [bytes], with
/// room: the map, the FFT's input and output, the contours' masks, labels and sorted columns
/// (24 bytes), measured 28 with the rest of the process at 8192 x 8192.
inline constexpr double MAP_BYTES_PER_PIXEL = 32.0;

struct StatsOptions
{
    std::string grid = "density"; ///< the FloatGrid projected
    int axis = 2;                 ///< the line of sight: 0 x, 1 y, 2 z
    /// The index box projected: "auto", "active" or "I0,J0,K0,I1,J1,K1" (nebexport's --bbox).
    std::string bbox = "auto";
    /// The power spectrum's fitted k range [cycles per map edge]; 0: edge / 40 to edge / 4
    /// (a decade).
    double kMin = 0.0, kMax = 0.0;
    double binWidth = 0.1;  ///< the PDF's bins in ln N
    double pdfFloor = 0.25; ///< the PDF's pixels: N >= pdfFloor <N> (fitColumnPdf())
    int levels = 8;         ///< contour levels of the perimeter-area fit
    int minArea = 4;        ///< smallest contour fitted [pixels]

    /// Throws UsageError naming the option.
    void validate() const;
};

/// Everything nebstats measures.
struct CloudStats
{
    std::string grid;
    int axis = 2;
    std::array<std::array<int, 3>, 2> box{};  ///< the index box projected (inclusive)
    double voxelPc = 0.0;                     ///< voxel edge [pc]
    std::string columnUnit;                   ///< "cm^-2" for density, else "<units> pc"
    LogMoments volume;                        ///< ln of the grid's positive voxels in the box
    ColumnMap map;                            ///< the column along the axis
    double meanColumn = 0.0, maxColumn = 0.0; ///< over the pixels with a column > 0
    PdfFit pdf;
    SpectrumFit spectrum;
    PerimeterAreaFit contours;
};

/// The statistics of grid opts.grid of @p grids: its voxels summed along the axis over the box
/// times the voxel edge (N_H [cm^-2] for `density`, whose voxels are n_H [cm^-3]), and the
/// fits. The work follows the active voxels and the map, not the box's volume: an active tile
/// adds its value times its depth to each pixel of its face. Throws UsageError naming --grid,
/// --bbox (an inverted box; a map too large) or --k-range; Error naming the file and grid for
/// a map from the file's own box larger than MAX_MAP_EDGE or the machine's memory, and for a
/// NaN or infinite active value (requireFinite()).
CloudStats cloudStatistics(const GridSet& grids, const StatsOptions& opts);

/// The report nebstats prints: one line per figure, each with its method's parameters.
std::string statsReport(const CloudStats& stats);

/// The same as JSON (nebstats --json), with the ring power spectrum.
std::string statsJson(const CloudStats& stats);

} // namespace nebula
