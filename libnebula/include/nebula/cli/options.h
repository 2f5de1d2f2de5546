// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file options.h
/// Option groups shared by several tools: stars (--star, --stars), dust parameters, filters,
/// and nebrender's and nebview's light (emission, star sprites) and tone.

#include "nebula/io/image.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/filters.h"
#include "nebula/physics/stars.h"
#include "nebula/render/camera_framing.h"
#include "nebula/render/options.h"

#include <CLI/CLI.hpp>

#include <array>
#include <map>
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

/// A passband given on the command line: --filter NAME (a standard one) or --filter-file.
struct FilterOptions
{
    std::string name;
    std::string file;
    std::string unit = "nm"; ///< --filter-unit: the file's wavelength unit if it names none
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

/// The tone given on the command line (addTone()).
struct ToneOptions
{
    double exposure = 0.0;
    CLI::Option* exposureOption = nullptr;
    CLI::Option* gammaOption = nullptr;
    /// @p tone with --exposure (a fixed curve) or --gamma alone (a fixed gamma with the
    /// automatic white point) applied.
    void apply(ToneParams& tone) const;
};

namespace cli {

/// Options that mean something only in some scopes of a run ("--spectral", "--integrator
/// path"): each is declared once with its scopes, and check() refuses every one given outside
/// them in one way: "--spp is for --integrator path (here: --integrator fast)". (Camera
/// parameters are checked the same way against the camera's model by makeCamera() and
/// validateCamera().)
class OptionScopes
{
public:
    /// Declares that @p option applies only in @p scopes; returns it.
    CLI::Option* add(std::vector<std::string> scopes, CLI::Option* option);
    /// Throws UsageError for the first declared option that was given while none of its
    /// scopes is in @p active; @p here describes the run ("--integrator fast").
    void check(const std::vector<std::string>& active, const std::string& here) const;

private:
    std::vector<std::pair<CLI::Option*, std::vector<std::string>>> mOptions;
};

/// The camera given on the command line (addCamera(), makeCamera()).
struct CameraOptions
{
    Camera camera; ///< --eye, --look-at, --up, --fov, --roll as given
    std::string model = "perspective";
    bool stereo = false;
    std::string res; ///< --res WxH; empty: the model's default size
    /// The model's shape fitted into --res (nebview: equirect W x W/2, fisheye the smaller
    /// side squared) instead of --res refused when it is not the model's shape.
    bool fitSize = false;
    /// Each model parameter given (cameraParameters(), render/camera_model.h): its text.
    std::map<std::string, std::string> parameters;
    CLI::Option* fovOption = nullptr;
    CLI::Option* eyeOption = nullptr;
    CLI::Option* lookAtOption = nullptr;
    /// --frame-nebula: aim and size the camera at the dust (stages/framing.h).
    bool frameNebula = false;
};

/// --eye, --look-at, --up, --camera (the registered models, their help from the registry),
/// --stereo, --fov, --roll, --res (if @p withRes) and every model parameter's option
/// (--dome-tilt, --ipd, ...). @p prefix starts the view's help texts ("Starting ").
void addCamera(CLI::App& app, CameraOptions& opts, const std::string& prefix = "",
               bool withRes = true);
/// The camera given: the model (--stereo: its stereo form), --fov and the size the model's
/// defaults where not given, the parameters parsed; valid (a Projection of it is made).
/// Throws UsageError naming the option, e.g. a parameter the model does not read.
Camera makeCamera(const CameraOptions& opts);
/// What --frame-nebula keeps as given (--eye, --pixel-size). Throws UsageError if
/// --frame-nebula comes with --look-at (both aim the camera) or, @p cameraPath, with
/// --camera-path (a path's keyframes aim each frame).
FramingChoice framingChoice(const CameraOptions& opts, bool cameraPath);

void addStars(CLI::App& app, StarOptions& opts);
/// The stars of --stars FILE followed by each --star; empty if neither was given.
/// Throws Error (file, JSON, a file that holds no stars) or UsageError (--star syntax).
std::vector<Star> loadStars(const StarOptions& opts);
/// Parses one --star value.
Star parseStarOption(const std::string& text);

/// --kappa-v, --albedo, --g, --phase-function, --rv, --extinction-curve. @p withKappa false leaves
/// out --kappa-v.
void addDust(CLI::App& app, DustOptions& opts, bool withKappa = true);

/// The gas's emission and the stars as a render shows them (nebrender, nebview):
/// --emission-grid, --emission-scale, --emission-color (given, it sets opts.lineColours
/// false: DESIGN §3.4), --no-stars (into @p noStars: the caller sets opts.drawStars =
/// !noStars), --sprite-radius, --min-star-distance.
void addEmissionAndStars(CLI::App& app, RenderOptions& opts, bool& noStars);
/// --exposure, --gamma and --percentile into @p tone and @p opts (ToneOptions::apply() after
/// parsing); @p prefix starts each help text ("PNG: ", "Starting tone: ").
void addTone(CLI::App& app, ToneParams& tone, ToneOptions& opts, const std::string& prefix);
/// Adds --filter, --filter-file and --filter-unit (@p what says what the band does).
void addFilter(CLI::App& app, FilterOptions& opts, const std::string& what);

/// The filter given, if any: standardFilter() or the parsed file (read with readInput(),
/// errors naming --filter-file).
std::optional<Filter> loadFilter(const FilterOptions& opts);

/// The three wavelengths [nm] of a band's three-node quadrature (bandQuadrature()): the
/// channels a render or a field through the band uses. Throws UsageError if --wavelengths
/// was given too (@p wavelengthsGiven).
std::array<double, 3> filterWavelengths(const Filter& filter, bool wavelengthsGiven);

} // namespace cli
} // namespace nebula
