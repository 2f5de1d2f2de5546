#pragma once
/// @file camera.h
/// Cameras (DESIGN §8): the view a user sets (Camera) and the projection an integrator uses
/// for every pixel, with its basis computed once (PinholeProjection). A new projection (dome,
/// 360 degrees) is a new class with the same three functions, chosen from the Camera.

#include "nebula/volume/volume.h"

#include <array>

namespace nebula {

/// Perspective pinhole camera (world space, pc).
struct Camera
{
    Vec3 eye{4, 3, -19};
    Vec3 lookAt{0, 0, 0};
    Vec3 up{0, 1, 0};
    double fovDeg = 36.0; ///< horizontal field of view [degrees]
    int width = 512;
    int height = 512;

    /// Convenience: the same as PinholeProjection(*this).direction() etc.; integrators build
    /// the projection once and use it for every pixel.
    Vec3 direction(double px, double py) const;
    double pixelSolidAngle(double px, double py) const;
    bool project(const Vec3& p, double& px, double& py) const;
};

/// The perspective pinhole projection of a Camera, its orthonormal basis precomputed.
class PinholeProjection
{
public:
    explicit PinholeProjection(const Camera& camera);

    /// Unit world direction through the image point (px, py) [pixels] (py = 0 is the top
    /// row; pixel centres at +0.5).
    Vec3 direction(double px, double py) const;
    /// Solid angle [sr] of the pixel centred at (px, py).
    double pixelSolidAngle(double px, double py) const;
    /// Projects world point @p p [pc] to pixel coordinates; false if behind the eye.
    bool project(const Vec3& p, double& px, double& py) const;

    const Vec3& eye() const { return mEye; }

private:
    Vec3 mEye, mForward, mRight, mUp;
    double mTanH; ///< tan of half the horizontal field of view
    int mWidth, mHeight;
};

/// The largest magnitude of a coordinate of --eye, --look-at and --up: squared distances
/// stay finite.
inline constexpr double MAX_CAMERA_COORDINATE = 1e150;

/// Throws UsageError naming the option unless --eye, --look-at and --up are finite with
/// coordinates of at most MAX_CAMERA_COORDINATE in magnitude, the eye differs from the
/// look-at point and up is not parallel to the view direction.
void validateCamera(const Camera& camera);

} // namespace nebula
