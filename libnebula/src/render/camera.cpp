// SPDX-License-Identifier: Apache-2.0
#include "nebula/render/camera.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/render/camera_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace nebula {

namespace {

constexpr double DEG = PI / 180.0;

} // namespace

CameraProjection::CameraProjection(const Camera& c) : eye(c.eye), width(c.width), height(c.height)
{
    const Vec3 f = (c.lookAt - c.eye).normalized();
    Vec3 r = f.cross(c.up).normalized();
    Vec3 u = r.cross(f);
    if (c.rollDeg != 0.0) { // the camera turns clockwise as seen from behind it
        const double cr = std::cos(c.rollDeg * DEG), sr = std::sin(c.rollDeg * DEG);
        const Vec3 r2 = r * cr - u * sr, u2 = u * cr + r * sr;
        r = r2;
        u = u2;
    }
    forward = f;
    right = r;
    up = u;
}

double CameraProjection::pixelAngle(double px, double py) const
{
    return std::sqrt(pixelSolidAngle(px, py));
}

Vec3 CameraProjection::origin(double, double) const
{
    return eye;
}

Vec3 CameraProjection::originTowards(const Vec3&) const
{
    return eye;
}

double CameraProjection::distanceSquared(const Vec3& p) const
{
    const Vec3 v = p - eye;
    return v.dot(v);
}

void CameraProjection::viewRows(int, int& y0, int& y1) const
{
    y0 = 0;
    y1 = height;
}

Projection::Projection(const Camera& camera) : mModel(&cameraModel(camera.model))
{
    validateCamera(camera);
    mMap = mModel->projection(camera);
}

bool Projection::direction(double px, double py, Vec3& d) const
{
    return mMap->direction(px, py, d);
}

Vec3 Projection::direction(double px, double py) const
{
    Vec3 d = mMap->forward;
    mMap->direction(px, py, d);
    return d;
}

Vec3 Projection::origin(double px, double py) const
{
    return mMap->origin(px, py);
}
Vec3 Projection::originTowards(const Vec3& p) const
{
    return mMap->originTowards(p);
}
double Projection::distanceSquared(const Vec3& p) const
{
    return mMap->distanceSquared(p);
}
bool Projection::parallel() const
{
    return mMap->parallel();
}
bool Projection::wrapsHorizontally() const
{
    return mMap->wrapsHorizontally();
}
bool Projection::coversImage() const
{
    return mMap->coversImage();
}
int Projection::views() const
{
    return mMap->views();
}
void Projection::viewRows(int view, int& y0, int& y1) const
{
    mMap->viewRows(view, y0, y1);
}
const Vec3& Projection::eye() const
{
    return mMap->eye;
}
const Vec3& Projection::forward() const
{
    return mMap->forward;
}
const Vec3& Projection::right() const
{
    return mMap->right;
}
const Vec3& Projection::upward() const
{
    return mMap->up;
}

bool Projection::inView(double px, double py) const
{
    Vec3 d;
    return mMap->direction(px, py, d);
}

double Projection::pixelSolidAngle(double px, double py) const
{
    return mMap->pixelSolidAngle(px, py);
}

double Projection::pixelAngle(double px, double py) const
{
    return mMap->pixelAngle(px, py);
}

bool Projection::project(const Vec3& p, double& px, double& py) const
{
    return mMap->project(p, px, py, 0);
}

bool Projection::project(const Vec3& p, double& px, double& py, int view) const
{
    return mMap->project(p, px, py, view);
}

double Camera::orthographicPixel() const
{
    if (!std::isnan(pixelSizePc)) return pixelSizePc;
    return 2.0 * (lookAt - eye).length() * std::tan(0.5 * fovDeg * DEG) / width;
}

double Camera::observerDistance() const
{
    return std::isnan(distancePc) ? (lookAt - eye).length() : distancePc;
}

Vec3 Camera::direction(double px, double py) const
{
    return Projection(*this).direction(px, py);
}

double Camera::pixelSolidAngle(double px, double py) const
{
    return Projection(*this).pixelSolidAngle(px, py);
}

bool Camera::project(const Vec3& p, double& px, double& py) const
{
    return Projection(*this).project(p, px, py);
}

