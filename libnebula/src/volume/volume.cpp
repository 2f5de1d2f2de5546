#include "nebula/volume/volume.h"

#include "nebula/core/error.h"

namespace nebula {

Affine Affine::inverse() const
{
    const auto& a = m;
    const double det = a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
                       a[2] * (a[3] * a[7] - a[4] * a[6]);
    if (det == 0.0 || !std::isfinite(det)) throw Error("singular grid transform");
    const double s = 1.0 / det;
    Affine r;
    r.m = {(a[4] * a[8] - a[5] * a[7]) * s, (a[2] * a[7] - a[1] * a[8]) * s,
           (a[1] * a[5] - a[2] * a[4]) * s, (a[5] * a[6] - a[3] * a[8]) * s,
           (a[0] * a[8] - a[2] * a[6]) * s, (a[2] * a[3] - a[0] * a[5]) * s,
           (a[3] * a[7] - a[4] * a[6]) * s, (a[1] * a[6] - a[0] * a[7]) * s,
           (a[0] * a[4] - a[1] * a[3]) * s};
    r.t = -r.applyLinear(t);
    return r;
}

DenseVolume::DenseVolume(std::array<int, 3> lo, std::array<int, 3> dims, int channels)
    : mLo(lo), mDims(dims), mChannels(channels)
{
    if (channels <= 0 || dims[0] <= 0 || dims[1] <= 0 || dims[2] <= 0) {
        throw Error("DenseVolume: empty volume");
    }
    mData.assign(voxelCount() * std::size_t(channels), 0.0f);
}

} // namespace nebula
