// SPDX-License-Identifier: Apache-2.0
/// @file montecarlo.cpp
/// Monte Carlo transport in a slab and a cube (DESIGN §4); see montecarlo.h.

#include "nebula/physics/montecarlo.h"

#include "nebula/core/format.h"

#include "nebula/core/error.h"
#include "nebula/core/rng.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nebula {

namespace {

using detail::numberText;

constexpr double INF = std::numeric_limits<double>::infinity();
constexpr std::uint64_t GRAIN = 1024; ///< photons per leaf of the deterministic reduction

/// Slab z in [0, tau], infinite in x and y; beam along (sqrt(1 - mu0^2), 0, mu0).
struct SlabGeometry
{
    double tau;
    double mu0;

    void enter(Pcg32&, double p[3], double d[3]) const
    {
        p[0] = p[1] = p[2] = 0.0;
        d[0] = std::sqrt(std::max(0.0, 1.0 - mu0 * mu0));
        d[1] = 0.0;
        d[2] = mu0;
    }
    /// Optical distance from @p p to the boundary along unit @p d (>= 0, may be inf).
    double exit(const double p[3], const double d[3]) const
    {
        const double s = d[2] > 0.0 ? (tau - p[2]) / d[2] : d[2] < 0.0 ? -p[2] / d[2] : INF;
        return std::max(s, 0.0);
    }
};

/// Cube [0, t]^3; photons enter the z = 0 face uniformly, along +z.
struct CubeGeometry
{
    double t;

    void enter(Pcg32& rng, double p[3], double d[3]) const
    {
        p[0] = rng.uniformDouble() * t;
        p[1] = rng.uniformDouble() * t;
        p[2] = 0.0;
        d[0] = d[1] = 0.0;
        d[2] = 1.0;
    }
    double exit(const double p[3], const double d[3]) const
    {
        double s = INF;
        for (int a = 0; a < 3; ++a) {
            if (d[a] > 0.0) {
                s = std::min(s, (t - p[a]) / d[a]);
            } else if (d[a] < 0.0) {
                s = std::min(s, -p[a] / d[a]);
            }
        }
        return std::max(s, 0.0);
    }
};

/// Scratch space of one photon, reused across photons.
struct PhotonScratch
{
    double totals[McTally::TOTALS] = {};
    std::vector<double> bins, single, points;
    PhotonScratch(int muBins, std::size_t muPoints) : bins(muBins), single(muBins), points(muPoints)
    {}
    void clear()
    {
        std::fill(std::begin(totals), std::end(totals), 0.0);
        std::fill(bins.begin(), bins.end(), 0.0);
        std::fill(single.begin(), single.end(), 0.0);
        std::fill(points.begin(), points.end(), 0.0);
    }
};

/// The medium's phase function with Henyey-Greenstein inlined (the hot case).
struct Phase
{
    ScatteringMedium medium;
    bool hg;
    explicit Phase(const ScatteringMedium& m)
        : medium(m), hg(m.phase == PhaseModel::HenyeyGreenstein)
    {}
    double operator()(double mu) const
    {
        return hg ? henyeyGreenstein(mu, medium.g) : phaseFunction(medium.phase, mu, medium.g);
    }
    /// Scatters @p d in place; returns the scattering cosine.
    double scatter(Pcg32& rng, double d[3]) const
    {
        const double mu = samplePhaseCosine(medium.phase, medium.g, rng.uniformDouble());
        const double phi = 2.0 * PI * rng.uniformDouble();
        const double in[3] = {d[0], d[1], d[2]};
        sampleDirection(mu, phi, in, d);
        // Keep the direction unit length over many scatterings.
        const double n = 1.0 / std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; ++a)
            d[a] *= n;
        return mu;
    }
};

/// The mu bin of exit cosine @p muZ; the sign of muZ decides the hemisphere (so a rounding
/// 1 + muZ = 1 cannot put a reflected packet into a transmitted bin).
int binOf(double muZ, int bins)
{
    const int k = static_cast<int>(std::floor(0.5 * (muZ + 1.0) * bins));
    return muZ < 0.0 ? std::clamp(k, 0, bins / 2 - 1) : std::clamp(k, bins / 2, bins - 1);
}

/// Russian roulette below @p wr (unbiased): returns false if the packet dies; adds the net
/// weight it created to the photon's roulette total.
bool roulette(double& w, double wr, Pcg32& rng, PhotonScratch& ph)
{
    if (w >= wr) return true;
    if (rng.uniformDouble() * wr < w) {
        ph.totals[McTally::ROULETTE] += wr - w;
        w = wr;
        return true;
    }
    ph.totals[McTally::ROULETTE] -= w;
    w = 0.0;
    return false;
}

