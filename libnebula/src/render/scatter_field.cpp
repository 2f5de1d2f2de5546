/// @file scatter_field.cpp
/// nebscatter's Monte Carlo (DESIGN §5b); see scatter_field.h.

#include "nebula/render/scatter_field.h"

#include "nebula/core/error.h"
#include "nebula/core/rng.h"
#include "nebula/core/units.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/star_depth.h"
#include "nebula/volume/block_walk.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>

namespace nebula {

Affine fieldLevelMap(const Affine& level0, int level)
{
    const double s = double(1 << level), off = 0.5 * (s - 1.0);
    Affine a;
    for (std::size_t i = 0; i < 9; ++i)
        a.m[i] = level0.m[i] * s;
    a.t = level0.apply(Vec3(off, off, off));
    return a;
}

namespace {

/// The grid's own extent along its longest axis [voxels]: the dense lattice has a one-voxel
/// zero border on each side.
int gridExtent(const RenderScene& scene)
{
    const auto& d = scene.fields.dims();
    return std::max({d[0], d[1], d[2]}) - 2;
}

/// The coarsest field level whose cells are not larger than a grid of @p extent voxels.
int coarsestFieldLevel(int extent)
{
    int k = 0;
    while ((2 << k) <= std::max(extent, 1))
        ++k;
    return k;
}

} // namespace

FieldLevelChoice autoFieldLevel(const RenderScene& scene, int order, int channels)
{
    FieldLevelChoice c;
    const auto& d = scene.fields.dims();
    const int extent = gridExtent(scene);
    // About 64 cells across: 45 to 90.
    while (double(extent) >= 64.0 * std::sqrt(2.0) * std::ldexp(1.0, c.gridLevel))
        ++c.gridLevel;
    const int coarsest = coarsestFieldLevel(extent);
    // The densest 1 % of the dust voxels.
    std::vector<float> n;
    for (std::size_t i = 0; i < scene.fields.voxelCount(); ++i)
        if (const float v = scene.fields.voxel(i)[0]; v > 0.0f) n.push_back(v);
    double n99 = 0.0;
    if (!n.empty()) {
        const auto k = std::size_t(0.99 * double(n.size() - 1));
        std::nth_element(n.begin(), n.begin() + std::ptrdiff_t(k), n.end());
        n99 = n[k];
    }
    c.voxelTau = scene.dust.kappa_V * n99 * voxelSize(scene.fields.indexToWorld);
    const auto tallyBytes = [&](int k) {
        double cells = 1.0;
        for (int a = 0; a < 3; ++a)
            cells *= double(((d[a] - 2) >> k) + 2);
        return cells * double(shCount(order)) * double(channels) * 8.0;
    };
    c.level = c.gridLevel;
    while (c.level > 0 && std::ldexp(c.voxelTau, c.level) > AUTO_FIELD_MAX_CELL_TAU &&
           tallyBytes(c.level - 1) <= AUTO_FIELD_MAX_TALLY_BYTES)
        --c.level;
    while (c.level < coarsest && tallyBytes(c.level) > AUTO_FIELD_MAX_TALLY_BYTES)
        ++c.level; // many channels (a spectral field)
    c.cellTau = std::ldexp(c.voxelTau, c.level);
    c.tallyBytes = tallyBytes(c.level);
    return c;
}

void validateScatterOptions(const RenderScene& scene, const ScatterOptions& opts)
{
    if (opts.order < 0 || opts.order > SH_MAX_DEGREE) {
        throw UsageError("--order must be in 0.." + std::to_string(SH_MAX_DEGREE) +
                         " (the degree of the spherical harmonics), got " +
                         std::to_string(opts.order));
    }
    if (opts.packets == 0 || opts.packets > MAX_PACKETS) {
        throw UsageError(fmt::format(
            "--packets must be in [1, {:g}] per source, got {} (the default 1e6 takes 15-60 s "
            "per star on 2 cores, so {:g} would take 4-17 hours and more would not finish)",
            double(MAX_PACKETS), opts.packets, double(MAX_PACKETS)));
    }
    const auto& d = scene.fields.dims();
    const int extent = gridExtent(scene);
    if (opts.fieldLevel < 0 || (1 << std::min(opts.fieldLevel, 30)) > std::max(extent, 1)) {
        throw UsageError(fmt::format(
            "--field-level {}: cells of {} voxels are larger than the grid ({}x{}x{} voxels); "
            "use a level in 0..{}",
            opts.fieldLevel, opts.fieldLevel < 31 ? std::to_string(1LL << opts.fieldLevel) : "2^k",
            d[0] - 2, d[1] - 2, d[2] - 2, coarsestFieldLevel(extent)));
    }
}

namespace {

constexpr double INF = std::numeric_limits<double>::infinity();
/// A flight stops walking once even the least dimmed channel is below e^-17 (4e-8).
constexpr double TAU_CUTOFF = 17.0;
/// Russian roulette below this channel weight (initial weights are about 1).
constexpr double ROULETTE_WEIGHT = 0.25;
constexpr std::uint64_t MAX_FLIGHTS = 1000000;

/// Fixed-point quantum 2^-e of the tallies (weight x length in voxels; weights): the
/// finest for which @p packets packets cannot overflow an int64 sum (a bound of 64 flights
/// per packet crossing a cell, weights up to 4, field cells of 2^level voxels). 2^-32 for
/// 2 million packets at level 1: a tally of 10^-6 is rounded by 2e-4 of itself.
double fixedQuantum(std::uint64_t packets, int level)
{
    const double bound = double(packets) * 64.0 * 4.0 * 2.0 * std::ldexp(1.0, level);
    const int e = std::min(40, int(std::floor(62.0 - std::log2(std::max(bound, 1.0)))));
    return std::ldexp(1.0, -e);
}

/// Adds @p scaled (a value over the quantum) to @p p, rounded to the nearest integer, as an
/// integer addition (atomic when @p atomic): the sum does not depend on the order.
inline void addFixed(std::int64_t* p, double scaled, bool atomic)
{
    // Rounded half away from zero, as llround, without its library call (a tenth of the
    // walk's time at L = 4).
    const auto q = std::int64_t(scaled + std::copysign(0.5, scaled));
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

Channels rgbChannels(const RenderScene& scene)
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
/// corner's linear index), with cumulative weights.
struct Sampler
{
    std::vector<std::uint32_t> cell;
    std::vector<float> proxy; ///< the cell's weight: mean of eta over its 8 corners
    std::vector<double> cdf;  ///< inclusive prefix sums of proxy
    double total = 0.0;
};

/// Per-voxel source strength eta (summed over channels) -> the sampler of lattice cells.
Sampler buildSampler(const DenseVolume& lattice, const std::vector<float>& eta)
{
    Sampler s;
    const auto& lo = lattice.lo();
    const auto& d = lattice.dims();
    double sum = 0.0;
    for (int k = lo[2]; k < lo[2] + d[2] - 1; ++k)
        for (int j = lo[1]; j < lo[1] + d[1] - 1; ++j)
            for (int i = lo[0]; i < lo[0] + d[0] - 1; ++i) {
                double m = 0.0;
                for (int c = 0; c < 8; ++c)
                    m += eta[lattice.index(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2))];
                if (!(m > 0.0)) continue;
                s.cell.push_back(std::uint32_t(lattice.index(i, j, k)));
                s.proxy.push_back(float(m / 8.0));
                sum += double(s.proxy.back());
                s.cdf.push_back(sum);
            }
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
          mOrder(opts.order), mNm(shCount(opts.order)), mScale(1 << opts.fieldLevel)
    {
        const DenseVolume& f = scene.fields;
        mDensity = f.channel(0);
        mW2I = f.indexToWorld.inverse();
        mVoxel = voxelSize(f.indexToWorld);
        mRmin2 = std::pow(ropts.minStarDistance * mVoxel, 2);
        for (int a = 0; a < 3; ++a) {
            mLo[a] = f.lo()[a];
            mHi[a] = f.lo()[a] + f.dims()[a] - 1;
            mFLo[a] = floorDiv(mLo[a]) - 1;
            mFDims[a] = floorDiv(mHi[a]) + 1 - mFLo[a] + 1;
        }
        mRMin = *std::min_element(mCh.r.begin(), mCh.r.end());
        // Lattice cells without dust (all 8 corners zero): nothing to sample there.
        mEmpty.assign(f.voxelCount(), 1);
        for (int k = mLo[2]; k < mHi[2]; ++k)
            for (int j = mLo[1]; j < mHi[1]; ++j)
                for (int i = mLo[0]; i < mHi[0]; ++i) {
                    bool empty = true;
                    for (int c = 0; c < 8 && empty; ++c)
                        empty = !(f.voxel(f.index(i + (c & 1), j + ((c >> 1) & 1),
                                                  k + (c >> 2)))[0] > 0.0f);
                    mEmpty[f.index(i, j, k)] = empty ? 1 : 0;
                }
        // Dust per field cell (n_H summed over its voxels), and the cells the renderer
        // reads: those holding dust and their 26 neighbours.
        mCellDust.assign(fieldCells(), 0.0);
        for (int k = mLo[2]; k <= mHi[2]; ++k)
            for (int j = mLo[1]; j <= mHi[1]; ++j)
                for (int i = mLo[0]; i <= mHi[0]; ++i) {
                    const float n = f.voxel(f.index(i, j, k))[0];
                    if (n > 0.0f)
                        mCellDust[cellIndex(floorDiv(i) - mFLo[0], floorDiv(j) - mFLo[1],
                                            floorDiv(k) - mFLo[2])] += n;
                }
        mActive.assign(fieldCells(), 0);
        for (int K = 0; K < mFDims[2]; ++K)
            for (int J = 0; J < mFDims[1]; ++J)
                for (int I = 0; I < mFDims[0]; ++I) {
                    if (!(mCellDust[cellIndex(I, J, K)] > 0.0)) continue;
                    for (int c = 0; c < 27; ++c) {
                        const int a = I + c % 3 - 1, b = J + (c / 3) % 3 - 1, e = K + c / 9 - 1;
                        if (a >= 0 && b >= 0 && e >= 0 && a < mFDims[0] && b < mFDims[1] &&
                            e < mFDims[2])
                            mActive[cellIndex(a, b, e)] = 1;
                    }
                }
        // The tallies hold only the active cells (slots in cell order).
        mSlot.assign(fieldCells(), -1);
        for (std::size_t c = 0; c < mActive.size(); ++c)
            if (mActive[c]) mSlot[c] = std::int32_t(mSlots++);
        for (const auto& s : scene.stars)
            mStarPos.emplace_back(s.position[0], s.position[1], s.position[2]);
        if (ropts.exactStarDepth) mDepth.emplace(scene);
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
    int order() const { return mOrder; }
    const std::array<int, 3>& fieldLo() const { return mFLo; }
    const std::array<int, 3>& fieldDims() const { return mFDims; }
    double voxel() const { return mVoxel; }
    double rmin2() const { return mRmin2; }
    const std::vector<Vec3>& starPos() const { return mStarPos; }
    const DenseVolume& density() const { return mDensity; }

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

    /// Field cell of level-0 index coordinate @p p along one axis.
    int floorDiv(double p) const { return int(std::floor((p + 0.5) / mScale)); }

    /// The overlap of field cell @p I with the walked box [lo, hi], in index units^3.
    double cellVolume(const std::array<int, 3>& I) const
    {
        double v = 1.0;
        for (int a = 0; a < 3; ++a) {
            const double c0 = double(mScale) * I[a] - 0.5, c1 = c0 + mScale;
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
                const Tally* out, std::vector<Piece>& pieces) const
    {
        pieces.clear();
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
        const Vec3 p0 = oI + dI * (0.5 * (ta + std::min(tb, ta + 1e-6))); // inside the box
        for (int a = 0; a < 3; ++a) {
            q[a] = std::clamp(int(std::floor(2.0 * p0[a])), 2 * mLo[a], 2 * mHi[a] - 1);
            if (dI[a] > 0.0) {
                step[a] = 1;
                tNext[a] = ((q[a] + 1) * 0.5 - oI[a]) / dI[a];
                tDelta[a] = 0.5 / dI[a];
            } else if (dI[a] < 0.0) {
                step[a] = -1;
                tNext[a] = (q[a] * 0.5 - oI[a]) / dI[a];
                tDelta[a] = -0.5 / dI[a];
            } else {
                step[a] = 0;
                tNext[a] = INF;
                tDelta[a] = INF;
            }
            li[a] = floorDiv2(q[a]);
            fi[a] = fieldIndex(q[a], a);
        }
        double t = ta, tau = 0.0;
        float nPrev = mDensity.sample0(oI + dI * ta);
        double att[MAX_CHANNELS], acc[MAX_CHANNELS];
        for (int ch = 0; ch < mC; ++ch) {
            att[ch] = w[ch]; // w_c e^-tau_c before the piece
            acc[ch] = 0.0;
        }
        long cell = -1, slot = -1; // the piece's field cell and its tally slot (-1: none)
        const double kappa = mDust.kappa_V;
        while (t < tb) {
            int a = 0;
            if (tNext[1] < tNext[a]) a = 1;
            if (tNext[2] < tNext[a]) a = 2;
            const double tn = std::min(tNext[a], tb);
            const double len = tn - t;
            if (len > 0.0) {
                // The piece's lattice cell and field cell follow its half-voxel cell q.
                double dTau = 0.0;
                if (!mEmpty[mDensity.index(li[0], li[1], li[2])]) {
                    float nm, ne;
                    mDensity.sampleChannels(oI + dI * (0.5 * (t + tn)), 0, 1, &nm);
                    mDensity.sampleChannels(oI + dI * tn, 0, 1, &ne);
                    dTau = kappa * len * (double(nPrev) + 4.0 * nm + ne) / 6.0;
                    nPrev = ne;
                } else {
                    nPrev = 0.0f; // the faces of an empty cell are empty
                }
                if (tally) {
                    const long c = long(cellIndex(fi[0], fi[1], fi[2]));
                    if (c != cell) {
                        flush(slot, acc, Y, out);
                        cell = c;
                        slot = mSlot[std::size_t(c)];
                        if (slot >= 0) prefetchSlot(slot, out);
                    }
                }
                if (dTau > 0.0) {
                    for (int ch = 0; ch < mC; ++ch) {
                        const double xc = mCh.r[std::size_t(ch)] * dTau;
                        const double em1 = -std::expm1(-xc); // 1 - e^-x
                        if (slot >= 0) {
                            // integral of w e^-tau over the piece, in voxel lengths
                            const double frac = xc > 1e-9 ? em1 / xc : 1.0 - 0.5 * xc;
                            acc[ch] += att[ch] * frac * len / mVoxel;
                        }
                        att[ch] *= 1.0 - em1;
                    }
                    pieces.push_back({t, len, dTau / len, tau});
                    tau += dTau;
                    if (mRMin * tau > TAU_CUTOFF) break;
                } else if (slot >= 0) {
                    for (int ch = 0; ch < mC; ++ch)
                        acc[ch] += att[ch] * len / mVoxel;
                }
            }
            t = tn;
            tNext[a] += tDelta[a];
            q[a] += step[a];
            if (q[a] < 2 * mLo[a] || q[a] > 2 * mHi[a] - 1) break; // left the box
            li[a] = floorDiv2(q[a]);
            fi[a] = fieldIndex(q[a], a);
        }
        if (tally) flush(slot, acc, Y, out);
        return tau;
    }

    const RenderScene& mScene;
    const ChannelDust& mDust;

private:
    Channels mCh;
    int mC; ///< channels per walk
    static int floorDiv2(int q) { return q >= 0 ? q / 2 : -((1 - q) / 2); }

    /// Field cell index (0-based) along axis @p a of half-voxel cell @p q: the cell holding
    /// level-0 coordinates [q / 2, (q + 1) / 2], i.e. floor((q + 1) / 2^(k+1)).
    int fieldIndex(int q, int a) const
    {
        const int n = q + 1, d = 2 * mScale;
        const int f = n >= 0 ? n / d : -((d - 1 - n) / d);
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
        for (int k = 0; k < mNm; ++k)
            for (int c = 0; c < mC; ++c)
                addFixed(m + k * mC + c, acc[c] * Y[k], out->atomic);
        const double g = acc[noiseChannel()];
        addFixed(out->sq + slot, g * g * out->invQSq / (out->invQ * out->invQ), out->atomic);
        std::fill(acc, acc + mC, 0.0);
    }

    int mOrder, mNm, mScale;
    DenseVolume mDensity;
    Affine mW2I;
    double mVoxel = 1.0, mRmin2 = 0.0, mRMin = 1.0;
    std::array<int, 3> mLo{}, mHi{}, mFLo{}, mFDims{};
    std::vector<Vec3> mStarPos;
    std::vector<std::uint8_t> mEmpty;  ///< per lattice cell (lower corner's index): no dust
    std::vector<std::uint8_t> mActive; ///< per field cell: read by the renderer
    std::vector<std::int32_t> mSlot;   ///< per field cell: its tally slot, -1 if not active
    std::size_t mSlots = 0;            ///< active cells
    std::vector<double> mCellDust;     ///< per field cell: n_H summed over its voxels
    std::optional<StarDepth> mDepth;   ///< with RenderOptions::exactStarDepth
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
    std::string name;
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
               const Transport::Tally& tally, EnergySums& energy, PacketScratch& sc)
{
    std::vector<Piece>& pieces = sc.pieces;
    std::vector<double>& etaS = sc.etaS;
    std::vector<double>& etaSum = sc.etaSum;
    std::vector<float>& fv = sc.fv;
    const RenderScene& scene = tr.mScene;
    const ChannelDust& dust = tr.mDust;
    Pcg32 rng(index, seed ^ (0x9E3779B97F4A7C15ULL * (sourceIndex + 1)));
    // The starting cell and point.
    const double u = rng.uniformDouble() * sampler.total;
    auto it = std::upper_bound(sampler.cdf.begin(), sampler.cdf.end(), u);
    if (it == sampler.cdf.end()) --it;
    const std::size_t ci = std::size_t(it - sampler.cdf.begin());
    const DenseVolume& f = scene.fields;
    std::size_t lin = sampler.cell[ci];
    const auto& lo = f.lo();
    const auto& dims = f.dims();
    const int i = int(lin % std::size_t(dims[0])) + lo[0];
    lin /= std::size_t(dims[0]);
    const int j = int(lin % std::size_t(dims[1])) + lo[1];
    const int k = int(lin / std::size_t(dims[1])) + lo[2];
    const Vec3 pI(i + rng.uniformDouble(), j + rng.uniformDouble(), k + rng.uniformDouble());
    Vec3 x = f.indexToWorld.apply(pI);
    fv.resize(std::size_t(f.channels()));
    f.sample(pI, fv.data());
    tr.starDepths(pI, fv.data());
    const int C = tr.channels();
    const double norm = C / double(sampler.proxy[ci]); // w_c = C eta_c(x) / proxy(cell)
    double w[MAX_CHANNELS];
    Vec3 d;
    const bool fromStars = !src.stars.empty();
    if (fromStars) {
        // eta_{s,c} = k_c a E_{s,c}; the star is drawn in proportion to its eta, the
        // direction from its phase function; the weight is the mixture's exact ratio.
        const std::size_t S = src.stars.size();
        etaS.assign(S * std::size_t(C), 0.0);
        double etaTot = 0.0;
        etaSum.assign(S, 0.0);
        const double n = fv[0];
        for (std::size_t q = 0; q < S; ++q) {
            const std::size_t s = src.stars[q];
            const Vec3 v = x - tr.starPos()[s];
            double* eq = &etaS[q * std::size_t(C)];
            tr.firstScatteringSource(s, n, std::max(v.dot(v), tr.rmin2()), double(fv[2 + s]), eq);
            etaSum[q] = eq[0];
            for (int c = 1; c < C; ++c)
                etaSum[q] += eq[c];
            etaTot += etaSum[q];
        }
        if (!(etaTot > 0.0)) return;
        double pick = rng.uniformDouble() * etaTot;
        std::size_t chosen = 0;
        while (chosen + 1 < S && pick >= etaSum[chosen]) {
            pick -= etaSum[chosen];
            ++chosen;
        }
        const Vec3 from = x - tr.starPos()[src.stars[chosen]];
        const double r = from.length();
        const Vec3 in = r > 0.0 ? from * (1.0 / r) : Vec3(0, 0, 1);
        const double mu = samplePhaseCosine(dust.phase, dust.g, rng.uniformDouble());
        const double inA[3] = {in.x, in.y, in.z};
        double out[3];
        sampleDirection(mu, 2.0 * PI * rng.uniformDouble(), inA, out);
        d = Vec3(out[0], out[1], out[2]).normalized();
        if (S == 1) {
            for (int c = 0; c < C; ++c)
                w[c] = norm * etaS[std::size_t(c)];
        } else {
            double num[MAX_CHANNELS] = {}, den = 0.0;
            for (std::size_t q = 0; q < S; ++q) {
                const Vec3 fq = x - tr.starPos()[src.stars[q]];
                const double rq = fq.length();
                const double p = phaseFunction(dust.phase, rq > 0.0 ? fq.dot(d) / rq : 1.0, dust.g);
                for (int c = 0; c < C; ++c)
                    num[c] += etaS[q * std::size_t(C) + std::size_t(c)] * p;
                den += etaSum[q] / etaTot * p;
            }
            for (int c = 0; c < C; ++c)
                w[c] = den > 0.0 ? norm * num[c] / den : 0.0;
        }
        for (int c = 0; c < C; ++c)
            addFixed(&energy.power[c], w[c] * tally.invQ, true);
    } else {
        const double e = 4.0 * PI * double(fv[1]);
        for (int c = 0; c < C; ++c)
            w[c] = norm * e;
        const double mu = 2.0 * rng.uniformDouble() - 1.0;
        const double phi = 2.0 * PI * rng.uniformDouble();
        const double st = std::sqrt(std::max(0.0, 1.0 - mu * mu));
        d = Vec3(st * std::cos(phi), st * std::sin(phi), mu);
    }
    bool any = false;
    for (int c = 0; c < C; ++c)
        any = any || w[c] > 0.0;
    if (!any) return;

    bool tallyOn = fromStars; // the emission's first flight is uncollided light
    double Y[shCount(SH_MAX_DEGREE)];
    double esc[MAX_CHANNELS] = {}, abs_[MAX_CHANNELS] = {}, pow_[MAX_CHANNELS] = {};
    const std::vector<double>& r = tr.channelSet().r;
    std::uint64_t flights = 0;
    for (; flights < MAX_FLIGHTS; ++flights) {
        if (tallyOn) realSphericalHarmonics(d, tr.order(), Y);
        const double tau = tr.walk(x, d, w, tallyOn, Y, &tally, pieces);
        double oneMinusT[MAX_CHANNELS];
        for (int c = 0; c < C; ++c) {
            oneMinusT[c] = -std::expm1(-r[std::size_t(c)] * tau);
            if (tallyOn) {
                esc[c] += w[c] * (1.0 - oneMinusT[c]);
                abs_[c] += w[c] * oneMinusT[c] * (1.0 - dust.albedo);
            } else {
                pow_[c] += w[c] * oneMinusT[c] * dust.albedo; // becomes collided light
            }
        }
        if (pieces.empty() || !(tau > 0.0)) break;
        // Collide inside the walked part for certain: a channel at random, a V optical
        // depth from its truncated exponential, the mixture's pdf for the weights.
        const int cs = std::min(C - 1, int(double(C) * rng.uniformDouble()));
        const double target = -std::log1p(-rng.uniformDouble() * oneMinusT[cs]) /
                              r[std::size_t(cs)]; // V optical depth
        auto pit = std::upper_bound(pieces.begin(), pieces.end(), target,
                                    [](double v, const Piece& p) { return v < p.tau0; });
        const Piece& pc = *(pit == pieces.begin() ? pit : pit - 1);
        const double s = pc.t + std::min(pc.len, std::max(0.0, (target - pc.tau0) / pc.k));
        double fc[MAX_CHANNELS], pdf = 0.0;
        for (int c = 0; c < C; ++c) {
            fc[c] = r[std::size_t(c)] * pc.k * std::exp(-r[std::size_t(c)] * target);
            pdf += fc[c] / oneMinusT[c] / double(C);
        }
        if (!(pdf > 0.0)) break;
        for (int c = 0; c < C; ++c)
            w[c] *= dust.albedo * fc[c] / pdf;
        x = x + d * s;
        tallyOn = true;
        const double mu = samplePhaseCosine(dust.phase, dust.g, rng.uniformDouble());
        const double inA[3] = {d.x, d.y, d.z};
        double out[3];
        sampleDirection(mu, 2.0 * PI * rng.uniformDouble(), inA, out);
        d = Vec3(out[0], out[1], out[2]).normalized();
        const double wmax = *std::max_element(w, w + C);
        if (!(wmax > 0.0)) break;
        if (wmax < ROULETTE_WEIGHT) {
            const double q = wmax / ROULETTE_WEIGHT;
            if (rng.uniformDouble() >= q) break;
            for (int c = 0; c < C; ++c)
                w[c] /= q;
        }
    }
    for (int c = 0; c < C; ++c) {
        addFixed(&energy.escaped[c], esc[c] * tally.invQ, true);
        addFixed(&energy.absorbed[c], abs_[c] * tally.invQ, true);
        if (!fromStars) addFixed(&energy.power[c], pow_[c] * tally.invQ, true);
    }
    energy.flights.fetch_add(flights + 1, std::memory_order_relaxed);
}

} // namespace

namespace {

/// computeScatterField() for the channels @p channels (R, G, B or a spectral field's
/// wavelengths): one walk carries them all.
ScatterField computeField(const RenderScene& scene, const RenderOptions& ropts,
                          const ScatterOptions& opts, Channels channels, const Run* run)
{
    validateScatterOptions(scene, opts);
    const Transport tr(scene, ropts, opts, std::move(channels));
    const int C = tr.channels();
    const std::size_t UC = std::size_t(C);
    const DenseVolume& f = scene.fields;
    const std::size_t S = scene.stars.size();
    const double detA = std::pow(voxelSize(f.indexToWorld), 3); // world volume of a voxel

    std::vector<SourceSpec> specs;
    if (opts.perStar) {
        for (std::size_t s = 0; s < S; ++s)
            specs.push_back({"star_" + scene.stars[s].name, {s}});
    } else if (S > 0) {
        SourceSpec all{"stars", {}};
        for (std::size_t s = 0; s < S; ++s)
            all.stars.push_back(s);
        specs.push_back(all);
    }
    bool hasEmission = false;
    for (std::size_t i = 0; i < f.voxelCount() && !hasEmission; ++i)
        hasEmission = f.voxel(i)[1] > 0.0f;
    if (opts.emission && hasEmission) specs.push_back({"emission", {}});

    ScatterField field;
    field.order = opts.order;
    field.level = opts.fieldLevel;
    const auto& fLo = tr.fieldLo();
    const auto& fDims = tr.fieldDims();
    const int nm = tr.moments();
    const Affine fieldMap = fieldLevelMap(f.indexToWorld, opts.fieldLevel);
    const double rmin2 = tr.rmin2();

    field.active = tr.active();
    const std::vector<double>& cellDust = tr.cellDust(); // the noise report's weights

    for (std::size_t si = 0; si < specs.size(); ++si) {
        const SourceSpec& spec = specs[si];
        // Source strength per voxel, summed over channels: eta = k_c a E_c (stars) or
        // 4 pi j (emission, colour 1 in every channel).
        std::vector<float> eta(f.voxelCount(), 0.0f);
        for (int k = f.lo()[2]; k < f.lo()[2] + f.dims()[2]; ++k)
            for (int j = f.lo()[1]; j < f.lo()[1] + f.dims()[1]; ++j)
                for (int i = f.lo()[0]; i < f.lo()[0] + f.dims()[0]; ++i) {
                    const std::size_t v = f.index(i, j, k);
                    const float* fv = f.voxel(v);
                    double e = 0.0;
                    if (spec.stars.empty()) {
                        e = double(C) * 4.0 * PI * double(fv[1]);
                    } else if (fv[0] > 0.0f) {
                        const Vec3 xw = f.indexToWorld.apply(Vec3(i, j, k));
                        for (const std::size_t s : spec.stars) {
                            const Vec3 dv = xw - tr.starPos()[s];
                            double es[MAX_CHANNELS];
                            tr.firstScatteringSource(s, fv[0], std::max(dv.dot(dv), rmin2),
                                                     double(fv[2 + s]), es);
                            for (int c = 0; c < C; ++c)
                                e += es[c];
                        }
                    }
                    eta[v] = float(e);
                }
        const Sampler sampler = buildSampler(f, eta);
        eta = {};

        ScatterSourceField out;
        out.name = spec.name;
        out.packets = opts.packets;
        out.power.assign(UC, 0.0);
        out.escaped.assign(UC, 0.0);
        out.absorbed.assign(UC, 0.0);
        out.moments = DenseVolume(fLo, fDims, nm * C);
        out.moments.indexToWorld = fieldMap;
        if (sampler.total > 0.0) {
            // Integer sums: per-thread buffers added at the end, or one shared buffer with
            // atomic additions; the same sums either way, whatever the threads.
            const double quantum = fixedQuantum(opts.packets, opts.fieldLevel);
            const std::size_t slots = tr.slotCount();
            const std::size_t sumSize = slots * std::size_t(nm) * UC;
            const double bytes =
                double(sumSize + slots) * 8.0 * double(tbb::this_task_arena::max_concurrency() + 1);
            const bool perThread = bytes <= opts.perThreadTallyBytes;
            std::vector<std::int64_t> sumAll(sumSize, 0), sqAll(slots, 0);
            tbb::enumerable_thread_specific<
                std::pair<std::vector<std::int64_t>, std::vector<std::int64_t>>>
                local;
            Transport::Tally shared;
            shared.sum = sumAll.data();
            shared.sq = sqAll.data();
            shared.atomic = true;
            shared.invQ = 1.0 / quantum;
            shared.invQSq = 1.0 / (quantum * 256.0);
            EnergySums energy;
            {
                Progress bar(run, "nebscatter " + spec.name, opts.packets);
                tbb::parallel_for(tbb::blocked_range<std::uint64_t>(0, opts.packets, 4096),
                                  [&](const tbb::blocked_range<std::uint64_t>& r) {
                                      Transport::Tally tally = shared;
                                      if (perThread) {
                                          auto& buf = local.local();
                                          if (buf.first.empty()) {
                                              buf.first.assign(sumSize, 0);
                                              buf.second.assign(slots, 0);
                                          }
                                          tally.sum = buf.first.data();
                                          tally.sq = buf.second.data();
                                          tally.atomic = false;
                                      }
                                      PacketScratch scratch;
                                      scratch.pieces.reserve(1024);
                                      for (std::uint64_t p = r.begin(); p != r.end(); ++p)
                                          runPacket(tr, spec, sampler, p, opts.seed, si, tally,
                                                    energy, scratch);
                                      bar.add(r.size());
                                  });
            }
            for (const auto& buf : local) {
                for (std::size_t i = 0; i < sumSize; ++i)
                    sumAll[i] += buf.first[i];
                for (std::size_t i = 0; i < slots; ++i)
                    sqAll[i] += buf.second[i];
            }
            // Unit of the weights: the source's power over C N (w_c is about 1).
            const double U = sampler.total * detA / (double(C) * double(opts.packets));
            for (int c = 0; c < C; ++c) {
                out.power[c] = double(energy.power[c]) * quantum * U;
                out.escaped[c] = double(energy.escaped[c]) * quantum * U;
                out.absorbed[c] = double(energy.absorbed[c]) * quantum * U;
            }
            out.flights = energy.flights.load();
            // c_lm = sum (w U) (length) Y_lm / V over the cell.
            double errW = 0.0, errSum = 0.0;
            for (int K = 0; K < fDims[2]; ++K)
                for (int J = 0; J < fDims[1]; ++J)
                    for (int I = 0; I < fDims[0]; ++I) {
                        const std::size_t c = (std::size_t(K) * fDims[1] + J) * fDims[0] + I;
                        const double vol =
                            tr.cellVolume({I + fLo[0], J + fLo[1], K + fLo[2]}) * detA;
                        const std::int32_t slot = tr.slots()[c];
                        if (!(vol > 0.0) || slot < 0) continue; // not active: stays 0
                        const double scale = quantum * U * tr.voxel() / vol;
                        float* m = out.moments.voxel(c);
                        const std::int64_t* t =
                            sumAll.data() + std::size_t(slot) * std::size_t(nm) * UC;
                        for (int q = 0; q < nm * C; ++q)
                            m[q] = float(double(t[q]) * scale);
                        const double s1 = double(t[tr.noiseChannel()]) * quantum;
                        if (cellDust[c] > 0.0 && s1 > 0.0) {
                            // Y_00 folded out: the noise channel's J tally is t[c] / Y_00.
                            const double sq = double(sqAll[std::size_t(slot)]) * quantum * 256.0;
                            const double rel = std::sqrt(sq) / (s1 / (0.5 / std::sqrt(PI)));
                            const double wgt = cellDust[c] * s1 / vol;
                            errW += wgt;
                            errSum += wgt * rel;
                        }
                    }
            out.relativeError = errW > 0.0 ? errSum / errW : 0.0;
            // The border cells (outside the walked box) copy their nearest cell, so the
            // trilinear field does not fall towards zero at the grid's edge.
            for (int K = 0; K < fDims[2]; ++K)
                for (int J = 0; J < fDims[1]; ++J)
                    for (int I = 0; I < fDims[0]; ++I) {
                        const int I2 = std::clamp(I, 1, fDims[0] - 2);
                        const int J2 = std::clamp(J, 1, fDims[1] - 2);
                        const int K2 = std::clamp(K, 1, fDims[2] - 2);
                        if (I2 == I && J2 == J && K2 == K) continue;
                        const float* src = out.moments.voxel(
                            out.moments.index(I2 + fLo[0], J2 + fLo[1], K2 + fLo[2]));
                        float* dst = out.moments.voxel(
                            out.moments.index(I + fLo[0], J + fLo[1], K + fLo[2]));
                        std::copy(src, src + nm * C, dst);
                    }
        }
        if (run) {
            // R, G, B; a spectral field: its first, middle and last wavelengths.
            const std::size_t a = 0, b = std::size_t(tr.noiseChannel()), e = UC - 1;
            const auto& wl = tr.channelSet().wavelengths;
            const std::string which =
                wl.empty() ? std::string("R,G,B")
                           : fmt::format("at {:g}, {:g}, {:g} nm", wl[a], wl[b], wl[e]);
            run->info(fmt::format(
                "{}: {} packets, {} flights ({:.3g} per packet); collided power {} {:.4g} "
                "{:.4g} {:.4g} L_sun{}: escaped {:.4g} {:.4g} {:.4g}, absorbed {:.4g} {:.4g} "
                "{:.4g}; noise of J {:.2g} % (mean relative standard error per field cell, "
                "weighted by its scattered light)",
                out.name, out.packets, out.flights, double(out.flights) / double(out.packets),
                which, out.power[a], out.power[b], out.power[e], wl.empty() ? "" : " nm^-1",
                out.escaped[a], out.escaped[b], out.escaped[e], out.absorbed[a], out.absorbed[b],
                out.absorbed[e], 100.0 * out.relativeError));
        }
        field.sources.push_back(std::move(out));
    }
    return field;
}

} // namespace

ScatterField computeScatterField(const RenderScene& scene, const RenderOptions& ropts,
                                 const ScatterOptions& opts, const Run* run)
{
    return computeField(scene, ropts, opts, rgbChannels(scene), run);
}

void addScatterMoments(DenseVolume& total, const DenseVolume& src,
                       const std::vector<double>& factor, double c00Factor)
{
    const std::size_t C = std::size_t(src.channels());
    const std::size_t per = factor.size(); // channels per moment: it divides C
    const auto& a = src.data();
    auto& b = total.data();
    for (std::size_t i = 0; i < a.size(); ++i) {
        const std::size_t q = i % C; // k * per + c
        b[i] += float(factor[q % per] * a[i] * (q < per ? c00Factor : 1.0));
    }
}

std::vector<double> spectralFieldWavelengths(int n)
{
    if (n < 2) {
        throw UsageError("a spectral field needs at least 2 wavelengths, got " + std::to_string(n));
    }
    std::vector<double> wl;
    for (int i = 0; i < n; ++i)
        wl.push_back(SPECTRAL_FIELD_MIN_NM +
                     (SPECTRAL_FIELD_MAX_NM - SPECTRAL_FIELD_MIN_NM) * i / double(n - 1));
    return wl;
}

double starSpectralPower(const Star& star, double lambda_nm)
{
    // Y of the unit black body: the spectrum linear between 1 nm nodes against the CMFs.
    constexpr int NODES = 471; // 360..830 nm
    static const std::vector<XYZ> weights = hatWeights(360.0, 1.0, NODES);
    double Y = 0.0;
    for (int j = 0; j < NODES; ++j)
        Y += weights[std::size_t(j)][1] * planckPerNm(360.0 + j, star.temperature);
    return star.luminosity * planckPerNm(lambda_nm, star.temperature) / Y;
}

ScatterField computeSpectralScatterField(const RenderScene& scene, const RenderOptions& ropts,
                                         const ScatterOptions& opts,
                                         const std::vector<double>& wavelengths, const Run* run)
{
    const std::size_t N = wavelengths.size();
    if (N < 2 || N > SPECTRAL_FIELD_MAX_WAVELENGTHS) {
        throw UsageError(fmt::format("a spectral field has 2..{} wavelengths, got {}",
                                     SPECTRAL_FIELD_MAX_WAVELENGTHS, N));
    }
    Channels ch;
    ch.wavelengths = wavelengths;
    for (const double lam : wavelengths) {
        try {
            ch.r.push_back(extinctionRatio(scene.dust, lam));
        } catch (const Error& e) {
            throw UsageError("spectral field: " + std::string(e.what()));
        }
    }
    for (const auto& star : scene.stars) {
        ch.starPower.emplace_back();
        for (const double lam : wavelengths)
            ch.starPower.back().push_back(starSpectralPower(star, lam));
    }
    ScatterOptions o = opts;
    o.emission = false; // the spectral renderer does not scatter the gas's glow
    ScatterField field = computeField(scene, ropts, o, std::move(ch), run);
    field.wavelengths = wavelengths;
    return field;
}

ScatterField spectralFieldSubset(const ScatterField& field, std::size_t stride)
{
    ScatterField sub = field;
    const std::size_t N = field.wavelengths.size();
    std::vector<std::size_t> keep;
    sub.wavelengths.clear();
    for (std::size_t i = 0; i < N; i += std::max<std::size_t>(stride, 1)) {
        keep.push_back(i);
        sub.wavelengths.push_back(field.wavelengths[i]);
    }
    const int nm = shCount(field.order);
    for (std::size_t si = 0; si < field.sources.size(); ++si) {
        const DenseVolume& a = field.sources[si].moments;
        DenseVolume b(a.lo(), a.dims(), nm * int(keep.size()));
        b.indexToWorld = a.indexToWorld;
        for (std::size_t v = 0; v < a.voxelCount(); ++v)
            for (int k = 0; k < nm; ++k)
                for (std::size_t i = 0; i < keep.size(); ++i)
                    b.voxel(v)[std::size_t(k) * keep.size() + i] =
                        a.voxel(v)[std::size_t(k) * N + keep[i]];
        ScatterSourceField& out = sub.sources[si];
        out.moments = std::move(b);
        for (auto* per : {&out.power, &out.escaped, &out.absorbed}) {
            std::vector<double> kept;
            for (const std::size_t i : keep)
                kept.push_back((*per)[i]);
            *per = std::move(kept);
        }
    }
    return sub;
}

SceneScatterField sceneScatterField(const ScatterField& field, const RenderOptions& opts)
{
    SceneScatterField out;
    if (field.sources.empty()) return out;
    out.order = field.order;
    out.level = field.level;
    out.wavelengths = field.wavelengths;
    out.moments = field.sources[0].moments;
    std::fill(out.moments.data().begin(), out.moments.data().end(), 0.0f);
    for (const auto& src : field.sources) {
        std::vector<double> factor(field.wavelengths.empty() ? 3 : field.wavelengths.size(), 1.0);
        if (src.name == "emission" && field.wavelengths.empty()) {
            for (std::size_t c = 0; c < 3; ++c)
                factor[c] = opts.emissionScale * opts.emissionColor[c];
        }
        addScatterMoments(out.moments, src.moments, factor);
    }
    out.description = "scattered-light field (in memory)";
    return out;
}

} // namespace nebula
