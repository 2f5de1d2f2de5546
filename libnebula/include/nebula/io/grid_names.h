// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file grid_names.h
/// The names that are a contract between the tools (DESIGN §1-2): file-level metadata keys
/// and the names of the grids one stage makes for the next.

#include <cstdio>
#include <string>

namespace nebula {

/// File-level metadata keys (DESIGN §1-2).
inline constexpr const char* META_TOOL = "nebula:tool";       ///< the last tool that wrote
inline constexpr const char* META_VERSION = "nebula:version"; ///< its version
inline constexpr const char* META_COMMAND = "nebula:command"; ///< its full command line
/// JSON array of {"tool", "version", "command"}, one entry per stage that wrote the file, in
/// order: the whole chain that made it (nebgen's seed included).
inline constexpr const char* META_HISTORY = "nebula:history";
/// Grid name -> checksum of its contents (io/checksum.h), verified on read.
inline constexpr const char* META_CHECKSUMS = "nebula:checksums";
inline constexpr const char* META_STARS = "nebula:stars"; ///< JSON array of stars
inline constexpr const char* META_DUST = "nebula:dust";   ///< JSON object of dust parameters
/// JSON object: what nebscatter's field was made for (order, level, sources, dust, stars,
/// wavelengths, transform; DESIGN §5b).
inline constexpr const char* META_SCATTER = "nebula:scatter";
/// JSON object: the same for nebscatter --spectral's field (wavelengths: its list [nm]).
inline constexpr const char* META_SCATTER_SPECTRAL = "nebula:scatter_spectral";
/// Grid metadata: the spectral lines an emission grid emits ("NAME:STRENGTH,...").
inline constexpr const char* META_LINES = "nebula:lines";

/// Grid metadata: the absorption lines of an `absorption.<species>` grid ("NAME:STRENGTH,...";
/// the grid's value times STRENGTH is the line's opacity integrated over wavelength per unit
/// length [nm pc^-1], DESIGN §7.6).
inline constexpr const char* META_ABSORPTION_LINES = "nebula:absorption-lines";

/// The prefix of the absorbing species' grids: "absorption.<species>" (DESIGN §2, §7.6).
inline constexpr const char* ABSORPTION_GRID_PREFIX = "absorption.";

/// The absorption grid of species @p species ("nai", "caii"): "absorption.<species>".
inline std::string absorptionGridName(const std::string& species)
{
    return ABSORPTION_GRID_PREFIX + species;
}

/// Whether @p name is an absorption grid's name (starts with ABSORPTION_GRID_PREFIX).
inline bool isAbsorptionGridName(const std::string& name)
{
    return name.rfind(ABSORPTION_GRID_PREFIX, 0) == 0;
}

/// nebillum's optical depth grid for star @p star: "tau.<star>".
inline std::string tauGridName(const std::string& star)
{
    return "tau." + star;
}

/// nebpyramid's level @p level of grid @p base: "<base>.L<level>".
inline std::string levelGridName(const std::string& base, int level)
{
    return base + ".L" + std::to_string(level);
}

/// nebscatter's grid of moment (@p l, @p m) of RGB channel @p channel (0, 1, 2) of source
/// @p source ("stars", "star_<name>", "emission"): "scatter.<source>.J.<R|G|B>" for l = 0
/// (the mean intensity J), else "scatter.<source>.c<l>_<m>.<R|G|B>" (DESIGN §5b).
inline std::string scatterGridName(const std::string& source, int l, int m, int channel)
{
    static const char* const CH[3] = {"R", "G", "B"};
    const std::string moment =
        l == 0 ? std::string("J") : "c" + std::to_string(l) + "_" + std::to_string(m);
    return "scatter." + source + "." + moment + "." + CH[channel];
}

/// The prefix of nebscatter --spectral's grids; an RGB field's grids never start with it.
inline constexpr const char* SPECTRAL_SCATTER_PREFIX = "scatter.spectral.";

/// nebscatter --spectral's grid of moment (@p l, @p m) at wavelength @p lambda [nm] of
/// source @p source: "scatter.spectral.<source>.J.<lambda>nm" for l = 0, else
/// "scatter.spectral.<source>.c<l>_<m>.<lambda>nm", lambda with up to 5 significant digits
/// ("430nm", "416.36nm"; DESIGN §5b).
inline std::string spectralScatterGridName(const std::string& source, int l, int m, double lambda)
{
    const std::string moment =
        l == 0 ? std::string("J") : "c" + std::to_string(l) + "_" + std::to_string(m);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.5gnm", lambda);
    return SPECTRAL_SCATTER_PREFIX + source + "." + moment + "." + buf;
}

} // namespace nebula
