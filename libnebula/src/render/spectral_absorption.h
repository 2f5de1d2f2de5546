// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file spectral_absorption.h
/// Internal to render/: the absorption lines of the spectral renderer (DESIGN §7.6).
///
/// Each absorption line of each `absorption.<species>` grid can reach only the wavelengths
/// lambda0 D +- eps for the scene's Doppler factors D; those ranges, merged where they
/// overlap, are the windows. A window is cut into fine bins (a 64th of the narrowest line's
/// half-width eps, at most MAX_BINS) that hold the ray's accumulated line optical depth as
/// exact bin means of the lines' Doppler trapezoids. Every source on the ray (the continuum's
/// increments at the nodes, linear between them, and each emission-line piece) loses, in each
/// bin, its exact bin integral times 1 - e^-tau (times the step's own escape fraction for the
/// step's sources): the deficit, booked per component (each star, the field, the gas) and
/// turned into colour and spectral layers by per-bin weights computed once.

#include "nebula/physics/colour.h"
#include "nebula/physics/spectrum.h"
#include "nebula/render/spectral.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace nebula::detail {

/// The ray's state of the absorption lines (reused from pixel to pixel).
struct AbsorptionScratch
{
    std::vector<double> tau;         ///< [bin] line optical depth from the eye (bin mean)
    std::vector<double> keep;        ///< [bin] e^-tau
    std::vector<double> stepTau;     ///< [bin] this step's own (0 outside its profiles)
    std::vector<double> esc;         ///< [bin] (1 - e^-stepTau) / stepTau (1 outside)
    std::vector<double> deficit;     ///< [component][bin] the absorbed energy in the bin [.. nm]
    std::vector<double> before;      ///< [component][watched node] continuum before the step
    std::vector<double> delta;       ///< [watched node] one component's increment in the step
    std::vector<int> lo, hi;         ///< [window] the bins touched on this ray: [lo, hi)
    std::vector<int> stepLo, stepHi; ///< [window] the bins of this step's profiles
    bool met = false;                ///< the ray has met an absorber
    bool armed = false;              ///< `before` holds the continuum at the last absorbing step
    bool stepAbsorbs = false;        ///< this step has
};

/// The continuum accumulated so far on a ray, at the nodes (SpectralScratch's arrays).
struct ContinuumAt
{
    const double* star;  ///< [s][j]
    const double* field; ///< [j] (may be null: no field)
    const double* gas;   ///< [j]
};

class LineAbsorption
{
public:
    /// Windows of at most this many bins (wider ones get coarser bins).
    static constexpr int MAX_BINS = 16384;
    /// Bins per half-width eps of the narrowest line of a window.
    static constexpr int BINS_PER_EPS = 64;

    /// @p nodes: the continuum's node wavelengths; @p layers of equal width over 360-830 nm;
    /// @p lineWidth: the lines' half-width [km/s] (exaggerated); @p dMin, @p dMax: the
    /// scene's range of Doppler factors; @p stars: the number of stars.
    LineAbsorption(const SpectralScene& scene, const std::vector<double>& nodes, int layers,
                   double lineWidth, double dMin, double dMax, std::size_t stars);

    bool active() const { return !mWindows.empty(); }
    /// Components: each star's scattered light (0..S-1), the field's (S), the gas's (S + 1).
    std::size_t components() const { return mStars + 2; }
    std::size_t fieldComponent() const { return mStars; }
    std::size_t gasComponent() const { return mStars + 1; }

