// SPDX-License-Identifier: Apache-2.0
/// @file camera_fisheye_stereo.cpp
/// The stereo fisheye dome master (--camera fisheye --stereo): two fisheyes (each W x W, as
/// --camera fisheye makes them), the left eye's on top (W x 2W). Every ray leaves from half
/// the IPD to the left (left eye) or right of its direction's horizontal part, horizontal
/// meaning perpendicular to the camera's up (after --roll, before --dome-tilt: a tilted
/// dome's zenith is up), and the IPD fades to 0 towards up between the --pole-merge
/// latitudes, as omni-directional stereo does: the zenith of a dome has no parallax.
#include "camera_fisheye.h"
#include "camera_stereo.h"

#include "nebula/core/error.h"

#include <algorithm>
#include <cmath>

namespace nebula {
namespace {

/// One eye's camera: the square of width x width.
Camera eyeCamera(const Camera& c)
{
    Camera e = c;
    e.height = c.width;
    return e;
}

class StereoFisheyeProjection final : public CameraProjection
{
public:
    explicit StereoFisheyeProjection(const Camera& c)
        : CameraProjection(c), mDome(eyeCamera(c)), mStereo(c), mSide(c.width)
    {
        forward = mDome.forward; // the dome's axis
        up = mDome.up;
        const Vec3 pole = mDome.cameraUp();
        const Vec3 f = forward - pole * forward.dot(pole);
        mHorizontal = (f.length() > 1e-6 ? f : up - pole * up.dot(pole)).normalized();
    }

    bool direction(double px, double py, Vec3& d) const override
    {
        return mDome.direction(px, local(py), d);
    }
    double pixelSolidAngle(double px, double py) const override
    {
        return mDome.pixelSolidAngle(px, local(py));
    }
    double pixelAngle(double px, double py) const override
    {
        return mDome.pixelAngle(px, local(py));
    }
    Vec3 origin(double px, double py) const override
    {
        Vec3 d;
        if (!direction(px, py, d)) return eye;
        const Vec3& pole = mDome.cameraUp();
        const double z = std::clamp(d.dot(pole), -1.0, 1.0);
        const Vec3 h = d - pole * z;
        if (!(h.length() > 1e-12)) return eye; // at the pole: no parallax
        const double s =
            (py >= mSide ? mStereo.ipdHalf : -mStereo.ipdHalf) * mStereo.fade(std::asin(z));
        return eye + h.normalized().cross(pole) * s;
    }
    bool project(const Vec3& p, double& px, double& py, int view) const override
    {
        const Vec3& pole = mDome.cameraUp();
        const Vec3 across = mHorizontal.cross(pole);
        double lon = 0.0, lat = 0.0;
        if (!mStereo.rayThrough(p - eye, mHorizontal, across, pole, view, lon, lat)) return false;
        const double cl = std::cos(lat);
        const Vec3 d = mHorizontal * (cl * std::cos(lon)) + across * (cl * std::sin(lon)) +
                       pole * std::sin(lat);
        if (!mDome.projectDirection(d.normalized(), px, py)) return false;
        py += view * mSide;
        return true;
    }
    bool coversImage() const override { return false; }
    int views() const override { return 2; }
    void viewRows(int view, int& y0, int& y1) const override
    {
        y0 = view * mSide;
        y1 = y0 + mSide;
    }

private:
    double local(double py) const { return py >= mSide ? py - mSide : py; }

    detail::FisheyeProjection mDome; ///< either eye's directions (the image's top square)
    detail::StereoBase mStereo;
    int mSide;        ///< an eye's square [pixels]
    Vec3 mHorizontal; ///< a direction perpendicular to the pole: longitude 0
};

class StereoFisheye final : public CameraModel
{
public:
    std::string name() const override { return "fisheye-stereo"; }
    std::string help() const override
    {
        return "fisheye-stereo (or fisheye --stereo): two dome masters from eyes --ipd apart,\n"
               "the left eye's on top (W x 2W), parallax fading towards the zenith (--up)";
    }
    std::vector<std::string> parameters() const override
    {
        return {"dome-tilt", "ipd", "pole-merge"};
    }
    std::string stereoOf() const override { return "fisheye"; }
    double defaultFov() const override { return 180.0; }
    double maxFov() const override { return 360.0; }
    void defaultSize(int& width, int& height) const override { height = 2 * width; }
    void fitSize(int& width, int& height) const override
    {
        width = std::max(1, std::min(width, height / 2));
        height = 2 * width;
    }
    void validate(const Camera& c) const override
    {
        detail::validateFisheye(c, name());
        if (c.height != 2 * c.width) {
            throw UsageError("--camera fisheye-stereo makes two square dome masters, the left "
                             "eye's above the right's: --res " +
                             std::to_string(c.width) + "x" + std::to_string(c.height) +
                             " must be twice as high as wide, e.g. " + std::to_string(c.width) +
                             "x" + std::to_string(2 * c.width));
        }
        detail::validateStereo(c, name());
    }
    void validateInScene(const Camera& c, double across) const override
    {
        detail::validateStereoInScene(c, across);
    }
    std::unique_ptr<CameraProjection> projection(const Camera& c) const override
    {
        return std::make_unique<StereoFisheyeProjection>(c);
    }
    void describe(const Camera& c, nlohmann::json& j) const override
    {
        CameraModel::describe(c, j);
        detail::describeStereo(c, j);
    }
};

} // namespace

const CameraModel& fisheyeStereoCamera()
{
    static const StereoFisheye model;
    return model;
}

} // namespace nebula
