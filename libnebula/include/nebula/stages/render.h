// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file render.h
/// nebrender's stage: scene, integrator, EXR and PNG.

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"
#include "nebula/render/camera_path.h"
#include "nebula/render/options.h"
#include "nebula/stages/fits_output.h"

#include <memory>
#include <string>
#include <vector>

namespace nebula {

/// Output settings of nebrender.
struct RenderOutput
{
    std::string exr; ///< EXR path (required)
    std::string png; ///< PNG path ("" = the EXR's name with .png; "none" = no PNG)
    ToneParams tone;
    int pngBits = 8; ///< PNG bit depth: 8 or 16
    /// A camera path (--camera-path): each frame's view comes from it at time (N - 1) / fps.
    std::shared_ptr<const CameraPath> path;
    /// The frames of the path to render (1-based); the EXR and PNG names then hold a frame
    /// pattern (#### or %04d) when there is more than one. Empty without a path.
    std::vector<long> frames;
    /// Skip a frame whose EXR (and PNG) already exist and read back whole.
    bool skipExisting = false;
    /// Calibrated images (--fits): the render becomes monochromatic at the channel
    /// wavelengths (RenderOptions::monochromatic, with component layers), so the EXR holds
    /// spectral radiance [L_sun pc^-2 sr^-1 nm^-1] too.
    FitsOutput fits;
};

/// The PNG path: RenderOutput::png, or the EXR's name with .png; "" for none. Throws
/// UsageError unless the EXR's name ends in .exr.
std::string pngPath(const RenderOutput& out);

/// nebrender's entry point: builds the scene from @p grids (dust from nebula:dust with
/// @p dustOverride applied) once, renders the frame (or each of out.frames along out.path),
/// and writes each frame's EXR and PNG (and FITS) atomically, all or none.
void renderToFiles(const GridSet& grids, const RenderOptions& opts, const DustParams& dust,
                   const RenderOutput& out, const Run& run);

} // namespace nebula
