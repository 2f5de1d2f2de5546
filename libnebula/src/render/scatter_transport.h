#pragma once
/// @file scatter_transport.h
/// Internal to render/: nebscatter's Monte Carlo (DESIGN §5b) beneath computeField()
/// (scatter_field.cpp): the channels one walk carries, the sampler packets start from, the
/// Transport every flight reads (fields, occupancy, the tallies' layout, the spherical-harmonic
/// track-length tally), and runPacket() (scatter_packets.cpp): one packet through every order
/// of scattering.

#include "nebula/core/units.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/scatter_field.h"
#include "nebula/render/scene.h"
#include "nebula/render/star_depth.h"
#include "nebula/volume/block_walk.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace nebula::detail {

constexpr double INF = std::numeric_limits<double>::infinity();
/// A flight stops walking once even the least dimmed channel is below e^-17 (4e-8).
constexpr double TAU_CUTOFF = 17.0;
/// Russian roulette below this channel weight (initial weights are about 1, a collision
/// multiplies them by about the albedo). 0.6 made the field 22 % faster with the same noise
/// where the picture is bright, but 19 % noisier (RMS) in its faint parts (pixels at 0.1-1 %
/// of the brightest, the 128^3 example against a 6-million-packet field), so it stays 0.25.
constexpr double ROULETTE_WEIGHT = 0.25;
constexpr std::uint64_t MAX_FLIGHTS = 1000000;
/// Russian roulette on a flight's tail: past the point where even the least dimmed channel
/// is below e^-TAIL_TAU, a flight goes on with probability TAIL_KEEP (its weights there
/// divided by it) or stops. In thick dust most of a walk to TAU_CUTOFF is a tail carrying
/// about e^-TAIL_TAU of the flight's light. From e^-3 on, the faint parts of the example's
/// picture (behind the thick core) came out 15 % noisier; from e^-5 on they do not.
constexpr double TAIL_TAU = 5.0;
constexpr double TAIL_KEEP = 0.25;

/// A flight's tail roulette (walk()): where the tail starts (V optical depth), whether the
/// flight stops there; walk() sets where the tail started (the end of the piece that
/// reached it; infinity if it did not).
struct Tail
{
    double tau = INF;
    bool stop = false;
    double boundary = INF;
};

/// Fixed-point quantum 2^-e of the tallies (weight x length in voxels; weights): the
/// finest for which @p packets packets cannot overflow an int64 sum (a bound of 64 flights
/// per packet crossing a cell, weights up to 16, field cells of 2^level voxels) and one
/// addition stays below 2^50 quanta. 2^-28 for 2 million packets at level 1: one addition
/// of 10^-6 is rounded by at most 2e-3 of itself, errors that average out over additions.
inline double fixedQuantum(std::uint64_t packets, int level)
{
    // One addition: weight (up to 4, times 1 / TAIL_KEEP in a flight's tail) x length
    // (2^level voxels, up to 2 across) x |Y_lm| (below 1), at most 2^50 quanta (roundFixed()).
    const double one = 16.0 * 2.0 * std::ldexp(1.0, level);
    const double bound = double(packets) * 64.0 * one;
    const int e = std::min({40, int(std::floor(62.0 - std::log2(std::max(bound, 1.0)))),
                            int(std::floor(50.0 - std::log2(one)))});
    return std::ldexp(1.0, -e);
}

/// @p x rounded to the nearest integer (ties to even) for |x| < 2^51, without a branch or a
/// library call: the integer is in the low bits of 1.5 * 2^52 + x.
inline std::int64_t roundFixed(double x)
{
    const double y = x + 6755399441055744.0; // 1.5 * 2^52
    std::int64_t bits;
    std::memcpy(&bits, &y, sizeof bits);
    return bits - std::int64_t(0x4338000000000000);
}

/// Adds @p scaled (a value over the quantum, |scaled| < 2^51) to @p p, rounded to the nearest
/// integer (roundFixed()), as an integer addition (atomic when @p atomic): the sum does not
/// depend on the order.
inline void addFixed(std::int64_t* p, double scaled, bool atomic)
{
    const std::int64_t q = roundFixed(scaled);
    if (q == 0) return;
    if (atomic) {
        __atomic_fetch_add(p, q, __ATOMIC_RELAXED);
    } else {
        *p += q;
    }
}

