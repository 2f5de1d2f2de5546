// SPDX-License-Identifier: Apache-2.0
#include "nebula/render/camera_path.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"

#include <algorithm>
#include <cmath>

namespace nebula {

namespace {

/// One point of the centripetal Catmull-Rom segment P1 -> P2 (Barry and Goldman's pyramid,
/// knots spaced by the square root of the distance), at u in [0, 1]. Coincident
/// neighbours (a zero knot interval) fall back to the nearer point, so a camera that stays
/// put between two keyframes stays put.
Vec3 centripetal(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, double u)
{
    const auto knot = [](const Vec3& a, const Vec3& b) { return std::sqrt((b - a).length()); };
    const double t0 = 0.0, t1 = t0 + knot(p0, p1), t2 = t1 + knot(p1, p2), t3 = t2 + knot(p2, p3);
    if (!(t2 > t1)) return p1; // P1 == P2: no motion in this segment
    const double t = t1 + u * (t2 - t1);
    const auto lerp = [](const Vec3& a, const Vec3& b, double ta, double tb, double x) {
        if (!(tb > ta)) return b;
        return a * ((tb - x) / (tb - ta)) + b * ((x - ta) / (tb - ta));
    };
    const Vec3 a1 = lerp(p0, p1, t0, t1, t), a2 = lerp(p1, p2, t1, t2, t),
               a3 = lerp(p2, p3, t2, t3, t);
    const Vec3 b1 = lerp(a1, a2, t0, t2, t), b2 = lerp(a2, a3, t1, t3, t);
    return lerp(b1, b2, t1, t2, t);
}

/// Cubic Hermite interpolation of scalars v at keyframe times with Catmull-Rom tangents
/// (finite differences in time): C1 through the keyframes.
template <class Get>
double hermite(const std::vector<CameraKeyframe>& k, std::size_t i, double u, Get value)
{
    const std::size_t n = k.size();
    const double v1 = value(k[i]), v2 = value(k[i + 1]);
    const double h = k[i + 1].time - k[i].time;
    const auto slope = [&](std::size_t j) {
        const std::size_t a = j == 0 ? 0 : j - 1, b = j + 1 < n ? j + 1 : n - 1;
        return (value(k[b]) - value(k[a])) / (k[b].time - k[a].time);
    };
    const double m1 = slope(i) * h, m2 = slope(i + 1) * h;
    const double u2 = u * u, u3 = u2 * u;
    return (2 * u3 - 3 * u2 + 1) * v1 + (u3 - 2 * u2 + u) * m1 + (-2 * u3 + 3 * u2) * v2 +
           (u3 - u2) * m2;
}

Vec3 vec3At(const std::vector<CameraKeyframe>& k, std::size_t i, double u,
            Vec3 CameraKeyframe::*field)
{
    const std::size_t n = k.size();
    const Vec3& p1 = k[i].*field;
    const Vec3& p2 = k[i + 1].*field;
    // Phantom end points, reflected: the curve leaves the first and reaches the last
    // keyframe heading straight for its neighbour.
    const Vec3 p0 = i > 0 ? k[i - 1].*field : p1 * 2.0 - p2;
    const Vec3 p3 = i + 2 < n ? k[i + 2].*field : p2 * 2.0 - p1;
    return centripetal(p0, p1, p2, p3, u);
}

/// Time after easing: the speed ramps linearly from 0 over easeIn seconds and back to 0 over
/// the last easeOut seconds, constant between, and the eased clock covers [t0, t1] exactly.
double eased(double t, double t0, double t1, double in, double out)
{
    const double T = t1 - t0;
    if (!(T > 0.0) || (in <= 0.0 && out <= 0.0)) return t;
    const double x = std::clamp(t - t0, 0.0, T);
    const double v = T / (T - 0.5 * (in + out)); // the cruising speed
    double s;
    if (x < in) {
        s = 0.5 * v * x * x / in;
    } else if (x <= T - out) {
        s = 0.5 * v * in + v * (x - in);
    } else {
        const double r = T - x;
        s = T - 0.5 * v * r * r / out;
    }
    return t0 + s;
}

Vec3 readVec3(const nlohmann::json& j, const std::string& where)
{
    if (!j.is_array() || j.size() != 3) throw Error(where + " must be an array of 3 numbers");
    Vec3 v;
    for (int c = 0; c < 3; ++c) {
        if (!j[std::size_t(c)].is_number()) throw Error(where + " must be an array of 3 numbers");
        v[c] = j[std::size_t(c)].get<double>();
        if (!std::isfinite(v[c]) || std::fabs(v[c]) > MAX_CAMERA_COORDINATE) {
            throw Error(where + " must hold finite numbers of at most " +
                        detail::numberText(MAX_CAMERA_COORDINATE) + " in magnitude");
        }
    }
    return v;
}

double readNumber(const nlohmann::json& j, const std::string& where, double lo, double hi)
{
    if (!j.is_number()) throw Error(where + " must be a number");
    const double v = j.get<double>();
    if (!(v >= lo && v <= hi)) {
        throw Error(where + " must be in [" + detail::numberText(lo) + ", " +
                    detail::numberText(hi) + "], got " + detail::numberText(v));
    }
    return v;
}

} // namespace

long CameraPath::frameCount() const
{
    if (keys.empty()) return 0;
    return long(std::floor(keys.back().time * fps + 1e-9)) + 1;
}

Camera CameraPath::at(double t, const Camera& base) const
{
    Camera c = base;
    if (keys.empty()) return c;
    const double t0 = keys.front().time, t1 = keys.back().time;
    t = eased(std::clamp(t, t0, t1), t0, t1, easeIn, easeOut);
    if (keys.size() == 1 || t <= t0) {
        const auto& k = keys.front();
        c.eye = k.eye, c.lookAt = k.lookAt, c.up = k.up, c.fovDeg = k.fovDeg, c.rollDeg = k.rollDeg;
        return c;
    }
    // The segment and its parameter: by keyframe time, or by arc length along the eye's curve.
    std::size_t seg = 0;
    double u = 0.0;
    bool placed = false;
    if (constantSpeed) {
        constexpr int SAMPLES = 256; // per segment: a polyline of the curve
        std::vector<double> cumulative{0.0};
        for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
            Vec3 prev = keys[i].eye;
            for (int s = 1; s <= SAMPLES; ++s) {
                const Vec3 p = vec3At(keys, i, double(s) / SAMPLES, &CameraKeyframe::eye);
                cumulative.push_back(cumulative.back() + (p - prev).length());
                prev = p;
            }
        }
        const double total = cumulative.back();
        if (total > 0.0) { // else the eye stays put: keyframe times decide
            const double target = total * (t - t0) / (t1 - t0);
            const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), target);
            const auto j = std::size_t(std::clamp<std::ptrdiff_t>(
                it - cumulative.begin(), 1, std::ptrdiff_t(cumulative.size()) - 1));
            const double a = cumulative[j - 1], b = cumulative[j];
            const double frac = b > a ? std::clamp((target - a) / (b - a), 0.0, 1.0) : 0.0;
            const double g = (double(j - 1) + frac) / SAMPLES; // global curve parameter
            seg = std::min<std::size_t>(std::size_t(g), keys.size() - 2);
            u = std::clamp(g - double(seg), 0.0, 1.0);
            placed = true;
        }
    }
    if (!placed) {
        while (seg + 2 < keys.size() && t >= keys[seg + 1].time)
            ++seg;
        u = std::clamp((t - keys[seg].time) / (keys[seg + 1].time - keys[seg].time), 0.0, 1.0);
    }
    c.eye = vec3At(keys, seg, u, &CameraKeyframe::eye);
    c.lookAt = vec3At(keys, seg, u, &CameraKeyframe::lookAt);
    // Up: each component by Hermite in time, then normalised (validateCamera() refuses an up
    // along the view).
    Vec3 up;
    for (int comp = 0; comp < 3; ++comp)
        up[comp] = hermite(keys, seg, u, [comp](const CameraKeyframe& k) { return k.up[comp]; });
    c.up = up.length() > 0.0 ? up.normalized() : keys[seg].up;
    c.fovDeg = hermite(keys, seg, u, [](const CameraKeyframe& k) { return k.fovDeg; });
    c.rollDeg = hermite(keys, seg, u, [](const CameraKeyframe& k) { return k.rollDeg; });
    return c;
}

