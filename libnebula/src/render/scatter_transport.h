// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_transport.h
/// Internal to render/: nebscatter's Monte Carlo (DESIGN §5b) beneath computeField()
/// (scatter_field.cpp): the channels one walk carries, the sampler packets start from
/// (built in scatter_sources.cpp), the Transport every flight reads (fields, occupancy, the
/// tallies' layout; built in scatter_transport.cpp), and what scatter_packets.cpp defines:
/// runPacket(), one packet through every order of scattering, and Transport::walk(), the
/// flight walk with its spherical-harmonic track-length tally. The tallies' fixed point and
/// their sums over threads and ranks: scatter_tally.h; the adaptive cells' blocks turned
/// back into cells: scatter_reconstruct.h.

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
Sampler buildSampler(const SparseVolume& eta);

/// Everything a flight needs, shared by all packets: the scene's fields and the channels,
/// the field lattice, its active cells and their tally slots (adaptive cells: blocks of
/// 2x2x2 cells sharing one), and the flight walk's skip blocks. Built once per field
/// (scatter_transport.cpp); the flight walk, walk(), is in scatter_packets.cpp.
class Transport
{
public:
    Transport(const RenderScene& scene, const RenderOptions& ropts, const ScatterOptions& opts,
              Channels channels);

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

    /// The flight walk (scatter_packets.cpp; DESIGN §9 says why it is not BlockRay): walks
    /// the flight from world point @p x along unit @p d with channel weights @p w over the
    /// half-voxel lattice, tallies (if @p tally) the expected track length times Y_lm(d)
    /// into @p out, and records the pieces with dust; returns the V optical depth walked.
    double walk(const Vec3& x, const Vec3& d, const double* w, bool tally, const double* Y,
                const Tally* out, std::vector<Piece>& pieces, Tail& tail) const;

    const RenderScene& mScene;
    const ChannelDust& mDust;

private:
    Channels mCh;
    int mC;                                        ///< channels per walk
    static int floorDiv2(int q) { return q >> 1; } // floor(q / 2): an arithmetic shift

    /// Calls @p fn(field cell, n) for every voxel of the lattice with dust (n > 0) and the
    /// field cell holding its centre (half-voxel cells: each of the 8 cells round it, its
    /// centre being their common corner): only stored bricks hold dust.
    template <class Fn> void forEachDustVoxel(const Fn& fn) const;
    /// Adaptive cells (DESIGN §5b): a block of 2x2x2 field cells (a cell of the next level)
    /// is refined, each cell tallied on its own, where its densest voxel makes the block
    /// optically thicker than @p refineTau across (tau_V; inside it the field varies like
    /// e^-tau) or a star lies in it or in a block next to it (the field varies like 1/r
    /// there); elsewhere the block's active cells share one tally, eight times the packets
    /// per tally, and their values come from the blocks' values and slopes (reconstructCell()).
    void refineBlocks(double refineTau);
    /// The walk's empty space: per block of SKIP_BLOCK^3 lattice cells, 1 if a flight has
    /// anything to do in it (a lattice cell with dust, or a part of an active field cell);
    /// walk() jumps over the others.
    void buildLiveBlocks();
    /// The skip block of lattice cell (i, j, k) (its lower corner, absolute).
    std::size_t skipBlock(int i, int j, int k) const
    {
        return (std::size_t((k - mLo[2]) / SKIP_BLOCK) * mSkipDims[1] +
                std::size_t((j - mLo[1]) / SKIP_BLOCK)) *
                   mSkipDims[0] +
               std::size_t((i - mLo[0]) / SKIP_BLOCK);
    }

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
    void prefetchSlot(long slot, const Tally* out) const;

    /// Adds the track lengths @p acc gathered in one field cell (tally slot @p slot, -1:
    /// none) times Y_lm to the tallies, and clears them.
    void flush(long slot, double* acc, const double* Y, const Tally* out) const;

    /// The flight walk's steps (scatter_packets.cpp): where it leaves an empty skip block,
    /// and the tally slot of the field cell a piece lies in.
    double skipBlockExit(const int* li, const int* step, const Vec3& oI, const Vec3& dI, int& axis,
                         int& exitFace) const;
    void enterCell(long c, long& cell, long& slot, double* acc, const double* Y,
                   const Tally* out) const;

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

/// The sampler source @p spec's packets start from: its strength per voxel, summed over the
/// channels (eta = k_c a E_c from the stars, their first-scattering source; 4 pi j from the
/// emission, colour 1 in every channel), to buildSampler() (scatter_sources.cpp).
Sampler sourceSampler(const Transport& tr, const SourceSpec& spec);

/// Follows packet @p index of @p src through every order of scattering.
void runPacket(const Transport& tr, const SourceSpec& src, const Sampler& sampler,
               std::uint64_t index, std::uint64_t seed, std::uint64_t sourceIndex,
               const Transport::Tally& tally, EnergySums& energy, PacketScratch& sc);

} // namespace nebula::detail