/// One photon, MCML style.
template <class Geometry>
std::uint64_t photonAnalog(const Geometry& geo, const Phase& phase, const McSettings& set,
                           Pcg32& rng, PhotonScratch& ph)
{
    double p[3], d[3];
    geo.enter(rng, p, d);
    const double a = phase.medium.albedo;
    const int nb = set.muBins;
    double w = 1.0;
    bool scattered = false;
    std::uint64_t events = 0;
    for (;;) {
        const double s = -std::log1p(-rng.uniformDouble());
        const double sExit = geo.exit(p, d);
        if (s >= sExit) {
            if (!scattered) {
                ph.totals[McTally::DIRECT] += w;
            } else {
                ph.bins[binOf(d[2], nb)] += w;
                if (events == 1) ph.single[binOf(d[2], nb)] += w;
                ph.totals[d[2] < 0.0 ? McTally::REFLECTED : McTally::TRANSMITTED] += w;
            }
            break;
        }
        for (int i = 0; i < 3; ++i)
            p[i] += s * d[i];
        ++events;
        ph.totals[McTally::ABSORBED] += w * (1.0 - a);
        w *= a;
        scattered = true;
        phase.scatter(rng, d);
        if (!roulette(w, set.rouletteWeight, rng, ph)) break;
    }
    return events;
}

/// Per-bin direction sampling for the next-event estimator: bin k's lower edge and width,
/// and a golden-angle azimuth offset per bin (rotated by one random angle per event), so
/// every bin gets one direction uniform over its solid angle.
struct BinDirections
{
    std::vector<double> lo, cosOff, sinOff;
    double width, invSolidAngle;
    explicit BinDirections(int bins)
        : lo(bins), cosOff(bins), sinOff(bins), width(2.0 / bins),
          invSolidAngle(1.0 / (2.0 * PI * width))
    {
        const double golden = PI * (3.0 - std::sqrt(5.0));
        for (int k = 0; k < bins; ++k) {
            lo[k] = -1.0 + k * width;
            cosOff[k] = std::cos(golden * k);
            sinOff[k] = std::sin(golden * k);
        }
    }
};

/// Adds to the photon's tallies the power that an interaction at @p p (packet travelling
/// along @p d, weight @p ws after the albedo) sends directly out of the medium. Two
/// strategies share each bin's integral ws int_bin p e^-tau_exit dOmega by the balance
/// heuristic (Veach 1997): one direction uniform over the bin (pdf 1/dOmega, here) and the
/// direction the packet then scatters into (pdf p, escapeAlong()); so flat parts of p come
/// from every bin and a sharp forward peak from phase sampling. Per mu point: p e^-tau_exit
/// at a random azimuth.
template <class Geometry>
void nextEvent(const Geometry& geo, const Phase& phase, const McSettings& set,
               const BinDirections& dirs, double ws, const double p[3], const double d[3],
               bool first, Pcg32& rng, PhotonScratch& ph)
{
    const double phi0 = 2.0 * PI * rng.uniformDouble();
    const double c0 = std::cos(phi0), s0 = std::sin(phi0);
    const int nb = set.muBins;
    double refl = 0.0, trans = 0.0;
    for (int k = 0; k < nb; ++k) {
        const double mu = dirs.lo[k] + dirs.width * rng.uniformFloat();
        const double st = std::sqrt(std::max(0.0, 1.0 - mu * mu));
        const double cx = c0 * dirs.cosOff[k] - s0 * dirs.sinOff[k];
        const double sy = s0 * dirs.cosOff[k] + c0 * dirs.sinOff[k];
        const double e[3] = {st * cx, st * sy, mu};
        const double cosScatter = d[0] * e[0] + d[1] * e[1] + d[2] * e[2];
        const double pf = phase(cosScatter);
        const double c = ws * pf * std::exp(-geo.exit(p, e)) / (dirs.invSolidAngle + pf);
        ph.bins[k] += c;
        if (first) ph.single[k] += c;
        (k < nb / 2 ? refl : trans) += c;
    }
    ph.totals[McTally::REFLECTED] += refl;
    ph.totals[McTally::TRANSMITTED] += trans;
    for (std::size_t i = 0; i < set.muPoints.size(); ++i) {
        const double mu = set.muPoints[i];
        const double st = std::sqrt(std::max(0.0, 1.0 - mu * mu));
        const double phi = 2.0 * PI * rng.uniformDouble();
        const double e[3] = {st * std::cos(phi), st * std::sin(phi), mu};
        const double cosScatter = d[0] * e[0] + d[1] * e[1] + d[2] * e[2];
        ph.points[i] += ws * phase(cosScatter) * std::exp(-geo.exit(p, e));
    }
}

