// SPDX-License-Identifier: Apache-2.0
#include "nebula/volume/volume.h"

#include "nebula/core/error.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <thread>

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

SparseVolume::SparseVolume(std::array<int, 3> lo, std::array<int, 3> dims, int channels)
    : mLo(lo), mDims(dims), mChannels(channels)
{
    if (channels <= 0 || dims[0] <= 0 || dims[1] <= 0 || dims[2] <= 0) {
        throw Error("SparseVolume: empty volume");
    }
    double slots = 1.0;
    for (std::size_t a = 0; a < 3; ++a) {
        // Floor to a multiple of BRICK (an arithmetic shift floors negative numbers too).
        const std::int64_t first = std::int64_t(lo[a]) >> BRICK_LOG2;
        const std::int64_t last = (std::int64_t(lo[a]) + dims[a] - 1) >> BRICK_LOG2;
        mOrigin[a] = int(first * BRICK);
        mBricks[a] = int(last - first + 1);
        slots *= double(mBricks[a]);
    }
    if (slots > double(std::numeric_limits<std::uint32_t>::max() - 2)) {
        throw Error(fmt::format("a volume of {}x{}x{} voxels has {:.3g} bricks of {}^3 voxels, "
                                "more than the {} a volume can index",
                                dims[0], dims[1], dims[2], slots, BRICK,
                                std::numeric_limits<std::uint32_t>::max() - 2));
    }
    mSlots.assign(std::size_t(slots), 0);
    mReserved = (mSlots.size() + 1) * brickFloats() * sizeof(float);
    mBase = static_cast<float*>(
        reserveAddressSpace(mReserved, fmt::format("a volume of {}x{}x{} voxels, {} channels",
                                                   dims[0], dims[1], dims[2], channels)));
}

SparseVolume::SparseVolume(const SparseVolume& o)
    : indexToWorld(o.indexToWorld), mLo(o.mLo), mDims(o.mDims), mOrigin(o.mOrigin),
      mBricks(o.mBricks), mChannels(o.mChannels), mSlots(o.mSlots), mReserved(o.mReserved),
      mUsed(o.mUsed)
{
    if (!o.mBase) return;
    mBase = static_cast<float*>(reserveAddressSpace(mReserved, "a copy of a volume"));
    // The stored bricks (id 0, the zero brick, stays unwritten).
    std::memcpy(mBase + brickFloats(), o.mBase + brickFloats(),
                std::size_t(mUsed - 1) * brickFloats() * sizeof(float));
}

SparseVolume::SparseVolume(SparseVolume&& o) noexcept
{
    *this = std::move(o);
}

SparseVolume& SparseVolume::operator=(const SparseVolume& o)
{
    if (this != &o) *this = SparseVolume(o);
    return *this;
}

SparseVolume& SparseVolume::operator=(SparseVolume&& o) noexcept
{
    if (this == &o) return *this;
    release();
    indexToWorld = o.indexToWorld;
    mLo = o.mLo;
    mDims = o.mDims;
    mOrigin = o.mOrigin;
    mBricks = o.mBricks;
    mChannels = o.mChannels;
    mSlots = std::move(o.mSlots);
    mBase = o.mBase;
    mReserved = o.mReserved;
    mUsed = o.mUsed;
    o.mBase = nullptr;
    o.mReserved = 0;
    o.mUsed = 1;
    o.mSlots.clear();
    return *this;
}

SparseVolume::~SparseVolume()
{
    release();
}

void SparseVolume::release() noexcept
{
    releaseAddressSpace(mBase, mReserved);
    mBase = nullptr;
    mReserved = 0;
}

std::uint32_t SparseVolume::storeBrick(std::size_t slot)
{
    constexpr std::uint32_t BUSY = std::numeric_limits<std::uint32_t>::max();
    std::uint32_t* entry = &mSlots[slot];
    std::uint32_t id = __atomic_load_n(entry, __ATOMIC_ACQUIRE);
    while (id == 0 || id == BUSY) {
        std::uint32_t expected = 0;
        if (id == 0 && __atomic_compare_exchange_n(entry, &expected, BUSY, false, __ATOMIC_ACQ_REL,
                                                   __ATOMIC_ACQUIRE)) {
            // This thread stores the brick: the next id (its memory is still untouched, zero).
            id = __atomic_fetch_add(&mUsed, 1u, __ATOMIC_RELAXED);
            __atomic_store_n(entry, id, __ATOMIC_RELEASE);
            return id;
        }
        std::this_thread::yield(); // another thread is storing it
        id = __atomic_load_n(entry, __ATOMIC_ACQUIRE);
    }
    return id;
}

