// SPDX-License-Identifier: Apache-2.0
/// @file camera_ods.cpp
/// Omni-directional stereo: a square image of two equirect panoramas (each W x W/2), the left
/// eye's on top (Google's ODS layout): every ray leaves from a point on the circle of
/// diameter --ipd [pc] round the eye, half the IPD to the left (left eye) or right of its
/// horizontal direction, the IPD fading to 0 towards the poles between the two --pole-merge
/// latitudes, so that the poles have no parallax (Blender's spherical stereo does the same).
#include "camera_equirect.h"
#include "camera_stereo.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"

#include <algorithm>
#include <cmath>

namespace nebula {
namespace {

class OdsProjection final : public detail::EquirectProjection
{
public:
    explicit OdsProjection(const Camera& c) : EquirectProjection(c, 2), mStereo(c) {}

    Vec3 origin(double px, double py) const override
    {
        // Half the IPD (faded towards the poles) to the left or right of the ray's
        // horizontal direction: t = right cos(lon) - forward sin(lon).
        double y = 0.0, h = 0.0;
        const int view = panoramaRow(py, y, h);
        const double lon = (px / width - 0.5) * 2.0 * PI, lat = (0.5 - y / h) * PI;
        const double s = (view == 0 ? -mStereo.ipdHalf : mStereo.ipdHalf) * mStereo.fade(lat);
        return eye + (right * std::cos(lon) - forward * std::sin(lon)) * s;
    }

    bool project(const Vec3& p, double& px, double& py, int view) const override
    {
        double lon = 0.0, lat = 0.0;
        if (!mStereo.rayThrough(p - eye, forward, right, up, view, lon, lat)) return false;
        lon = std::remainder(lon, 2.0 * PI);
        const double h = 0.5 * height;
        px = (lon / (2.0 * PI) + 0.5) * width;
        py = view * h + (0.5 - lat / PI) * h;
        return true;
    }

private:
    detail::StereoBase mStereo;
};

class Ods final : public CameraModel
{
public:
    std::string name() const override { return "ods"; }
    std::string help() const override
    {
        return "ods: omni-directional stereo, two equirect panoramas (left eye on top, square\n"
               "image) from eyes --ipd apart";
    }
    std::vector<std::string> parameters() const override { return {"ipd", "pole-merge"}; }
    std::string stereoOf() const override { return "equirect"; }
    bool usesFov(const Camera&) const override { return false; }
    void fitSize(int& width, int& height) const override
    {
        const int small = std::min(width, height);
        width = height = std::max(2, small - small % 2);
    }
    void validate(const Camera& c) const override
    {
        if (c.width != c.height || c.height % 2 != 0) {
            // The even square within the size asked for: no more pixels, so it fits wherever
            // that size would have.
            const int small = std::min(c.width, c.height);
            const int side = std::max(2, small - small % 2);
            throw UsageError("--camera ods makes two 2:1 panoramas, the left eye's above the "
                             "right's: --res " +
                             std::to_string(c.width) + "x" + std::to_string(c.height) +
                             " must be square with an even height, e.g. " + std::to_string(side) +
                             "x" + std::to_string(side));
        }
        detail::validateStereo(c, name());
    }
    void validateInScene(const Camera& c, double across) const override
    {
        detail::validateStereoInScene(c, across);
    }
    std::unique_ptr<CameraProjection> projection(const Camera& c) const override
    {
        return std::make_unique<OdsProjection>(c);
    }
    void describe(const Camera& c, nlohmann::json& j) const override
    {
        detail::describeStereo(c, j);
    }
};

} // namespace

const CameraModel& odsCamera()
{
    static const Ods model;
    return model;
}

} // namespace nebula
