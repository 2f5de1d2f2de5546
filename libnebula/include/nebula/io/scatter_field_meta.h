// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_field_meta.h
/// What nebscatter's field (DESIGN §5b) is, how it was computed and what it was made for:
/// the content of the file metadata `nebula:scatter` (`nebula:scatter_spectral`), as types
/// that know no OpenVDB (io/scatter_field_vdb.h writes and reads them with the grids). The
/// Monte Carlo (render/scatter_field.h) and the scene assembly (stages/scene_assembly.h)
/// share them: a source is a typed ScatterSource; its name ("stars", "star_<name>",
/// "emission") is made and parsed only where grids and metadata are written and read.

#include "nebula/physics/dust.h"
#include "nebula/physics/stars.h"
#include "nebula/volume/volume.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace nebula {

/// A source of the field: what its packets start from.
struct ScatterSource
{
    enum class Kind {
        Stars,   ///< every star's first-scattering source in one field
        Star,    ///< one star's (nebscatter --per-star)
        Emission ///< the gas emission
    };
    Kind kind = Kind::Stars;
    std::size_t star = 0; ///< Kind::Star: the star's index in the field's stars

    static ScatterSource allStars() { return {Kind::Stars, 0}; }
    static ScatterSource oneStar(std::size_t s) { return {Kind::Star, s}; }
    static ScatterSource emission() { return {Kind::Emission, 0}; }
    bool operator==(const ScatterSource& o) const
    {
        return kind == o.kind && (kind != Kind::Star || star == o.star);
    }
    bool operator!=(const ScatterSource& o) const { return !(*this == o); }
};

/// @p source's name in grid names, metadata and messages: "stars", "star_<name>" (the name
/// of @p stars[source.star]) or "emission".
std::string scatterSourceName(const ScatterSource& source, const std::vector<Star>& stars);

/// The source named @p name (scatterSourceName()) among @p stars; Error naming @p where and
/// the name if it names none.
ScatterSource parseScatterSource(const std::string& name, const std::vector<Star>& stars,
                                 const std::string& where);

/// One source's Monte Carlo summary (nebscatter -v, the metadata, the README's error
/// figures); render/scatter_field.h's ScatterSourceField adds its moments.
struct ScatterSourceSummary
{
    ScatterSource source;
    std::uint64_t packets = 0;
    std::uint64_t flights = 0;    ///< straight flights walked (one per scattering order)
    std::vector<double> power;    ///< per channel: first-scattered (or emitted) power [L_sun]
    std::vector<double> escaped;  ///< per channel: collided power leaving the grid [L_sun]
    std::vector<double> absorbed; ///< per channel: collided power absorbed [L_sun]
    /// Relative standard error of J (green; a spectral field: the largest of its runs'
    /// middle wavelengths) per field cell, averaged with weights n_H J V (each cell's share
    /// of the scattered light) over the cells holding dust.
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

/// How a field is computed: nebscatter's options that shape it (render/scatter_field.h's
/// ScatterOptions adds how to run it), recorded in its metadata.
struct ScatterSettings
{
    int order = 2; ///< L: real spherical harmonics of degree 0..L, (L + 1)^2 moments
    /// Field cells of 2^k x 2^k x 2^k voxels (nebpyramid's level k layout), k >=
    /// MIN_FIELD_LEVEL (-1: half-voxel cells); render/scatter_field.h's AUTO_FIELD_LEVEL:
    /// autoFieldLevel()'s choice (the stage resolves it before computing).
    int fieldLevel = 1;
    /// Packets per source: all stars together (or each star with perStar), and the emission;
    /// at most MAX_PACKETS.
    std::uint64_t packets = 1000000;
    std::uint64_t seed = 1;
    /// Adaptive cells (> 0): a block of 2x2x2 field cells is tallied as one, its cells'
    /// values from the block's value and slopes, unless its densest voxel makes it
    /// optically thicker than this across (tau_V), a star is in or next to it, or it
    /// borders such a block; 0: every field cell tallied on its own (and fields from before
    /// adaptive cells). At most MAX_REFINE_TAU.
    double refineTau = 0.0;
    bool perStar = false; ///< one field per star instead of their sum
    /// The noise filter (DESIGN §5b "Noise filter"): each field cell moves towards the plane
    /// fitted to the (2 denoise + 1)^3 cells around it as far as its noise exceeds their
    /// spread about it; 0: none (and fields from before the filter). At most
    /// MAX_DENOISE_RADIUS.
    int denoise = 0;
};

/// The largest ScatterSettings::denoise (--denoise).
inline constexpr int MAX_DENOISE_RADIUS = 3;

/// The scene settings a field is made with: nebscatter's options of the same names as
/// nebrender's, recorded so that nebrender can refuse a field made for another scene.
struct ScatterSceneSettings
{
    std::string densityGrid = "density";
    std::string emissionGrid = "emission";
    double minStarDistance = 0.5; ///< 1/r^2 clamp [voxels] (--min-star-distance)
    /// Stars' optical depth exact through rough cells (RenderOptions::exactStarDepth; false
    /// in fields from before it).
    bool exactStarDepth = true;
};

/// A field's stored precision (nebscatter --precision, DESIGN §5b "Stored precision"): the
/// significant bits each stored moment keeps. FIELD_FLOAT_BITS: the floats as computed
/// (fields from before --precision); fewer: every moment of a cell is a multiple of
/// 2^(e + 1 - bits), 2^e <= that cell's |c_00| (J's own for the J grids) < 2^(e + 1), so it
/// is within 2^-bits of the cell's c_00 and the low bits of its float are zero (which the
/// file's compression removes).
inline constexpr int FIELD_FLOAT_BITS = 24; ///< a float's significand
inline constexpr int FIELD_HALF_BITS = 11;  ///< a half float's: within 0.049 % of c_00
inline constexpr int FIELD_MIN_BITS = 4;

/// What a field is, how it was computed and what it was made for: `nebula:scatter`.
struct ScatterFieldMeta
{
    ScatterSettings settings; ///< order 0..SH_MAX_DEGREE, fieldLevel MIN..MAX_FIELD_LEVEL
    ScatterSceneSettings scene;
    std::vector<ScatterSourceSummary> sources;
    DustParams dust;
    std::vector<Star> stars; ///< the stars it was made for: ScatterSource::star indexes them
    /// R, G, B: 3 channel wavelengths; a spectral field: at least 2, increasing [nm].
    std::vector<double> wavelengths;
    Affine indexToWorld; ///< level 0's (the density grid's) index-to-world map
    double seconds = 0.0;
    /// The significant bits the stored moments keep, FIELD_MIN_BITS..FIELD_FLOAT_BITS
    /// (`"stored_bits"`; fields without it: FIELD_FLOAT_BITS).
    int storedBits = FIELD_FLOAT_BITS;
};

} // namespace nebula
