// SPDX-License-Identifier: Apache-2.0
#include "nebula/render/camera.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace nebula {

std::string toString(CameraModel model)
{
    switch (model) {
    case CameraModel::Fisheye: return "fisheye";
    case CameraModel::Equirect: return "equirect";
    case CameraModel::Orthographic: return "orthographic";
    case CameraModel::Ods: return "ods";
    case CameraModel::Perspective: break;
    }
    return "perspective";
}

CameraModel cameraModelFromString(const std::string& name)
{
    for (const auto m : {CameraModel::Perspective, CameraModel::Fisheye, CameraModel::Equirect,
                         CameraModel::Orthographic, CameraModel::Ods}) {
        if (name == toString(m)) return m;
    }
    throw UsageError(
        "--camera must be perspective, fisheye, equirect, orthographic or ods, got \"" +
        detail::printable(name, 40) + "\"");
}

namespace {

constexpr double DEG = PI / 180.0;

/// The solid angle of the rectangle [0, x] x [0, y] (signed) on the plane at distance 1.
double cornerSolidAngle(double x, double y)
{
    return std::atan(x * y / std::sqrt(1.0 + x * x + y * y));
}

} // namespace

Projection::Projection(const Camera& c)
    : mModel(c.model), mEye(c.eye), mWidth(c.width), mHeight(c.height)
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
    mForward = f;
    mRight = r;
    mUp = u;
    if (mModel == CameraModel::Fisheye && std::isfinite(c.domeTiltDeg)) {
        // A dome tilted by T: the axis is up tipped T towards the view, the front (the view
        // direction) at the bottom of the image; right stays right (axis x top = right).
        const double ct = std::cos(c.domeTiltDeg * DEG), st = std::sin(c.domeTiltDeg * DEG);
        mForward = (u * ct + f * st).normalized();
        mUp = (u * st - f * ct).normalized();
    }
    mTanH = std::tan(0.5 * c.fovDeg * DEG);
    mThetaMax = 0.5 * c.fovDeg * DEG;
    if (mModel == CameraModel::Orthographic) {
        mPixel = c.orthographicPixel();
        mDistance = c.observerDistance();
    }
    if (mModel == CameraModel::Ods) {
        mIpdHalf = 0.5 * c.ipdPc;
        mMergeFrom = c.poleMergeFromDeg * DEG;
        mMergeTo = c.poleMergeToDeg * DEG;
    }
}

double Projection::ipdFade(double lat) const
{
    const double a = std::fabs(lat);
    if (a <= mMergeFrom) return 1.0;
    if (a >= mMergeTo) return 0.0;
    return (mMergeTo - a) / (mMergeTo - mMergeFrom);
}

int Projection::panoramaRow(double py, double& local, double& height) const
{
    height = mModel == CameraModel::Ods ? 0.5 * mHeight : double(mHeight);
    const int view = mModel == CameraModel::Ods && py >= height ? 1 : 0; // equirect: py <= H
    local = py - view * height;
    return view;
}

