// SPDX-License-Identifier: Apache-2.0
/// @file camera_orthographic.cpp
/// The orthographic camera: a telescope's view from far away: parallel rays along the view
/// direction, starting on the plane through --eye perpendicular to it, pixels of
/// --pixel-size pc; the observer is at a distance D (--distance), which gives each pixel its
/// solid angle (pixel / D)^2 and each star its flux L / (4 pi D^2).
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/render/camera_model.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace nebula {
namespace {

/// The nearest an orthographic observer may be [pc]: 0.2 au. Nearer, a star's flux
/// L / (4 pi D^2) is no telescope's (and D^2 underflows long before D does).
constexpr double MIN_OBSERVER_DISTANCE_PC = 1e-6;

class OrthographicProjection final : public CameraProjection
{
public:
    explicit OrthographicProjection(const Camera& c)
        : CameraProjection(c), mPixel(c.orthographicPixel()), mDistance(c.observerDistance())
    {}

    bool direction(double, double, Vec3& d) const override
    {
        d = forward;
        return true;
    }
    double pixelSolidAngle(double, double) const override
    {
        return (mPixel / mDistance) * (mPixel / mDistance);
    }
    double pixelAngle(double, double) const override { return 0.0; }
    Vec3 origin(double px, double py) const override
    {
        return eye + right * ((px - 0.5 * width) * mPixel) + up * ((0.5 * height - py) * mPixel);
    }
    Vec3 originTowards(const Vec3& p) const override
    {
        return p - forward * (p - eye).dot(forward);
    }
    double distanceSquared(const Vec3&) const override { return mDistance * mDistance; }
    bool parallel() const override { return true; }
    bool project(const Vec3& p, double& px, double& py, int) const override
    {
        const Vec3 v = p - eye;
        if (!(v.dot(forward) > 0.0)) return false; // on or behind the eye's plane
        px = 0.5 * width + v.dot(right) / mPixel;
        py = 0.5 * height - v.dot(up) / mPixel;
        return true;
    }

private:
    double mPixel;    ///< the pixel's edge [pc]
    double mDistance; ///< the observer's distance [pc]
};

class Orthographic final : public CameraModel
{
public:
    std::string name() const override { return "orthographic"; }
    std::string help() const override
    {
        return "orthographic: a telescope's parallel view along --eye -> --look-at, the rays\n"
               "starting on the plane through --eye (put it outside the nebula)";
    }
    std::vector<std::string> parameters() const override { return {"pixel-size", "distance"}; }
    bool usesFov(const Camera&) const override { return false; }
    void validate(const Camera& c) const override
    {
        if (std::isnan(c.pixelSizePc) && !(c.fovDeg > 0.0 && c.fovDeg <= 179.0)) {
            throw UsageError("--fov must be in (0, 179] degrees when it sets the orthographic "
                             "camera's pixel (the width it spans at --look-at), got " +
                             detail::numberText(c.fovDeg) + "; or give --pixel-size");
        }
        for (const auto& [value, option] :
             {std::pair{c.distancePc, "--distance"}, std::pair{c.pixelSizePc, "--pixel-size"}}) {
            if (std::isnan(value)) continue;
            if (!(value > 0.0) || !std::isfinite(value) || value > MAX_CAMERA_COORDINATE) {
                throw UsageError(std::string(option) + " must be a finite length > 0 [pc], got " +
                                 detail::numberText(value));
            }
        }
        const double p = c.orthographicPixel();
        if (!(p > 0.0) || !std::isfinite(p) || !std::isfinite(p * c.width * c.height)) {
            throw UsageError("the orthographic camera's pixel must be finite and > 0 [pc], got " +
                             detail::numberText(p));
        }
        requireObserverDistance(c);
    }
    std::unique_ptr<CameraProjection> projection(const Camera& c) const override
    {
        return std::make_unique<OrthographicProjection>(c);
    }
    void describe(const Camera& c, nlohmann::json& j) const override
    {
        j["pixel_size_pc"] = c.orthographicPixel();
        j["distance_pc"] = c.observerDistance();
    }
    std::optional<CameraSkyPlane> skyPlane(const Camera& c) const override
    {
        return CameraSkyPlane{c.orthographicPixel() / c.observerDistance(), c.orthographicPixel()};
    }
    std::vector<CameraCard> fitsCards(const Camera& c) const override
    {
        return {{"DISTANCE", c.observerDistance(), "observer's distance [pc]"},
                {"PIXSIZE", c.orthographicPixel(), "pixel size [pc]"}};
    }
    std::string observer(const Camera& c) const override
    {
        return fmt::format("distance {:g} pc", c.observerDistance());
    }

private:
    /// Throws UsageError naming --distance unless the observer is at least a pixel away (a
    /// pixel spans at most a radian: its solid angle (pixel / D)^2 at most a steradian) and
    /// MIN_OBSERVER_DISTANCE_PC: --distance 1e-300 overflowed the stars' sprites, and the
    /// error blamed their luminosity.
    static void requireObserverDistance(const Camera& c)
    {
        const double d = c.observerDistance(), p = c.orthographicPixel();
        if (d >= std::max(p, MIN_OBSERVER_DISTANCE_PC)) return;
        const std::string what = std::isnan(c.distancePc)
                                     ? "the observer's distance (--distance; default |--look-at "
                                       "- --eye|)"
                                     : "--distance";
        throw UsageError(fmt::format(
            "{} {} pc is too near: the orthographic observer must be at least a pixel ({} pc: a "
            "pixel spans at most a radian) and {} pc away, for the pixels' solid angles and the "
            "stars' fluxes L / (4 pi D^2)",
            what, detail::numberText(d), detail::numberText(p),
            detail::numberText(MIN_OBSERVER_DISTANCE_PC)));
    }
};

} // namespace

const CameraModel& orthographicCamera()
{
    static const Orthographic model;
    return model;
}

} // namespace nebula
