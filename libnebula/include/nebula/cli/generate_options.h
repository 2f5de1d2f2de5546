// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file generate_options.h
/// nebgen's command line (tools/nebgen): its options as a table over NebulaParams, its
/// description (--help, the man page), and the checks between options.

#include "nebula/cli/options.h"
#include "nebula/stages/generate.h"

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace nebula {

/// What nebgen's options fill; every default lives in NebulaParams or in a preset's
/// parameters (presets.cpp).
struct GenerateOptions
{
    /// @p preset: the --preset given on the command line (cli::argumentOf()), whose
    /// parameters are then the defaults --help shows and every option overrides; "" or an
    /// unknown name: NebulaParams' own (an unknown name is refused when parsed).
    explicit GenerateOptions(const std::string& preset);

    NebulaParams params;
    std::string presetName; ///< --preset as parsed (from the command line or --config)
    StarOptions stars;
    DustOptions dust;
    bool noStars = false;
    std::string lines; ///< --lines, parsed by resolve()
    std::string shape = "sphere";
    std::string centre; ///< --motion-centre, parsed by resolve()

    // Set by cli::addGenerate(): the options that mean something in one mode only.
    std::vector<CLI::Option*> fbmOnly, turbulenceOnly, spectralOnly;
    CLI::Option* shellWidth = nullptr;
    CLI::Option* motionCentre = nullptr;

    /// The nebula the options describe: the options of another model or mode refused,
    /// --lines and --motion-centre parsed, the stars (--star, --stars, else the preset's
    /// unless --no-stars) and the dust applied. Throws UsageError naming the option.
    NebulaParams resolve() const;
};

namespace cli {

/// nebgen's description: the examples, the presets, the grids and the lines.
std::string generateDescription();

/// Declares nebgen's own options on @p app (after addCommon()), with @p opts' values as
/// their defaults. The options write into @p opts: it must stay in place while @p app parses.
void addGenerate(CLI::App& app, GenerateOptions& opts);

} // namespace cli
} // namespace nebula
