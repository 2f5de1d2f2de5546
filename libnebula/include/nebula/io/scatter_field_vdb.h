// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_field_vdb.h
/// nebscatter's field as grids (DESIGN §5b), written and read here only: per source, per
/// moment (l, m) of degree l <= order and per channel, one FloatGrid on the field level's
/// transform (cells of 2^level voxels, level >= -1) named by scatterGridName() (R, G, B) or
/// spectralScatterGridName() (a spectral field), active on the cells the renderer reads;
/// the l = 0 grids hold the mean intensity J, the others c_lm. What the field was made for
/// (dust, stars, wavelengths, grids, level 0's transform) is ScatterFieldMeta, the JSON of
/// the file metadata `nebula:scatter` (`nebula:scatter_spectral`).

#include "nebula/io/grid_io.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/stars.h"
#include "nebula/volume/volume.h"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// One source's Monte Carlo summary (nebscatter -v, the README's error figures).
struct ScatterSourceSummary
{
    std::string name; ///< "stars", "star_<name>" (--per-star) or "emission"
    std::uint64_t packets = 0;
    std::uint64_t flights = 0;
    std::vector<double> power, escaped, absorbed; ///< per channel [L_sun]
    double relativeError = 0.0;
};

/// The field levels (cells of 2^level voxels): level -1's cells are half a voxel across, the
/// finest the walk's half-voxel lattice resolves (optically thick voxels, DESIGN §5b).
inline constexpr int MIN_FIELD_LEVEL = -1;
inline constexpr int MAX_FIELD_LEVEL = 16;

/// A field level's cell edge in voxels, as text: "4", "1", "1/2".
inline std::string fieldCellVoxels(int level)
{
    const long long k = level; // -level of INT_MIN would overflow an int
    return k >= 0 ? std::to_string(1LL << std::min(k, 62LL))
                  : "1/" + std::to_string(1LL << std::min(-k, 62LL));
}

/// What a field was made for, and how.
struct ScatterFieldMeta
{
    int order = 0; ///< highest spherical-harmonic degree, 0..SH_MAX_DEGREE
    int level = 0; ///< field level: cells of 2^level voxels, MIN_FIELD_LEVEL..MAX_FIELD_LEVEL
    bool perStar = false;
    std::uint64_t packets = 0;
    std::uint64_t seed = 0;
    /// Adaptive cells' --refine-tau (0: uniform cells; fields from before adaptive cells).
    double refineTau = 0.0;
    std::vector<ScatterSourceSummary> sources;
    DustParams dust;
    std::vector<Star> stars;
    /// R, G, B: 3 channel wavelengths; a spectral field: at least 2, increasing [nm].
    std::vector<double> wavelengths;
    double minStarDistance = 0.0;
    bool exactStarDepth = false;
    std::string densityGrid, emissionGrid;
    Affine indexToWorld; ///< level 0's (the density grid's) index-to-world map
    double seconds = 0.0;
};

/// The metadata key of a field of the kind: META_SCATTER or META_SCATTER_SPECTRAL.
const char* scatterMetaKey(bool spectral);

/// Replaces any field of the kind (R, G, B or @p spectral) in @p grids by this one:
/// moments[s] (shCount(meta.order) x meta.wavelengths.size() channels, channel
/// shIndex(l, m) * C + c, the l = 0 one holding c_00 = 4 pi Y_00 J) becomes source s's grids,
/// written on the cells where @p active is 1 (one byte per cell of the moments'
/// lattice, x fastest, then y, then z),
/// on @p fieldTransform; @p meta becomes the file metadata.
void writeScatterField(GridSet& grids, const ScatterFieldMeta& meta,
                       const std::vector<const SparseVolume*>& moments,
                       const std::vector<std::uint8_t>& active,
                       const openvdb::math::Transform& fieldTransform, bool spectral);

/// The metadata of the field of the kind in @p grids; nullopt if there is none. Throws
/// Error naming grids.source if field grids have no metadata, or the metadata is not
/// nebscatter's (not JSON, a field missing or mistyped, order or level out of range,
/// wavelengths not as the kind needs).
std::optional<ScatterFieldMeta> readScatterFieldMeta(const GridSet& grids, bool spectral);

/// The field as one dense volume: the sum over sources s of factors[s][c] times source s's
/// grids (the l = 0 ones turned into c_00), channel shIndex(l, m) * C + c, on the lattice
/// of the J grids' active voxels with a one-cell border and the index-to-world map
/// @p fieldMap. Each grid is read straight into the sum (no per-source copy). Throws Error
/// naming @p what and the grid if one is missing or not on @p fieldMap, or the lattice
/// would not fit in memory.
SparseVolume readScatterMoments(const GridSet& grids, const ScatterFieldMeta& meta, bool spectral,
                                const std::vector<std::vector<double>>& factors,
                                const Affine& fieldMap, const std::string& what,
                                const std::string& rerun);

} // namespace nebula
