// SPDX-License-Identifier: Apache-2.0
/// @file camera_fisheye.cpp
/// The fisheye: the azimuthal-equidistant dome master of fulldome production, a square image
/// whose inscribed circle holds the view, the distance from its centre proportional to the
/// angle from the dome's axis (--fov the full angle, 180 by default, up to 360); pixels
/// outside the circle are not in view. --dome-tilt: a tilted planetarium dome.
#include "camera_fisheye.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"

#include <algorithm>
#include <cmath>

namespace nebula {
namespace detail {

FisheyeProjection::FisheyeProjection(const Camera& c)
    : CameraProjection(c), mThetaMax(0.5 * c.fovDeg * DEG_RAD), mCameraUp(up)
{
    if (std::isfinite(c.domeTiltDeg)) {
        // A dome tilted by T: the axis is up tipped T towards the view, the front (the view
        // direction) at the bottom of the image; right stays right (axis x top = right).
        const Vec3 f = forward, u = up;
        const double ct = std::cos(c.domeTiltDeg * DEG_RAD), st = std::sin(c.domeTiltDeg * DEG_RAD);
        forward = (u * ct + f * st).normalized();
        up = (u * st - f * ct).normalized();
    }
}

bool FisheyeProjection::direction(double px, double py, Vec3& d) const
{
    const double u = 2.0 * px / width - 1.0, v = 1.0 - 2.0 * py / height;
    const double r = std::sqrt(u * u + v * v);
    if (r > 1.0) return false;
    const double theta = r * mThetaMax;
    if (r == 0.0) {
        d = forward;
        return true;
    }
    const double s = std::sin(theta) / r;
    d = (forward * std::cos(theta) + right * (s * u) + up * (s * v)).normalized();
    return true;
}

double FisheyeProjection::jacobian(double u, double v) const
{
    // dOmega = sin(theta) dtheta dphi with theta = r thetaMax; dA = r dr dphi.
    const double r = std::sqrt(u * u + v * v);
    if (r > 1.0) return 0.0;
    if (r < 1e-12) return mThetaMax * mThetaMax;
    return mThetaMax * std::sin(r * mThetaMax) / r;
}

double FisheyeProjection::pixelSolidAngle(double px, double py) const
{
    constexpr int N = 16;
    const double du = 2.0 / width, dv = 2.0 / height;
    const double u0 = 2.0 * (px - 0.5) / width - 1.0, v0 = 1.0 - 2.0 * (py - 0.5) / height;
    double sum = 0.0;
    for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i)
            sum += jacobian(u0 + (i + 0.5) * du / N, v0 - (j + 0.5) * dv / N);
    return sum * du * dv / (N * N);
}

double FisheyeProjection::pixelAngle(double, double) const
{
    return 2.0 * mThetaMax / width;
}

bool FisheyeProjection::projectDirection(const Vec3& d, double& px, double& py) const
{
    const double theta = std::acos(std::clamp(d.dot(forward), -1.0, 1.0));
    if (theta > mThetaMax) return false;
    const double phi = std::atan2(d.dot(up), d.dot(right));
    const double r = theta / mThetaMax;
    px = (1.0 + r * std::cos(phi)) * 0.5 * width;
    py = (1.0 - r * std::sin(phi)) * 0.5 * height;
    return true;
}

bool FisheyeProjection::project(const Vec3& p, double& px, double& py, int) const
{
    const Vec3 v = p - eye;
    const double len = v.length();
    if (!(len > 0.0)) return false;
    return projectDirection(v * (1.0 / len), px, py);
}

void validateFisheye(const Camera& c, const std::string& model)
{
    if (!(c.fovDeg > 0.0 && c.fovDeg <= 360.0)) {
        throw UsageError("--fov must be in (0, 360] degrees for the " + model + " camera, got " +
                         numberText(c.fovDeg));
    }
    if (!std::isnan(c.domeTiltDeg) && !(c.domeTiltDeg >= 0.0 && c.domeTiltDeg <= 90.0)) {
        throw UsageError("--dome-tilt must be in [0, 90] degrees, got " +
                         numberText(c.domeTiltDeg));
    }
}

} // namespace detail

namespace {

class Fisheye final : public CameraModel
{
public:
    std::string name() const override { return "fisheye"; }
    std::string help() const override
    {
        return "fisheye: an azimuthal-equidistant dome master (square, the view inside the\n"
               "circle, --fov the full angle, 180 by default)";
    }
    std::vector<std::string> parameters() const override { return {"dome-tilt"}; }
    double defaultFov() const override { return 180.0; }
    double maxFov() const override { return 360.0; }
    void fitSize(int& width, int& height) const override
    {
        width = height = std::min(width, height);
    }
    void validate(const Camera& c) const override
    {
        detail::validateFisheye(c, "fisheye");
        if (c.width != c.height) {
            throw UsageError("--camera fisheye makes a square dome master: --res " +
                             std::to_string(c.width) + "x" + std::to_string(c.height) +
                             " must be square, e.g. " + std::to_string(c.height) + "x" +
                             std::to_string(c.height));
        }
    }
    std::unique_ptr<CameraProjection> projection(const Camera& c) const override
    {
        return std::make_unique<detail::FisheyeProjection>(c);
    }
};

} // namespace

const CameraModel& fisheyeCamera()
{
    static const Fisheye model;
    return model;
}

} // namespace nebula
