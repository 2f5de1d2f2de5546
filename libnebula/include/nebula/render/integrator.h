// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file integrator.h
/// nebrender's integrators as registered types (DESIGN §18): each owns its name, how the
/// command line chooses it, the options it reads and their checks, its documentation, what
/// it says under -v and its EXR attributes. nebrender's stage looks the chosen one up and
/// calls it; it names no integrator.
///
/// Adding an integrator: its own `src/render/<name>.cpp` defining
/// `const IntegratorType& detail::<name>Integrator()`, and one line in `src/render/integrator.cpp`
/// (the registry) declaring it and listing it.

#include "nebula/core/run.h"
#include "nebula/io/image.h"
#include "nebula/render/options.h"
#include "nebula/render/spectral.h"

#include <string>
#include <vector>

namespace nebula {

/// What an integrator is told of its input before the scene is built (the stage reads it
/// from the grids): the fields it may use or ignore, for its warnings.
struct IntegratorInput
{
    std::string source;         ///< the input's name, for messages
    bool rgbField = false;      ///< nebscatter's R, G, B field, and RenderOptions::scatterField
    bool spectralField = false; ///< nebscatter --spectral's field, and RenderOptions::scatterField
    /// The density's first pyramid level (nebpyramid) if the input has one, else "".
    std::string pyramidLevel;
};

/// One integrator: a plain record of what it is and the functions that do its work.
struct IntegratorType
{
    std::string name;     ///< "fast", "path", "spectral"
    std::string chosenBy; ///< nebrender's options that choose it: "--integrator path", "--spectral"
    std::string doc;      ///< what it computes, one sentence (--help, the man page)
    /// The nebrender options it reads that not every integrator reads ("--spp", "--seed"): an
    /// option in another integrator's list and not in this one's does not apply to it.
    std::vector<std::string> options;
    /// Whether it renders calibrated light and its component layers (nebrender --fits, --sed;
    /// RenderOptions::monochromatic and componentLayers).
    bool calibrated = false;
    /// The EXR's "comments": what the image is.
    std::string comment;

    /// Throws UsageError naming the option if @p opts asks for what it cannot do (before the
    /// scene is built).
    void (*validate)(const RenderOptions& opts) = nullptr;
    /// Warns through @p run about what @p input holds that it will not use.
    void (*checkInput)(const IntegratorInput& input, const RenderOptions& opts,
                       const Run& run) = nullptr;
    /// Renders one frame of @p scene (an RGB integrator reads scene.base only).
    Image (*render)(const SpectralScene& scene, const RenderOptions& opts, const Run* run,
                    RenderStats* stats) = nullptr;
    /// The EXR's "nebula:integrator": the integrator and its settings.
    std::string (*describe)(const RenderOptions& opts, const SpectralScene& scene) = nullptr;
    /// What the render did (@p stats, @p seconds of rendering), under -v.
    void (*report)(const RenderOptions& opts, const SpectralScene& scene, const RenderStats& stats,
                   double seconds, const Run& run) = nullptr;
};

/// Every registered integrator, in the order --help lists them.
const std::vector<const IntegratorType*>& integratorTypes();

/// The integrator named @p name. Throws UsageError naming @p option, the name and the known
/// names if there is none.
const IntegratorType& integratorType(const std::string& name,
                                     const std::string& option = "--integrator");

/// The integrator @p opts choose: RenderOptions::integrator, or "spectral" with
/// SpectralOptions::enabled (nebrender --spectral, which is for the fast integrator only:
/// UsageError with another).
const IntegratorType& chosenIntegrator(const RenderOptions& opts);

} // namespace nebula
