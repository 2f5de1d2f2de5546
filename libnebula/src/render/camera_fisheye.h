// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera_fisheye.h
/// Internal to render/: the fisheye's mapping (camera_fisheye.cpp), which the stereo fisheye
/// (camera_fisheye_stereo.cpp) uses for each eye.

#include "nebula/render/camera_model.h"

namespace nebula::detail {

/// The azimuthal-equidistant fisheye of image @p width x @p height (one eye's square), its
/// axis forward (tipped by --dome-tilt).
class FisheyeProjection : public CameraProjection
{
public:
    explicit FisheyeProjection(const Camera& c);

    bool direction(double px, double py, Vec3& d) const override;
    double pixelSolidAngle(double px, double py) const override;
    double pixelAngle(double px, double py) const override;
    bool project(const Vec3& p, double& px, double& py, int view) const override;
    bool coversImage() const override { return false; }

    /// The image point of unit direction @p d (false beyond the fisheye's angle).
    bool projectDirection(const Vec3& d, double& px, double& py) const;
    /// The camera's up after --roll, before the dome tilt (the stereo fisheye's pole).
    const Vec3& cameraUp() const { return mCameraUp; }

protected:
    double jacobian(double u, double v) const;
    double mThetaMax; ///< half the full angle [rad]
    Vec3 mCameraUp;
};

/// The fisheye's checks of --fov and --dome-tilt (@p model names the camera in messages).
void validateFisheye(const Camera& c, const std::string& model);

} // namespace nebula::detail