namespace {

/// Throws UsageError naming @p option unless @p v is finite and its squared length (and
/// that of a difference with another such point) is too.
void requireSquarable(const Vec3& v, const char* option)
{
    for (double x : {v.x, v.y, v.z}) {
        if (!std::isfinite(x)) {
            throw UsageError(std::string(option) + " must be three finite numbers, got " +
                             detail::numberText(v.x) + "," + detail::numberText(v.y) + "," +
                             detail::numberText(v.z));
        }
        if (std::fabs(x) > MAX_CAMERA_COORDINATE) {
            throw UsageError(std::string(option) + " " + detail::numberText(v.x) + "," +
                             detail::numberText(v.y) + "," + detail::numberText(v.z) +
                             ": each number must be at most " +
                             detail::numberText(MAX_CAMERA_COORDINATE) +
                             " in magnitude (its distance squared would overflow)");
        }
    }
}

} // namespace

void validateCamera(const Camera& c)
{
    const CameraModel& model = cameraModel(c.model);
    requireSquarable(c.eye, "--eye");
    requireSquarable(c.lookAt, "--look-at");
    requireSquarable(c.up, "--up");
    const Vec3 f = c.lookAt - c.eye;
    if (!(f.length() > 0.0)) throw UsageError("--eye and --look-at must differ");
    if (!(c.up.length() > 0.0) || !(f.normalized().cross(c.up.normalized()).length() > 1e-6)) {
        throw UsageError("--up must be non-zero and not parallel to the view direction");
    }
    if (!(std::fabs(c.rollDeg) <= 360.0)) {
        throw UsageError("--roll must be in [-360, 360] degrees, got " +
                         detail::numberText(c.rollDeg));
    }
    for (const auto& p : cameraParameters())
        if (p.given(c)) model.requireReads(p.name);
    model.validate(c);
}

// ---- The registry's helpers (the list itself: camera_models.cpp) ----

const CameraModel& cameraModel(const std::string& name)
{
    for (const CameraModel* m : cameraModels())
        if (m->name() == name) return *m;
    throw UsageError("--camera must be " + cameraModelNames() + ", got \"" +
                     detail::printable(name, 40) + "\"");
}

const CameraModel& stereoCameraModel(const std::string& mono)
{
    std::string have;
    for (const CameraModel* m : cameraModels()) {
        if (m->stereoOf() == mono) return *m;
        if (!m->stereoOf().empty()) {
            have += (have.empty() ? "" : ", ") + m->stereoOf() + " (" + m->name() + ")";
        }
    }
    throw UsageError("--stereo: --camera " + detail::printable(mono, 40) +
                     " has no stereo form; the cameras that have one: " + have);
}

std::string cameraModelNames(const std::string& last)
{
    const auto& models = cameraModels();
    std::string s;
    for (std::size_t i = 0; i < models.size(); ++i) {
        if (i > 0) s += i + 1 == models.size() ? " " + last + " " : ", ";
        s += models[i]->name();
    }
    return s;
}

std::string cameraModelsReading(const std::string& name)
{
    std::vector<std::string> names;
    for (const CameraModel* m : cameraModels())
        if (m->reads(name)) names.push_back(m->name());
    std::string s;
    for (std::size_t i = 0; i < names.size(); ++i)
        s += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
    return s;
}

// ---- Model-specific parameters: one row each ----

namespace {

std::vector<double> one(double v)
{
    return {v};
}

/// --pixel-size: a number > 0 with an optional unit, "pc" (the default) or "arcsec" (which
/// needs the observer's --distance).
std::vector<double> parsePixelSize(const std::string& text, const Camera& c)
{
    const auto unitAt = text.find_first_not_of("0123456789.eE+-");
    const std::string number = text.substr(0, unitAt);
    const std::string unit = unitAt == std::string::npos ? "pc" : text.substr(unitAt);
    double value = 0.0;
    try {
        std::size_t used = 0;
        value = std::stod(number, &used);
        if (used != number.size()) throw std::invalid_argument(text);
    } catch (const std::exception&) {
        value = std::nan("");
    }
    if (!(value > 0.0) || !std::isfinite(value) || (unit != "pc" && unit != "arcsec")) {
        throw UsageError("--pixel-size \"" + detail::printable(text, 40) +
                         "\": expected a number > 0 with an optional unit pc or arcsec, e.g. "
                         "0.01pc or 2arcsec");
    }
    if (unit == "pc") return one(value);
    if (std::isnan(c.distancePc)) {
        throw UsageError("--pixel-size " + detail::printable(text, 40) +
                         " is an angle: it needs the observer's --distance [pc]");
    }
    return one(value * ARCSEC_RAD * c.distancePc);
}

} // namespace

