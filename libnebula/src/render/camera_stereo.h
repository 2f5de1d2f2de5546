// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera_stereo.h
/// Internal to render/: what the stereo cameras (camera_ods.cpp, camera_fisheye_stereo.cpp)
/// share: two eyes half the IPD left and right of each ray's horizontal direction (the plane
/// perpendicular to the pole), the IPD fading to 0 towards the pole between the two
/// --pole-merge latitudes, so that the pole has no parallax.

#include "nebula/render/camera_model.h"

namespace nebula::detail {

struct StereoBase
{
    explicit StereoBase(const Camera& c);

    /// The IPD's fraction at latitude @p lat [rad] (1 below the first --pole-merge latitude,
    /// 0 above the second).
    double fade(double lat) const;
    /// The ray of eye @p view (0 left, 1 right) that passes through @p v (the point less the
    /// eye) in the frame forward @p f, right @p r, pole @p u: its longitude from f towards r
    /// and its latitude [rad]; false if none does (within half the IPD of the pole's axis).
    /// The fade depends on the latitude: a few fixed-point steps (it converges: |d fade /
    /// d lat| IPD is far below the horizontal distance).
    bool rayThrough(const Vec3& v, const Vec3& f, const Vec3& r, const Vec3& u, int view,
                    double& lon, double& lat) const;

    double ipdHalf;            ///< half the IPD [pc]
    double mergeFrom, mergeTo; ///< the pole merge latitudes [rad]
};

/// --ipd (required, finite, > 0) and --pole-merge (0 <= FROM < TO <= 90) of camera @p model.
void validateStereo(const Camera& c, const std::string& model);
/// Refuses an IPD larger than the scene (@p across [pc]): the eyes would stand outside each
/// other's view of it.
void validateStereoInScene(const Camera& c, double across);
/// ipd_pc, pole_merge_deg and the layout ("left eye top") in the camera's JSON.
void describeStereo(const Camera& c, nlohmann::json& j);

} // namespace nebula::detail
