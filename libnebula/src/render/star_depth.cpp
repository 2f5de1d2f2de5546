/// @file star_depth.cpp
/// Short characteristics through cells where a star's optical depth bends; see star_depth.h.

#include "nebula/render/star_depth.h"

#include <algorithm>
#include <cmath>

namespace nebula {

StarDepth::StarDepth(const RenderScene& scene)
    : mScene(scene), mDensity(scene.fields.channel(0)), mColumn(mDensity), mLo(scene.fields.lo()),
      mDims(scene.fields.dims()), mKappa(scene.dust.kappa_V)
{
    const DenseVolume& f = scene.fields;
    const std::size_t n = f.voxelCount(), words = (n + 63) / 64;
    const std::size_t sx = 1, sy = std::size_t(mDims[0]), sz = sy * std::size_t(mDims[1]);
    mAny.assign(words, 0);
    // Lattice points within one voxel of dust (where nebillum wrote tau), then the cells
    // whose 8 corners all are.
    std::vector<std::uint8_t> near(n, 0);
    for (int k = 0; k < mDims[2]; ++k)
        for (int j = 0; j < mDims[1]; ++j)
            for (int i = 0; i < mDims[0]; ++i) {
                const std::size_t v = std::size_t(k) * sz + std::size_t(j) * sy + std::size_t(i);
                if (!(f.voxel(v)[0] > 0.0f)) continue;
                for (int c = 0; c < 27; ++c) {
                    const int a = i + c % 3 - 1, b = j + (c / 3) % 3 - 1, e = k + c / 9 - 1;
                    if (a >= 0 && b >= 0 && e >= 0 && a < mDims[0] && b < mDims[1] && e < mDims[2])
                        near[std::size_t(e) * sz + std::size_t(b) * sy + std::size_t(a)] = 1;
                }
            }
    mValid.assign(words, 0);
    for (int k = 0; k + 1 < mDims[2]; ++k)
        for (int j = 0; j + 1 < mDims[1]; ++j)
            for (int i = 0; i + 1 < mDims[0]; ++i) {
                const std::size_t v = std::size_t(k) * sz + std::size_t(j) * sy + std::size_t(i);
                bool all = true;
                for (int c = 0; c < 8 && all; ++c)
                    all = near[v + (c & 1) * sx + ((c >> 1) & 1) * sy + (c >> 2) * sz] != 0;
                if (all) mValid[v >> 6] |= std::uint64_t(1) << (v & 63);
            }
    std::vector<std::uint8_t> bends(n);
    for (std::size_t s = 0; s < scene.stars.size(); ++s) {
        // Per lattice point: whether tau's second difference along an axis reaches CURVED.
        const auto tau = [&](std::size_t v) { return double(f.voxel(v)[2 + s]); };
        std::fill(bends.begin(), bends.end(), 0);
        for (int k = 1; k + 1 < mDims[2]; ++k)
            for (int j = 1; j + 1 < mDims[1]; ++j)
                for (int i = 1; i + 1 < mDims[0]; ++i) {
                    const std::size_t v =
                        std::size_t(k) * sz + std::size_t(j) * sy + std::size_t(i);
                    if (!near[v]) continue;
                    // Along each axis whose three points hold tau (beyond the active band
                    // the grid reads 0, which is no bend of the true tau).
                    const double t = 2.0 * tau(v);
                    bool b = false;
                    for (const std::size_t st : {sx, sy, sz})
                        b = b || (near[v - st] && near[v + st] &&
                                  std::abs(tau(v - st) - t + tau(v + st)) >= CURVED);
                    bends[v] = b;
                }
        // A cell is curved if one of its corners is.
        std::vector<std::uint64_t> cells(words, 0);
        for (int k = 0; k + 1 < mDims[2]; ++k)
            for (int j = 0; j + 1 < mDims[1]; ++j)
                for (int i = 0; i + 1 < mDims[0]; ++i) {
                    const std::size_t v =
                        std::size_t(k) * sz + std::size_t(j) * sy + std::size_t(i);
                    bool any = false;
                    for (int c = 0; c < 8 && !any; ++c)
                        any = bends[v + (c & 1) * sx + ((c >> 1) & 1) * sy + (c >> 2) * sz] != 0;
                    if (any) {
                        cells[v >> 6] |= std::uint64_t(1) << (v & 63);
                        mAny[v >> 6] |= std::uint64_t(1) << (v & 63);
                    }
                }
        mCurved.push_back(std::move(cells));
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
    for (int step = 0;; ++step) {
        const double len = std::min(1.0, dist - walked);
        const Vec3 q = p + u * len;
        tau += mKappa * mColumn(p, q);
        walked += len;
        p = q;
        if (walked >= dist) return tau; // reached the star
        const std::size_t c = cellOf(p);
        if (c == NONE) return tau;     // left the grid: no dust from here to the star
        if (!bit(mValid, c)) continue; // no tau here: cross the gap
        if (tau > TAU_STOP || step + 1 >= MAX_STEPS || !bit(mCurved[s], c)) break;
    }
    // The rest from the tau grid at p.
    float rest = 0.0f;
    mScene.fields.sampleChannels(p, 2 + int(s), 1, &rest);
    return tau + std::max(0.0, double(rest));
}

double StarDepth::curvedFraction(std::size_t s) const
{
    std::size_t n = 0;
    for (const auto w : mCurved[s])
        n += std::size_t(__builtin_popcountll(w));
    const std::size_t cells =
        std::size_t(mDims[0] - 1) * std::size_t(mDims[1] - 1) * std::size_t(mDims[2] - 1);
    return cells > 0 ? double(n) / double(cells) : 0.0;
}

} // namespace nebula
