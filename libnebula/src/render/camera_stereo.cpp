// SPDX-License-Identifier: Apache-2.0
#include "camera_stereo.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"

#include <fmt/format.h>

#include <cmath>

namespace nebula::detail {

StereoBase::StereoBase(const Camera& c)
    : ipdHalf(0.5 * c.ipdPc), mergeFrom(c.poleMergeFromDeg * DEG_RAD),
      mergeTo(c.poleMergeToDeg * DEG_RAD)
{}

double StereoBase::fade(double lat) const
{
    const double a = std::fabs(lat);
    if (a <= mergeFrom) return 1.0;
    if (a >= mergeTo) return 0.0;
    return (mergeTo - a) / (mergeTo - mergeFrom);
}

bool StereoBase::rayThrough(const Vec3& v, const Vec3& f, const Vec3& r, const Vec3& u, int view,
                            double& lon, double& lat) const
{
    // The ray's longitude lon = lon0 - asin(s / r_h), with s the signed offset of its origin
    // (-IPD/2 left, +IPD/2 right, faded at its latitude) and r_h the point's horizontal
    // distance; its latitude atan2(height, r_h cos(lon0 - lon)).
    const double a = v.dot(f), b = v.dot(r), c = v.dot(u);
    const double rh = std::sqrt(a * a + b * b);
    const double lon0 = std::atan2(b, a);
    lat = std::atan2(c, rh);
    lon = lon0;
    for (int i = 0; i < 8; ++i) {
        const double s = (view == 0 ? -ipdHalf : ipdHalf) * fade(lat);
        if (!(std::fabs(s) < rh)) return false;
        const double delta = std::asin(s / rh);
        lon = lon0 - delta;
        lat = std::atan2(c, rh * std::cos(delta));
    }
    return true;
}

void validateStereo(const Camera& c, const std::string& model)
{
    if (std::isnan(c.ipdPc)) {
        throw UsageError("--camera " + model +
                         " needs --ipd, the inter-pupillary distance, a finite length > 0 [pc] "
                         "(not given; about 1/30 of the distance to the nebula is comfortable)");
    }
    if (!(c.ipdPc > 0.0) || !std::isfinite(c.ipdPc) || c.ipdPc > MAX_CAMERA_COORDINATE) {
        throw UsageError("--camera " + model +
                         " needs --ipd, the inter-pupillary distance, a finite length > 0 [pc], "
                         "got " +
                         numberText(c.ipdPc));
    }
    if (!(c.poleMergeFromDeg >= 0.0 && c.poleMergeFromDeg < c.poleMergeToDeg &&
          c.poleMergeToDeg <= 90.0)) {
        throw UsageError("--pole-merge FROM,TO must have 0 <= FROM < TO <= 90 degrees, got " +
                         numberText(c.poleMergeFromDeg) + "," + numberText(c.poleMergeToDeg));
    }
}

void validateStereoInScene(const Camera& c, double across)
{
    if (c.ipdPc > across) {
        throw UsageError(fmt::format("--ipd {:g} pc is larger than the scene, whose box is "
                                     "{:.4g} pc across: the eyes would stand outside each "
                                     "other's view of it (try about 1/30 of the distance to "
                                     "the nebula)",
                                     c.ipdPc, across));
    }
}

void describeStereo(const Camera& c, nlohmann::json& j)
{
    j["ipd_pc"] = c.ipdPc;
    j["pole_merge_deg"] = {c.poleMergeFromDeg, c.poleMergeToDeg};
    j["layout"] = "left eye top";
}

} // namespace nebula::detail
