// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera_model.h
/// Cameras as registered types (DESIGN §8, §18). A camera model is one class in one file,
/// src/render/camera_<name>.cpp, that owns its name, its documentation, the parameters it
/// reads and their checks, its defaults, its entries in the camera's JSON and FITS header,
/// and its per-pixel mapping (a CameraProjection); and one line in
/// src/render/camera_models.cpp registers it. Nothing outside render/ names a model: the
/// command line, nebview, the EXR and FITS writers and camera paths ask the registry.

#include "nebula/render/camera.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// The per-pixel mapping of one camera, built once per frame from a valid Camera (see
/// Projection, which holds one and documents each function). The base holds the camera's
/// orthonormal basis (the view direction, right and up after --roll) and the image size.
class CameraProjection
{
public:
    explicit CameraProjection(const Camera& camera);
    virtual ~CameraProjection() = default;

    virtual bool direction(double px, double py, Vec3& d) const = 0;
    virtual double pixelSolidAngle(double px, double py) const = 0;
    /// Default: the square root of pixelSolidAngle().
    virtual double pixelAngle(double px, double py) const;
    /// Where the ray of view @p view through @p p falls in the image; mono models ignore
    /// @p view.
    virtual bool project(const Vec3& p, double& px, double& py, int view) const = 0;
    /// Default: every ray starts at the eye.
    virtual Vec3 origin(double px, double py) const;
    virtual Vec3 originTowards(const Vec3& p) const;
    /// Default: |p - eye|^2.
    virtual double distanceSquared(const Vec3& p) const;
    virtual bool parallel() const { return false; }
    virtual bool wrapsHorizontally() const { return false; }
    virtual bool coversImage() const { return true; }
    virtual int views() const { return 1; }
    /// Default: the whole image is view 0.
    virtual void viewRows(int view, int& y0, int& y1) const;

    Vec3 eye, forward, right, up;
    int width, height;
};

/// A model-specific camera parameter: one row of cameraParameters(), which the command line
/// (its option and help), the checks (given only for a model that reads it) and the JSON
/// form share. A model lists the names of those it reads (CameraModel::parameters()).
struct CameraParameter
{
    std::string name; ///< the option without its dashes: "ipd"
    std::string json; ///< its key in the camera's JSON: "ipd_pc"
    std::string help; ///< the option's help text (its models are appended)
    std::string type; ///< the option's type name: "DEG", "PC", "FROM,TO"
    int values = 1;   ///< how many numbers (--pole-merge: 2)
    /// Whether the camera has it (not its default), and its values; setting them (none: back
    /// to the default).
    bool (*given)(const Camera&);
    std::vector<double> (*get)(const Camera&);
    void (*set)(Camera&, const std::vector<double>&);
    /// The option's text as values (null: @p values comma-separated numbers); may read the
    /// camera's other parameters, which are set first. Throws UsageError naming the option.
    std::vector<double> (*parse)(const std::string& text, const Camera&) = nullptr;
};

/// Every model-specific parameter, in the order of the options.
const std::vector<CameraParameter>& cameraParameters();
/// The values of parameter @p p's option text @p text (p.parse, or p.values comma-separated
/// finite numbers); throws UsageError naming the option.
std::vector<double> parseCameraParameter(const CameraParameter& p, const std::string& text,
                                         const Camera& camera);
/// The row named @p name (an internal error if there is none).
const CameraParameter& cameraParameter(const std::string& name);

/// What a FITS image of a camera's view is: the tangent plane's radians per pixel, and the
/// pixel's size [pc] where it has one (the orthographic camera's; NaN for angles only).
struct CameraSkyPlane
{
    double radiansPerPixel = 0.0;
    double pixelPc = 0.0;
};

/// A header card of a camera (the FITS writer's FitsCard, kept free of io/).
struct CameraCard
{
    std::string key;
    double value = 0.0;
    std::string comment;
};

/// A registered camera model.
class CameraModel
{
public:
    virtual ~CameraModel() = default;