SparseVolume SparseVolume::halfResolution(int firstDepth, int weight) const
{
    std::array<int, 3> lo, dims;
    for (int a = 0; a < 3; ++a) {
        // The voxels covering this lattice (>> floors negative indices too), and a zero
        // border: the trilinear field falls to zero over one half voxel beyond them, as the
        // sum it keeps needs (zero outside the lattice would cut the edge voxels' cells).
        lo[std::size_t(a)] = (mLo[std::size_t(a)] >> 1) - 1;
        const int hi = ((mLo[std::size_t(a)] + mDims[std::size_t(a)] - 1) >> 1) + 1;
        dims[std::size_t(a)] = hi - lo[std::size_t(a)] + 1;
    }
    SparseVolume half(lo, dims, mChannels);
    // Index 2I + 0.5 of this volume is index I of the half one.
    half.indexToWorld.m = indexToWorld.m;
    for (double& v : half.indexToWorld.m)
        v *= 2.0;
    half.indexToWorld.t = indexToWorld.apply(Vec3(0.5, 0.5, 0.5));
    // Each stored brick (8^3, aligned to multiples of 8) fills 4^3 voxels of the half volume
    // that no other brick touches: bricks in parallel, no two writing the same voxel.
    std::vector<std::size_t> firsts;
    forEachStoredBrick([&](std::size_t first) { firsts.push_back(first); });
    const int C = mChannels;
    const int D = firstDepth >= 0 && firstDepth < C ? firstDepth : C; // depths: D .. C - 1
    const auto fill = [&](std::size_t first) {
        const auto p0 = point(first);
        // The brick's voxels, channel-interleaved, x fastest; those off the lattice are zero.
        const float* brick = voxel(first);
        std::vector<double> sum(static_cast<std::size_t>(C), 0.0),
            weighted(static_cast<std::size_t>(C), 0.0);
        for (int z = 0; z < BRICK; z += 2)
            for (int y = 0; y < BRICK; y += 2)
                for (int x = 0; x < BRICK; x += 2) {
                    std::fill(sum.begin(), sum.end(), 0.0);
                    std::fill(weighted.begin(), weighted.end(), 0.0);
                    double weights = 0.0;
                    bool any = false;
                    for (int c = 0; c < 8; ++c) {
                        const int at =
                            ((z + (c >> 2)) * BRICK + y + (c >> 1 & 1)) * BRICK + x + (c & 1);
                        const float* v = brick + std::size_t(at) * std::size_t(C);
                        for (int ch = 0; ch < C; ++ch) {
                            sum[std::size_t(ch)] += v[ch];
                            any = any || v[ch] != 0.0f;
                        }
                        if (D < C && v[weight] > 0.0f) {
                            weights += v[weight];
                            for (int ch = D; ch < C; ++ch)
                                weighted[std::size_t(ch)] += v[weight] * std::exp(-double(v[ch]));
                        }
                    }
                    if (!any) continue;
                    const int i = (p0[0] + x) >> 1, j = (p0[1] + y) >> 1, k = (p0[2] + z) >> 1;
                    float* out = half.writable(half.index(i, j, k));
                    for (int ch = 0; ch < C; ++ch) {
                        const double w = weighted[std::size_t(ch)];
                        out[ch] = ch >= D && weights > 0.0 && w > 0.0
                                      ? float(-std::log(w / weights))
                                      : float(0.125 * sum[std::size_t(ch)]);
                    }
                }
    };
    tbb::parallel_for(std::size_t(0), firsts.size(), [&](std::size_t b) { fill(firsts[b]); });
    return half;
}

std::array<int, 3> SparseVolume::point(std::size_t idx) const
{
    const std::size_t slot = idx >> (3 * BRICK_LOG2);
    const int at = int(idx & (BRICK_VOXELS - 1));
    const std::size_t bx = std::size_t(mBricks[0]), by = std::size_t(mBricks[1]);
    constexpr int M = BRICK - 1;
    return {mOrigin[0] + int(slot % bx) * BRICK + (at & M),
            mOrigin[1] + int((slot / bx) % by) * BRICK + ((at >> BRICK_LOG2) & M),
            mOrigin[2] + int(slot / (bx * by)) * BRICK + (at >> (2 * BRICK_LOG2))};
}

void SparseVolume::setZero()
{
    if (mBase && mUsed > 1) {
        std::memset(mBase + brickFloats(), 0,
                    std::size_t(mUsed - 1) * brickFloats() * sizeof(float));
    }
}

SparseVolume SparseVolume::channel(int c) const
{
    SparseVolume v(mLo, mDims, 1);
    v.indexToWorld = indexToWorld;
    const std::size_t C = std::size_t(mChannels);
    forEachStoredBrick([&](std::size_t first) {
        const float* src = voxel(first) + c;
        float* dst = v.writable(first);
        for (std::size_t i = 0; i < BRICK_VOXELS; ++i)
            dst[i] = src[i * C];
    });
    return v;
}

} // namespace nebula
