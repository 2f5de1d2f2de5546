/// @file star_depth.cpp
/// Short characteristics through optically rough cells; see star_depth.h.

#include "nebula/render/star_depth.h"

#include "nebula/volume/block_walk.h"

#include <algorithm>
#include <cmath>

namespace nebula {

namespace {

DenseVolume densityOf(const DenseVolume& f)
{
    DenseVolume d(f.lo(), f.dims(), 1);
    d.indexToWorld = f.indexToWorld;
    for (std::size_t i = 0; i < f.voxelCount(); ++i)
        d.voxel(i)[0] = f.voxel(i)[0];
    return d;
}

} // namespace

StarDepth::StarDepth(const RenderScene& scene)
    : mScene(scene), mDensity(densityOf(scene.fields)), mColumn(mDensity), mLo(scene.fields.lo()),
      mDims(scene.fields.dims()), mKappa(scene.dust.kappa_V)
{
    const DenseVolume& f = scene.fields;
    const double h = voxelSize(f.indexToWorld);
    const double limit = ROUGH / (mKappa * h); // n_max - n_min of a rough cell
    mRough.assign(f.voxelCount(), 0);
    for (int k = 0; k + 1 < mDims[2]; ++k)
        for (int j = 0; j + 1 < mDims[1]; ++j)
            for (int i = 0; i + 1 < mDims[0]; ++i) {
                float lo = INFINITY, hi = -INFINITY;
                for (int c = 0; c < 8; ++c) {
                    const float n =
                        f.voxel(f.index(mLo[0] + i + (c & 1), mLo[1] + j + ((c >> 1) & 1),
                                        mLo[2] + k + (c >> 2)))[0];
                    lo = std::min(lo, n);
                    hi = std::max(hi, n);
                }
                if (double(hi) - double(lo) >= limit)
                    mRough[(std::size_t(k) * std::size_t(mDims[1]) + std::size_t(j)) *
                               std::size_t(mDims[0]) +
                           std::size_t(i)] = 1;
            }
    const Affine w2i = f.indexToWorld.inverse();
    for (const auto& s : scene.stars)
        mStarI.push_back(w2i.apply(Vec3(s.position[0], s.position[1], s.position[2])));
}

double StarDepth::march(std::size_t s, const Vec3& pI) const
{
    const Vec3 toStar = mStarI[s] - pI;
    const double dist = toStar.length(); // [voxels, index space]
    if (!(dist > 0.0)) return 0.0;
    const Vec3 u = toStar * (1.0 / dist);
    double tau = 0.0, walked = 0.0;
    Vec3 p = pI;
    for (int step = 0; step < MAX_STEPS; ++step) {
        const double len = std::min(1.0, dist - walked);
        const Vec3 q = p + u * len;
        tau += mKappa * mColumn(p, q);
        walked += len;
        p = q;
        if (walked >= dist) return tau; // reached the star
        if (tau > TAU_STOP || (!rough(p) && tauSpread(s, p) < SMOOTH_TAU)) break;
    }
    // The rest from the tau grid at p (exact at and beyond the grid's edge: no dust there).
    float rest = 0.0f;
    mScene.fields.sampleChannels(p, 2 + int(s), 1, &rest);
    return tau + std::max(0.0, double(rest));
}

double StarDepth::tauSpread(std::size_t s, const Vec3& pI) const
{
    const DenseVolume& f = mScene.fields;
    const int i = int(std::floor(pI.x)), j = int(std::floor(pI.y)), k = int(std::floor(pI.z));
    if (i < mLo[0] || j < mLo[1] || k < mLo[2] || i + 1 >= mLo[0] + mDims[0] ||
        j + 1 >= mLo[1] + mDims[1] || k + 1 >= mLo[2] + mDims[2])
        return 0.0; // outside the grid: no dust from here to the star
    float lo = INFINITY, hi = -INFINITY;
    for (int c = 0; c < 8; ++c) {
        const float t = f.voxel(f.index(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)))[2 + s];
        lo = std::min(lo, t);
        hi = std::max(hi, t);
    }
    return double(hi) - double(lo);
}

double StarDepth::roughFraction() const
{
    std::size_t n = 0;
    for (const auto r : mRough)
        n += r;
    return mRough.empty() ? 0.0 : double(n) / double(mRough.size());
}

} // namespace nebula