/// The channels one walk carries: R, G, B (the scene's channel dust and star colours) or a
/// spectral field's wavelengths.
struct Channels
{
    std::vector<double> wavelengths;            ///< a spectral field's [nm]; empty: R, G, B
    std::vector<double> r;                      ///< A(lambda_c)/A_V per channel
    std::vector<std::vector<double>> starPower; ///< per star and channel [L_sun (nm^-1)]
    std::size_t size() const { return r.size(); }
};

/// The most channels one walk carries (a spectral field's wavelengths).
constexpr std::size_t MAX_CHANNELS = SPECTRAL_FIELD_MAX_WAVELENGTHS;

inline Channels rgbChannels(const RenderScene& scene)
{
    Channels ch;
    ch.r.assign(scene.dust.r.begin(), scene.dust.r.end());
    for (const auto& c : scene.starColor)
        ch.starPower.emplace_back(c.begin(), c.end());
    return ch;
}

/// (1 - e^-x) / x for x > 0: its Taylor series where x is small (most pieces of a flight; a
/// tenth of the walk's time went to expm1 and a division), expm1 above.
inline double oneMinusExpOverX(double x)
{
    if (x < 0.0625) { // the series' first omitted term, x^8 / 9!, is below 2e-16
        return 1.0 - x * (1.0 / 2 -
                          x * (1.0 / 6 -
                               x * (1.0 / 24 -
                                    x * (1.0 / 120 -
                                         x * (1.0 / 720 - x * (1.0 / 5040 - x * (1.0 / 40320)))))));
    }
    return -std::expm1(-x) / x;
}

/// The lattice cell a walk is in: whether it holds dust and, if it does, the density at its
/// 8 corners, so a sample in it is a trilinear blend of 8 floats (what
/// SparseVolume::sampleChannels() gives for channel 0, without finding the cell again).
struct LatticeCell
{
    int lo[3] = {0, 0, 0};
    bool dusty = false;
    float n[8] = {};

    void load(const SparseVolume& density, const VoxelBits& dustyCells, const int* ijk)
    {
        const std::size_t idx = density.index(ijk[0], ijk[1], ijk[2]);
        dusty = dustyCells[idx];
        if (!dusty) return;
        for (int a = 0; a < 3; ++a)
            lo[a] = ijk[a];
        const float* q[8];
        density.cellCorners(ijk[0], ijk[1], ijk[2], idx, q);
        for (int c = 0; c < 8; ++c)
            n[c] = q[c][0];
    }
    /// n_H at index point @p p in (or on the faces of) the cell.
    float sample(const Vec3& p) const
    {
        const float u = float(p.x - lo[0]), v = float(p.y - lo[1]), w = float(p.z - lo[2]);
        const float c00 = n[0] + u * (n[1] - n[0]);
        const float c10 = n[2] + u * (n[3] - n[2]);
        const float c01 = n[4] + u * (n[5] - n[4]);
        const float c11 = n[6] + u * (n[7] - n[6]);
        const float c0 = c00 + v * (c10 - c00);
        const float c1 = c01 + v * (c11 - c01);
        return c0 + w * (c1 - c0);
    }
};

/// One piece of a flight (a half-voxel cell) with dust: where it starts (world distance),
/// its length [pc], its constant V extinction [1/pc] and the V optical depth before it.
struct Piece
{
    double t, len, k, tau0;
};

/// A source: the cells packets start from (lattice cells [i, i+1]^3 given by their lower
/// corner), brick by brick in voxel-index order, each with its weight (the mean of eta over
/// its 8 corners); a cell is drawn by the bricks' running sums, then by a scan of its
/// brick's cells. 6 bytes a cell (at 512^3, 20 million cells: 122 MB; a running sum and a
/// voxel index per cell took 325 MB), and any lattice size (voxel indices past 2^32).
struct Sampler
{
    std::vector<std::uint16_t> local;    ///< the cell's lower corner's place in its brick
    std::vector<float> proxy;            ///< the cell's weight: mean of eta over its 8 corners
    std::vector<std::size_t> brickFirst; ///< per brick with cells: its first cell; then the end
    std::vector<std::size_t> brickSlot;  ///< per brick with cells: its voxel index / 512
    std::vector<double> brickCdf;        ///< inclusive running sums of proxy to each brick's end
    double total = 0.0;

