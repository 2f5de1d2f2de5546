// SPDX-License-Identifier: Apache-2.0
/// @file spectral_absorption.cpp
/// The spectral renderer's absorption lines (DESIGN §7.6): see spectral_absorption.h.

#include "spectral_absorption.h"

#include "nebula/core/units.h"
#include "nebula/physics/lines.h"

#include <algorithm>
#include <cmath>

namespace nebula::detail {

namespace {

/// (1 - e^-y) / y, -> 1 as y -> 0.
inline double escapeFraction(double y)
{
    return y > 1e-7 ? -std::expm1(-y) / y : 1.0 - 0.5 * y;
}

/// Integral of the piece p over [a, b] (clipped to the piece).
inline double pieceIntegral(const Piece& p, double a, double b)
{
    const double lo = std::max(a, p.x0), hi = std::min(b, p.x1);
    if (!(hi > lo)) return 0.0;
    return (hi - lo) * p.at(0.5 * (lo + hi));
}

} // namespace

LineAbsorption::LineAbsorption(const SpectralScene& scene, const std::vector<double>& nodes,
                               int layers, double lineWidth, double dMin, double dMax,
                               std::size_t stars)
    : mStars(stars), mLayers(layers),
      mLayerWidth(layers > 0 ? (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / layers : 0.0),
      mLineWidth(lineWidth), mNodes(nodes.size())
{
    makeWindows(scene, dMin, dMax);
    if (!mWindows.empty()) makeBins(nodes);
}

void LineAbsorption::makeWindows(const SpectralScene& scene, double dMin, double dMax)
{
    struct Reach
    {
        double lo, hi, eps;
        Contribution line;
    };
    std::vector<Reach> reach;
    for (std::size_t a = 0; a < scene.absorbers.size(); ++a) {
        const SpectralAbsorber& ab = scene.absorbers[a];
        for (const SpectralLine& l : ab.lines) {
            const double eps = l.wavelength * mLineWidth / SPEED_OF_LIGHT_KMS;
            const double margin = 1e-9 * l.wavelength; // rounding of the Doppler factors
            const double lo = std::max(SPECTRAL_MIN_NM, l.wavelength * dMin - eps - margin);
            const double hi = std::min(SPECTRAL_MAX_NM, l.wavelength * dMax + eps + margin);
            if (!(hi > lo)) continue; // outside the visible range: nothing it can dim
            reach.push_back({lo, hi, eps, {a, ab.channel, l.wavelength, l.strength}});
        }
    }
    std::sort(reach.begin(), reach.end(),
              [](const Reach& x, const Reach& y) { return x.lo < y.lo; });
    std::vector<double> epsMin;
    for (const Reach& r : reach) {
        if (mWindows.empty() || r.lo > mWindows.back().lo + mWindows.back().h) {
            mWindows.emplace_back();
            mWindows.back().lo = r.lo;
            epsMin.push_back(r.eps);
        }
        Window& w = mWindows.back();
        w.h = std::max(w.h, r.hi - w.lo); // the window's width, until the bins are cut
        w.lines.push_back(r.line);
        epsMin.back() = std::min(epsMin.back(), r.eps);
    }
    std::size_t offset = 0;
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        Window& w = mWindows[k];
        const double width = w.h, h = epsMin[k] / BINS_PER_EPS;
        w.bins = int(std::clamp(std::ceil(width / h), 1.0, double(MAX_BINS)));
        w.h = width / w.bins;
        w.offset = offset;
        offset += std::size_t(w.bins);
    }
}

void LineAbsorption::makeBins(const std::vector<double>& nodes)
{
    // The node at or below each bin's centre, and the nodes the windows need.
    const std::size_t J = nodes.size();
    std::vector<std::size_t> left;
    for (const Window& w : mWindows) {
        for (int b = 0; b < w.bins; ++b) {
            const double c = w.lo + w.h * (b + 0.5);
            const auto it = std::upper_bound(nodes.begin(), nodes.end(), c);
            const std::size_t j =
                std::min(std::size_t(std::max<std::ptrdiff_t>(it - nodes.begin() - 1, 0)), J - 2);
            left.push_back(j);
            mWatched.push_back(j);
            mWatched.push_back(j + 1);
        }
    }
    std::sort(mWatched.begin(), mWatched.end());
    mWatched.erase(std::unique(mWatched.begin(), mWatched.end()), mWatched.end());
    std::size_t i = 0;
    for (const Window& w : mWindows) {
        for (int b = 0; b < w.bins; ++b, ++i) {
            Bin bin;
            const std::size_t j = left[i];
            const double a = edge(w, b), e = edge(w, b + 1), c = 0.5 * (a + e);
            bin.w0 = std::size_t(std::lower_bound(mWatched.begin(), mWatched.end(), j) -
                                 mWatched.begin());
            bin.frac = (c - nodes[j]) / (nodes[j + 1] - nodes[j]);
            bin.cmf = pieceToXYZ(Piece{a, e, 0.0, 1.0 / w.h});
            if (mLayers > 0) {
                const int k = std::clamp(int((a - SPECTRAL_MIN_NM) / mLayerWidth), 0, mLayers - 1);
                const double end = SPECTRAL_MIN_NM + (k + 1) * mLayerWidth;
                bin.layer = k;
                bin.inLayer = k + 1 < mLayers ? std::clamp((end - a) / w.h, 0.0, 1.0) : 1.0;
            }
            mBins.push_back(bin);
        }
    }
}

AbsorptionScratch LineAbsorption::scratch() const
{
    AbsorptionScratch sc;
    const std::size_t NB = mBins.size(), W = mWindows.size();
    sc.tau.assign(NB, 0.0);
    sc.keep.assign(NB, 1.0);
    sc.stepTau.assign(NB, 0.0);
    sc.esc.assign(NB, 1.0);
    sc.deficit.assign(components() * NB, 0.0);
    sc.before.assign(components() * mWatched.size(), 0.0);
    sc.delta.assign(mWatched.size(), 0.0);
    sc.lo.assign(W, 0);
    sc.hi.assign(W, 0);
    sc.stepLo.assign(W, 0);
    sc.stepHi.assign(W, 0);
    return sc;
}

void LineAbsorption::startRay(AbsorptionScratch& sc) const
{
    const std::size_t NB = mBins.size();
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        const std::size_t o = mWindows[k].offset;
        for (int b = sc.lo[k]; b < sc.hi[k]; ++b) {
            sc.tau[o + std::size_t(b)] = 0.0;
            sc.keep[o + std::size_t(b)] = 1.0;
            for (std::size_t c = 0; c < components(); ++c)
                sc.deficit[c * NB + o + std::size_t(b)] = 0.0;
        }
        sc.lo[k] = mWindows[k].bins;
        sc.hi[k] = 0;
        sc.stepLo[k] = mWindows[k].bins;
        sc.stepHi[k] = 0;
    }
    sc.met = false;
    sc.armed = false;
    sc.stepAbsorbs = false;
}

