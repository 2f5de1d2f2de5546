// SPDX-License-Identifier: Apache-2.0
/// @file camera_perspective.cpp
/// The perspective camera: a pinhole, --fov the horizontal angle.
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/render/camera_model.h"

#include <cmath>

namespace nebula {
namespace {

/// The solid angle of the rectangle [0, x] x [0, y] (signed) on the plane at distance 1.
double cornerSolidAngle(double x, double y)
{
    return std::atan(x * y / std::sqrt(1.0 + x * x + y * y));
}

class PerspectiveProjection final : public CameraProjection
{
public:
    explicit PerspectiveProjection(const Camera& c)
        : CameraProjection(c), mTanH(std::tan(0.5 * c.fovDeg * DEG_RAD))
    {}

    bool direction(double px, double py, Vec3& d) const override
    {
        const double sx = (2.0 * px / width - 1.0) * mTanH;
        const double sy = (1.0 - 2.0 * py / height) * mTanH * height / width;
        d = (forward + right * sx + up * sy).normalized();
        return true;
    }

    double pixelSolidAngle(double px, double py) const override
    {
        // Exact: the signed corner solid angles of the pixel's rectangle on the image plane.
        const double sx = 2.0 * mTanH / width, sy = 2.0 * mTanH * height / width / height;
        const double x0 = (px - 0.5) * sx - mTanH, x1 = x0 + sx;
        const double yTop = mTanH * height / width;
        const double y0 = yTop - (py + 0.5) * sy, y1 = y0 + sy;
        return cornerSolidAngle(x1, y1) - cornerSolidAngle(x0, y1) - cornerSolidAngle(x1, y0) +
               cornerSolidAngle(x0, y0);
    }

    bool project(const Vec3& p, double& px, double& py, int) const override
    {
        const Vec3 v = p - eye;
        const double z = v.dot(forward);
        if (z <= 0.0) return false;
        const double sx = v.dot(right) / z, sy = v.dot(up) / z;
        px = (sx / mTanH + 1.0) * 0.5 * width;
        py = (1.0 - sy / (mTanH * height / width)) * 0.5 * height;
        return true;
    }

private:
    double mTanH; ///< tan of half the horizontal field of view
};

class Perspective final : public CameraModel
{
public:
    std::string name() const override { return "perspective"; }
    std::string help() const override
    {
        return "perspective: a pinhole, --fov the horizontal angle";
    }
    void validate(const Camera& c) const override
    {
        if (!(c.fovDeg > 0.0 && c.fovDeg <= 179.0)) {
            throw UsageError("--fov must be in (0, 179] degrees for the perspective camera, got " +
                             detail::numberText(c.fovDeg) +
                             " (wider views: --camera fisheye or equirect)");
        }
    }
    std::unique_ptr<CameraProjection> projection(const Camera& c) const override
    {
        return std::make_unique<PerspectiveProjection>(c);
    }
    std::optional<CameraSkyPlane> skyPlane(const Camera& c) const override
    {
        // The image plane at distance 1 is the gnomonic plane.
        return CameraSkyPlane{2.0 * std::tan(0.5 * c.fovDeg * DEG_RAD) / c.width, NAN};
    }
};

} // namespace

const CameraModel& perspectiveCamera()
{
    static const Perspective model;
    return model;
}

} // namespace nebula
