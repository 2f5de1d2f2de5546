/// @file star_depth.cpp
/// Short characteristics through cells where a star's optical depth bends; see star_depth.h.

#include "nebula/render/star_depth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nebula {

namespace {

/// Packs one byte per lattice point (non-zero: set) into one bit each, in parallel over
/// 64-bit words (no word is shared between threads).
std::vector<std::uint64_t> packBits(const std::vector<std::uint8_t>& bytes)
{
    const std::size_t n = bytes.size(), words = (n + 63) / 64;
    std::vector<std::uint64_t> bits(words, 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, words, 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t w = r.begin(); w != r.end(); ++w) {
                              std::uint64_t word = 0;
                              const std::size_t end = std::min(n, w * 64 + 64);
                              for (std::size_t v = w * 64; v < end; ++v)
                                  word |= std::uint64_t(bytes[v] != 0) << (v - w * 64);
                              bits[w] = word;
                          }
                      });
    return bits;
}

} // namespace

StarDepth::StarDepth(const RenderScene& scene)
    : mScene(scene), mColumn(scene.fields), mLo(scene.fields.lo()), mDims(scene.fields.dims()),
      mKappa(scene.dust.kappa_V)
{
    const DenseVolume& f = scene.fields;
    const std::size_t n = f.voxelCount();
    const std::size_t sx = 1, sy = std::size_t(mDims[0]), sz = sy * std::size_t(mDims[1]);
    const int nx = mDims[0], ny = mDims[1], nz = mDims[2];
    const auto index = [&](int i, int j, int k) {
        return std::size_t(k) * sz + std::size_t(j) * sy + std::size_t(i);
    };
    // Every pass below is parallel over z-slices, each thread writing only its own slice.
    const auto forSlices = [&](int k0, int k1, const auto& body) {
        tbb::parallel_for(std::max(0, k0), std::max(0, k1), [&](int k) { body(k); });
    };
    // Lattice points within one voxel of dust (where nebillum wrote tau): the dust dilated by
    // one in each of x, y and z in turn (the 27-point neighbourhood, separably), then the
    // cells whose 8 corners all are.
    std::vector<std::uint8_t> near(n, 0), tmp(n, 0);
    forSlices(0, nz, [&](int k) {
        for (std::size_t v = index(0, 0, k), end = v + sz; v < end; ++v)
            tmp[v] = f.voxel(v)[0] > 0.0f;
    });
    // dst = src dilated by one lattice point along @p axis (clipped to the lattice).
    const auto dilate = [&](const std::vector<std::uint8_t>& src, std::vector<std::uint8_t>& dst,
                            int axis) {
        const int len = mDims[std::size_t(axis)];
        const std::size_t stride = axis == 0 ? sx : axis == 1 ? sy : sz;
        forSlices(0, nz, [&](int k) {
            for (int j = 0; j < ny; ++j)
                for (int i = 0; i < nx; ++i) {
                    const int at = axis == 0 ? i : axis == 1 ? j : k;
                    const std::size_t v = index(i, j, k);
                    dst[v] =
                        src[v] || (at > 0 && src[v - stride]) || (at + 1 < len && src[v + stride]);
                }
        });
    };
    dilate(tmp, near, 0);
    dilate(near, tmp, 1);
    dilate(tmp, near, 2);
    // A bit per lattice cell (its lower corner): whether all (@p all) or any of its 8 corners
    // are set in @p points. Cells on the lattice's upper faces have no 8 corners: unset.
    std::vector<std::uint8_t> cells(n, 0);
    const auto cornerCells = [&](const std::vector<std::uint8_t>& points, bool all) {
        forSlices(0, nz - 1, [&](int k) {
            for (int j = 0; j + 1 < ny; ++j)
                for (int i = 0; i + 1 < nx; ++i) {
                    const std::size_t v = index(i, j, k);
                    bool result = all;
                    for (int c = 0; c < 8 && result == all; ++c)
                        result =
                            points[v + (c & 1) * sx + ((c >> 1) & 1) * sy + (c >> 2) * sz] != 0;
                    cells[v] = result;
                }
        });
        return packBits(cells);
    };
    mValid = cornerCells(near, true);
    mAny.assign(mValid.size(), 0);
    std::vector<std::uint8_t>& bends = tmp;
    for (std::size_t s = 0; s < scene.stars.size(); ++s) {
        // Per lattice point: whether tau's second difference along an axis reaches CURVED.
        const auto tau = [&](std::size_t v) { return double(f.voxel(v)[2 + s]); };
        std::fill(bends.begin(), bends.end(), 0);
        forSlices(1, nz - 1, [&](int k) {
            for (int j = 1; j + 1 < ny; ++j)
                for (int i = 1; i + 1 < nx; ++i) {
                    const std::size_t v = index(i, j, k);
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
        });
        // A cell is curved if one of its corners is.
        auto bits = cornerCells(bends, false);
        for (std::size_t w = 0; w < bits.size(); ++w)
            mAny[w] |= bits[w];
        mCurved.push_back(std::move(bits));
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