void LineAbsorption::addProfile(std::size_t k, const LineTrapezoid& t, AbsorptionScratch& sc) const
{
    const Window& w = mWindows[k];
    const int b0 = binEdge(w, t.x[0], false), b1 = binEdge(w, t.x[3], true);
    if (b0 >= b1) return;
    double prev = t.integralTo(edge(w, b0));
    for (int b = b0; b < b1; ++b) {
        const double next = t.integralTo(edge(w, b + 1));
        sc.stepTau[w.offset + std::size_t(b)] += (next - prev) / w.h;
        prev = next;
    }
    sc.stepLo[k] = std::min(sc.stepLo[k], b0);
    sc.stepHi[k] = std::max(sc.stepHi[k], b1);
}

void LineAbsorption::stepProfiles(const float* f, double dA, double dB, double seg,
                                  AbsorptionScratch& sc) const
{
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        for (const Contribution& c : mWindows[k].lines) {
            const double value = f[c.channel];
            if (!(value > 0.0)) continue;
            // The line's optical depth integrated over wavelength on this step [nm].
            const double area = value * c.strength * seg;
            addProfile(k, lineTrapezoidFactors(c.lambda0, dA, dB, mLineWidth, area), sc);
        }
        if (sc.stepLo[k] >= sc.stepHi[k]) continue;
        sc.stepAbsorbs = sc.met = true;
        for (int b = sc.stepLo[k]; b < sc.stepHi[k]; ++b) {
            const std::size_t i = mWindows[k].offset + std::size_t(b);
            sc.esc[i] = escapeFraction(sc.stepTau[i]);
        }
        sc.lo[k] = std::min(sc.lo[k], sc.stepLo[k]);
        sc.hi[k] = std::max(sc.hi[k], sc.stepHi[k]);
    }
}

void LineAbsorption::remember(const ContinuumAt& c, AbsorptionScratch& sc) const
{
    const std::size_t Wn = mWatched.size();
    for (std::size_t comp = 0; comp < components(); ++comp)
        for (std::size_t q = 0; q < Wn; ++q)
            sc.before[comp * Wn + q] = continuum(c, comp, mWatched[q]);
    sc.armed = true;
}

void LineAbsorption::bookSince(const ContinuumAt& c, bool own, AbsorptionScratch& sc) const
{
    const std::size_t Wn = mWatched.size();
    for (std::size_t comp = 0; comp < components(); ++comp) {
        bool any = false;
        for (std::size_t q = 0; q < Wn; ++q) {
            const double now = continuum(c, comp, mWatched[q]);
            sc.delta[q] = now - sc.before[comp * Wn + q];
            sc.before[comp * Wn + q] = now;
            any = any || sc.delta[q] != 0.0;
        }
        if (any) bookSource(comp, sc.delta.data(), own, sc);
    }
}