/// One photon with forced interactions and next-event estimation.
template <class Geometry>
std::uint64_t photonNextEvent(const Geometry& geo, const Phase& phase, const McSettings& set,
                              const BinDirections& dirs, Pcg32& rng, PhotonScratch& ph)
{
    double p[3], d[3];
    geo.enter(rng, p, d);
    const double a = phase.medium.albedo;
    double w = 1.0;
    double wr = 0.0;
    double pfScattered = 0.0; // p(mu) of the last scattering
    std::uint64_t events = 0;
    for (;;) {
        // Force the next interaction inside: the packet keeps the fraction that interacts.
        const double sExit = geo.exit(p, d);
        const double pInteract = -std::expm1(-sExit);
        if (events == 0) {
            ph.totals[McTally::DIRECT] += w * (1.0 - pInteract);
        } else {
            // The phase-sampled strategy of nextEvent(): escape along the scattered direction.
            const double c =
                w * (1.0 - pInteract) * pfScattered / (dirs.invSolidAngle + pfScattered);
            ph.bins[binOf(d[2], set.muBins)] += c;
            if (events == 1) ph.single[binOf(d[2], set.muBins)] += c;
            ph.totals[d[2] < 0.0 ? McTally::REFLECTED : McTally::TRANSMITTED] += c;
        }
        w *= pInteract;
        if (events == 0) {
            wr = set.rouletteWeight * w;
        }
        if (!(w > 0.0) || !roulette(w, wr, rng, ph)) break;
        const double s = std::min(-std::log1p(-rng.uniformDouble() * pInteract), sExit);
        for (int i = 0; i < 3; ++i)
            p[i] += s * d[i];
        ++events;
        ph.totals[McTally::ABSORBED] += w * (1.0 - a);
        w *= a;
        if (!(w > 0.0)) break;
        nextEvent(geo, phase, set, dirs, w, p, d, events == 1, rng, ph);
        pfScattered = phase(phase.scatter(rng, d));
    }
    return events;
}

template <class Geometry>
McTally simulate(const Geometry& geo, const ScatteringMedium& medium, const McSettings& set,
                 std::uint64_t first, std::uint64_t count, const McProgress& progress)
{
    medium.validate();
    set.validate();
    const Phase phase(medium);
    const BinDirections dirs(set.muBins);
    const std::size_t np = set.muPoints.size();
    const McTally identity(set.muBins, np);
    if (count == 0) return identity;
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::uint64_t>(first, first + count, GRAIN), identity,
        [&](const tbb::blocked_range<std::uint64_t>& range, McTally acc) {
            PhotonScratch ph(set.muBins, np);
            for (std::uint64_t i = range.begin(); i != range.end(); ++i) {
                Pcg32 rng(i, set.seed);
                ph.clear();
                acc.events += set.estimator == McEstimator::Analog
                                  ? photonAnalog(geo, phase, set, rng, ph)
                                  : photonNextEvent(geo, phase, set, dirs, rng, ph);
                auto& t = ph.totals;
                t[McTally::BALANCE] = t[McTally::DIRECT] + t[McTally::REFLECTED] +
                                      t[McTally::TRANSMITTED] + t[McTally::ABSORBED] -
                                      t[McTally::ROULETTE];
                for (int j = 0; j < McTally::TOTALS; ++j) {
                    acc.sum[j] += t[j];
                    acc.sumSq[j] += t[j] * t[j];
                }
                for (int k = 0; k < set.muBins; ++k) {
                    acc.binSum[k] += ph.bins[k];
                    acc.binSumSq[k] += ph.bins[k] * ph.bins[k];
                    acc.singleSum[k] += ph.single[k];
                    acc.singleSumSq[k] += ph.single[k] * ph.single[k];
                }
                for (std::size_t k = 0; k < np; ++k) {
                    acc.pointSum[k] += ph.points[k];
                    acc.pointSumSq[k] += ph.points[k] * ph.points[k];
                }
            }
            acc.photons += range.size();
            if (progress) progress(range.size());
            return acc;
        },
        [](McTally lhs, const McTally& rhs) {
            lhs.merge(rhs);
            return lhs;
        });
}

Estimate estimate(double sum, double sumSq, std::uint64_t n)
{
    Estimate e;
    if (n == 0) return e;
    const double N = static_cast<double>(n);
    e.mean = sum / N;
    e.error = n > 1 ? std::sqrt(std::max(0.0, sumSq / N - e.mean * e.mean) / (N - 1.0)) : 0.0;
    return e;
}

} // namespace

void McSettings::validate() const
{
    if (photons == 0) throw UsageError("the photon count must be > 0");
    if (muBins <= 0 || muBins % 2 != 0) {
        throw UsageError("the number of mu bins must be even and > 0, got " +
                         std::to_string(muBins));
    }
    if (!(rouletteWeight > 0.0 && rouletteWeight < 1.0)) {
        throw UsageError("the roulette weight must be in (0, 1), got " +
                         numberText(rouletteWeight));
    }
    for (double mu : muPoints) {
        if (!(mu >= -1.0 && mu <= 1.0)) {
            throw UsageError("mu points must be in [-1, 1], got " + numberText(mu));
        }
    }
    if (!muPoints.empty() && estimator != McEstimator::NextEvent) {
        throw UsageError("mu points need the next-event estimator");
    }
}