std::vector<double> parseCameraParameter(const CameraParameter& p, const std::string& text,
                                         const Camera& camera)
{
    if (p.parse) return p.parse(text, camera);
    std::vector<double> v;
    std::size_t start = 0;
    while (true) {
        const auto comma = text.find(',', start);
        const std::string item =
            text.substr(start, comma == std::string::npos ? comma : comma - start);
        double x = std::nan("");
        try {
            std::size_t used = 0;
            x = std::stod(item, &used);
            if (used != item.size()) x = std::nan("");
        } catch (const std::exception&) {
        }
        if (!std::isfinite(x) || int(v.size()) >= p.values) {
            throw UsageError("--" + p.name + " \"" + detail::printable(text, 40) + "\": expected " +
                             p.type + ", " + std::to_string(p.values) + " finite number" +
                             (p.values > 1 ? "s" : "") +
                             (p.values > 1 ? " separated by commas" : ""));
        }
        v.push_back(x);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    if (int(v.size()) != p.values) {
        throw UsageError("--" + p.name + " \"" + detail::printable(text, 40) + "\": expected " +
                         p.type + ", " + std::to_string(p.values) + " numbers separated by commas");
    }
    return v;
}

const std::vector<CameraParameter>& cameraParameters()
{
    static const std::vector<CameraParameter> table{
        {"dome-tilt", "dome_tilt_deg",
         "A planetarium dome tilted T degrees, the audience facing --look-at: the dome's\n"
         "centre is --up tipped T towards the view direction (0 a horizontal dome: the\n"
         "look-at point on the bottom edge; 90 the same as no tilt: the centre at --look-at)",
         "DEG", 1, [](const Camera& c) { return !std::isnan(c.domeTiltDeg); },
         [](const Camera& c) { return one(c.domeTiltDeg); },
         [](Camera& c, const std::vector<double>& v) { c.domeTiltDeg = v.empty() ? NAN : v[0]; }},
        {"pixel-size", "pixel_size_pc",
         "The pixel's size, 0.01pc (pc if no unit) or, with --distance, 2arcsec (default:\n"
         "the width --fov spans at --look-at, over the width)",
         "SIZE", 1, [](const Camera& c) { return !std::isnan(c.pixelSizePc); },
         [](const Camera& c) { return one(c.orthographicPixel()); },
         [](Camera& c, const std::vector<double>& v) { c.pixelSizePc = v.empty() ? NAN : v[0]; },
         parsePixelSize},
        {"distance", "distance_pc",
         "The observer's distance [pc]: pixel solid angles (pixel / distance)^2, star\n"
         "fluxes, arcsec pixels, fluxes in --sed (default: the distance from --eye to\n"
         "--look-at); at least a pixel and 1e-6 pc",
         "PC", 1, [](const Camera& c) { return !std::isnan(c.distancePc); },
         [](const Camera& c) { return one(c.observerDistance()); },
         [](Camera& c, const std::vector<double>& v) { c.distancePc = v.empty() ? NAN : v[0]; }},
        {"ipd", "ipd_pc",
         "The inter-pupillary distance [pc] (required; about 1/30 of the distance to the\n"
         "nebula gives a comfortable depth)",
         "PC", 1, [](const Camera& c) { return !std::isnan(c.ipdPc); },
         [](const Camera& c) { return one(c.ipdPc); },
         [](Camera& c, const std::vector<double>& v) { c.ipdPc = v.empty() ? NAN : v[0]; }},
        {"pole-merge", "pole_merge_deg",
         "The latitudes FROM,TO [degrees] between which the IPD fades to 0, so the poles\n"
         "have no parallax (default 60,75)",
         "FROM,TO", 2,
         [](const Camera& c) {
             return c.poleMergeFromDeg != Camera().poleMergeFromDeg ||
                    c.poleMergeToDeg != Camera().poleMergeToDeg;
         },
         [](const Camera& c) {
             return std::vector<double>{c.poleMergeFromDeg, c.poleMergeToDeg};
         },
         [](Camera& c, const std::vector<double>& v) {
             c.poleMergeFromDeg = v.empty() ? Camera().poleMergeFromDeg : v[0];
             c.poleMergeToDeg = v.empty() ? Camera().poleMergeToDeg : v[1];
         }},
    };
    return table;
}

const CameraParameter& cameraParameter(const std::string& name)
{
    for (const auto& p : cameraParameters())
        if (p.name == name) return p;
    throw Error("internal: no camera parameter " + name);
}

// ---- Defaults of the model interface ----

bool CameraModel::reads(const std::string& name) const
{
    const auto names = parameters();
    return std::find(names.begin(), names.end(), name) != names.end();
}

void CameraModel::requireReads(const std::string& name) const
{
    if (reads(name)) return;
    throw UsageError("--" + name + " is for --camera " + cameraModelsReading(name) +
                     " (--camera is " + this->name() + ")");
}

void CameraModel::describe(const Camera& c, nlohmann::json& j) const
{
    for (const auto& name : parameters()) {
        const CameraParameter& p = cameraParameter(name);
        if (!p.given(c)) continue;
        const auto v = p.get(c);
        j[p.json] = v.size() == 1 ? nlohmann::json(v[0]) : nlohmann::json(v);
    }
}

std::vector<CameraCard> CameraModel::fitsCards(const Camera& c) const
{
    return {{"FOV", c.fovDeg, "horizontal field of view [deg]"}};
}

// ---- One camera JSON ----

nlohmann::json cameraToJson(const Camera& c)
{
    const auto vec = [](const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); };
    const CameraModel& model = cameraModel(c.model);
    nlohmann::json j = {{"eye", vec(c.eye)},
                        {"look_at", vec(c.lookAt)},
                        {"up", vec(c.up)},
                        {"roll_deg", c.rollDeg},
                        {"projection", model.name()}};
    if (model.usesFov(c)) j["fov_deg"] = c.fovDeg;
    model.describe(c, j);
    return j;
}

