// SPDX-License-Identifier: Apache-2.0
/// @file scatter_packets.cpp
/// nebscatter's packets (DESIGN §5b): runPacket(), see scatter_transport.h.

#include "scatter_transport.h"

#include "nebula/core/rng.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"

namespace nebula::detail {

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
    std::size_t corner = 0;
    const std::size_t ci = sampler.pick(u, corner);
    const SparseVolume& f = scene.fields;
    const auto cell = f.point(corner);
    const Vec3 pI(cell[0] + rng.uniformDouble(), cell[1] + rng.uniformDouble(),
                  cell[2] + rng.uniformDouble());
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