    /// The cell drawn by @p u in [0, total): the first whose running sum of proxy passes u;
    /// its lower corner's voxel index into @p voxel.
    std::size_t pick(double u, std::size_t& voxel) const
    {
        auto it = std::upper_bound(brickCdf.begin(), brickCdf.end(), u);
        if (it == brickCdf.end()) --it;
        const std::size_t b = std::size_t(it - brickCdf.begin());
        double acc = b ? brickCdf[b - 1] : 0.0;
        const std::size_t end = brickFirst[b + 1];
        std::size_t i = brickFirst[b];
        for (; i + 1 < end; ++i) {
            acc += double(proxy[i]);
            if (u < acc) break;
        }
        voxel = brickSlot[b] * SparseVolume::BRICK_VOXELS + local[i];
        return i;
    }
};

/// Per-voxel source strength eta (summed over channels; a one-channel volume on the scene's
/// lattice, stored where eta > 0) -> the sampler of lattice cells: the cells with a corner
/// where eta > 0, found from the stored bricks (a bit per voxel index), in index order.
inline Sampler buildSampler(const SparseVolume& eta)
{
    Sampler s;
    const auto& lo = eta.lo();
    const auto& d = eta.dims();
    VoxelBits cells(eta, false);
    eta.forEachStoredBrick([&](std::size_t first) {
        for (std::size_t v = first; v < first + SparseVolume::BRICK_VOXELS; ++v) {
            if (!(eta.voxel(v)[0] > 0.0f)) continue;
            const auto p = eta.point(v);
            for (int c = 0; c < 8; ++c) { // the cells with corner p
                const int i = p[0] - (c & 1), j = p[1] - (c >> 1 & 1), k = p[2] - (c >> 2);
                if (i < lo[0] || j < lo[1] || k < lo[2] || i >= lo[0] + d[0] - 1 ||
                    j >= lo[1] + d[1] - 1 || k >= lo[2] + d[2] - 1)
                    continue;
                cells.set(eta.index(i, j, k));
            }
        }
    });
    double sum = 0.0;
    std::size_t brick = SIZE_MAX;
    const float* q[8];
    cells.forEachSet([&](std::size_t idx) {
        const auto p = eta.point(idx);
        eta.cellCorners(p[0], p[1], p[2], idx, q);
        double m = 0.0;
        for (int c = 0; c < 8; ++c)
            m += q[c][0];
        if (!(m > 0.0)) return;
        const std::size_t br = idx / SparseVolume::BRICK_VOXELS;
        if (br != brick) {
            if (brick != SIZE_MAX) s.brickCdf.push_back(sum);
            s.brickFirst.push_back(s.local.size());
            s.brickSlot.push_back(br);
            brick = br;
        }
        s.local.push_back(std::uint16_t(idx % SparseVolume::BRICK_VOXELS));
        s.proxy.push_back(float(m / 8.0));
        sum += double(s.proxy.back());
    });
    if (brick != SIZE_MAX) s.brickCdf.push_back(sum);
    s.brickFirst.push_back(s.local.size());
    s.total = sum;
    return s;
}

