// SPDX-License-Identifier: Apache-2.0
/// @file camera_options.cpp
/// The camera's options (addCamera(), makeCamera()), built from the registered models and
/// their parameters (render/camera_model.h), and the scopes of options (OptionScopes).
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/core/error.h"
#include "nebula/render/camera_model.h"

#include <algorithm>

namespace nebula::cli {

CLI::Option* OptionScopes::add(std::vector<std::string> scopes, CLI::Option* option)
{
    mOptions.emplace_back(option, std::move(scopes));
    return option;
}

void OptionScopes::check(const std::vector<std::string>& active, const std::string& here) const
{
    for (const auto& [option, scopes] : mOptions) {
        if (option->count() == 0) continue;
        const bool applies = std::any_of(scopes.begin(), scopes.end(), [&](const std::string& s) {
            return std::find(active.begin(), active.end(), s) != active.end();
        });
        if (applies) continue;
        std::string list;
        for (std::size_t i = 0; i < scopes.size(); ++i)
            list += (i == 0 ? "" : i + 1 == scopes.size() ? " or " : ", ") + scopes[i];
        throw UsageError(option->get_name() + " is for " + list + " (here: " + here + ")");
    }
}

void addCamera(CLI::App& app, CameraOptions& opts, const std::string& prefix, bool withRes)
{
    Camera& c = opts.camera;
    opts.eyeOption = addVec3(app, "--eye", c.eye,
                             prefix + (prefix.empty() ? "Camera" : "camera") + " position [pc]");
    opts.lookAtOption =
        addVec3(app, "--look-at", c.lookAt,
                prefix + (prefix.empty() ? "Point" : "point") + " the camera looks at [pc]");
    app.add_flag(
        "--frame-nebula", opts.frameNebula,
        "Aim and size the camera at the dust: its mass-weighted centroid on the image\n"
        "centre (a tilted dome's sweet spot, 40 degrees above its front edge), the\n"
        "radius holding 90 % of its mass sized to the view. Sets --look-at; moves --eye\n"
        "(keeping the view direction) unless --eye is given, which only turns the camera;\n"
        "sets the orthographic --pixel-size unless given. Not with --look-at or\n"
        "--camera-path");
    addVec3(app, "--up", c.up, "Up direction");
    std::string help = "Camera model:";
    std::vector<std::string> names;
    for (const CameraModel* m : cameraModels()) {
        help += "\n" + m->help();
        names.push_back(m->name());
    }
    app.add_option("--camera", opts.model, help)
        ->check(CLI::IsMember(names))
        ->capture_default_str();
    app.add_flag("--stereo", opts.stereo,
                 "The stereo form of --camera: two views from eyes --ipd apart, the left eye's\n"
                 "on top (fisheye: fisheye-stereo; equirect: ods)");
    opts.fovOption =
        app.add_option("--fov", c.fovDeg,
                       prefix + (prefix.empty() ? "Field" : "field") +
                           " of view [degrees]: perspective: horizontal, in (0, 179]\n"
                           "(default 36); fisheye: the circle's full angle, up to 360\n"
                           "(default 180); panoramas: always 360 x 180")
            ->check(numberIn(0.01, 360.0));
    app.add_option("--roll", c.rollDeg,
                   "Turn the camera about its view direction [degrees], clockwise as seen\n"
                   "from behind it (the picture turns counter-clockwise)")
        ->capture_default_str()
        ->check(numberIn(-360.0, 360.0));
    if (withRes) {
        app.add_option("--res", opts.res,
                       "Image size WxH, each in [1, 65536] (default 512x512; equirect 1024x512,\n"
                       "fisheye-stereo 512x1024), as far as the image fits in memory");
    }
    for (const CameraParameter& p : cameraParameters()) {
        auto* o = app.add_option(
            "--" + p.name,
            [&opts, name = p.name](const CLI::results_t& r) {
                opts.parameters[name] = r.at(0);
                return true;
            },
            p.help + "\n(--camera " + cameraModelsReading(p.name) + ")");
        o->type_name(p.type)->expected(1);
    }
}

Camera makeCamera(const CameraOptions& opts)
{
    Camera c = opts.camera;
    const CameraModel& model =
        opts.stereo ? stereoCameraModel(opts.model) : cameraModel(opts.model);
    c.model = model.name();
    if (opts.fovOption == nullptr || opts.fovOption->count() == 0) c.fovDeg = model.defaultFov();
    if (!opts.res.empty()) {
        parseResolution(opts.res, c.width, c.height);
        if (opts.fitSize) model.fitSize(c.width, c.height);
    } else {
        model.defaultSize(c.width, c.height);
    }
    for (int pass = 0; pass < 2; ++pass) { // the parsers that read others' values last
        for (const CameraParameter& p : cameraParameters()) {
            const auto it = opts.parameters.find(p.name);
            if (it == opts.parameters.end() || (p.parse != nullptr) != (pass == 1)) continue;
            model.requireReads(p.name);
            p.set(c, parseCameraParameter(p, it->second, c));
        }
    }
    (void)Projection(c); // a created camera is valid
    return c;
}

FramingChoice framingChoice(const CameraOptions& opts, bool cameraPath)
{
    if (opts.lookAtOption && opts.lookAtOption->count() > 0) {
        throw UsageError("--frame-nebula chooses --look-at itself (the dust's centroid); give "
                         "one or the other");
    }
    if (cameraPath) {
        throw UsageError("--frame-nebula frames one view; a --camera-path's keyframes aim "
                         "every frame (use nebview's --frame-nebula to start a path)");
    }
    FramingChoice keep;
    keep.keepEye = opts.eyeOption && opts.eyeOption->count() > 0;
    keep.keepPixelSize = opts.parameters.count("pixel-size") > 0;
    return keep;
}

} // namespace nebula::cli
