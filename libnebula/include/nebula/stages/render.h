#pragma once
/// @file render.h
/// nebrender's stage: scene, integrator, EXR and PNG.

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"
#include "nebula/render/options.h"

#include <string>

namespace nebula {

/// Output settings of nebrender.
struct RenderOutput
{
    std::string exr; ///< EXR path (required)
    std::string png; ///< PNG path ("" = the EXR's name with .png; "none" = no PNG)
    ToneParams tone;
};

/// nebrender's entry point: builds the scene from @p grids (dust from nebula:dust with
/// @p dustOverride applied), renders, and writes the EXR and PNG atomically.
void renderToFiles(const GridSet& grids, const RenderOptions& opts, const DustParams& dust,
                   const RenderOutput& out, const Run& run);

} // namespace nebula
