// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file render_command.h
/// nebrender's command line: its options declared (addRenderCommand()) and what a run does
/// with them (runRenderCommand()), so that tools/nebrender/main.cpp is its description alone.

#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/stages/render.h"

#include <memory>
#include <string>
#include <vector>

namespace nebula::cli {

/// Every value nebrender's options fill.
struct RenderCommand
{
    CommonOptions common;
    RenderOptions opts; ///< every render default lives here
    RenderOutput out;
    DustOptions dust;
    CameraOptions camera;
    FilterOptions filter;
    ToneOptions tone;
    OptionScopes scopes; ///< options of one integrator or mode (--spectral, --integrator path)
    std::string phaseFile, phaseUse = "gain", integrator = "fast", fitsLayout = "planes";
    std::string pathFile, frameText, framesText;
    std::vector<double> sky;
    bool noStars = false, noPng = false, noScatterField = false, interpolatedTau = false;
    CLI::Option* skyOption = nullptr;
    CLI::Option* bandsOption = nullptr;
    CLI::Option* wavelengthsOption = nullptr;
};

/// Declares nebrender's options on @p app into @p c.
void addRenderCommand(CLI::App& app, RenderCommand& c);
/// Checks the options given (scopes, camera, frames, outputs), reads the inputs and renders.
void runRenderCommand(CLI::App& app, RenderCommand& c, Run& run);

/// A camera path read from @p file (--camera-path), its first keyframe's unset values from
/// @p defaults (parseCameraPath()).
std::shared_ptr<CameraPath> readCameraPathOption(const std::string& file, const Camera& defaults);

} // namespace nebula::cli
