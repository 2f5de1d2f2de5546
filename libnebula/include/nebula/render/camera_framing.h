// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera_framing.h
/// --frame-nebula (DESIGN §8): a camera aimed at, and sized to, a target sphere (the dust's
/// mass-weighted centroid and the radius that holds most of its mass), for every camera
/// model. Pure geometry on Camera and Projection: the target is computed elsewhere
/// (stages/framing.h, from the density grid).
///
/// The rule: framing chooses what the user did not.
///  - --look-at always (the aim; --look-at given with --frame-nebula is refused by the
///    command line). The target's centre lands on the framing point (framingDirection()):
///    the centre of the image (of the left eye's view for stereo), or, for a dome with
///    --dome-tilt, the tilted dome's sweet spot.
///  - --eye unless given: the camera keeps its orientation (view direction, --up, --roll,
///    --dome-tilt) and moves along the framing direction to the distance at which the
///    target's radius spans FRAMING_FILL of the angle from the framing point to the nearest
///    edge of the view (at most FRAMING_MAX_ANGLE_DEG); the orthographic camera's eye (the
///    plane its rays start on) is put outside all the dust. With --eye given the eye stays
///    and the camera only turns (aiming only).
///  - the orthographic --pixel-size unless given: the radius spans FRAMING_FILL of half the
///    image's smaller side.
/// --fov, --up, --roll, --dome-tilt, --res and the other parameters are never changed.

#include "nebula/render/camera.h"

namespace nebula {

/// What a frame is aimed at and sized to [pc].
struct FramingTarget
{
    Vec3 centre;         ///< the dust's mass-weighted centroid
    double radius = 0.0; ///< the radius about centre holding FRAMING_MASS_FRACTION of the mass
    double extent = 0.0; ///< the distance from centre to the farthest dust
};

/// What framing keeps as the user gave it.
struct FramingChoice
{
    bool keepEye = false;       ///< --eye given: aim only
    bool keepPixelSize = false; ///< --pixel-size given (orthographic)
};

/// The part of the dust's mass inside FramingTarget::radius.
inline constexpr double FRAMING_MASS_FRACTION = 0.9;
/// The part of the angle from the framing point to the view's nearest edge (or of the
/// orthographic image's half side) that the target's radius spans.
inline constexpr double FRAMING_FILL = 0.8;
/// The widest angle [degrees] the target's radius spans (fisheye, panoramas).
inline constexpr double FRAMING_MAX_ANGLE_DEG = 45.0;
/// A tilted dome's sweet spot: on its front meridian, this many degrees above its lower edge
/// (its spring line for --fov 180 or more), where a forward-facing audience looks (the
/// fulldome literature puts it 30-45 degrees up); at the dome's centre if --fov is below
/// twice this.
inline constexpr double DOME_SWEET_SPOT_DEG = 40.0;

/// The unit direction of the framing point of @p projection's image: the ray through the
/// centre of view 0 (the left eye's for stereo); for a fisheye with a finite --dome-tilt,
/// the sweet spot: the dome's axis tipped towards the front (the image's bottom) by
/// clamp(fov / 2 - DOME_SWEET_SPOT_DEG, 0, 90 - DOME_SWEET_SPOT_DEG) degrees.
Vec3 framingDirection(const Projection& projection, const Camera& camera);

/// The angle [rad] from @p dir (framingDirection()) to the nearest edge of the view:
/// image points walked outwards from dir's pixel in 32 directions until they leave the
/// image (the view's rows) or the view (a fisheye's circle); a panorama's poles bound it.
double framingRoom(const Projection& projection, const Camera& camera, const Vec3& dir);

/// @p camera framed on @p target (the rule above). Throws UsageError naming --frame-nebula
/// if no valid camera aims there (the target straight along --up from a given --eye).
Camera frameCamera(const Camera& camera, const FramingTarget& target, const FramingChoice& keep);

} // namespace nebula
