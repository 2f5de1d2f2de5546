// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera.h
/// Cameras (DESIGN §8): the view a user sets (Camera) and the projection an integrator uses
/// for every pixel, its basis computed once (Projection). The models are registered types
/// (render/camera_model.h: each one file, src/render/camera_<name>.cpp, and one line in
/// src/render/camera_models.cpp); today:
///  - perspective: a pinhole, --fov the horizontal angle;
///  - fisheye: the azimuthal-equidistant dome master of fulldome production: a square image
///    whose inscribed circle holds the view, the distance from its centre proportional to the
///    angle from the dome's axis (--fov the full angle, 180 by default, up to 360); pixels
///    outside the circle are not in view;
///  - equirect: a 360 x 180 degree latitude-longitude panorama (width = 2 x height), the view
///    direction at the centre, the camera's up at the top, longitude growing to the right;
///  - orthographic: a telescope's view from far away: parallel rays along the view direction,
///    starting on the plane through --eye perpendicular to it, pixels of --pixel-size pc;
///    the observer is at a distance D (--distance), which gives each pixel its solid angle
///    (pixel / D)^2 and each star its flux L / (4 pi D^2);
///  - ods: omni-directional stereo, a square image of two equirect panoramas (each W x W/2),
///    the left eye's on top (Google's ODS layout): every ray leaves from a point on the circle
///    of diameter --ipd [pc] round the eye, half the IPD to the left (left eye) or right of
///    its horizontal direction, the IPD fading to 0 towards the poles between the two
///    --pole-merge latitudes, so that the poles have no parallax (Blender's spherical stereo
///    does the same);
///  - fisheye-stereo (--camera fisheye --stereo): two fisheye dome masters, the left eye's on
///    top (W x 2W), each ray leaving from half the IPD left or right of its direction's
///    horizontal part, faded to 0 towards the pole (the up direction) as ODS does.
/// Every pixel carries its true solid angle (pixelSolidAngle()), so radiance times solid
/// angle summed over pixels is the flux in every projection.

#include "nebula/volume/volume.h"

#include <limits>
#include <memory>
#include <string>

namespace nebula {

class CameraModel;
class CameraProjection;

/// A camera (world space, pc).
struct Camera
{
    Vec3 eye{4, 3, -19};
    Vec3 lookAt{0, 0, 0};
    Vec3 up{0, 1, 0};
    double fovDeg = 36.0; ///< perspective: horizontal; fisheye: the full angle of the circle
    int width = 512;
    int height = 512;
    /// The model: a registered camera's name (cameraModel(), render/camera_model.h).
    std::string model = "perspective";
    double rollDeg = 0.0; ///< turns the image about the view direction, clockwise as seen
    /// Fisheye only. NaN (the default): the dome's axis (the image centre) is the view
    /// direction, a fisheye lens pointed at --look-at. A number T in [0, 90]: a planetarium
    /// dome tilted by T degrees, the audience facing --look-at: the axis is the camera's up
    /// tipped T degrees towards the view direction (0: a horizontal dome, the look-at point
    /// on the bottom edge of the circle; 90: the same as NaN), and the front of the dome is
    /// at the bottom of the image, as in a dome master.
    double domeTiltDeg = std::numeric_limits<double>::quiet_NaN();
    /// Orthographic only: the pixel's edge [pc]. NaN (the default): the width the perspective
    /// camera's --fov spans at the look-at point, over the image width.
    double pixelSizePc = std::numeric_limits<double>::quiet_NaN();
    /// Orthographic only: the observer's distance D [pc] (pixel solid angles, star fluxes).
    /// NaN (the default): the distance from --eye to --look-at.
    double distancePc = std::numeric_limits<double>::quiet_NaN();
    /// ODS only: the inter-pupillary distance [pc] (required; choose it for the scene's
    /// depth: a pupil distance of about 1/30 of the distance to the nebula gives a
    /// comfortable stereo depth).
    double ipdPc = std::numeric_limits<double>::quiet_NaN();
    /// ODS only: the latitudes [degrees] between which the IPD fades linearly from full to 0.
    double poleMergeFromDeg = 60.0;
    double poleMergeToDeg = 75.0;

    /// Orthographic: the pixel's edge [pc], pixelSizePc or its default.
    double orthographicPixel() const;
    /// Orthographic: the observer's distance [pc], distancePc or its default.
    double observerDistance() const;

