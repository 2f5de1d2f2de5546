// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file presets.h
/// nebgen's presets (DESIGN §2b): recognisable nebula types, each a turbulent lognormal cloud
/// (physics/turbulence.h) shaped by a documented geometry, with its stars, dust and gas.
/// One table, presets.cpp, holds them all: a preset is a row there (its defaults, stars and
/// geometry) and nothing else.

#include "nebula/stages/generate.h"

#include <string>
#include <vector>

namespace nebula {

/// What a preset is, for --help, errors and the docs.
struct PresetInfo
{
    NebulaPreset id;
    const char* name;    ///< what --preset takes
    const char* summary; ///< one line: the type and its real models
    /// Its glow is the gas its stars ionise: nebgen paints none (`--emission` is refused) and
    /// nebionize computes it (Makefile.data runs it for these).
    bool ionised = false;
};

/// Every preset, in the order the docs list them; fbm (the procedural cloud of the seeds, the
/// default) first.
const std::vector<PresetInfo>& nebulaPresets();

/// The preset called @p name; UsageError naming --preset and listing the known names if none.
NebulaPreset parsePreset(const std::string& name);

/// The preset's name.
const char* presetName(NebulaPreset preset);

/// Whether the preset's glow is the gas its stars ionise (PresetInfo::ionised).
bool presetIonised(NebulaPreset preset);

/// The parameters of @p preset: NebulaParams' defaults with the preset's own (size, density,
/// turbulence, emission, cavity, dust, stars). Options the user gives then override them.
NebulaParams presetParams(NebulaPreset preset);

/// The preset's stars for a cube of @p size pc (they scale with the cube, so --size keeps
/// the picture); the example's two stars for fbm.
std::vector<Star> presetStars(NebulaPreset preset, double size);

} // namespace nebula
