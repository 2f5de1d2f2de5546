#include "nebula/render/camera.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"

#include <cmath>

namespace nebula {

PinholeProjection::PinholeProjection(const Camera& c)
    : mEye(c.eye), mWidth(c.width), mHeight(c.height)
{
    mForward = (c.lookAt - c.eye).normalized();
    mRight = mForward.cross(c.up).normalized();
    mUp = mRight.cross(mForward);
    mTanH = std::tan(0.5 * c.fovDeg * PI / 180.0);
}

Vec3 PinholeProjection::direction(double px, double py) const
{
    const double sx = (2.0 * px / mWidth - 1.0) * mTanH;
    const double sy = (1.0 - 2.0 * py / mHeight) * mTanH * mHeight / mWidth;
    return (mForward + mRight * sx + mUp * sy).normalized();
}

double PinholeProjection::pixelSolidAngle(double px, double py) const
{
    const double du = 2.0 * mTanH / mWidth; // square pixels on the image plane at distance 1
    const double sx = (2.0 * px / mWidth - 1.0) * mTanH;
    const double sy = (1.0 - 2.0 * py / mHeight) * mTanH * mHeight / mWidth;
    const double cosTheta = 1.0 / std::sqrt(1.0 + sx * sx + sy * sy);
    return du * du * cosTheta * cosTheta * cosTheta;
}

bool PinholeProjection::project(const Vec3& p, double& px, double& py) const
{
    const Vec3 v = p - mEye;
    const double z = v.dot(mForward);
    if (z <= 0.0) return false;
    const double sx = v.dot(mRight) / z, sy = v.dot(mUp) / z;
    px = (sx / mTanH + 1.0) * 0.5 * mWidth;
    py = (1.0 - sy / (mTanH * mHeight / mWidth)) * 0.5 * mHeight;
    return true;
}

Vec3 Camera::direction(double px, double py) const
{
    return PinholeProjection(*this).direction(px, py);
}

double Camera::pixelSolidAngle(double px, double py) const
{
    return PinholeProjection(*this).pixelSolidAngle(px, py);
}

bool Camera::project(const Vec3& p, double& px, double& py) const
{
    return PinholeProjection(*this).project(p, px, py);
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
}

} // namespace nebula
