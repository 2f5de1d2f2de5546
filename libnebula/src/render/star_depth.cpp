// SPDX-License-Identifier: Apache-2.0
/// @file star_depth.cpp
/// Short characteristics through cells where a star's optical depth bends; see star_depth.h.

#include "nebula/render/star_depth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <thread>

namespace nebula {

namespace {

constexpr int B = SparseVolume::BRICK;

} // namespace

StarDepth::StarDepth(const RenderScene& scene)
    : mScene(scene), mColumn(scene.column.get(scene.fields)), mLo(scene.fields.lo()),
      mDims(scene.fields.dims()), mKappa(scene.dust.kappa_V)
{
    const SparseVolume& f = scene.fields;
    const std::size_t bricks = f.voxelCount() / SparseVolume::BRICK_VOXELS;
    mValid = VoxelBits(f, false);
    mAny = VoxelBits(f, false);
    mCurved.assign(scene.stars.size(), VoxelBits(f, false));
    mBuilt.reset(new std::atomic<std::uint8_t>[bricks]);
    for (std::size_t b = 0; b < bricks; ++b)
        mBuilt[b].store(0, std::memory_order_relaxed);
    mBricks = bricks;
    const Affine w2i = f.indexToWorld.inverse();
    for (const auto& s : scene.stars)
        mStarI.push_back(w2i.apply(Vec3(s.position[0], s.position[1], s.position[2])));
}

void StarDepth::build(std::size_t b) const
{
    std::uint8_t idle = 0;
    if (!mBuilt[b].compare_exchange_strong(idle, 1, std::memory_order_acq_rel)) {
        while (mBuilt[b].load(std::memory_order_acquire) != 2)
            std::this_thread::yield(); // another thread is building it
        return;
    }
    const SparseVolume& f = mScene.fields;
    const auto p0 = f.point(b * SparseVolume::BRICK_VOXELS); // the brick's first point
    const std::array<int, 3> hi{mLo[0] + mDims[0] - 1, mLo[1] + mDims[1] - 1,
                                mLo[2] + mDims[2] - 1};
    const auto onLattice = [&](int i, int j, int k) { return f.contains(i, j, k); };
    // Dust on the points p0 - 2 .. p0 + 10 (D), dilated by one along x, y and z in turn: the
    // points within one voxel of dust (where nebillum wrote tau), on p0 - 1 .. p0 + 9 (N).
    constexpr int ND = B + 5, NN = B + 3, NB = B + 1;
    std::uint8_t D[ND][ND][ND], X[ND][ND][NN], Y[ND][NN][NN], N[NN][NN][NN];
    for (int z = 0; z < ND; ++z)
        for (int y = 0; y < ND; ++y)
            for (int x = 0; x < ND; ++x) {
                const int i = p0[0] + x - 2, j = p0[1] + y - 2, k = p0[2] + z - 2;
                D[z][y][x] = onLattice(i, j, k) && f.voxel(f.index(i, j, k))[0] > 0.0f;
            }
    for (int z = 0; z < ND; ++z)
        for (int y = 0; y < ND; ++y)
            for (int x = 0; x < NN; ++x)
                X[z][y][x] = D[z][y][x] | D[z][y][x + 1] | D[z][y][x + 2];
    for (int z = 0; z < ND; ++z)
        for (int y = 0; y < NN; ++y)
            for (int x = 0; x < NN; ++x)
                Y[z][y][x] = X[z][y][x] | X[z][y + 1][x] | X[z][y + 2][x];
    for (int z = 0; z < NN; ++z)
        for (int y = 0; y < NN; ++y)
            for (int x = 0; x < NN; ++x) {
                const int i = p0[0] + x - 1, j = p0[1] + y - 1, k = p0[2] + z - 1;
                N[z][y][x] = onLattice(i, j, k) && (Y[z][y][x] | Y[z + 1][y][x] | Y[z + 2][y][x]);
            }
    // A cell of the brick (its lower corner on the lattice, not on the upper faces): valid if
    // its 8 corners are near dust.
    const auto isCell = [&](int i, int j, int k) {
        return onLattice(i, j, k) && i < hi[0] && j < hi[1] && k < hi[2];
    };
    for (int z = 0; z < B; ++z)
        for (int y = 0; y < B; ++y)
            for (int x = 0; x < B; ++x) {
                const int i = p0[0] + x, j = p0[1] + y, k = p0[2] + z;
                if (!isCell(i, j, k)) continue;
                bool all = true;
                for (int c = 0; c < 8 && all; ++c)
                    all = N[z + 1 + (c >> 2)][y + 1 + (c >> 1 & 1)][x + 1 + (c & 1)] != 0;
                if (all) mValid.set(f.index(i, j, k));
            }
    // Per star: the points p0 .. p0 + 8 where tau's second difference along an axis reaches
    // CURVED (interior points near dust whose neighbours on that axis are too: beyond the
    // active band the grid reads 0, which is no bend of the true tau); a cell is curved if
    // one of its corners is.
    for (std::size_t s = 0; s < mCurved.size(); ++s) {
        const int c = 2 + int(s);
        const auto tau = [&](int i, int j, int k) { return double(f.voxel(f.index(i, j, k))[c]); };
        std::uint8_t bends[NB][NB][NB];
        for (int z = 0; z < NB; ++z)
            for (int y = 0; y < NB; ++y)
                for (int x = 0; x < NB; ++x) {
                    const int i = p0[0] + x, j = p0[1] + y, k = p0[2] + z;
                    bool b = false;
                    if (i > mLo[0] && j > mLo[1] && k > mLo[2] && i < hi[0] && j < hi[1] &&
                        k < hi[2] && N[z + 1][y + 1][x + 1]) {
                        const double t = 2.0 * tau(i, j, k);
                        for (int a = 0; a < 3 && !b; ++a) {
                            const int di = a == 0, dj = a == 1, dk = a == 2;
                            b = N[z + 1 - dk][y + 1 - dj][x + 1 - di] &&
                                N[z + 1 + dk][y + 1 + dj][x + 1 + di] &&
                                std::abs(tau(i - di, j - dj, k - dk) - t +
                                         tau(i + di, j + dj, k + dk)) >= CURVED;
                        }
                    }
                    bends[z][y][x] = b;
                }
        for (int z = 0; z < B; ++z)
            for (int y = 0; y < B; ++y)
                for (int x = 0; x < B; ++x) {
                    const int i = p0[0] + x, j = p0[1] + y, k = p0[2] + z;
                    if (!isCell(i, j, k)) continue;
                    bool any = false;
                    for (int q = 0; q < 8 && !any; ++q)
                        any = bends[z + (q >> 2)][y + (q >> 1 & 1)][x + (q & 1)] != 0;
                    if (!any) continue;
                    const std::size_t v = f.index(i, j, k);
                    mCurved[s].set(v);
                    mAny.set(v);
                }
    }
    mBuilt[b].store(2, std::memory_order_release);
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
        if (c == NONE) return tau; // left the grid: no dust from here to the star
        ensure(c);
        if (!mValid[c]) continue; // no tau here: cross the gap
        if (tau > TAU_STOP || step + 1 >= MAX_STEPS || !mCurved[s][c]) break;
    }
    // The rest from the tau grid at p.
    float rest = 0.0f;
    mScene.fields.sampleChannels(p, 2 + int(s), 1, &rest);
    return tau + std::max(0.0, double(rest));
}

double StarDepth::curvedFraction(std::size_t s) const
{
    tbb::parallel_for(std::size_t(0), mBricks, [&](std::size_t b) { build(b); });
    const std::size_t n = mCurved[s].count();
    const std::size_t cells =
        std::size_t(mDims[0] - 1) * std::size_t(mDims[1] - 1) * std::size_t(mDims[2] - 1);
    return cells > 0 ? double(n) / double(cells) : 0.0;
}

} // namespace nebula