    /// --camera NAME.
    virtual std::string name() const = 0;
    /// A few lines for --camera's help, the man page and completion.
    virtual std::string help() const = 0;
    /// The cameraParameters() it reads, by name.
    virtual std::vector<std::string> parameters() const { return {}; }
    /// Whether it reads parameter @p name.
    bool reads(const std::string& name) const;
    /// Throws UsageError unless it reads parameter @p name: "--ipd is for --camera ods or
    /// fisheye-stereo (--camera is perspective)" (validateCamera(), cli::makeCamera()).
    void requireReads(const std::string& name) const;
    /// The mono model whose stereo form this is (--camera MONO --stereo), or "".
    virtual std::string stereoOf() const { return {}; }
    /// --fov when it is not given (36 degrees; fisheye 180).
    virtual double defaultFov() const { return 36.0; }
    /// Whether --fov means something to it (not for panoramas; the JSON leaves it out).
    virtual bool usesFov(const Camera&) const { return true; }
    /// The widest --fov it takes [degrees] (nebview's slider; validate() checks it).
    virtual double maxFov() const { return 179.0; }
    /// The image size when --res is not given, from @p width x @p height (512x512).
    virtual void defaultSize(int& /*width*/, int& /*height*/) const {}
    /// The largest image of its shape within @p width x @p height (nebview's stages).
    virtual void fitSize(int& /*width*/, int& /*height*/) const {}
    /// Its own checks (fov, image shape, its parameters' values); the common ones
    /// (validateCamera()) are done first. Throws UsageError naming the option.
    virtual void validate(const Camera& camera) const = 0;
    /// Checks against the scene's size [pc across its box] (a stereo base beyond the scene).
    virtual void validateInScene(const Camera& /*camera*/, double /*across*/) const {}
    /// The per-pixel mapping of a valid @p camera.
    virtual std::unique_ptr<CameraProjection> projection(const Camera& camera) const = 0;
    /// Its entries in the camera's JSON beyond the common ones (cameraToJson()).
    virtual void describe(const Camera& camera, nlohmann::json& j) const;
    /// Its FITS projection, if its images have one.
    virtual std::optional<CameraSkyPlane> skyPlane(const Camera& /*camera*/) const
    {
        return std::nullopt;
    }
    /// Its FITS header cards after CAMERA, EYE, LOOKAT and UP (default: FOV).
    virtual std::vector<CameraCard> fitsCards(const Camera& camera) const;
    /// How a calibrated SED names where its fluxes are ("at the eye").
    virtual std::string observer(const Camera& /*camera*/) const { return "at the eye"; }
};

/// The registered models, in the order of --camera's help.
const std::vector<const CameraModel*>& cameraModels();
/// The model named @p name; throws UsageError naming --camera and listing the models.
const CameraModel& cameraModel(const std::string& name);
/// The stereo form of model @p mono (--camera MONO --stereo); throws UsageError naming
/// --stereo and listing the models that have one.
const CameraModel& stereoCameraModel(const std::string& mono);
/// The names of the registered models, "perspective, fisheye, ... or ods" (messages, help).
std::string cameraModelNames(const std::string& last = "or");
/// The names of the models that read parameter @p name ("ods or fisheye-stereo").
std::string cameraModelsReading(const std::string& name);

/// The camera's JSON (the EXR's nebula:camera, nebview's protocol, camera paths' keyframes):
///   {"projection": MODEL, "eye": [x,y,z], "look_at": [x,y,z], "up": [x,y,z],
///    "fov_deg": F (models that use it), "roll_deg": R, ...the model's parameters}
nlohmann::json cameraToJson(const Camera& camera);
/// @p base with the entries of @p j (any subset of cameraToJson()'s; a parameter null: its
/// default) applied; throws Error
/// naming @p where and the key for an unknown key or a value of the wrong type. The camera is
/// not validated (Projection does that).
Camera cameraFromJson(const nlohmann::json& j, const Camera& base, const std::string& where);

} // namespace nebula
