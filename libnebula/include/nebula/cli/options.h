#pragma once
/// @file options.h
/// Option groups shared by several tools: stars (--star, --stars) and dust parameters.

#include "nebula/physics/dust.h"
#include "nebula/physics/stars.h"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// Stars given on the command line.
struct StarOptions
{
    std::vector<std::string> star; ///< "NAME:X,Y,Z:LUMINOSITY:CLASS_OR_KELVIN"
    std::string starsFile;         ///< JSON file in the nebula:stars format
};

/// Dust parameters given on the command line; unset ones keep the file's (or the defaults).
struct DustOptions
{
    std::optional<double> kappa_V, albedo, g, R_V;
    std::optional<std::string> phase;
    std::optional<std::string> curve;

    /// @p base with every option that was given applied; validated.
    DustParams apply(DustParams base) const;
    bool any() const { return kappa_V || albedo || g || R_V || phase || curve; }
};

namespace cli {

void addStars(CLI::App& app, StarOptions& opts);
/// The stars of --stars FILE followed by each --star; empty if neither was given.
/// Throws Error (file, JSON, a file that holds no stars) or UsageError (--star syntax).
std::vector<Star> loadStars(const StarOptions& opts);
/// Parses one --star value.
Star parseStarOption(const std::string& text);

/// --kappa-v, --albedo, --g, --phase-function, --rv, --extinction-curve. @p withKappa false leaves
/// out --kappa-v.
void addDust(CLI::App& app, DustOptions& opts, bool withKappa = true);

} // namespace cli
} // namespace nebula
