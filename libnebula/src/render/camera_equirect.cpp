// SPDX-License-Identifier: Apache-2.0
/// @file camera_equirect.cpp
/// The equirect camera: a 360 x 180 degree latitude-longitude panorama (width = 2 x height),
/// the view direction at the centre, the camera's up at the top, longitude growing to the
/// right.
#include "camera_equirect.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <algorithm>
#include <cmath>

namespace nebula {
namespace detail {

EquirectProjection::EquirectProjection(const Camera& c, int views)
    : CameraProjection(c), mViews(views)
{}

int EquirectProjection::panoramaRow(double py, double& local, double& viewHeight) const
{
    viewHeight = mViews == 2 ? 0.5 * height : double(height);
    const int view = mViews == 2 && py >= viewHeight ? 1 : 0; // one view: py <= H
    local = py - view * viewHeight;
    return view;
}

void EquirectProjection::viewRows(int view, int& y0, int& y1) const
{
    if (mViews != 2) {
        y0 = 0;
        y1 = height;
        return;
    }
    y0 = view * (height / 2);
    y1 = y0 + height / 2;
}

bool EquirectProjection::direction(double px, double py, Vec3& d) const
{
    double y = 0.0, h = 0.0;
    panoramaRow(py, y, h);
    const double lon = (px / width - 0.5) * 2.0 * PI, lat = (0.5 - y / h) * PI;
    const double cl = std::cos(lat);
    d = (forward * (cl * std::cos(lon)) + right * (cl * std::sin(lon)) + up * std::sin(lat))
            .normalized();
    return true;
}

double EquirectProjection::pixelSolidAngle(double px, double py) const
{
    (void)px;
    double y = 0.0, h = 0.0;
    panoramaRow(py, y, h);
    const double latTop = (0.5 - (y - 0.5) / h) * PI, latBottom = (0.5 - (y + 0.5) / h) * PI;
    return 2.0 * PI / width *
           (std::sin(std::min(latTop, 0.5 * PI)) - std::sin(std::max(latBottom, -0.5 * PI)));
}

bool EquirectProjection::project(const Vec3& p, double& px, double& py, int) const
{
    const Vec3 v = p - eye;
    const double len = v.length();
    if (!(len > 0.0)) return false;
    const Vec3 d = v * (1.0 / len);
    const double lon = std::atan2(d.dot(right), d.dot(forward));
    const double lat = std::asin(std::clamp(d.dot(up), -1.0, 1.0));
    px = (lon / (2.0 * PI) + 0.5) * width;
    py = (0.5 - lat / PI) * height;
    return true;
}

} // namespace detail

namespace {

class Equirect final : public CameraModel
{
public:
    std::string name() const override { return "equirect"; }
    std::string help() const override
    {
        return "equirect: a 360 x 180 latitude-longitude panorama (2:1), the view direction\n"
               "at the centre";
    }
    bool usesFov(const Camera&) const override { return false; }
    void defaultSize(int& width, int& height) const override { width = 2 * height; }
    void fitSize(int& width, int& height) const override { height = std::max(1, width / 2); }
    void validate(const Camera& c) const override
    {
        if (c.width != 2 * c.height) {
            throw UsageError("--camera equirect makes a 2:1 panorama: --res " +
                             std::to_string(c.width) + "x" + std::to_string(c.height) +
                             " must be twice as wide as high, e.g. " +
                             std::to_string(2 * c.height) + "x" + std::to_string(c.height));
        }
    }
    std::unique_ptr<CameraProjection> projection(const Camera& c) const override
    {
        return std::make_unique<detail::EquirectProjection>(c, 1);
    }
};

} // namespace

const CameraModel& equirectCamera()
{
    static const Equirect model;
    return model;
}

} // namespace nebula