void Projection::viewRows(int view, int& y0, int& y1) const
{
    if (mModel != CameraModel::Ods) {
        y0 = 0;
        y1 = mHeight;
        return;
    }
    y0 = view * (mHeight / 2);
    y1 = y0 + mHeight / 2;
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

Vec3 Projection::origin(double px, double py) const
{
    if (mModel == CameraModel::Ods) {
        // Half the IPD (faded towards the poles) to the left or right of the ray's
        // horizontal direction: t = right cos(lon) - forward sin(lon).
        double y = 0.0, h = 0.0;
        const int view = panoramaRow(py, y, h);
        const double lon = (px / mWidth - 0.5) * 2.0 * PI, lat = (0.5 - y / h) * PI;
        const double s = (view == 0 ? -mIpdHalf : mIpdHalf) * ipdFade(lat);
        return mEye + (mRight * std::cos(lon) - mForward * std::sin(lon)) * s;
    }
    if (mModel != CameraModel::Orthographic) return mEye;
    return mEye + mRight * ((px - 0.5 * mWidth) * mPixel) + mUp * ((0.5 * mHeight - py) * mPixel);
}

Vec3 Projection::originTowards(const Vec3& p) const
{
    if (mModel != CameraModel::Orthographic) return mEye;
    return p - mForward * (p - mEye).dot(mForward);
}

double Projection::distanceSquared(const Vec3& p) const
{
    if (mModel == CameraModel::Orthographic) return mDistance * mDistance;
    const Vec3 v = p - mEye;
    return v.dot(v);
}

bool Projection::direction(double px, double py, Vec3& d) const
{
    switch (mModel) {
    case CameraModel::Perspective: {
        const double sx = (2.0 * px / mWidth - 1.0) * mTanH;
        const double sy = (1.0 - 2.0 * py / mHeight) * mTanH * mHeight / mWidth;
        d = (mForward + mRight * sx + mUp * sy).normalized();
        return true;
    }
    case CameraModel::Fisheye: {
        const double u = 2.0 * px / mWidth - 1.0, v = 1.0 - 2.0 * py / mHeight;
        const double r = std::sqrt(u * u + v * v);
        if (r > 1.0) return false;
        const double theta = r * mThetaMax;
        if (r == 0.0) {
            d = mForward;
            return true;
        }
        const double s = std::sin(theta) / r;
        d = (mForward * std::cos(theta) + mRight * (s * u) + mUp * (s * v)).normalized();
        return true;
    }
    case CameraModel::Equirect:
    case CameraModel::Ods: { // ODS: each eye's view an equirect panorama W x H/2
        double y = 0.0, h = 0.0;
        panoramaRow(py, y, h);
        const double lon = (px / mWidth - 0.5) * 2.0 * PI, lat = (0.5 - y / h) * PI;
        const double cl = std::cos(lat);
        d = (mForward * (cl * std::cos(lon)) + mRight * (cl * std::sin(lon)) + mUp * std::sin(lat))
                .normalized();
        return true;
    }
    case CameraModel::Orthographic: d = mForward; return true;
    }
    return false;
}

Vec3 Projection::direction(double px, double py) const
{
    Vec3 d = mForward;
    direction(px, py, d);
    return d;
}

bool Projection::inView(double px, double py) const
{
    Vec3 d;
    return direction(px, py, d);
}

double Projection::fisheyeJacobian(double u, double v) const
{
    // dOmega = sin(theta) dtheta dphi with theta = r thetaMax; dA = r dr dphi.
    const double r = std::sqrt(u * u + v * v);
    if (r > 1.0) return 0.0;
    if (r < 1e-12) return mThetaMax * mThetaMax;
    return mThetaMax * std::sin(r * mThetaMax) / r;
}

double Projection::pixelSolidAngle(double px, double py) const
{
    switch (mModel) {
    case CameraModel::Perspective: {
        // Exact: the signed corner solid angles of the pixel's rectangle on the image plane.
        const double sx = 2.0 * mTanH / mWidth, sy = 2.0 * mTanH * mHeight / mWidth / mHeight;
        const double x0 = (px - 0.5) * sx - mTanH, x1 = x0 + sx;
        const double yTop = mTanH * mHeight / mWidth;
        const double y0 = yTop - (py + 0.5) * sy, y1 = y0 + sy;
        return cornerSolidAngle(x1, y1) - cornerSolidAngle(x0, y1) - cornerSolidAngle(x1, y0) +
               cornerSolidAngle(x0, y0);
    }
    case CameraModel::Fisheye: {
        constexpr int N = 16;
        const double du = 2.0 / mWidth, dv = 2.0 / mHeight;
        const double u0 = 2.0 * (px - 0.5) / mWidth - 1.0, v0 = 1.0 - 2.0 * (py - 0.5) / mHeight;
        double sum = 0.0;
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i)
                sum += fisheyeJacobian(u0 + (i + 0.5) * du / N, v0 - (j + 0.5) * dv / N);
        return sum * du * dv / (N * N);
    }
    case CameraModel::Equirect:
    case CameraModel::Ods: { // ODS: each eye's view an equirect panorama W x H/2
        double y = 0.0, h = 0.0;
        panoramaRow(py, y, h);
        const double latTop = (0.5 - (y - 0.5) / h) * PI, latBottom = (0.5 - (y + 0.5) / h) * PI;
        return 2.0 * PI / mWidth *
               (std::sin(std::min(latTop, 0.5 * PI)) - std::sin(std::max(latBottom, -0.5 * PI)));
    }
    case CameraModel::Orthographic: return (mPixel / mDistance) * (mPixel / mDistance);
    }
    return 0.0;
}