/// Everything a flight needs, shared by all packets.
class Transport
{
public:
    Transport(const RenderScene& scene, const RenderOptions& ropts, const ScatterOptions& opts,
              Channels channels)
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
    void buildLiveBlocks()
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
                                mLive[(std::size_t(z) * mSkipDims[1] + std::size_t(y)) *
                                          mSkipDims[0] +
                                      std::size_t(x)] = 1;
                }
    }
    /// The skip block of lattice cell (i, j, k) (its lower corner, absolute).
    std::size_t skipBlock(int i, int j, int k) const
    {
        return (std::size_t((k - mLo[2]) / SKIP_BLOCK) * mSkipDims[1] +
                std::size_t((j - mLo[1]) / SKIP_BLOCK)) *
                   mSkipDims[0] +
               std::size_t((i - mLo[0]) / SKIP_BLOCK);
    }

    /// Calls @p fn(linear index) for (x, y, z) and each of its neighbours up to @p reach
    /// cells away along each axis (26 of them for 1) inside a box lattice of @p dims (x
    /// fastest).
    template <class Fn>
    static void forEachNeighbour(const std::array<int, 3>& dims, int x, int y, int z, const Fn& fn,
                                 int reach = 1)
    {
        for (int e = std::max(z - reach, 0); e <= std::min(z + reach, dims[2] - 1); ++e)
            for (int b = std::max(y - reach, 0); b <= std::min(y + reach, dims[1] - 1); ++b)
                for (int a = std::max(x - reach, 0); a <= std::min(x + reach, dims[0] - 1); ++a)
                    fn((std::size_t(e) * std::size_t(dims[1]) + std::size_t(b)) *
                           std::size_t(dims[0]) +
                       std::size_t(a));
    }

    /// Calls @p fn(field cell, n) for every voxel of the lattice with dust (n > 0) and the
    /// field cell holding its centre (half-voxel cells: each of the 8 cells round it, its
    /// centre being their common corner): only stored bricks hold dust.
    template <class Fn> void forEachDustVoxel(const Fn& fn) const
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

    /// Adaptive cells (DESIGN §5b): a block of 2x2x2 field cells (a cell of the next level)
    /// is refined, each cell tallied on its own, where its densest voxel makes the block
    /// optically thicker than @p refineTau across (tau_V; inside it the field varies like
    /// e^-tau) or a star lies in it or in a block next to it (the field varies like 1/r
    /// there); elsewhere the block's active cells share one tally, eight times the packets
    /// per tally, and their values come from the blocks' values and slopes (computeField()).
    void refineBlocks(double refineTau)
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
                        if (!mBlockRefined[(std::size_t(z) * mBDims[1] + std::size_t(y)) *
                                               mBDims[0] +
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
            forEachNeighbour(mBDims, B[0], B[1], B[2],
                             [&](std::size_t b) { mBlockRefined[b] = 1; });
        }
    }

    /// Each star's tau_V at index point @p pI into fv[2 + s] (the fields sampled there):
    /// exact where it bends (StarDepth), as the renderers take it.
    void starDepths(const Vec3& pI, float* fv) const
    {
        if (!mDepth || !mDepth->anyCurved(pI)) return;
        for (std::size_t s = 0; s < mStarPos.size(); ++s)
            if (mDepth->curved(s, pI)) fv[2 + s] = float(mDepth->march(s, pI));
    }

    std::size_t fieldCells() const { return std::size_t(mFDims[0]) * mFDims[1] * mFDims[2]; }
    /// Whether the field cells are half a voxel across (level -1, MIN_FIELD_LEVEL).
    bool halfVoxel() const { return mScale < 1.0; }
    int channels() const { return mC; }
    /// The channel whose J's noise is reported: green, a spectral field's middle wavelength.
    int noiseChannel() const { return mC / 2; }
    const Channels& channelSet() const { return mCh; }

    /// The light of star @p s first scattered at a point with dust @p n [cm^-3], squared
    /// distance @p r2 [pc^2] from the star (already clamped) and V optical depth @p tau from
    /// it, per channel: eta_c = k_c a E_c [L_sun pc^-3], integrated over directions.
    void firstScatteringSource(std::size_t s, double n, double r2, double tau, double* eta) const
    {
        for (int c = 0; c < mC; ++c)
            eta[c] = mDust.kappa_V * mCh.r[std::size_t(c)] * n * mDust.albedo *
                     mCh.starPower[s][std::size_t(c)] / (4.0 * PI * r2) *
                     std::exp(-mCh.r[std::size_t(c)] * tau);
    }
    int moments() const { return mNm; }
    /// The V optical depth where a flight's tail starts (TAIL_TAU in the least dimmed
    /// channel).
    double tailTau() const { return TAIL_TAU / mRMin; }
    int order() const { return mOrder; }
    const std::array<int, 3>& fieldLo() const { return mFLo; }
    const std::array<int, 3>& fieldDims() const { return mFDims; }
    double voxel() const { return mVoxel; }
    double rmin2() const { return mRmin2; }
    const std::vector<Vec3>& starPos() const { return mStarPos; }
    const SparseVolume& density() const { return mDensity; }

    /// Linear index of field cell (I, J, K) (0-based on the field lattice).
    std::size_t cellIndex(int I, int J, int K) const
    {
        return (std::size_t(K) * mFDims[1] + std::size_t(J)) * mFDims[0] + std::size_t(I);
    }
    /// Per field cell: 1 if the renderer reads it (dust in it or next to it).
    const std::vector<std::uint8_t>& active() const { return mActive; }
    /// Per field cell: its place among the active cells in the tallies, or -1.
    const std::vector<std::int32_t>& slots() const { return mSlot; }
    /// The number of active cells (tally slots).
    std::size_t slotCount() const { return mSlots; }
    /// Per field cell: n_H summed over its voxels [cm^-3].
    const std::vector<double>& cellDust() const { return mCellDust; }
    /// Whether blocks of 2x2x2 field cells may share a tally (refineBlocks()).
    bool adaptive() const { return !mBlockRefined.empty(); }
    /// The block of field cell @p c (linear index): the next level's cell holding it.
    std::size_t blockOf(std::size_t c) const
    {
        const std::size_t I = c % std::size_t(mFDims[0]),
                          J = (c / std::size_t(mFDims[0])) % std::size_t(mFDims[1]),
                          K = c / (std::size_t(mFDims[0]) * std::size_t(mFDims[1]));
        const int x = blockCoord(int(I) + mFLo[0]) - mBLo[0],
                  y = blockCoord(int(J) + mFLo[1]) - mBLo[1],
                  z = blockCoord(int(K) + mFLo[2]) - mBLo[2];
        return (std::size_t(z) * mBDims[1] + std::size_t(y)) * mBDims[0] + std::size_t(x);
    }
    /// The block lattice: its first block (absolute, the next level's index) and size.
    const std::array<int, 3>& blockLo() const { return mBLo; }
    const std::array<int, 3>& blockDims() const { return mBDims; }
    /// Per block: 1 if refined (its cells tallied each).
    const std::vector<std::uint8_t>& blockRefined() const { return mBlockRefined; }
    /// Per tally slot: the block it tallies whole, or -1 (one field cell's slot).
    const std::vector<std::int64_t>& slotBlock() const { return mSlotBlock; }
    /// The block holding absolute field cell coordinate @p i along an axis: floor(i / 2).
    static int blockCoord(int i) { return i >= 0 ? i / 2 : -((1 - i) / 2); }

    /// Field cell of level-0 index coordinate @p p along one axis.
    int floorDiv(double p) const { return int(std::floor((p + 0.5) / mScale)); }

    /// The overlap of field cell @p I with the walked box [lo, hi], in index units^3.
    double cellVolume(const std::array<int, 3>& I) const
    {
        double v = 1.0;
        for (int a = 0; a < 3; ++a) {
            const double c0 = mScale * I[a] - 0.5, c1 = c0 + mScale;
            v *= std::max(0.0, std::min(c1, double(mHi[a])) - std::max(c0, double(mLo[a])));
        }
        return v;
    }

    /// Where a flight adds its tallies: moments (cell, k, c) and squared green J per cell,
    /// fixed point (quantum q, squares q * 2^8), atomically into a shared buffer or plainly
    /// into the thread's own.
    struct Tally
    {
        std::int64_t* sum = nullptr;
        std::int64_t* sq = nullptr;
        bool atomic = true;
        double invQ = 1.0, invQSq = 1.0;
    };

    /// Walks the flight from world point @p x along unit @p d with channel weights @p w:
    /// tallies (if @p tally) the expected track length times Y_lm(d) into @p out, and
    /// records the pieces with dust; returns the V optical depth walked.
    double walk(const Vec3& x, const Vec3& d, const double* w, bool tally, const double* Y,
                const Tally* out, std::vector<Piece>& pieces, Tail& tail) const
    {
        pieces.clear();
        tail.boundary = INF;
        const Vec3 oI = mW2I.apply(x), dI = mW2I.applyLinear(d);
        double ta = 0.0, tb = INF;
        for (int a = 0; a < 3; ++a) {
            if (std::abs(dI[a]) < 1e-300) {
                if (oI[a] < mLo[a] || oI[a] > mHi[a]) return 0.0;
                continue;
            }
            const double t1 = (mLo[a] - oI[a]) / dI[a], t2 = (mHi[a] - oI[a]) / dI[a];
            ta = std::max(ta, std::min(t1, t2));
            tb = std::min(tb, std::max(t1, t2));
        }
        if (!(ta < tb)) return 0.0;
        // Half-voxel cells: q = floor(2 p) along each axis; every such cell lies inside one
        // lattice cell (the trilinear density is one cubic along the piece: Simpson is
        // exact) and inside one field cell (boundaries at half-integers).
        int q[3], step[3], li[3], fi[3];
        double tNext[3], tDelta[3];
        for (int a = 0; a < 3; ++a) {
            step[a] = dI[a] > 0.0 ? 1 : dI[a] < 0.0 ? -1 : 0;
            tDelta[a] = step[a] ? 0.5 / std::abs(dI[a]) : INF;
        }
        // The half-voxel cells from half-voxel cell q on: the crossings ahead, the lattice
        // and field cells.
        const auto enter = [&] {
            for (int a = 0; a < 3; ++a) {
                tNext[a] = step[a] > 0   ? ((q[a] + 1) * 0.5 - oI[a]) / dI[a]
                           : step[a] < 0 ? (q[a] * 0.5 - oI[a]) / dI[a]
                                         : INF;
                li[a] = floorDiv2(q[a]);
                fi[a] = fieldIndex(q[a], a);
            }
        };
        // q: the half-voxel cell holding index point p (clamped into the box).
        const auto cellAt = [&](const Vec3& p) {
            for (int a = 0; a < 3; ++a)
                q[a] = std::clamp(int(std::floor(2.0 * p[a])), 2 * mLo[a], 2 * mHi[a] - 1);
        };
        cellAt(oI + dI * (0.5 * (ta + std::min(tb, ta + 1e-6)))); // inside the box
        enter();
        double t = ta, tp = ta, tau = 0.0; // tp: where the current piece starts
        float nPrev = mDensity.sample0(oI + dI * ta);
        // The piece's lattice cell: whether it holds dust and, if so, its 8 corners' n_H
        // (read once for the pieces in it, not per sample).
        LatticeCell lc;
        // Empty space: from a skip block with nothing to do, on to where the ray leaves it
        // (its cells have no dust, so the density there is 0, and no tallies).
        const auto skipEmpty = [&]() -> bool {
            const std::size_t b = skipBlock(li[0], li[1], li[2]);
            if (mLive[b]) return false;
            double tExit = INF;
            int axis = 0, exitFace = 0;
            for (int a = 0; a < 3; ++a) {
                if (!step[a]) continue;
                const int blk = (li[a] - mLo[a]) / SKIP_BLOCK;
                const int face = mLo[a] + SKIP_BLOCK * (blk + (step[a] > 0 ? 1 : 0));
                const double tf = (face - oI[a]) / dI[a];
                if (tf < tExit) {
                    tExit = tf;
                    axis = a;
                    exitFace = face;
                }
            }
            if (!(tExit < tb)) {
                t = tb;
                return true;
            }
            cellAt(oI + dI * tExit);
            q[axis] = step[axis] > 0 ? 2 * exitFace : 2 * exitFace - 1; // past it, for certain
            if (q[axis] < 2 * mLo[axis] || q[axis] > 2 * mHi[axis] - 1) {
                t = tb;
                return true;
            }
            t = std::max(t, tExit);
            tp = t;
            enter();
            lc.load(mDensity, mDusty, li);
            nPrev = 0.0f;
            return true;
        };
        // Into lattice cell li: its corners, or past the empty blocks from it.
        const auto loadCell = [&] {
            lc.load(mDensity, mDusty, li);
            if (lc.dusty) return;
            while (t < tb && skipEmpty()) {
            }
        };
        loadCell();
        double att[MAX_CHANNELS], acc[MAX_CHANNELS];
        for (int ch = 0; ch < mC; ++ch) {
            att[ch] = w[ch]; // w_c e^-tau_c before the piece
            acc[ch] = 0.0;
        }
        long cell = -1, slot = -1; // the piece's field cell and its tally slot (-1: none)
        const double kappa = mDust.kappa_V, invVoxel = 1.0 / mVoxel;
        while (t < tb) {
            int a = 0;
            if (tNext[1] < tNext[a]) a = 1;
            if (tNext[2] < tNext[a]) a = 2;
            const double tn = std::min(tNext[a], tb);
            // A piece ends where the walk leaves its lattice cell or its field cell; the
            // half-voxel crossings between (a lattice cell's midplane that is no field face,
            // every other one from level 1 on) do not end it.
            const int qn = q[a] + step[a];
            if (tn < tb && floorDiv2(qn) == li[a] && fieldIndex(qn, a) == fi[a] &&
                qn >= 2 * mLo[a] && qn <= 2 * mHi[a] - 1) {
                t = tn;
                tNext[a] += tDelta[a];
                q[a] = qn;
                continue;
            }
            const double len = tn - tp;
            if (len > 0.0) {
                // The piece [tp, tn]: its lattice cell and field cell are those of q.
                double dTau = 0.0;
                if (lc.dusty) {
                    const float nm = lc.sample(oI + dI * (0.5 * (tp + tn)));
                    const float ne = lc.sample(oI + dI * tn);
                    dTau = kappa * len * (double(nPrev) + 4.0 * nm + ne) / 6.0;
                    nPrev = ne;
                } else {
                    nPrev = 0.0f; // the faces of an empty cell are empty
                }
                if (tally) {
                    const long c = long(cellIndex(fi[0], fi[1], fi[2]));
                    if (c != cell) {
                        cell = c;
                        // An unrefined block's cells share one slot.
                        const long sc = mSlot[std::size_t(c)];
                        if (sc != slot) {
                            flush(slot, acc, Y, out);
                            slot = sc;
                            if (slot >= 0) prefetchSlot(slot, out);
                        }
                    }
                }
                if (dTau > 0.0) {
                    for (int ch = 0; ch < mC; ++ch) {
                        const double xc = mCh.r[std::size_t(ch)] * dTau;
                        const double frac = oneMinusExpOverX(xc); // (1 - e^-x) / x
                        // integral of w e^-tau over the piece, in voxel lengths
                        if (slot >= 0) acc[ch] += att[ch] * frac * len * invVoxel;
                        att[ch] *= 1.0 - xc * frac;
                    }
                    pieces.push_back({tp, len, dTau / len, tau});
                    tau += dTau;
                    if (tau >= tail.tau && tail.boundary == INF) {
                        tail.boundary = tau;
                        if (tail.stop) break;
                        for (int ch = 0; ch < mC; ++ch)
                            att[ch] /= TAIL_KEEP;
                    }
                    if (mRMin * tau > TAU_CUTOFF) break;
                } else if (slot >= 0) {
                    for (int ch = 0; ch < mC; ++ch)
                        acc[ch] += att[ch] * len * invVoxel;
                }
            }
            t = tn;
            tp = tn;
            tNext[a] += tDelta[a];
            q[a] = qn;
            if (q[a] < 2 * mLo[a] || q[a] > 2 * mHi[a] - 1) break; // left the box
            fi[a] = fieldIndex(q[a], a);
            if (const int l = floorDiv2(q[a]); l != li[a]) {
                li[a] = l;
                loadCell();
            }
        }
        if (tally) flush(slot, acc, Y, out);
        return tau;
    }

    const RenderScene& mScene;
    const ChannelDust& mDust;