void LineAbsorption::beforeSources(const ContinuumAt& c, AbsorptionScratch& sc) const
{
    if (!sc.stepAbsorbs) return; // the losses stay as they are: nothing to book yet
    // What came since the last absorbing step lost 1 - e^-T at the T before this step.
    if (sc.armed) bookSince(c, false, sc);
    remember(c, sc);
}

void LineAbsorption::afterSources(const ContinuumAt& c, AbsorptionScratch& sc) const
{
    if (sc.stepAbsorbs) bookSince(c, true, sc);
}

void LineAbsorption::finishRay(const ContinuumAt& c, AbsorptionScratch& sc) const
{
    if (sc.armed) bookSince(c, false, sc);
}

void LineAbsorption::absorbSpectrum(std::size_t comp, const double* values,
                                    AbsorptionScratch& sc) const
{
    if (!sc.met) return;
    for (std::size_t q = 0; q < mWatched.size(); ++q)
        sc.delta[q] = values[mWatched[q]];
    bookSource(comp, sc.delta.data(), false, sc);
}

void LineAbsorption::bookSource(std::size_t comp, const double* delta, bool own,
                                AbsorptionScratch& sc) const
{
    double* deficit = &sc.deficit[comp * mBins.size()];
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        const Window& w = mWindows[k];
        for (int b = sc.lo[k]; b < sc.hi[k]; ++b) {
            const std::size_t i = w.offset + std::size_t(b);
            const Bin& bin = mBins[i];
            // The increment is linear between nodes: its bin integral is h times its value at
            // the bin's centre.
            const double s = delta[bin.w0] + bin.frac * (delta[bin.w0 + 1] - delta[bin.w0]);
            deficit[i] += s * w.h * (1.0 - sc.keep[i] * (own ? sc.esc[i] : 1.0));
        }
    }
}

void LineAbsorption::absorbPiece(const Piece& p, AbsorptionScratch& sc) const
{
    if (!sc.met) return;
    double* deficit = &sc.deficit[gasComponent() * mBins.size()];
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        const Window& w = mWindows[k];
        const int b0 = std::max(sc.lo[k], binEdge(w, p.x0, false));
        const int b1 = std::min(sc.hi[k], binEdge(w, p.x1, true));
        for (int b = b0; b < b1; ++b) {
            const std::size_t i = w.offset + std::size_t(b);
            deficit[i] +=
                pieceIntegral(p, edge(w, b), edge(w, b + 1)) * (1.0 - sc.keep[i] * sc.esc[i]);
        }
    }
}

void LineAbsorption::endStep(AbsorptionScratch& sc) const
{
    if (!sc.stepAbsorbs) return;
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        for (int b = sc.stepLo[k]; b < sc.stepHi[k]; ++b) {
            const std::size_t i = mWindows[k].offset + std::size_t(b);
            sc.tau[i] += sc.stepTau[i];
            sc.keep[i] = std::exp(-sc.tau[i]);
            sc.stepTau[i] = 0.0;
            sc.esc[i] = 1.0;
        }
        sc.stepLo[k] = mWindows[k].bins;
        sc.stepHi[k] = 0;
    }
    sc.stepAbsorbs = false;
}

XYZ LineAbsorption::deficitXYZ(const AbsorptionScratch& sc, std::size_t comp) const
{
    XYZ xyz{0, 0, 0};
    const double* deficit = &sc.deficit[comp * mBins.size()];
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        for (int b = sc.lo[k]; b < sc.hi[k]; ++b) {
            const std::size_t i = mWindows[k].offset + std::size_t(b);
            for (std::size_t c = 0; c < 3; ++c)
                xyz[c] += deficit[i] * mBins[i].cmf[c];
        }
    }
    return xyz;
}

void LineAbsorption::addDeficitLayers(const AbsorptionScratch& sc, std::size_t comp,
                                      double* perLayer) const
{
    if (mLayers == 0) return;
    const double* deficit = &sc.deficit[comp * mBins.size()];
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        for (int b = sc.lo[k]; b < sc.hi[k]; ++b) {
            const std::size_t i = mWindows[k].offset + std::size_t(b);
            const Bin& bin = mBins[i];
            const double d = deficit[i] / mLayerWidth;
            perLayer[bin.layer] += d * bin.inLayer;
            if (bin.inLayer < 1.0) perLayer[bin.layer + 1] += d * (1.0 - bin.inLayer);
        }
    }
}

void LineAbsorption::deficitPieces(const AbsorptionScratch& sc, std::size_t comp,
                                   std::vector<Piece>& out) const
{
    const double* deficit = &sc.deficit[comp * mBins.size()];
    for (std::size_t k = 0; k < mWindows.size(); ++k) {
        const Window& w = mWindows[k];
        for (int b = sc.lo[k]; b < sc.hi[k]; ++b) {
            const double d = deficit[w.offset + std::size_t(b)];
            if (d != 0.0) out.push_back(Piece{edge(w, b), edge(w, b + 1), 0.0, -d / w.h});
        }
    }
}

} // namespace nebula::detail
