// SPDX-License-Identifier: Apache-2.0
/// @file scatter_transport.cpp
/// nebscatter's Transport (scatter_transport.h, DESIGN §5b): the field lattice, its active
/// cells and tally slots, the adaptive cells' blocks and the flight walk's skip blocks,
/// built once per field.

#include "scatter_transport.h"

#include <algorithm>
#include <cmath>

namespace nebula::detail {

namespace {

/// Calls @p fn(linear index) for (x, y, z) and each of its neighbours up to @p reach
/// cells away along each axis (26 of them for 1) inside a box lattice of @p dims (x
/// fastest).
template <class Fn>
void forEachNeighbour(const std::array<int, 3>& dims, int x, int y, int z, const Fn& fn,
                      int reach = 1)
{
    for (int e = std::max(z - reach, 0); e <= std::min(z + reach, dims[2] - 1); ++e)
        for (int b = std::max(y - reach, 0); b <= std::min(y + reach, dims[1] - 1); ++b)
            for (int a = std::max(x - reach, 0); a <= std::min(x + reach, dims[0] - 1); ++a)
                fn((std::size_t(e) * std::size_t(dims[1]) + std::size_t(b)) * std::size_t(dims[0]) +
                   std::size_t(a));
}

} // namespace

/// Calls @p fn(field cell, n) for every voxel of the lattice with dust (n > 0) and the
/// field cell holding its centre (half-voxel cells: each of the 8 cells round it, its
/// centre being their common corner): only stored bricks hold dust.
template <class Fn> void Transport::forEachDustVoxel(const Fn& fn) const
{
    const SparseVolume& f = mScene.fields;
    const int below = halfVoxel() ? 1 : 0; // cells 2p and 2p + 1
    f.forEachStoredBrick([&](std::size_t first) {
        for (std::size_t v = first; v < first + SparseVolume::BRICK_VOXELS; ++v) {
            const float n = f.voxel(v)[0];
            if (!(n > 0.0f)) continue;
            const auto p = f.point(v);
            if (!f.contains(p[0], p[1], p[2])) continue;
            const int I = floorDiv(p[0]) - mFLo[0], J = floorDiv(p[1]) - mFLo[1],
                      K = floorDiv(p[2]) - mFLo[2];
            for (int z = K - below; z <= K; ++z)
                for (int y = J - below; y <= J; ++y)
                    for (int x = I - below; x <= I; ++x)
                        fn(cellIndex(x, y, z), n);
        }
    });
}

Transport::Transport(const RenderScene& scene, const RenderOptions& ropts,
                     const ScatterOptions& opts, Channels channels)
    : mScene(scene), mDust(scene.dust), mCh(std::move(channels)), mC(int(mCh.size())),
      mOrder(opts.order), mNm(shCount(opts.order)), mScale(std::ldexp(1.0, opts.fieldLevel)),
      mFieldShift(opts.fieldLevel + 1), mDensity(scene.fields),
      mDusty(scene.column.get(scene.fields).dusty())
{
    const SparseVolume& f = scene.fields;
    mW2I = f.indexToWorld.inverse();
    mVoxel = voxelSize(f.indexToWorld);
    mRmin2 = std::pow(ropts.minStarDistance * mVoxel, 2);
    for (int a = 0; a < 3; ++a) {
        mLo[a] = f.lo()[a];
        mHi[a] = f.lo()[a] + f.dims()[a] - 1;
        // One border cell on each side: the cells holding mLo and mHi from inside, and
        // one more (for half-voxel cells, mHi is a cell face: the cell below it).
        mFLo[a] = floorDiv(mLo[a]) - 1;
        mFDims[a] = int(std::ceil((mHi[a] + 0.5) / mScale)) - mFLo[a] + 1;
    }
    mRMin = *std::min_element(mCh.r.begin(), mCh.r.end());
    // Dust per field cell (n_H summed over its voxels), and the cells the renderer
    // reads: those holding dust and their 26 neighbours. Only stored bricks hold dust.
    // Half-voxel cells: a voxel's dust is shared by the 8 cells round its centre, and
    // the trilinear density reaches two cells further (the renderer reads the field
    // wherever there is dust).
    const double share = halfVoxel() ? 0.125 : 1.0;
    mCellDust.assign(fieldCells(), 0.0);
    forEachDustVoxel([&](std::size_t cell, float n) { mCellDust[cell] += share * n; });
    mActive.assign(fieldCells(), 0);
    const int reach = halfVoxel() ? 2 : 1;
    for (int K = 0; K < mFDims[2]; ++K)
        for (int J = 0; J < mFDims[1]; ++J)
            for (int I = 0; I < mFDims[0]; ++I) {
                if (!(mCellDust[cellIndex(I, J, K)] > 0.0)) continue;
                forEachNeighbour(
                    mFDims, I, J, K, [&](std::size_t c) { mActive[c] = 1; }, reach);
            }
    for (const auto& s : scene.stars)
        mStarPos.emplace_back(s.position[0], s.position[1], s.position[2]);
    // Adaptive cells: blocks of 2x2x2 field cells (the next level's cells) tallied as
    // one unless refined (refineBlocks()).
    if (opts.refineTau > 0.0) refineBlocks(opts.refineTau);
    // The tallies hold only the active cells (slots in cell order): a cell of a refined
    // block (or every cell, without adaptive cells) has its own slot, an unrefined
    // block's active cells share the block's.
    mSlot.assign(fieldCells(), -1);
    std::vector<std::int32_t> blockSlot(mBlockRefined.size(), -1);
    for (std::size_t c = 0; c < mActive.size(); ++c) {
        if (!mActive[c]) continue;
        if (mBlockRefined.empty() || mBlockRefined[blockOf(c)]) {
            mSlot[c] = std::int32_t(mSlots++);
            mSlotBlock.push_back(-1);
            continue;
        }
        std::int32_t& b = blockSlot[blockOf(c)];
        if (b < 0) {
            b = std::int32_t(mSlots++);
            mSlotBlock.push_back(std::int64_t(blockOf(c)));
        }
        mSlot[c] = b;
    }
    buildLiveBlocks();
    if (ropts.exactStarDepth) mDepth.emplace(scene);
}

/// The walk's empty space: per block of SKIP_BLOCK^3 lattice cells, 1 if a flight has
/// anything to do in it (a lattice cell with dust, or a part of an active field cell);
/// walk() jumps over the others.
void Transport::buildLiveBlocks()
{
    const SparseVolume& f = mScene.fields;
    std::size_t n = 1;
    for (int a = 0; a < 3; ++a) {
        mSkipDims[a] = (f.dims()[a] - 1 + SKIP_BLOCK - 1) / SKIP_BLOCK;
        n *= std::size_t(std::max(mSkipDims[a], 0));
    }
    mLive.assign(n, 0);
    mDusty.forEachSet([&](std::size_t idx) {
        const auto p = f.point(idx);
        mLive[skipBlock(p[0], p[1], p[2])] = 1;
    });
    // An active field cell covers level-0 coordinates [S I - 1/2, S (I + 1) - 1/2] (S =
    // 2^level, I absolute): the lattice cells from floor(S I - 1/2) to
    // ceil(S (I + 1) - 1/2) - 1.
    for (int K = 0; K < mFDims[2]; ++K)
        for (int J = 0; J < mFDims[1]; ++J)
            for (int I = 0; I < mFDims[0]; ++I) {
                if (!mActive[cellIndex(I, J, K)]) continue;
                const int X[3] = {I, J, K};
                int b0[3], b1[3];
                for (int a = 0; a < 3; ++a) {
                    const int first =
                        std::max(mLo[a], int(std::floor(mScale * (X[a] + mFLo[a]) - 0.5)));
                    const int last = std::min(
                        mHi[a] - 1, int(std::ceil(mScale * (X[a] + mFLo[a] + 1) - 0.5)) - 1);
                    b0[a] = (first - mLo[a]) / SKIP_BLOCK;
                    b1[a] = last < first ? b0[a] - 1 : (last - mLo[a]) / SKIP_BLOCK;
                }
                for (int z = b0[2]; z <= b1[2]; ++z)
                    for (int y = b0[1]; y <= b1[1]; ++y)
                        for (int x = b0[0]; x <= b1[0]; ++x)
                            mLive[(std::size_t(z) * mSkipDims[1] + std::size_t(y)) * mSkipDims[0] +
                                  std::size_t(x)] = 1;
            }
}

/// Adaptive cells (DESIGN §5b): a block of 2x2x2 field cells (a cell of the next level)
/// is refined, each cell tallied on its own, where its densest voxel makes the block
/// optically thicker than @p refineTau across (tau_V; inside it the field varies like
/// e^-tau) or a star lies in it or in a block next to it (the field varies like 1/r
/// there); elsewhere the block's active cells share one tally, eight times the packets
/// per tally, and their values come from the blocks' values and slopes (computeField()).
void Transport::refineBlocks(double refineTau)
{
    for (int a = 0; a < 3; ++a) {
        mBLo[a] = blockCoord(mFLo[a]);
        mBDims[a] = blockCoord(mFLo[a] + mFDims[a] - 1) - mBLo[a] + 1;
    }
    const std::size_t blocks = std::size_t(mBDims[0]) * mBDims[1] * mBDims[2];
    std::vector<float> densest(blocks, 0.0f);
    forEachDustVoxel([&](std::size_t cell, float n) {
        float& m = densest[blockOf(cell)];
        m = std::max(m, n);
    });
    const double across = mDust.kappa_V * mVoxel * 2.0 * mScale; // tau_V per unit n
    mBlockRefined.assign(blocks, 0);
    for (std::size_t b = 0; b < blocks; ++b)
        mBlockRefined[b] = double(densest[b]) * across > refineTau;
    // A ring of refined blocks round the refined ones: an unrefined block's cells are
    // interpolated from blocks that are tallied whole too, never from the average of a
    // thick block (whose lit face and shadowed back would mix). Not for half-voxel
    // cells: there a block is a voxel, tallied as full resolution would tally it (its
    // cells keep its value on average whatever their neighbours), and the ring refined
    // 2.5 times the cells for no gain (the thick scene's pixel noise 3.6 % against
    // 3.3 % without it, its error against the reference the same).
    if (!halfVoxel()) {
        std::vector<std::uint8_t> ring = mBlockRefined;
        for (int z = 0; z < mBDims[2]; ++z)
            for (int y = 0; y < mBDims[1]; ++y)
                for (int x = 0; x < mBDims[0]; ++x) {
                    if (!mBlockRefined[(std::size_t(z) * mBDims[1] + std::size_t(y)) * mBDims[0] +
                                       std::size_t(x)])
                        continue;
                    forEachNeighbour(mBDims, x, y, z, [&](std::size_t b) { ring[b] = 1; });
                }
        mBlockRefined = std::move(ring);
    }
    for (const Vec3& star : mStarPos) {
        const Vec3 pI = mW2I.apply(star);
        int B[3];
        for (int a = 0; a < 3; ++a)
            B[a] = blockCoord(floorDiv(pI[a])) - mBLo[a];
        forEachNeighbour(mBDims, B[0], B[1], B[2], [&](std::size_t b) { mBlockRefined[b] = 1; });
    }
}

} // namespace nebula::detail