double Projection::pixelAngle(double px, double py) const
{
    if (mModel == CameraModel::Fisheye) return 2.0 * mThetaMax / mWidth;
    if (mModel == CameraModel::Orthographic) return 0.0;
    return std::sqrt(pixelSolidAngle(px, py));
}

bool Projection::project(const Vec3& p, double& px, double& py, int view) const
{
    if (mModel != CameraModel::Ods) return project(p, px, py);
    // The ray of this eye through p: its longitude lon = lon0 - asin(s / r_h), with s the
    // signed offset of its origin (-IPD/2 left, +IPD/2 right, faded at its latitude) and
    // r_h p's horizontal distance; its latitude atan2(height, r_h cos(lon0 - lon)). The fade
    // depends on the latitude: a few fixed-point steps (it converges: |d fade / d lat| IPD is
    // far below r_h).
    const Vec3 v = p - mEye;
    const double a = v.dot(mForward), b = v.dot(mRight), c = v.dot(mUp);
    const double rh = std::sqrt(a * a + b * b);
    const double lon0 = std::atan2(b, a);
    double lat = std::atan2(c, rh), lon = lon0;
    for (int i = 0; i < 8; ++i) {
        const double s = (view == 0 ? -mIpdHalf : mIpdHalf) * ipdFade(lat);
        if (!(std::fabs(s) < rh)) return false;
        const double delta = std::asin(s / rh);
        lon = lon0 - delta;
        lat = std::atan2(c, rh * std::cos(delta));
    }
    lon = std::remainder(lon, 2.0 * PI);
    const double h = 0.5 * mHeight;
    px = (lon / (2.0 * PI) + 0.5) * mWidth;
    py = view * h + (0.5 - lat / PI) * h;
    return true;
}

