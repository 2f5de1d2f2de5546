// SPDX-License-Identifier: Apache-2.0
/// @file scatter_packets.cpp
/// nebscatter's packets (DESIGN §5b), see scatter_transport.h: the flight walk
/// (Transport::walk(), one straight flight over the half-voxel lattice with its track-length
/// tallies) and runPacket() (one packet through every order of scattering), in one unit so
/// the walk stays next to its one caller.

#include "scatter_tally.h"
#include "scatter_transport.h"

#include "nebula/core/rng.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"

namespace nebula::detail {

namespace {

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

} // namespace

/// Starts loading slot @p slot's tallies while the flight crosses its cell: they are
/// added to when it leaves, and the cells along a flight are far apart in memory (the
/// walk waited on these loads a third of its time at L = 4).
inline void Transport::prefetchSlot(long slot, const Tally* out) const
{
    const std::size_t n = std::size_t(mNm) * std::size_t(mC);
    const char* p = reinterpret_cast<const char*>(out->sum + std::size_t(slot) * n);
    for (std::size_t b = 0; b < n * sizeof(std::int64_t); b += 64)
        __builtin_prefetch(p + b, 1);
    __builtin_prefetch(out->sq + slot, 1);
}

/// Adds the track lengths @p acc gathered in one field cell (tally slot @p slot, -1:
/// none) times Y_lm to the tallies, and clears them.
inline void Transport::flush(long slot, double* acc, const double* Y, const Tally* out) const
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

/// The flight walk's skip block holding lattice cell @p li: the distance at which the ray
/// (index-space origin @p oI, direction @p dI, its signs @p step) leaves it (INF if it is
/// parallel to every face), the axis of the face it leaves by and that face's coordinate.
inline double Transport::skipBlockExit(const int* li, const int* step, const Vec3& oI,
                                       const Vec3& dI, int& axis, int& exitFace) const
{
    double tExit = INF;
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
    return tExit;
}

/// A piece in field cell @p c (linear index): where the flight enters another tally slot,
/// the track lengths @p acc gathered in the old one go to its tallies (flush()) and the new
/// one's are prefetched. @p cell, @p slot: the previous piece's cell and slot (-1: none).
inline void Transport::enterCell(long c, long& cell, long& slot, double* acc, const double* Y,
                                 const Tally* out) const
{
    if (c == cell) return;
    cell = c;
    // An unrefined block's cells share one slot.
    const long sc = mSlot[std::size_t(c)];
    if (sc == slot) return;
    flush(slot, acc, Y, out);
    slot = sc;
    if (slot >= 0) prefetchSlot(slot, out);
}

/// The flight walk (DESIGN §5b "Flights"; §9 says why it is not BlockRay's steps): from world
/// point @p x along unit @p d with channel weights @p w, pieces each inside one lattice cell
/// and one field cell; tallies (if @p tally) the expected track length times Y_lm(d) into
/// @p out, and records the pieces with dust; returns the V optical depth walked.
inline double Transport::walk(const Vec3& x, const Vec3& d, const double* w, bool tally,
                              const double* Y, const Tally* out, std::vector<Piece>& pieces,
                              Tail& tail) const
{
    pieces.clear();
    tail.boundary = INF;
    // The flight's part inside the lattice box, clipped by BlockRay (its blocks
    // are the skip blocks); within it, the walk steps over half-voxel cells itself.
    const BlockRay ray(mDensity, mW2I, mSkipDims, x, d);
    if (!ray.hits()) return 0.0;
    const Vec3 &oI = ray.oI, &dI = ray.dI;
    const double ta = ray.t0, tb = ray.t1;
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
        int axis = 0, exitFace = 0;
        const double tExit = skipBlockExit(li, step, oI, dI, axis, exitFace);
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
        if (tn < tb && floorDiv2(qn) == li[a] && fieldIndex(qn, a) == fi[a] && qn >= 2 * mLo[a] &&
            qn <= 2 * mHi[a] - 1) {
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
            if (tally) enterCell(long(cellIndex(fi[0], fi[1], fi[2])), cell, slot, acc, Y, out);
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

namespace {

/// A packet from the stars at world point @p x (the fields there @p fv): a star drawn in
/// proportion to its first-scattering source there, a direction @p d from the phase function
/// about its light, and the channel weights @p w (the mixture's exact ratio times @p norm).
/// False where no star lights the point.
bool startFromStars(const Transport& tr, const SourceSpec& src, const Vec3& x,
                    const std::vector<float>& fv, double norm, Pcg32& rng, PacketScratch& sc,
                    Vec3& d, double* w)
{
    std::vector<double>& etaS = sc.etaS;
    std::vector<double>& etaSum = sc.etaSum;
    const ChannelDust& dust = tr.mDust;
    const int C = tr.channels();
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
    if (!(etaTot > 0.0)) return false;
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
    return true;
}

/// Where packet @p rng's journey starts (DESIGN §5b "Sources"): a lattice cell drawn from
/// @p sampler, a point uniform in it (@p x), a direction @p d and the channel weights @p w;
/// the stars' first-scattered power goes to @p energy. False where the packet carries nothing.
bool startPacket(const Transport& tr, const SourceSpec& src, const Sampler& sampler, Pcg32& rng,
                 const Transport::Tally& tally, EnergySums& energy, PacketScratch& sc, Vec3& x,
                 Vec3& d, double* w)
{
    std::vector<float>& fv = sc.fv;
    // The starting cell and point.
    const double u = rng.uniformDouble() * sampler.total;
    std::size_t corner = 0;
    const std::size_t ci = sampler.pick(u, corner);
    const SparseVolume& f = tr.mScene.fields;
    const auto cell = f.point(corner);
    const Vec3 pI(cell[0] + rng.uniformDouble(), cell[1] + rng.uniformDouble(),
                  cell[2] + rng.uniformDouble());
    x = f.indexToWorld.apply(pI);
    fv.resize(std::size_t(f.channels()));
    f.sample(pI, fv.data());
    tr.starDepths(pI, fv.data());
    const int C = tr.channels();
    const double norm = C / double(sampler.proxy[ci]); // w_c = C eta_c(x) / proxy(cell)
    if (!src.stars.empty()) {
        if (!startFromStars(tr, src, x, fv, norm, rng, sc, d, w)) return false;
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
    return any;
}

} // namespace

/// Follows packet @p index of @p src through every order of scattering.
void runPacket(const Transport& tr, const SourceSpec& src, const Sampler& sampler,
               std::uint64_t index, std::uint64_t seed, std::uint64_t sourceIndex,
               const Transport::Tally& tally, EnergySums& energy, PacketScratch& sc)
{
    std::vector<Piece>& pieces = sc.pieces;
    const ChannelDust& dust = tr.mDust;
    Pcg32 rng(index, seed ^ (0x9E3779B97F4A7C15ULL * (sourceIndex + 1)));
    Vec3 x, d;
    double w[MAX_CHANNELS];
    if (!startPacket(tr, src, sampler, rng, tally, energy, sc, x, d, w)) return;
    const int C = tr.channels();
    const bool fromStars = !src.stars.empty();

    bool tallyOn = fromStars; // the emission's first flight is uncollided light
    double Y[shCount(SH_MAX_DEGREE)];
    double esc[MAX_CHANNELS] = {}, abs_[MAX_CHANNELS] = {}, pow_[MAX_CHANNELS] = {};
    const std::vector<double>& r = tr.channelSet().r;
    std::uint64_t flights = 0;
    for (; flights < MAX_FLIGHTS; ++flights) {
        if (tallyOn) realSphericalHarmonics(d, tr.order(), Y);
        Tail tail;
        tail.tau = tr.tailTau();
        tail.stop = rng.uniformDouble() >= TAIL_KEEP;
        const double tau = tr.walk(x, d, w, tallyOn, Y, &tally, pieces, tail);
        // The tail's weight (1 / TAIL_KEEP where the flight went on past its start, 0 where
        // it stopped there) in what the flight's light does: collides (interacts) or escapes.
        const bool inTail = tail.boundary < INF, went = inTail && !tail.stop;
        double oneMinusT[MAX_CHANNELS];
        for (int c = 0; c < C; ++c) {
            oneMinusT[c] = -std::expm1(-r[std::size_t(c)] * tau);
            double interacts = oneMinusT[c], escapes = inTail ? 0.0 : 1.0 - oneMinusT[c];
            if (went) {
                const double tb = std::exp(-r[std::size_t(c)] * tail.boundary);
                interacts = (1.0 - tb) + (oneMinusT[c] - (1.0 - tb)) / TAIL_KEEP;
                escapes = (1.0 - oneMinusT[c]) / TAIL_KEEP;
            }
            if (tallyOn) {
                esc[c] += w[c] * escapes;
                abs_[c] += w[c] * interacts * (1.0 - dust.albedo);
            } else {
                pow_[c] += w[c] * interacts * dust.albedo; // becomes collided light
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
        const double tailWeight = went && target > tail.boundary ? 1.0 / TAIL_KEEP : 1.0;
        for (int c = 0; c < C; ++c)
            w[c] *= dust.albedo * fc[c] / pdf * tailWeight;
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

} // namespace nebula::detail
