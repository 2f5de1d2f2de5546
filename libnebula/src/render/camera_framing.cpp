// SPDX-License-Identifier: Apache-2.0
/// @file camera_framing.cpp
/// --frame-nebula's geometry (render/camera_framing.h).
#include "nebula/render/camera_framing.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/render/camera_model.h"

#include <algorithm>
#include <cmath>

namespace nebula {

namespace {

/// @p v turned by @p angle [rad] about unit axis @p k (Rodrigues).
Vec3 rotated(const Vec3& v, const Vec3& k, double angle)
{
    const double c = std::cos(angle), s = std::sin(angle);
    return v * c + k.cross(v) * s + k * (k.dot(v) * (1.0 - c));
}

/// The projection of @p c, its refusal said as --frame-nebula's.
Projection framedProjection(const Camera& c)
{
    try {
        return Projection(c);
    } catch (const UsageError& e) {
        throw UsageError(std::string("--frame-nebula: no camera from this --eye aims at the "
                                     "dust: ") +
                         e.what());
    }
}

} // namespace

Vec3 framingDirection(const Projection& projection, const Camera& camera)
{
    if (projection.model().reads("dome-tilt") && std::isfinite(camera.domeTiltDeg)) {
        const double sigma =
            std::clamp(0.5 * camera.fovDeg - DOME_SWEET_SPOT_DEG, 0.0, 90.0 - DOME_SWEET_SPOT_DEG) *
            DEG_RAD;
        // The front of a tilted dome is at the bottom of the image (-upward()).
        return (projection.forward() * std::cos(sigma) - projection.upward() * std::sin(sigma))
            .normalized();
    }
    int y0 = 0, y1 = camera.height;
    projection.viewRows(0, y0, y1);
    return projection.direction(0.5 * camera.width, 0.5 * (y0 + y1));
}

double framingRoom(const Projection& projection, const Camera& camera, const Vec3& dir)
{
    if (projection.parallel()) return 0.5 * PI;
    double px0 = 0.0, py0 = 0.0;
    if (!projection.project(projection.eye() + dir * 1e9, px0, py0, 0)) return 0.0;
    int y0 = 0, y1 = 0;
    projection.viewRows(0, y0, y1);
    double room = PI;
    constexpr int DIRECTIONS = 32;
    const double stepPx = std::max(0.5, (y1 - y0) / 512.0);
    for (int k = 0; k < DIRECTIONS; ++k) {
        const double a = 2.0 * PI * k / DIRECTIONS;
        const double cx = std::cos(a) * stepPx, cy = std::sin(a) * stepPx;
        Vec3 last = dir, d;
        for (int s = 1; s < 1 << 20; ++s) {
            const double px = px0 + cx * s, py = py0 + cy * s;
            if (py < y0 || py > y1 || px < 0.0 || px > camera.width) break;
            if (!projection.direction(px, py, d)) break;
            last = d;
        }
        room = std::min(room, std::acos(std::clamp(last.dot(dir), -1.0, 1.0)));
    }
    return std::min(room, PI);
}

Camera frameCamera(const Camera& camera, const FramingTarget& target, const FramingChoice& keep)
{
    Camera c = camera;
    const double radius = target.radius > 0.0 ? target.radius : std::max(target.extent, 1e-6);
    const Vec3 view = camera.lookAt - camera.eye;
    if (!keep.keepEye) {
        // The camera keeps its orientation and moves so that the target's centre lies along
        // the framing direction, at the distance that sizes it.
        const Projection p = framedProjection(c);
        const Vec3 dir = framingDirection(p, c);
        double distance = 0.0;
        if (p.parallel()) {
            distance = 1.1 * std::max(target.extent, radius);
        } else {
            const double angle =
                std::min(FRAMING_FILL * framingRoom(p, c, dir), FRAMING_MAX_ANGLE_DEG * DEG_RAD);
            distance = radius / std::sin(std::max(angle, 1e-6));
        }
        c.eye = target.centre - dir * distance;
        c.lookAt = c.eye + view * (distance / view.length());
    } else {
        // Aiming only: turn the view direction until the framing direction meets the target.
        Vec3 n = target.centre - c.eye;
        const double distance = n.length();
        if (!(distance > 0.0)) {
            throw UsageError("--frame-nebula: --eye is at the dust's centroid; there is no "
                             "direction to aim at (give another --eye)");
        }
        n = n * (1.0 / distance);
        Vec3 f = n;
        double miss = PI;
        for (int it = 0; it < 64 && miss > 1e-12; ++it) {
            c.lookAt = c.eye + f * distance;
            const Projection p = framedProjection(c);
            const Vec3 d = framingDirection(p, c);
            const Vec3 axis = d.cross(n);
            const double s = axis.length();
            miss = std::atan2(s, d.dot(n));
            if (miss <= 1e-12) break;
            const Vec3 k = s > 1e-300 ? axis * (1.0 / s) : p.right();
            f = rotated(f, k, miss).normalized();
        }
        if (miss > 1e-6) {
            throw UsageError("--frame-nebula: found no view from this --eye that puts the dust "
                             "at the framing point (" +
                             std::to_string(miss / DEG_RAD) + " degrees off)");
        }
    }
    if (!keep.keepPixelSize && cameraModel(c.model).reads("pixel-size")) {
        const Projection p = framedProjection(c);
        int y0 = 0, y1 = c.height;
        p.viewRows(0, y0, y1);
        c.pixelSizePc = radius / (FRAMING_FILL * 0.5 * std::min(c.width, y1 - y0));
    }
    (void)framedProjection(c); // a framed camera is valid
    return c;
}

} // namespace nebula