    /// Convenience: the same as Projection(*this).direction() etc.; integrators build the
    /// projection once and use it for every pixel.
    Vec3 direction(double px, double py) const;
    double pixelSolidAngle(double px, double py) const;
    bool project(const Vec3& p, double& px, double& py) const;
};

/// The projection of a Camera, its orthonormal basis precomputed: a created projection is
/// of a valid camera (the constructor calls validateCamera()). Copies share the model's
/// per-pixel mapping (CameraProjection, render/camera_model.h).
class Projection
{
public:
    explicit Projection(const Camera& camera);

    /// The camera's registered model.
    const CameraModel& model() const { return *mModel; }

    /// The unit world direction through the image point (px, py) [pixels] (py = 0 is the top
    /// edge; pixel centres at +0.5) into @p d; false (d untouched) if the point is not in
    /// view: outside a fisheye's circle.
    bool direction(double px, double py, Vec3& d) const;
    /// direction() for a point in view; for one that is not, the view direction.
    Vec3 direction(double px, double py) const;
    /// Where the ray through (px, py) starts [pc]: the eye, or for the orthographic camera
    /// the pixel's point on the plane through the eye perpendicular to the view.
    Vec3 origin(double px, double py) const;
    /// Where the ray that reaches the eye from world point @p p starts: the eye, or for the
    /// orthographic camera @p p's foot on the eye's plane (optical depth eye -> star).
    Vec3 originTowards(const Vec3& p) const;
    /// The squared distance [pc^2] over which a point source at @p p spreads its light to the
    /// observer: |p - eye|^2, or D^2 for the orthographic camera (star sprites).
    double distanceSquared(const Vec3& p) const;
    /// Whether all rays are parallel (orthographic): they start at origin(), not at eye().
    bool parallel() const;
    /// Whether the centre of pixel (px, py) is in view (the integrators render only those).
    bool inView(double px, double py) const;
    double pixelSolidAngle(double px, double py) const;
    /// Solid angle [sr] of the pixel centred at (px, py): exact for perspective and
    /// equirect; for fisheye the integral of the projection's Jacobian over the part of the
    /// pixel inside the circle (16 x 16 midpoints), 0 for a pixel wholly outside; for the
    /// orthographic camera (pixel / D)^2.
    /// (The level of detail:) the angle a pixel centred at (px, py) spans [rad]: the square
    /// root of pixelSolidAngle() for perspective and equirect; for fisheye the equidistant
    /// projection's radial angle per pixel (cheap; it varies little across the circle); for
    /// the orthographic camera 0 (its footprint does not grow with distance).
    double pixelAngle(double px, double py) const;
    /// Projects world point @p p [pc] to image coordinates; false if it is not in view
    /// (behind a perspective eye, beyond a fisheye's angle, or at the eye).
    bool project(const Vec3& p, double& px, double& py) const;
    /// Whether the image wraps around horizontally (equirect, ODS: column W is column 0).
    bool wrapsHorizontally() const;
    /// Whether every pixel is in view (false: a fisheye's corners; the integrators render only
    /// the pixels inView(), and Image::inView marks them).
    bool coversImage() const;
    /// How many views the image holds: 2 for stereo (the left eye's rows on top), else 1.
    int views() const;
    /// The rows [y0, y1) of view @p view.
    void viewRows(int view, int& y0, int& y1) const;
    /// project() into view @p view (stereo: 0 left eye, 1 right eye): where the ray of that eye
    /// that passes through @p p is; false if none does (p within half the IPD of the eye's
    /// axis).
    bool project(const Vec3& p, double& px, double& py, int view) const;

    const Vec3& eye() const;
    /// The axis (image centre), the image's right and up directions in the world.
    const Vec3& forward() const;
    const Vec3& right() const;
    const Vec3& upward() const;

private:
    const CameraModel* mModel;
    std::shared_ptr<const CameraProjection> mMap;
};

/// The largest magnitude of a coordinate of --eye, --look-at and --up: squared distances
/// stay finite.
inline constexpr double MAX_CAMERA_COORDINATE = 1e150;

/// Throws UsageError naming the option unless --eye, --look-at and --up are finite with
/// coordinates of at most MAX_CAMERA_COORDINATE in magnitude, the eye differs from the
/// look-at point and up is not parallel to the view direction, --roll is in [-360, 360], every
/// model-specific parameter given (cameraParameters()) is one the model reads, and the
/// model's own checks pass (CameraModel::validate()). Called by Projection's constructor
/// alone: a created camera is valid.
void validateCamera(const Camera& camera);

} // namespace nebula