private:
    Channels mCh;
    int mC;                                        ///< channels per walk
    static int floorDiv2(int q) { return q >> 1; } // floor(q / 2): an arithmetic shift

    /// Field cell index (0-based) along axis @p a of half-voxel cell @p q: the cell holding
    /// level-0 coordinates [q / 2, (q + 1) / 2], i.e. floor((q + 1) / 2^(k+1)).
    int fieldIndex(int q, int a) const
    {
        const int f = (q + 1) >> mFieldShift; // floor((q + 1) / (2 mScale))
        return std::clamp(f - mFLo[a], 0, mFDims[a] - 1);
    }

    /// Starts loading slot @p slot's tallies while the flight crosses its cell: they are
    /// added to when it leaves, and the cells along a flight are far apart in memory (the
    /// walk waited on these loads a third of its time at L = 4).
    void prefetchSlot(long slot, const Tally* out) const
    {
        const std::size_t n = std::size_t(mNm) * std::size_t(mC);
        const char* p = reinterpret_cast<const char*>(out->sum + std::size_t(slot) * n);
        for (std::size_t b = 0; b < n * sizeof(std::int64_t); b += 64)
            __builtin_prefetch(p + b, 1);
        __builtin_prefetch(out->sq + slot, 1);
    }

    /// Adds the track lengths @p acc gathered in one field cell (tally slot @p slot, -1:
    /// none) times Y_lm to the tallies, and clears them.
    void flush(long slot, double* acc, const double* Y, const Tally* out) const
    {
        bool any = false;
        for (int c = 0; c < mC; ++c)
            any = any || acc[c] > 0.0;
        if (slot < 0 || !any) {
            std::fill(acc, acc + mC, 0.0);
            return;
        }
        std::int64_t* m = out->sum + std::size_t(slot) * std::size_t(mNm) * std::size_t(mC);
        for (int c = 0; c < mC; ++c)
            acc[c] *= out->invQ;
        if (out->atomic) {
            for (int k = 0; k < mNm; ++k)
                for (int c = 0; c < mC; ++c)
                    addFixed(m + k * mC + c, acc[c] * Y[k], true);
        } else if (mC == 3) { // R, G, B: the moments in a row, without a branch
            for (int k = 0; k < mNm; ++k, m += 3) {
                m[0] += roundFixed(acc[0] * Y[k]);
                m[1] += roundFixed(acc[1] * Y[k]);
                m[2] += roundFixed(acc[2] * Y[k]);
            }
        } else {
            for (int k = 0; k < mNm; ++k)
                for (int c = 0; c < mC; ++c)
                    m[k * mC + c] += roundFixed(acc[c] * Y[k]);
        }
        const double g = acc[noiseChannel()];
        addFixed(out->sq + slot, g * g * out->invQSq / (out->invQ * out->invQ), out->atomic);
        std::fill(acc, acc + mC, 0.0);
    }

    int mOrder, mNm;
    double mScale;                ///< a field cell's edge in voxels, 2^level
    int mFieldShift;              ///< log2(2 mScale)
    const SparseVolume& mDensity; ///< channel 0 of the scene's fields, in place
    Affine mW2I;
    double mVoxel = 1.0, mRmin2 = 0.0, mRMin = 1.0;
    std::array<int, 3> mLo{}, mHi{}, mFLo{}, mFDims{};
    std::vector<Vec3> mStarPos;
    /// A bit per lattice cell (lower corner's index): dust, the only cells a flight samples
    /// (the scene's column integrator's, which StarDepth shares).
    const VoxelBits& mDusty;
    std::vector<std::uint8_t> mActive;       ///< per field cell: read by the renderer
    std::vector<std::int32_t> mSlot;         ///< per field cell: its tally slot, -1 if not active
    std::size_t mSlots = 0;                  ///< tally slots
    std::vector<std::int64_t> mSlotBlock;    ///< per slot: its block, or -1 (a cell's)
    std::array<int, 3> mBLo{}, mBDims{};     ///< the block lattice (adaptive cells)
    std::vector<std::uint8_t> mBlockRefined; ///< per block: refined; empty: not adaptive
    std::vector<double> mCellDust;           ///< per field cell: n_H summed over its voxels
    std::optional<StarDepth> mDepth;         ///< with RenderOptions::exactStarDepth
    static constexpr int SKIP_BLOCK = 8;     ///< edge of the walk's skip blocks [cells]
    std::array<int, 3> mSkipDims{};          ///< skip blocks along each axis
    std::vector<std::uint8_t> mLive;         ///< per skip block: 1 if a flight works in it
};

/// Integer sums of a source's energy statistics (weights, fixed point).
struct EnergySums
{
    std::int64_t power[MAX_CHANNELS] = {}, escaped[MAX_CHANNELS] = {}, absorbed[MAX_CHANNELS] = {};
    std::atomic<std::uint64_t> flights{0};
};

/// What a source is: a set of stars (their first-scattering source), or the emission.
struct SourceSpec
{
    ScatterSource source;
    std::vector<std::size_t> stars; ///< empty: the emission
};

/// What one thread's packets reuse from packet to packet (no allocation per packet).
struct PacketScratch
{
    std::vector<Piece> pieces;  ///< the current flight's pieces with dust
    std::vector<float> fv;      ///< the scene's fields at the starting point
    std::vector<double> etaS;   ///< per star and channel: its first-scattering source there
    std::vector<double> etaSum; ///< per star: summed over channels
};

/// Follows packet @p index of @p src through every order of scattering.
void runPacket(const Transport& tr, const SourceSpec& src, const Sampler& sampler,
               std::uint64_t index, std::uint64_t seed, std::uint64_t sourceIndex,
               const Transport::Tally& tally, EnergySums& energy, PacketScratch& sc);

} // namespace nebula::detail