    AbsorptionScratch scratch() const;
    /// Forgets the previous ray.
    void startRay(AbsorptionScratch& sc) const;
    /// The profiles of the step of length @p seg [pc] with field sample @p f and Doppler
    /// factors @p dA, @p dB at its ends (sc.stepTau, sc.esc). Call endStep() after the
    /// step's sources.
    void stepProfiles(const float* f, double dA, double dB, double seg,
                      AbsorptionScratch& sc) const;
    /// Before the step's sources: on an absorbing step, books what the continuum gained
    /// since the last one (it lost 1 - e^-T at the T it saw, constant since) and remembers
    /// the continuum. Between absorbing steps nothing is done.
    void beforeSources(const ContinuumAt& c, AbsorptionScratch& sc) const;
    /// After the step's sources: on an absorbing step, books what they added, with the
    /// step's own escape fraction.
    void afterSources(const ContinuumAt& c, AbsorptionScratch& sc) const;
    /// At the ray's end: books what the continuum gained since the last absorbing step.
    void finishRay(const ContinuumAt& c, AbsorptionScratch& sc) const;
    /// Books the absorbed part of the emission-line piece @p p of this step.
    void absorbPiece(const Piece& p, AbsorptionScratch& sc) const;
    /// Books the absorbed part of the spectrum @p values (at the nodes, linear between them)
    /// seen through the whole ray's lines, to component @p comp (a star's sprite).
    void absorbSpectrum(std::size_t comp, const double* values, AbsorptionScratch& sc) const;
    /// Folds the step's profiles into the ray's optical depth.
    void endStep(AbsorptionScratch& sc) const;

    /// XYZ of component @p c's deficit (to subtract).
    XYZ deficitXYZ(const AbsorptionScratch& sc, std::size_t c) const;
    /// Adds component @p c's deficit to @p perLayer (mean per nm over each spectral layer).
    void addDeficitLayers(const AbsorptionScratch& sc, std::size_t c, double* perLayer) const;
    /// Component @p c's deficit as pieces (constant per bin), for counting.
    void deficitPieces(const AbsorptionScratch& sc, std::size_t c, std::vector<Piece>& out) const;

private:
    struct Contribution
    {
        std::size_t absorber; ///< index into SpectralScene::absorbers
        int channel;
        double lambda0, strength;
    };
    struct Window
    {
        double lo = 0.0, h = 0.0; ///< first bin edge, bin width [nm]
        int bins = 0;
        std::size_t offset = 0; ///< its first bin in the per-bin arrays
        std::vector<Contribution> lines;
    };
    struct Bin
    {
        std::size_t w0 = 0;   ///< the watched node at or below its centre (w0 + 1 above)
        double frac = 0.0;    ///< its centre's position between them
        XYZ cmf{0, 0, 0};     ///< XYZ of a unit deficit in the bin (pieceToXYZ / h)
        int layer = -1;       ///< the spectral layer of its left part (-1: none)
        double inLayer = 0.0; ///< the fraction of it in that layer (the rest in the next)
    };

    void makeWindows(const SpectralScene& scene, double dMin, double dMax);
    void makeBins(const std::vector<double>& nodes);
    void addProfile(std::size_t w, const LineTrapezoid& t, AbsorptionScratch& sc) const;
    /// Books @p delta (at the watched nodes) to component @p c: in each touched bin its
    /// integral times 1 - e^-T, times the step's escape fraction if @p own.
    void bookSource(std::size_t c, const double* delta, bool own, AbsorptionScratch& sc) const;
    /// sc.before := the continuum at the watched nodes.
    void remember(const ContinuumAt& c, AbsorptionScratch& sc) const;
    /// Books the continuum's gain since sc.before (@p own as bookSource()) and remembers it.
    void bookSince(const ContinuumAt& c, bool own, AbsorptionScratch& sc) const;
    /// Component @p comp of the continuum at node @p j.
    double continuum(const ContinuumAt& c, std::size_t comp, std::size_t j) const
    {
        return comp < mStars    ? c.star[comp * mNodes + j]
               : comp == mStars ? (c.field ? c.field[j] : 0.0)
                                : c.gas[j];
    }
    double edge(const Window& w, int b) const { return w.lo + w.h * b; }
    /// The bin edge at or below (@p up: at or above) wavelength @p x, in [0, w.bins].
    static int binEdge(const Window& w, double x, bool up)
    {
        const double u = (x - w.lo) / w.h;
        return int(std::clamp(up ? std::ceil(u) : std::floor(u), 0.0, double(w.bins)));
    }

    std::size_t mStars = 0;
    int mLayers = 0;
    double mLayerWidth = 0.0;
    double mLineWidth = 0.0;
    std::vector<Window> mWindows;
    std::vector<Bin> mBins;            ///< all windows' bins
    std::vector<std::size_t> mWatched; ///< the continuum nodes the windows lie between
    std::size_t mNodes = 0;
};

} // namespace nebula::detail