CameraPath parseCameraPath(const std::string& text, const std::string& source,
                           const Camera& defaults)
{
    const auto j = detail::parseJson(text, source, "the camera path is ");
    const std::string where = detail::printable(source, 120);
    if (!j.is_object()) throw Error(where + ": a camera path must be a JSON object");
    CameraPath path;
    path.source = source;
    for (const auto& [key, value] : j.items()) {
        if (key != "version" && key != "fps" && key != "keyframes" && key != "constant_speed" &&
            key != "ease_in" && key != "ease_out") {
            throw Error(where + ": unknown key \"" + detail::printable(key, 40) +
                        "\" (expected version, fps, keyframes, constant_speed, ease_in, "
                        "ease_out)");
        }
    }
    // Version 2 (what nebula writes): keyframes in the camera's JSON (cameraToJson(): fov_deg,
    // roll_deg); version 1 (no "version"): fov and roll.
    int version = 1;
    if (j.contains("version")) {
        const auto& v = j["version"];
        if (!v.is_number_integer() ||
            (v.get<long>() != 1 && v.get<long>() != CAMERA_PATH_VERSION)) {
            throw Error(where + ": version must be 1 or 2 (this nebula reads camera paths of "
                                "versions 1 and 2)");
        }
        version = int(v.get<long>());
    }
    const std::string fovKey = version == 1 ? "fov" : "fov_deg";
    const std::string rollKey = version == 1 ? "roll" : "roll_deg";
    if (!j.contains("fps")) throw Error(where + ": \"fps\" is missing");
    path.fps = readNumber(j["fps"], where + ": fps", 1e-3, 1e4);
    if (j.contains("constant_speed")) {
        if (!j["constant_speed"].is_boolean()) {
            throw Error(where + ": constant_speed must be true or false");
        }
        path.constantSpeed = j["constant_speed"].get<bool>();
    }
    if (!j.contains("keyframes") || !j["keyframes"].is_array() || j["keyframes"].empty()) {
        throw Error(where + ": \"keyframes\" must be a non-empty array");
    }
    Vec3 up = defaults.up;
    double fov = defaults.fovDeg, roll = defaults.rollDeg;
    std::size_t n = 0;
    for (const auto& k : j["keyframes"]) {
        const std::string at = where + ": keyframe " + std::to_string(n + 1);
        if (!k.is_object()) throw Error(at + " must be an object");
        for (const auto& [key, value] : k.items()) {
            if (key != "time" && key != "eye" && key != "look_at" && key != "up" && key != fovKey &&
                key != rollKey) {
                const bool other =
                    key == "fov" || key == "roll" || key == "fov_deg" || key == "roll_deg";
                throw Error(at + ": unknown key \"" + detail::printable(key, 40) +
                            "\" (expected time, eye, look_at, up, " + fovKey + ", " + rollKey +
                            ")" +
                            (!other         ? ""
                             : version == 1 ? "; fov_deg and roll_deg are version 2's: add "
                                              "\"version\": 2 to the path"
                                            : "; version 2 names them fov_deg and roll_deg"));
            }
        }
        for (const char* req : {"time", "eye", "look_at"}) {
            if (!k.contains(req)) throw Error(at + ": \"" + req + "\" is missing");
        }
        CameraKeyframe key;
        key.time = readNumber(k["time"], at + ": time", 0.0, 1e7);
        key.eye = readVec3(k["eye"], at + ": eye");
        key.lookAt = readVec3(k["look_at"], at + ": look_at");
        if (k.contains("up")) up = readVec3(k["up"], at + ": up");
        if (k.contains(fovKey)) fov = readNumber(k[fovKey], at + ": " + fovKey, 1e-3, 360.0);
        if (k.contains(rollKey)) {
            roll = readNumber(k[rollKey], at + ": " + rollKey, -3600.0, 3600.0);
        }
        key.up = up;
        key.fovDeg = fov;
        key.rollDeg = roll;
        if (!path.keys.empty() && !(key.time > path.keys.back().time)) {
            throw Error(at + ": time " + detail::numberText(key.time) +
                        " must be after the previous keyframe's " +
                        detail::numberText(path.keys.back().time));
        }
        Camera check = defaults;
        check.eye = key.eye, check.lookAt = key.lookAt, check.up = key.up;
        check.fovDeg = key.fovDeg;
        try {
            (void)Projection(check); // a created camera is valid
        } catch (const UsageError& e) {
            throw Error(at + ": " + e.what());
        }
        path.keys.push_back(key);
        ++n;
    }
    const double span = path.keys.back().time - path.keys.front().time;
    for (const char* name : {"ease_in", "ease_out"}) {
        if (!j.contains(name)) continue;
        const double v = readNumber(j[name], where + ": " + name, 0.0, 1e7);
        (std::string(name) == "ease_in" ? path.easeIn : path.easeOut) = v;
    }
    if (path.easeIn + path.easeOut > span) {
        throw Error(where + ": ease_in + ease_out (" +
                    detail::numberText(path.easeIn + path.easeOut) +
                    " s) must not exceed the path's duration (" + detail::numberText(span) + " s)");
    }
    return path;
}

} // namespace nebula