McTally::McTally(int muBins, std::size_t muPoints)
    : sum(TOTALS, 0.0), sumSq(TOTALS, 0.0), binSum(muBins, 0.0), binSumSq(muBins, 0.0),
      singleSum(muBins, 0.0), singleSumSq(muBins, 0.0), pointSum(muPoints, 0.0),
      pointSumSq(muPoints, 0.0)
{}

void McTally::merge(const McTally& o)
{
    if (o.binSum.size() != binSum.size() || o.pointSum.size() != pointSum.size()) {
        throw Error("McTally::merge: tallies with different bins");
    }
    photons += o.photons;
    events += o.events;
    for (std::size_t i = 0; i < sum.size(); ++i) {
        sum[i] += o.sum[i];
        sumSq[i] += o.sumSq[i];
    }
    for (std::size_t i = 0; i < binSum.size(); ++i) {
        binSum[i] += o.binSum[i];
        binSumSq[i] += o.binSumSq[i];
        singleSum[i] += o.singleSum[i];
        singleSumSq[i] += o.singleSumSq[i];
    }
    for (std::size_t i = 0; i < pointSum.size(); ++i) {
        pointSum[i] += o.pointSum[i];
        pointSumSq[i] += o.pointSumSq[i];
    }
}

McResult summarize(const McTally& t, int muBins)
{
    McResult r;
    r.photons = t.photons;
    r.events = t.events;
    const auto n = t.photons;
    r.direct = estimate(t.sum[McTally::DIRECT], t.sumSq[McTally::DIRECT], n);
    r.reflected = estimate(t.sum[McTally::REFLECTED], t.sumSq[McTally::REFLECTED], n);
    r.transmitted = estimate(t.sum[McTally::TRANSMITTED], t.sumSq[McTally::TRANSMITTED], n);
    r.absorbed = estimate(t.sum[McTally::ABSORBED], t.sumSq[McTally::ABSORBED], n);
    r.roulette = estimate(t.sum[McTally::ROULETTE], t.sumSq[McTally::ROULETTE], n);
    r.balance = estimate(t.sum[McTally::BALANCE], t.sumSq[McTally::BALANCE], n);
    const double dOmega = 2.0 * PI * 2.0 / muBins;
    for (int k = 0; k <= muBins; ++k)
        r.muEdges.push_back(-1.0 + 2.0 * k / muBins);
    for (int k = 0; k < muBins; ++k) {
        Estimate e = estimate(t.binSum[k], t.binSumSq[k], n);
        e.mean /= dOmega;
        e.error /= dOmega;
        r.perSteradian.push_back(e);
        Estimate s = estimate(t.singleSum[k], t.singleSumSq[k], n);
        s.mean /= dOmega;
        s.error /= dOmega;
        r.singlePerSteradian.push_back(s);
    }
    for (std::size_t k = 0; k < t.pointSum.size(); ++k) {
        r.points.push_back(estimate(t.pointSum[k], t.pointSumSq[k], n));
    }
    return r;
}

McTally simulateSlab(const ScatteringMedium& medium, double tau, double mu0,
                     const McSettings& settings, std::uint64_t first, std::uint64_t count,
                     const McProgress& progress)
{
    if (!(tau > 0.0) || !std::isfinite(tau)) {
        throw UsageError("the slab's optical depth must be a finite number > 0, got " +
                         numberText(tau));
    }
    if (!(mu0 > 0.0 && mu0 <= 1.0)) {
        throw UsageError("the incidence cosine mu0 must be in (0, 1], got " + numberText(mu0));
    }
    return simulate(SlabGeometry{tau, mu0}, medium, settings, first, count, progress);
}

McTally simulateCube(const ScatteringMedium& medium, double t, const McSettings& settings,
                     std::uint64_t first, std::uint64_t count, const McProgress& progress)
{
    if (!(t > 0.0) || !std::isfinite(t)) {
        throw UsageError("the voxel's optical thickness t must be a finite number > 0, got " +
                         numberText(t));
    }
    return simulate(CubeGeometry{t}, medium, settings, first, count, progress);
}

McResult runSlab(const ScatteringMedium& medium, double tau, double mu0, const McSettings& settings)
{
    return summarize(simulateSlab(medium, tau, mu0, settings, 0, settings.photons),
                     settings.muBins);
}

McResult runCube(const ScatteringMedium& medium, double t, const McSettings& settings)
{
    return summarize(simulateCube(medium, t, settings, 0, settings.photons), settings.muBins);
}

} // namespace nebula