namespace {

double jsonNumber(const nlohmann::json& v, const std::string& where)
{
    if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw Error(where + " must be a finite number");
    return v.get<double>();
}

Vec3 jsonVec3(const nlohmann::json& v, const std::string& where)
{
    if (!v.is_array() || v.size() != 3)
        throw Error(where + " must be an array of three numbers [x, y, z]");
    return {jsonNumber(v[0], where), jsonNumber(v[1], where), jsonNumber(v[2], where)};
}

} // namespace

Camera cameraFromJson(const nlohmann::json& j, const Camera& base, const std::string& where)
{
    if (!j.is_object()) throw Error(where + ": a camera must be a JSON object");
    Camera c = base;
    for (const auto& [key, value] : j.items()) {
        const std::string at = where + ": " + key;
        if (key == "projection") {
            if (!value.is_string()) throw Error(at + " must be a camera model's name");
            c.model = cameraModel(value.get<std::string>()).name();
        } else if (key == "eye") {
            c.eye = jsonVec3(value, at);
        } else if (key == "look_at") {
            c.lookAt = jsonVec3(value, at);
        } else if (key == "up") {
            c.up = jsonVec3(value, at);
        } else if (key == "fov_deg") {
            c.fovDeg = jsonNumber(value, at);
        } else if (key == "roll_deg") {
            c.rollDeg = jsonNumber(value, at);
        } else if (key == "layout") {
            continue; // written for readers; the model fixes it
        } else {
            const CameraParameter* param = nullptr;
            for (const auto& p : cameraParameters())
                if (p.json == key) param = &p;
            if (!param) {
                throw Error(where + ": unknown camera key \"" + detail::printable(key, 40) +
                            "\" (expected projection, eye, look_at, up, fov_deg, roll_deg or a "
                            "model's parameter)");
            }
            std::vector<double> v;
            if (value.is_null()) {
                param->set(c, {}); // unset: the default
                continue;
            }
            if (value.is_array()) {
                for (const auto& x : value)
                    v.push_back(jsonNumber(x, at));
            } else {
                v.push_back(jsonNumber(value, at));
            }
            if (int(v.size()) != param->values) {
                throw Error(at + " must be " + std::to_string(param->values) + " number(s)");
            }
            param->set(c, v);
        }
    }
    return c;
}

} // namespace nebula