bool Projection::project(const Vec3& p, double& px, double& py) const
{
    if (mModel == CameraModel::Ods) return project(p, px, py, 0);
    const Vec3 v = p - mEye;
    switch (mModel) {
    case CameraModel::Perspective: {
        const double z = v.dot(mForward);
        if (z <= 0.0) return false;
        const double sx = v.dot(mRight) / z, sy = v.dot(mUp) / z;
        px = (sx / mTanH + 1.0) * 0.5 * mWidth;
        py = (1.0 - sy / (mTanH * mHeight / mWidth)) * 0.5 * mHeight;
        return true;
    }
    case CameraModel::Fisheye: {
        const double len = v.length();
        if (!(len > 0.0)) return false;
        const Vec3 d = v * (1.0 / len);
        const double theta = std::acos(std::clamp(d.dot(mForward), -1.0, 1.0));
        if (theta > mThetaMax) return false;
        const double phi = std::atan2(d.dot(mUp), d.dot(mRight));
        const double r = theta / mThetaMax;
        px = (1.0 + r * std::cos(phi)) * 0.5 * mWidth;
        py = (1.0 - r * std::sin(phi)) * 0.5 * mHeight;
        return true;
    }
    case CameraModel::Equirect: {
        const double len = v.length();
        if (!(len > 0.0)) return false;
        const Vec3 d = v * (1.0 / len);
        const double lon = std::atan2(d.dot(mRight), d.dot(mForward));
        const double lat = std::asin(std::clamp(d.dot(mUp), -1.0, 1.0));
        px = (lon / (2.0 * PI) + 0.5) * mWidth;
        py = (0.5 - lat / PI) * mHeight;
        return true;
    }
    case CameraModel::Orthographic: {
        if (!(v.dot(mForward) > 0.0)) return false; // on or behind the eye's plane
        px = 0.5 * mWidth + v.dot(mRight) / mPixel;
        py = 0.5 * mHeight - v.dot(mUp) / mPixel;
        return true;
    }
    case CameraModel::Ods: break; // per view, above
    }
    return false;
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
    const std::string res = std::to_string(c.width) + "x" + std::to_string(c.height);
    switch (c.model) {
    case CameraModel::Perspective:
        if (!(c.fovDeg > 0.0 && c.fovDeg <= 179.0)) {
            throw UsageError("--fov must be in (0, 179] degrees for the perspective camera, got " +
                             detail::numberText(c.fovDeg) +
                             " (wider views: --camera fisheye or equirect)");
        }
        break;
    case CameraModel::Orthographic:
        if (std::isnan(c.pixelSizePc) && !(c.fovDeg > 0.0 && c.fovDeg <= 179.0)) {
            throw UsageError("--fov must be in (0, 179] degrees when it sets the orthographic "
                             "camera's pixel (the width it spans at --look-at), got " +
                             detail::numberText(c.fovDeg) + "; or give --pixel-size");
        }
        break;
    case CameraModel::Fisheye:
        if (!(c.fovDeg > 0.0 && c.fovDeg <= 360.0)) {
            throw UsageError("--fov must be in (0, 360] degrees for the fisheye camera, got " +
                             detail::numberText(c.fovDeg));
        }
        if (c.width != c.height) {
            throw UsageError("--camera fisheye makes a square dome master: --res " + res +
                             " must be square, e.g. " + std::to_string(c.height) + "x" +
                             std::to_string(c.height));
        }
        break;
    case CameraModel::Ods:
        if (c.width != c.height || c.height % 2 != 0) {
            // The even square within the size asked for: no more pixels, so it fits wherever
            // that size would have.
            const int small = std::min(c.width, c.height);
            const int side = std::max(2, small - small % 2);
            throw UsageError("--camera ods makes two 2:1 panoramas, the left eye's above the "
                             "right's: --res " +
                             res + " must be square with an even height, e.g. " +
                             std::to_string(side) + "x" + std::to_string(side));
        }
        if (std::isnan(c.ipdPc)) {
            throw UsageError("--camera ods needs --ipd, the inter-pupillary distance, a finite "
                             "length > 0 [pc] (not given; about 1/30 of the distance to the "
                             "nebula is comfortable)");
        }
        if (!(c.ipdPc > 0.0) || !std::isfinite(c.ipdPc) || c.ipdPc > MAX_CAMERA_COORDINATE) {
            throw UsageError("--camera ods needs --ipd, the inter-pupillary distance, a finite "
                             "length > 0 [pc], got " +
                             detail::numberText(c.ipdPc));
        }
        if (!(c.poleMergeFromDeg >= 0.0 && c.poleMergeFromDeg < c.poleMergeToDeg &&
              c.poleMergeToDeg <= 90.0)) {
            throw UsageError("--pole-merge FROM,TO must have 0 <= FROM < TO <= 90 degrees, got " +
                             detail::numberText(c.poleMergeFromDeg) + "," +
                             detail::numberText(c.poleMergeToDeg));
        }
        break;
    case CameraModel::Equirect:
        if (c.width != 2 * c.height) {
            throw UsageError("--camera equirect makes a 2:1 panorama: --res " + res +
                             " must be twice as wide as high, e.g. " +
                             std::to_string(2 * c.height) + "x" + std::to_string(c.height));
        }
        break;
    }
    for (const auto& [value, option] :
         {std::pair{c.distancePc, "--distance"}, std::pair{c.pixelSizePc, "--pixel-size"}}) {
        if (std::isnan(value)) continue;
        if (c.model != CameraModel::Orthographic) {
            throw UsageError(std::string(option) + " is for --camera orthographic");
        }
        if (!(value > 0.0) || !std::isfinite(value) || value > MAX_CAMERA_COORDINATE) {
            throw UsageError(std::string(option) + " must be a finite length > 0 [pc], got " +
                             detail::numberText(value));
        }
    }
    if (c.model == CameraModel::Orthographic) {
        const double p = c.orthographicPixel();
        if (!(p > 0.0) || !std::isfinite(p) || !std::isfinite(p * c.width * c.height)) {
            throw UsageError("the orthographic camera's pixel must be finite and > 0 [pc], got " +
                             detail::numberText(p));
        }
    }
    if (c.model != CameraModel::Ods && !std::isnan(c.ipdPc)) {
        throw UsageError("--ipd is for --camera ods");
    }
    if (c.model != CameraModel::Ods && (c.poleMergeFromDeg != Camera().poleMergeFromDeg ||
                                        c.poleMergeToDeg != Camera().poleMergeToDeg)) {
        throw UsageError("--pole-merge is for --camera ods");
    }
    if (!std::isnan(c.domeTiltDeg)) {
        if (c.model != CameraModel::Fisheye) {
            throw UsageError("--dome-tilt is for --camera fisheye");
        }
        if (!(c.domeTiltDeg >= 0.0 && c.domeTiltDeg <= 90.0)) {
            throw UsageError("--dome-tilt must be in [0, 90] degrees, got " +
                             detail::numberText(c.domeTiltDeg));
        }
    }
}

} // namespace nebula
