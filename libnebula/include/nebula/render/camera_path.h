// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera_path.h
/// Keyframed camera paths for fly-throughs (DESIGN §8): a JSON file of keyframes (time, eye,
/// look-at, up, fov, roll), the eye and the look-at point following centripetal Catmull-Rom
/// curves through their keyframes, optionally at constant speed along the eye's curve, with
/// optional ease in and out; frame N of the sequence is at time (N - 1) / fps.

#include "nebula/render/camera.h"

#include <string>
#include <vector>

namespace nebula {

/// One keyframe of a camera path.
struct CameraKeyframe
{
    double time = 0.0; ///< [s]
    Vec3 eye, lookAt, up;
    double fovDeg = 36.0;
    double rollDeg = 0.0;
};

/// A camera path: keyframes in time order and how to move between them.
struct CameraPath
{
    double fps = 24.0;
    std::vector<CameraKeyframe> keys;
    /// Move the eye at constant speed along its curve (arc-length parametrisation) between
    /// the first and last keyframe times instead of reaching each keyframe at its time.
    bool constantSpeed = false;
    double easeIn = 0.0;  ///< [s] the speed rises linearly from 0 over the first easeIn seconds
    double easeOut = 0.0; ///< [s] and falls to 0 over the last easeOut seconds
    std::string source;   ///< the file, for messages

    /// The number of frames the path covers: frame 1 at time 0 up to the last keyframe.
    long frameCount() const;
    /// The time [s] of frame @p frame (1-based).
    double frameTime(long frame) const { return double(frame - 1) / fps; }
    /// @p base (model, resolution, ...) with the view of the path at time @p t [s] (clamped
    /// to the keyframes' times).
    Camera at(double t, const Camera& base) const;
};

/// The version of camera paths nebula writes (keyframes in cameraToJson()'s keys).
inline constexpr int CAMERA_PATH_VERSION = 2;

/// Parses a camera path:
///   {"version": 2, "fps": 24, "constant_speed": false, "ease_in": 0, "ease_out": 0,
///    "keyframes": [{"time": 0, "eye": [x,y,z], "look_at": [x,y,z], "up": [x,y,z],
///                   "fov_deg": 40, "roll_deg": 0}, ...]}
/// Version 1 (no "version"; nebula before 2026-12) named them "fov" and "roll": read as
/// before; a key of the other version is refused saying which version has it.
/// fps, time and eye and look_at of every keyframe are required; "up", "fov" and "roll" carry
/// over from the previous keyframe (the first takes them from @p defaults, the command
/// line's --up, --fov and --roll). Times must increase strictly. Throws Error naming
/// @p source and the keyframe for anything else.
CameraPath parseCameraPath(const std::string& text, const std::string& source,
                           const Camera& defaults);

} // namespace nebula
