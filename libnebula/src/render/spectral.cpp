// SPDX-License-Identifier: Apache-2.0
/// @file spectral.cpp
/// nebrender --spectral (DESIGN §7): see spectral.h.
///
/// Along a ray the renderer keeps the V-band optical depth tau from the eye; every
/// extinction in the scene is kappa_V A(lambda)/A_V n, so the transmittance at any wavelength
/// is exp(-tau Lambda(lambda)) with Lambda = A(lambda)/A_V. A segment of V optical depth x lets
/// the fraction (1 - exp(-x Lambda)) / (x Lambda) of its emission out and, for its scattered
/// light, contributes S (1 - exp(-x Lambda)) with S the source function (as the RGB kernel).
///
/// Continuum (each star's black body scattered by the dust, black-body emission of the gas):
/// smooth spectra, accumulated on fixed wavelengths (piecewise-linear mode: nodes
/// continuumStep apart, the spectrum linear between them; fixed-band mode: the band centres).
/// Lines: each segment adds an exact trapezoid per line (lineTrapezoid) whose values are
/// multiplied by the segment's transmittance factor at its breakpoints. Colour is linear in
/// the spectrum, so each piece is integrated against the CMFs as it is made (exact, O(1));
/// the ray's spectrum is assembled (Spectrum::sum) only to count its pieces.

#include "nebula/render/spectral.h"

#include "frame.h"
#include "near_star.h"
#include "spectral_absorption.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/integrator.h"
#include "nebula/render/sprites.h"
#include "nebula/render/star_depth.h"

#include "nebula/volume/block_walk.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <optional>
#include <utility>

namespace nebula {

namespace {

/// A(lambda)/A_V tabulated every 0.25 nm over 300-1000 nm, linear between (the curve is
/// smooth: the table's error is below 1e-7 relative), clamped outside.
class ExtinctionTable
{
public:
    explicit ExtinctionTable(const DustParams& dust)
    {
        mValues.resize(std::size_t((HI - LO) / STEP) + 1);
        for (std::size_t i = 0; i < mValues.size(); ++i) {
            mValues[i] = extinctionRatio(dust, LO + STEP * double(i));
        }
    }
    double operator()(double lambda) const
    {
        const double u = std::clamp((lambda - LO) / STEP, 0.0, double(mValues.size() - 1));
        const std::size_t i = std::min(std::size_t(u), mValues.size() - 2);
        const double f = u - double(i);
        return mValues[i] + f * (mValues[i + 1] - mValues[i]);
    }

private:
    static constexpr double LO = 300.0, HI = 1000.0, STEP = 0.25;
    std::vector<double> mValues;
};

/// (1 - e^-y) / y, -> 1 as y -> 0.
inline double escapeFraction(double y)
{
    return y > 1e-7 ? -std::expm1(-y) / y : 1.0 - 0.5 * y;
}

std::string bandName(double centre)
{
    char buf[64];
    std::snprintf(buf, sizeof buf, "S0.%.2fnm", centre);
    std::string s = buf;
    std::replace(s.begin(), s.end() - 2, '.', ',');
    s[2] = '.'; // "S0." keeps its dot: the layer separator
    return s;
}

/// Integral of the piece p over [a, b] (clipped to the piece).
inline double pieceIntegral(const Piece& p, double a, double b)
{
    const double lo = std::max(a, p.x0), hi = std::min(b, p.x1);
    if (!(hi > lo)) return 0.0;
    return (hi - lo) * p.at(0.5 * (lo + hi));
}

/// XYZ of a continuum given by its values at the nodes, from the nodes' colour weights.
XYZ nodesToXYZ(const double* values, const std::vector<XYZ>& weight)
{
    XYZ xyz{0, 0, 0};
    for (std::size_t j = 0; j < weight.size(); ++j)
        for (std::size_t c = 0; c < 3; ++c)
            xyz[c] += values[j] * weight[j][c];
    return xyz;
}

/// The wavelengths on which the continuum is kept, and their colour weights.
struct ContinuumNodes
{
    bool bandsMode = false;
    double bandWidth = 0.0;     ///< fixed-band mode: the width of a band [nm]
    std::vector<double> lam;    ///< node wavelengths [nm]
    std::vector<double> lamExt; ///< A(lambda)/A_V at each node
    std::vector<XYZ> weight;    ///< XYZ of a unit value at each node (hat or box function)
    double LambdaMin = 0.0;     ///< the smallest A(lambda)/A_V: the last light to be absorbed

    ContinuumNodes(const SpectralOptions& so, const ExtinctionTable& Lambda)
        : bandsMode(so.bands > 0)
    {
        if (bandsMode) {
            bandWidth = (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / so.bands;
            for (int j = 0; j < so.bands; ++j) {
                lam.push_back(SPECTRAL_MIN_NM + (j + 0.5) * bandWidth);
                XYZ w = cmfAt(lam.back());
                for (auto& c : w)
                    c *= bandWidth;
                weight.push_back(w);
            }
        } else {
            const int n =
                int(std::ceil((SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / so.continuumStep - 1e-9)) + 1;
            const double step = (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / (n - 1);
            for (int j = 0; j < n; ++j)
                lam.push_back(SPECTRAL_MIN_NM + j * step);
            weight = hatWeights(SPECTRAL_MIN_NM, step, n);
        }
        for (double l : lam)
            lamExt.push_back(Lambda(l));
        LambdaMin = *std::min_element(lamExt.begin(), lamExt.end());
    }
    std::size_t size() const { return lam.size(); }
};

/// The layers and channels a frame's pixels are written to, looked up once per frame.
struct SpectralLayers
{
    detail::FrameLayers frame;
    std::vector<ChannelId> bands; ///< the spectral layers' channels, per band
    /// With componentLayers, per band: the channels of SPECTRAL_COMPONENTS.
    std::vector<ChannelId> direct, single, field, emission;
};

/// What one band of rows keeps (reused from pixel to pixel).
struct SpectralScratch
{
    std::vector<float> f;             ///< field sample
    std::vector<double> Cstar;        ///< per star and node: scattered starlight
    std::vector<double> Cgas;         ///< per node: black-body and (fixed bands) line emission
    std::vector<double> Cfield;       ///< per node: the scattered-light field's (nebscatter)
    std::vector<double> Ctotal;       ///< per node: the whole continuum
    std::vector<double> A;            ///< per node: 1 - e^-x Lambda of the current segment
    std::vector<double> layerAcc;     ///< per spectral layer: the lines' share
    std::vector<Piece> rayPieces;     ///< with countPieces: the ray's pieces
    std::vector<float> fs;            ///< the field's moments at a sample
    std::vector<double> Sfield;       ///< per field wavelength: its source function towards the eye
    std::vector<double> layerDeficit; ///< [component][layer]: what the absorption lines took
    detail::AbsorptionScratch abs;    ///< the absorption lines' state (none without them)
    std::vector<detail::RayStar> rayStars; ///< per star: as the pixel's ray sees it
    detail::StarNodes nodes;               ///< one step's, for one star
    RenderStats stats;
};

/// The range of Doppler factors of @p scene's gas under @p so (1, 1 without a velocity
/// grid): the speeds up to maxSpeed in any direction, first order or relativistic.
std::pair<double, double> dopplerRange(const SpectralScene& scene, const SpectralOptions& so)
{
    if (scene.velocityChannel < 0) return {1.0, 1.0};
    const double beta = scene.maxSpeed * so.exaggerateVelocity / SPEED_OF_LIGHT_KMS;
    if (!so.relativistic) return {1.0 - beta, 1.0 + beta};
    return {std::sqrt((1.0 - beta) / (1.0 + beta)), std::sqrt((1.0 + beta) / (1.0 - beta))};
}

/// The absorption lines of @p scene (DESIGN §7.6); UsageError with fixed bands.
detail::LineAbsorption lineAbsorption(const SpectralScene& scene, const SpectralOptions& so,
                                      const std::vector<double>& nodes)
{
    if (!scene.absorbers.empty() && so.bands > 0) {
        throw UsageError("--bands: absorption grid \"" + scene.absorbers.front().grid +
                         "\" needs the piecewise-linear spectra (leave out --bands)");
    }
    const auto [dMin, dMax] = dopplerRange(scene, so);
    return detail::LineAbsorption(scene, nodes, so.layers, so.lineWidth * so.exaggerateVelocity,
                                  dMin, dMax, scene.base.stars.size());
}

/// One ray: direction, V optical depth from the eye, the lines' colour, and the Doppler
/// factor at the end of the previous segment (shared with the next).
struct SpectralRay
{
    Vec3 oW; ///< world origin: the eye, or the orthographic camera's pixel on its plane
    Vec3 dW, dI;
    double tau = 0.0;
    XYZ lineXYZ{0, 0, 0};
    double lastEndT = -1.0, lastEndD = 1.0;
    double fieldWeight[shCount(SH_MAX_DEGREE)] = {}; ///< a p_l Y_lm(-dW) per field moment
};

class SpectralIntegrator
{
public:
    SpectralIntegrator(const SpectralScene& scene, const RenderOptions& opts)
        : mScene(scene), mRs(scene.base), mOpts(opts), mSo(opts.spectral), mDust(scene.dust),
          mLambda(mDust), mNodes(mSo, mLambda), mCam(opts.camera),
          mLevel0(mRs.fields, mRs.blocks, mRs.occupied, mCam.eye()),
          mAbsorption(lineAbsorption(scene, mSo, mNodes.lam))
    {
        starSpectra();
        layerWeights();
        mDFloor = detail::NEAR_STAR_FLOOR * mLevel0.voxelWorld;
        for (const auto& s : mRs.stars) {
            mStarPos.emplace_back(s.position[0], s.position[1], s.position[2]);
        }
        mBbFactor = mSo.blackbodyScale * (1.0 - mDust.albedo) * WM2_TO_LSUN_PC2;
        // Every velocity is exaggerated alike, the thermal and turbulent line width included,
        // so that a spectrum keeps its shape and is only stretched.
        mLineWidth = mSo.lineWidth * mSo.exaggerateVelocity;
        for (int c = 0; c < 3; ++c) {
            mRChannel[std::size_t(c)] = extinctionRatio(mDust, opts.wavelengths[std::size_t(c)]);
        }
        fieldSetup();
        if (opts.exactStarDepth) mDepth.emplace(mRs);
    }

    int layers() const { return mSo.layers; }
    /// The exact star depth this integrator marches (null: --interpolated-tau).
    const StarDepth* starDepth() const { return mDepth ? &*mDepth : nullptr; }

    SpectralScratch scratch() const
    {
        const std::size_t S = mRs.stars.size(), J = mNodes.size();
        SpectralScratch sc;
        sc.f.resize(std::size_t(mRs.fields.channels()));
        sc.Cstar.resize(S * J);
        sc.Cgas.resize(J);
        sc.Cfield.resize(J);
        sc.Ctotal.resize(J);
        if (mField) {
            sc.fs.resize(std::size_t(mField->channels()));
            sc.Sfield.resize(mFieldLambda.size());
        }
        sc.A.resize(J);
        sc.layerAcc.resize(std::size_t(mSo.layers));
        if (mAbsorption.active()) {
            sc.abs = mAbsorption.scratch();
            sc.layerDeficit.resize(mAbsorption.components() * std::size_t(mSo.layers));
        }
        return sc;
    }

    /// Renders pixel (px, py) into @p img's beauty and its layers and channels @p ids.
    void renderPixel(int px, int py, SpectralScratch& sc, Image& img,
                     const SpectralLayers& ids) const
    {
        SpectralRay ray;
        if (!mCam.direction(px + 0.5, py + 0.5, ray.dW)) return; // outside the view: black
        ray.dI = mLevel0.w2i.applyLinear(ray.dW);
        ray.oW = mCam.origin(px + 0.5, py + 0.5);
        detail::rayStars(mCam, px + 0.5, py + 0.5, ray.oW, ray.dW, mStarPos, mDFloor, sc.rayStars);
        if (mField) {
            // Scattered towards the eye: Y_lm of the light's travel direction, -dW.
            double Y[shCount(SH_MAX_DEGREE)];
            realSphericalHarmonics(-ray.dW, mRs.scatter.order, Y);
            for (int k = 0; k < mFieldMoments; ++k)
                ray.fieldWeight[k] = mFieldPl[k] * Y[k];
        }
        std::fill(sc.Cstar.begin(), sc.Cstar.end(), 0.0);
        std::fill(sc.Cgas.begin(), sc.Cgas.end(), 0.0);
        std::fill(sc.Cfield.begin(), sc.Cfield.end(), 0.0);
        std::fill(sc.layerAcc.begin(), sc.layerAcc.end(), 0.0);
        sc.rayPieces.clear();
        if (mAbsorption.active()) mAbsorption.startRay(sc.abs);
        sc.stats.rays += mLevel0.marchFrom(
            mLevel0.w2i.apply(ray.oW), ray.dW, mOpts.step,
            [&](const Vec3& pI, double tm, double seg) { return step(pI, tm, seg, ray, sc); });
        if (mAbsorption.active()) {
            mAbsorption.finishRay(
                {sc.Cstar.data(), mField ? sc.Cfield.data() : nullptr, sc.Cgas.data()}, sc.abs);
        }
        writePixel(std::size_t(py) * img.width + px, ray, sc, img, ids);
    }

    /// Adds each star's sprite: its attenuated spectrum's colour, and its share of every
    /// spectral layer (@p ids).
    void drawSprites(Image& img, const SpectralLayers& ids) const
    {
        const std::size_t S = mRs.stars.size(), J = mNodes.size();
        const int NL = mSo.layers;
        std::vector<double> att(S * J);
        const bool absorbs = mAbsorption.active();
        // What the absorption lines take of each sprite, per layer: [s][b].
        std::vector<double> lost(absorbs ? S * std::size_t(NL) : 0);
        SpectralScratch sc = absorbs ? scratch() : SpectralScratch();
        drawStarSprites(
            img, mRs, mOpts,
            [&](std::size_t s, double tauV) {
                for (std::size_t j = 0; j < J; ++j) {
                    att[s * J + j] = mStarSpec[s * J + j] * std::exp(-tauV * mNodes.lamExt[j]);
                }
                XYZ xyz = nodesToXYZ(&att[s * J], mNodes.weight);
                if (absorbs) spriteAbsorption(s, &att[s * J], sc, xyz, &lost[s * std::size_t(NL)]);
                return xyzToLinearSRGB(xyz);
            },
            [&](std::size_t s, std::size_t pix, double factor) {
                for (int b = 0; b < NL; ++b) {
                    double v = absorbs ? -lost[s * std::size_t(NL) + std::size_t(b)] : 0.0;
                    const auto [j0, j1] = mLayerNodes[std::size_t(b)];
                    for (std::size_t j = j0; j < j1; ++j) {
                        v += mLayerOfNode[std::size_t(b) * J + j] * att[s * J + j];
                    }
                    img.values(ids.bands[std::size_t(b)])[pix] += float(v * factor);
                    if (mOpts.componentLayers)
                        img.values(ids.direct[std::size_t(b)])[pix] += float(v * factor);
                }
            });
    }

private:
    /// The absorption lines between the eye and star @p s (DESIGN §7.6): marched from the
    /// camera's origin towards the star up to the step that holds it; what they take of its
    /// spectrum @p att (at the nodes) is subtracted from @p xyz and put per spectral layer
    /// in @p lost.
    void spriteAbsorption(std::size_t s, const double* att, SpectralScratch& sc, XYZ& xyz,
                          double* lost) const
    {
        const Vec3 o = mCam.originTowards(mStarPos[s]);
        const Vec3 d = mStarPos[s] - o;
        const double dist = d.length();
        mAbsorption.startRay(sc.abs);
        if (dist > 0.0) {
            SpectralRay ray;
            ray.oW = o;
            ray.dW = d * (1.0 / dist);
            ray.dI = mLevel0.w2i.applyLinear(ray.dW);
            mLevel0.marchFrom(mLevel0.w2i.apply(o), ray.dW, mOpts.step,
                              [&](const Vec3& pI, double tm, double seg) {
                                  if (tm > dist) return false;
                                  mRs.fields.sample(pI, sc.f.data());
                                  if (!(sc.f[1] > 0.0f)) return true;
                                  double dA = 1.0, dB = 1.0;
                                  segmentDoppler(pI, tm, seg, ray, dA, dB);
                                  mAbsorption.stepProfiles(sc.f.data(), dA, dB, seg, sc.abs);
                                  mAbsorption.endStep(sc.abs);
                                  return true;
                              });
        }
        mAbsorption.absorbSpectrum(s, att, sc.abs);
        const XYZ taken = mAbsorption.deficitXYZ(sc.abs, s);
        for (std::size_t c = 0; c < 3; ++c)
            xyz[c] -= taken[c];
        std::fill(lost, lost + mSo.layers, 0.0);
        mAbsorption.addDeficitLayers(sc.abs, s, lost);
    }

    /// The spectral scattered-light field (nebscatter --spectral), if the scene has one: the
    /// weights a p_l of its moments and, per continuum node, the two field wavelengths it
    /// lies between (the end ones beyond the field's range).
    void fieldSetup()
    {
        const SceneScatterField& f = mRs.scatter;
        if (f.order < 0 || f.wavelengths.empty()) return;
        mField = &f.moments;
        mFieldW2I = mField->indexToWorld.inverse();
        mFieldMoments = shCount(f.order);
        mFieldLambda = f.wavelengths;
        const auto p = phaseLegendreMoments(mDust.phase, mDust.g, f.order);
        for (int l = 0; l <= f.order; ++l)
            for (int m = -l; m <= l; ++m)
                mFieldPl[shIndex(l, m)] = mDust.albedo * p[std::size_t(l)];
        const auto& wl = mFieldLambda;
        const std::size_t last = wl.size() - 1;
        for (const double lam : mNodes.lam) {
            const auto it = std::upper_bound(wl.begin(), wl.end(), lam);
            const std::size_t i1 = std::size_t(it - wl.begin());
            if (i1 > last || i1 == 0) {
                // Beyond the field's wavelengths: the power law through the end two,
                // S = S_a (S_a / S_o)^e with e = ln(lambda / lambda_a) / ln(lambda_a / lambda_o).
                const std::size_t a = i1 == 0 ? 0 : last, o = i1 == 0 ? 1 : last - 1;
                mNodeField.push_back({a, o, std::log(lam / wl[a]) / std::log(wl[a] / wl[o]), true});
            } else {
                const std::size_t i0 = i1 - 1;
                mNodeField.push_back({i0, i1, (lam - wl[i0]) / (wl[i1] - wl[i0]), false});
            }
        }
    }

    /// Star spectra at the continuum nodes, normalised so that each star's Y is L_s in this
    /// representation (the RGB mode's convention, DESIGN §3), or calibrated
    /// (RenderOptions::monochromatic): the black body of bolometric luminosity L_s.
    void starSpectra()
    {
        const std::size_t S = mRs.stars.size(), J = mNodes.size();
        mStarSpec.resize(S * J);
        for (std::size_t s = 0; s < S; ++s) {
            if (mOpts.monochromatic) {
                const Star& star = mRs.stars[s];
                for (std::size_t j = 0; j < J; ++j)
                    mStarSpec[s * J + j] = blackbodySpectralLuminosity(
                        star.luminosity, star.temperature, mNodes.lam[j]);
                continue;
            }
            double Y = 0.0;
            for (std::size_t j = 0; j < J; ++j) {
                mStarSpec[s * J + j] =
                    planckPerNmUnchecked(mNodes.lam[j], mRs.stars[s].temperature);
                Y += mStarSpec[s * J + j] * mNodes.weight[j][1];
            }
            if (!(Y > 0.0)) {
                throw Error("star \"" + mRs.stars[s].name + "\" at " +
                            std::to_string(mRs.stars[s].temperature) +
                            " K emits no light between 360 and 830 nm to render");
            }
            for (std::size_t j = 0; j < J; ++j)
                mStarSpec[s * J + j] *= mRs.stars[s].luminosity / Y;
        }
    }

    /// Spectral layers: equal bands over 360-830 nm; the continuum's share of each.
    void layerWeights()
    {
        const int NL = mSo.layers;
        const std::size_t J = mNodes.size();
        const auto& lam = mNodes.lam;
        mLayerWidth = NL > 0 ? (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / NL : 0.0;
        mLayerOfNode.assign(std::size_t(NL) * J, 0.0); // [b][j]
        mLayerNodes.assign(std::size_t(NL), {J, 0});
        for (int b = 0; b < NL; ++b) {
            const double a = SPECTRAL_MIN_NM + b * mLayerWidth, e = a + mLayerWidth;
            for (std::size_t j = 0; j < J; ++j) {
                double v = 0.0;
                if (mNodes.bandsMode) {
                    const double lo = std::max(a, lam[j] - 0.5 * mNodes.bandWidth);
                    const double hi = std::min(e, lam[j] + 0.5 * mNodes.bandWidth);
                    v = std::max(0.0, hi - lo);
                } else { // the hat function of node j
                    if (j > 0) v += pieceIntegral(pieceThrough(lam[j - 1], 0.0, lam[j], 1.0), a, e);
                    if (j + 1 < J)
                        v += pieceIntegral(pieceThrough(lam[j], 1.0, lam[j + 1], 0.0), a, e);
                }
                mLayerOfNode[std::size_t(b) * J + j] = v / mLayerWidth;
                if (v > 0.0) {
                    auto& range = mLayerNodes[std::size_t(b)];
                    range.first = std::min(range.first, j);
                    range.second = j + 1;
                }
            }
        }
    }

    /// Doppler factor lambda_observed / lambda_emitted of the gas at index point @p pI.
    double dopplerAt(const Vec3& pI, const Vec3& dW) const
    {
        const double vScale = mSo.exaggerateVelocity;
        float v[3];
        mRs.fields.sampleChannels(pI, mScene.velocityChannel, 3, v);
        const double vr =
            vScale * (double(v[0]) * dW.x + double(v[1]) * dW.y + double(v[2]) * dW.z);
        if (!mSo.relativistic) return dopplerFactor(vr);
        const double v2 =
            vScale * vScale * (double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
        return relativisticDopplerFactor(vr, v2);
    }

    /// Adds the linear piece through (a, ya), (b, yb) of the line emission: its colour, its
    /// share of each spectral layer, and (countPieces) the piece itself.
    void addLinePiece(double a, double ya, double b, double yb, SpectralRay& ray,
                      SpectralScratch& sc) const
    {
        if (!(b > a)) return;
        const Piece p = pieceThrough(a, ya, b, yb);
        const XYZ xyz = pieceToXYZ(p);
        for (int c = 0; c < 3; ++c)
            ray.lineXYZ[std::size_t(c)] += xyz[std::size_t(c)];
        for (int k = 0; k < mSo.layers; ++k) {
            const double lo = SPECTRAL_MIN_NM + k * mLayerWidth;
            sc.layerAcc[std::size_t(k)] += pieceIntegral(p, lo, lo + mLayerWidth) / mLayerWidth;
        }
        if (mSo.countPieces) sc.rayPieces.push_back(p);
        ++sc.stats.pieces;
        if (mAbsorption.active()) mAbsorption.absorbPiece(p, sc.abs);
    }

    /// Every star's light scattered towards the eye from the step [tm - seg/2, tm + seg/2],
    /// at each node: the phase function (averaged over the step's nodes at equal
    /// angles near the star, DESIGN §3.5) and the step's mean of 1/(4 pi r^2) times the
    /// star's spectrum attenuated from the star and to the eye (one exponential per node for
    /// both), times 1 - e^-x Lambda (sc.A).
    void scatterStarlight(double tm, double seg, const SpectralRay& ray, SpectralScratch& sc) const
    {
        const std::size_t S = mRs.stars.size(), J = mNodes.size();
        detail::StarNodes& nodes = sc.nodes;
        for (std::size_t s = 0; s < S; ++s) {
            detail::starNodes(sc.rayStars[s], tm - 0.5 * seg, tm + 0.5 * seg, nodes);
            double p = 0.0;
            for (int i = 0; i < nodes.n; ++i)
                p += phaseFunction(mDust.phase, nodes.mu[i], mDust.g) / nodes.n;
            const double w = mDust.albedo * p * nodes.total / (4.0 * PI * seg);
            const double tauS = ray.tau + std::max(0.0f, sc.f[2 + s]);
            const double* spec = &mStarSpec[s * J];
            double* acc = &sc.Cstar[s * J];
            for (std::size_t j = 0; j < J; ++j) {
                acc[j] += w * spec[j] * std::exp(-tauS * mNodes.lamExt[j]) * sc.A[j];
            }
        }
    }

    /// The light scattered at least once before (nebscatter --spectral's field, DESIGN §5b)
    /// scattered towards the eye at xW, at each node: the source function a sum_l p_l sum_m
    /// c_lm Y_lm(-d) at each field wavelength (a negative sum counts as none), linear in
    /// wavelength between them and the power law of the end two beyond them (held where
    /// either is 0), attenuated to the eye, times 1 - e^-x Lambda (sc.A).
    void scatterField(const Vec3& xW, const SpectralRay& ray, SpectralScratch& sc) const
    {
        mField->sample(mFieldW2I.apply(xW), sc.fs.data());
        const std::size_t N = mFieldLambda.size();
        bool any = false;
        for (std::size_t i = 0; i < N; ++i) {
            double src = 0.0;
            for (int k = 0; k < mFieldMoments; ++k)
                src += ray.fieldWeight[k] * double(sc.fs[std::size_t(k) * N + i]);
            sc.Sfield[i] = std::max(0.0, src);
            any = any || src > 0.0;
        }
        if (!any) return;
        for (std::size_t j = 0; j < mNodes.size(); ++j) {
            const NodeField& nf = mNodeField[j];
            const double s0 = sc.Sfield[nf.i0], s1 = sc.Sfield[nf.i1];
            double S = s0 + nf.frac * (s1 - s0);
            if (nf.powerLaw) S = s0 > 0.0 && s1 > 0.0 ? s0 * std::pow(s0 / s1, nf.frac) : s0;
            sc.Cfield[j] += S * std::exp(-ray.tau * mNodes.lamExt[j]) * sc.A[j];
        }
    }

    /// Kirchhoff: j = (1 - a) k(lambda_e) B(lambda_e, T), emitted at lambda_e = lambda /
    /// (1 + v_r/c) and stretched by 1 + v_r/c, at each node.
    void blackbodyEmission(const Vec3& pI, const SpectralRay& ray, SpectralScratch& sc) const
    {
        const int tempCh = mScene.temperatureChannel;
        if (!(tempCh >= 0 && sc.f[std::size_t(tempCh)] > 0.0f && mBbFactor > 0.0)) return;
        const double T = mSo.temperatureScale * sc.f[std::size_t(tempCh)];
        const double D = mScene.velocityChannel >= 0 ? dopplerAt(pI, ray.dW) : 1.0;
        for (std::size_t j = 0; j < mNodes.size(); ++j) {
            const double le = mNodes.lam[j] / D;
            const double ratio = D == 1.0 ? 1.0 : mLambda(le) / mNodes.lamExt[j];
            sc.Cgas[j] += mBbFactor * ratio * planckPerNmUnchecked(le, T) / D * sc.A[j] *
                          std::exp(-ray.tau * mNodes.lamExt[j]);
        }
    }

    /// The Doppler factors @p dA, @p dB at the ends of the segment [tm - seg/2, tm + seg/2]
    /// (1 without a velocity grid); the end one is kept for the next segment.
    void segmentDoppler(const Vec3& pI, double tm, double seg, SpectralRay& ray, double& dA,
                        double& dB) const
    {
        dA = dB = 1.0;
        if (mScene.velocityChannel < 0) return;
        const double tA = tm - 0.5 * seg, tB = tm + 0.5 * seg;
        dA = std::abs(tA - ray.lastEndT) <= 1e-9 * seg
                 ? ray.lastEndD
                 : dopplerAt(pI - ray.dI * (0.5 * seg), ray.dW);
        dB = dopplerAt(pI + ray.dI * (0.5 * seg), ray.dW);
        ray.lastEndT = tB;
        ray.lastEndD = dB;
    }

    /// Line emission of the segment [tm - seg/2, tm + seg/2] (V optical depth @p x, Doppler
    /// factors @p dA, @p dB at its ends): each line of each emitter as an exact Doppler
    /// trapezoid (DESIGN §7.2), attenuated at its breakpoints (piecewise-linear mode) or at
    /// the band centres (fixed bands).
    void lineEmission(double dA, double dB, double seg, double x, SpectralRay& ray,
                      SpectralScratch& sc) const
    {
        // The segment's transmittance factor at wavelength lambda: e^-tau L (1 - e^-x L) /
        // (x L) times its length.
        const auto factor = [&](double ext) {
            return seg * std::exp(-ray.tau * ext) * escapeFraction(x * ext);
        };
        const std::size_t J = mNodes.size();
        for (const auto& e : mScene.emitters) {
            const double value = sc.f[std::size_t(e.channel)];
            if (!(value > 0.0)) continue;
            for (const auto& line : e.lines) {
                const LineTrapezoid t = lineTrapezoidFactors(line.wavelength, dA, dB, mLineWidth,
                                                             value * e.unit * line.strength);
                if (t.x[3] <= SPECTRAL_MIN_NM || t.x[0] >= SPECTRAL_MAX_NM) continue;
                if (mNodes.bandsMode) {
                    const double bw = mNodes.bandWidth;
                    const int j0 =
                        std::max(0, int(std::ceil((t.x[0] - SPECTRAL_MIN_NM) / bw - 0.5)));
                    const int j1 = std::min(int(J) - 1,
                                            int(std::floor((t.x[3] - SPECTRAL_MIN_NM) / bw - 0.5)));
                    for (int j = j0; j <= j1; ++j) {
                        const double v = t.at(mNodes.lam[std::size_t(j)]);
                        if (v > 0.0)
                            sc.Cgas[std::size_t(j)] += v * factor(mNodes.lamExt[std::size_t(j)]);
                    }
                } else {
                    double y[4];
                    for (int i = 0; i < 4; ++i) {
                        const double h = (i == 0 || i == 3) ? 0.0 : t.height;
                        y[i] = h * factor(mLambda(t.x[i]));
                    }
                    addLinePiece(t.x[0], y[0], t.x[1], y[1], ray, sc);
                    addLinePiece(t.x[1], y[1], t.x[2], y[2], ray, sc);
                    addLinePiece(t.x[2], y[2], t.x[3], y[3], ray, sc);
                }
            }
        }
    }

    /// One ray step at index point @p pI, ray distance @p tm, length @p seg [pc]. Returns
    /// false once the least absorbed wavelength is dimmer than minTransmittance.
    bool step(const Vec3& pI, double tm, double seg, SpectralRay& ray, SpectralScratch& sc) const
    {
        mRs.fields.sample(pI, sc.f.data());
        ++sc.stats.samples;
        const double n = std::max(0.0f, sc.f[0]), em = sc.f[1];
        if (n <= 0.0 && em <= 0.0) return true;
        if (n > 0.0 && mDepth && mDepth->anyCurved(pI)) { // tau exact where it bends
            for (std::size_t s = 0; s < mRs.stars.size(); ++s)
                if (mDepth->curved(s, pI)) sc.f[2 + s] = float(mDepth->march(s, pI));
        }
        const double x = mDust.kappa_V * n * seg; // the segment's V optical depth
        double dA = 1.0, dB = 1.0;                // Doppler factors at the segment's ends
        if (em > 0.0) segmentDoppler(pI, tm, seg, ray, dA, dB);
        // Absorption lines (DESIGN §7.6): profiles only where channel 1, which holds them, is
        // not 0; the sources' losses everywhere behind the first.
        const bool absorbs = mAbsorption.active();
        const detail::ContinuumAt cont{sc.Cstar.data(), mField ? sc.Cfield.data() : nullptr,
                                       sc.Cgas.data()};
        if (absorbs) {
            if (em > 0.0) mAbsorption.stepProfiles(sc.f.data(), dA, dB, seg, sc.abs);
            mAbsorption.beforeSources(cont, sc.abs);
        }
        if (n > 0.0) {
            // The fraction of the segment's source function that leaves it (1 - e^-x Lambda);
            // the eye's attenuation e^-tau Lambda is folded into each source's.
            for (std::size_t j = 0; j < mNodes.size(); ++j)
                sc.A[j] = -std::expm1(-x * mNodes.lamExt[j]);
            const Vec3 xW = ray.oW + ray.dW * tm;
            scatterStarlight(tm, seg, ray, sc);
            if (mField) scatterField(xW, ray, sc);
            blackbodyEmission(pI, ray, sc);
        }
        if (absorbs) mAbsorption.afterSources(cont, sc.abs);
        if (em > 0.0) lineEmission(dA, dB, seg, x, ray, sc);
        if (absorbs) mAbsorption.endStep(sc.abs);
        ray.tau += x;
        return std::exp(-ray.tau * mNodes.LambdaMin) >= mOpts.minTransmittance;
    }

    /// The pixel's colour (continuum per star and gas, plus the lines), transmittance,
    /// spectral layers and (countPieces) its spectrum's piece count.
    void writePixel(std::size_t pix, const SpectralRay& ray, SpectralScratch& sc, Image& img,
                    const SpectralLayers& ids) const
    {
        const std::size_t S = mRs.stars.size(), J = mNodes.size();
        const int NL = mSo.layers;
        XYZ total = ray.lineXYZ;
        const bool absorbs = mAbsorption.active();
        // Less what the absorption lines took from each component (DESIGN §7.6).
        const auto less = [&](XYZ xyz, std::size_t component) {
            if (!absorbs) return xyz;
            const XYZ d = mAbsorption.deficitXYZ(sc.abs, component);
            for (std::size_t c = 0; c < 3; ++c)
                xyz[c] -= d[c];
            return xyz;
        };
        for (std::size_t s = 0; s < S; ++s) {
            const XYZ xyz = less(nodesToXYZ(&sc.Cstar[s * J], mNodes.weight), s);
            const auto rgb = xyzToLinearSRGB(xyz);
            for (int c = 0; c < 3; ++c) {
                total[std::size_t(c)] += xyz[std::size_t(c)];
                img.rgb(ids.frame.stars[s])[pix * 3 + std::size_t(c)] = float(rgb[std::size_t(c)]);
            }
        }
        const XYZ gas = less(nodesToXYZ(sc.Cgas.data(), mNodes.weight), mAbsorption.gasComponent());
        const XYZ field = less(mField ? nodesToXYZ(sc.Cfield.data(), mNodes.weight) : XYZ{0, 0, 0},
                               mAbsorption.fieldComponent());
        for (int c = 0; c < 3; ++c)
            total[std::size_t(c)] += gas[std::size_t(c)] + field[std::size_t(c)];
        const auto rgb = xyzToLinearSRGB(total);
        std::vector<float>& trans = img.rgb(ids.frame.transmittance);
        for (int c = 0; c < 3; ++c) {
            img.rgba[pix * 4 + std::size_t(c)] = float(rgb[std::size_t(c)]);
            trans[pix * 3 + std::size_t(c)] = float(std::exp(-ray.tau * mRChannel[std::size_t(c)]));
        }
        img.rgba[pix * 4 + 3] = float(1.0 - std::exp(-ray.tau * mRChannel[1]));
        if (NL > 0 || mSo.countPieces) {
            // The whole continuum at the nodes (stars and gas).
            for (std::size_t j = 0; j < J; ++j) {
                sc.Ctotal[j] = sc.Cgas[j] + sc.Cfield[j];
                for (std::size_t s = 0; s < S; ++s)
                    sc.Ctotal[j] += sc.Cstar[s * J + j];
            }
        }
        if (absorbs && NL > 0) layerDeficits(sc);
        for (int b = 0; b < NL; ++b) {
            const double* weight = &mLayerOfNode[std::size_t(b) * J];
            const auto [j0, j1] = mLayerNodes[std::size_t(b)];
            double v = sc.layerAcc[std::size_t(b)];
            for (std::size_t j = j0; j < j1; ++j)
                v += weight[j] * sc.Ctotal[j];
            // The lines' losses: [stars][field][gas] per layer.
            double lost[3] = {0.0, 0.0, 0.0};
            if (absorbs) {
                for (std::size_t c = 0; c < mAbsorption.components(); ++c)
                    lost[std::min<std::size_t>(c < S ? 0 : c - S + 1, 2)] +=
                        sc.layerDeficit[c * std::size_t(NL) + std::size_t(b)];
                v -= lost[0] + lost[1] + lost[2];
            }
            img.values(ids.bands[std::size_t(b)])[pix] = float(v);
            if (!mOpts.componentLayers) continue;
            // The components besides the sprites' "direct".
            double single = -lost[0], field = -lost[1],
                   emission = sc.layerAcc[std::size_t(b)] - lost[2];
            for (std::size_t j = j0; j < j1; ++j) {
                single += weight[j] * (sc.Ctotal[j] - sc.Cgas[j] - sc.Cfield[j]); // the stars'
                field += weight[j] * sc.Cfield[j];
                emission += weight[j] * sc.Cgas[j];
            }
            img.values(ids.single[std::size_t(b)])[pix] = float(single);
            img.values(ids.field[std::size_t(b)])[pix] = float(field);
            img.values(ids.emission[std::size_t(b)])[pix] = float(emission);
        }
        if (mSo.countPieces && !mNodes.bandsMode) countPieces(sc);
        sc.stats.pieces += mNodes.bandsMode ? 0 : J - 1;
    }

    /// Each component's absorption-line losses per spectral layer (sc.layerDeficit).
    void layerDeficits(SpectralScratch& sc) const
    {
        const std::size_t NL = std::size_t(mSo.layers);
        std::fill(sc.layerDeficit.begin(), sc.layerDeficit.end(), 0.0);
        for (std::size_t c = 0; c < mAbsorption.components(); ++c)
            mAbsorption.addDeficitLayers(sc.abs, c, &sc.layerDeficit[c * NL]);
    }

    /// The ray's whole spectrum (continuum pieces between nodes plus the lines, less the
    /// absorption lines' losses), assembled to count its pieces before and after merging.
    void countPieces(SpectralScratch& sc) const
    {
        if (mAbsorption.active()) {
            for (std::size_t c = 0; c < mAbsorption.components(); ++c)
                mAbsorption.deficitPieces(sc.abs, c, sc.rayPieces);
        }
        const auto& lam = mNodes.lam;
        for (std::size_t j = 0; j + 1 < mNodes.size(); ++j) {
            if (sc.Ctotal[j] != 0.0 || sc.Ctotal[j + 1] != 0.0) {
                sc.rayPieces.push_back(
                    pieceThrough(lam[j], sc.Ctotal[j], lam[j + 1], sc.Ctotal[j + 1]));
            }
        }
        Spectrum spec = Spectrum::sum(sc.rayPieces);
        sc.stats.spectrumPieces += spec.size();
        sc.stats.maxSpectrumPieces =
            std::max<std::uint64_t>(sc.stats.maxSpectrumPieces, spec.size());
        if (mSo.mergeTolerance > 0.0) spec.merge(mSo.mergeTolerance);
        sc.stats.mergedPieces += spec.size();
    }

    const SpectralScene& mScene;
    const RenderScene& mRs;
    const RenderOptions& mOpts;
    const SpectralOptions& mSo;
    const DustParams& mDust;
    const ExtinctionTable mLambda;
    const ContinuumNodes mNodes;
    const Projection mCam;
    const Marcher mLevel0;
    const detail::LineAbsorption mAbsorption; ///< inactive without absorption grids
    std::vector<double> mStarSpec;            ///< [s][j]
    double mLayerWidth = 0.0;                 ///< [nm]
    std::vector<double> mLayerOfNode;         ///< [b][j]
    /// Per layer b: the nodes [first, second) whose weight in it is not 0 (a few).
    std::vector<std::pair<std::size_t, std::size_t>> mLayerNodes;
    double mDFloor = 0.0; ///< the least closest approach to a star [pc] (DESIGN §3.5)
    std::vector<Vec3> mStarPos;
    double mBbFactor = 0.0;
    double mLineWidth = 0.0;
    std::array<double, 3> mRChannel{};
    // The spectral scattered-light field (fieldSetup()); mField null without one.
    struct NodeField
    {
        std::size_t i0 = 0, i1 = 0; ///< the field wavelengths a continuum node lies between
        /// Between them: its position (linear in wavelength). Beyond the field's range
        /// (powerLaw): i0 the end wavelength, i1 its neighbour, frac the exponent e.
        double frac = 0.0;
        bool powerLaw = false;
    };
    const SparseVolume* mField = nullptr;
    std::optional<StarDepth> mDepth; ///< with RenderOptions::exactStarDepth
    Affine mFieldW2I;
    int mFieldMoments = 0;
    double mFieldPl[shCount(SH_MAX_DEGREE)] = {}; ///< a p_l per moment
    std::vector<double> mFieldLambda;             ///< the field's wavelengths [nm]
    std::vector<NodeField> mNodeField;            ///< per continuum node
};

} // namespace

std::string spectralChannelName(std::size_t band, std::size_t bands, const std::string& component)
{
    const double width = (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / double(bands);
    const std::string name = bandName(SPECTRAL_MIN_NM + (double(band) + 0.5) * width);
    return component.empty() ? name : component + "." + name;
}

Image renderSpectral(const SpectralScene& scene, const RenderOptions& opts, const Run* run,
                     RenderStats* stats)
{
    const Camera& view = opts.camera;
    if (view.width <= 0 || view.height <= 0) throw UsageError("--res must be WxH with W, H > 0");
    requireRayStep(scene.base, opts.step);
    const SpectralIntegrator integrator(scene, opts);
    const std::size_t NL = std::size_t(integrator.layers());
    const std::size_t parts = opts.componentLayers ? 1 + SPECTRAL_COMPONENT_COUNT : 1;
    if (opts.componentLayers && NL == 0) {
        throw UsageError("the spectral components need spectral layers (--spectral-layers)");
    }
    SpectralLayers ids;
    Image img = detail::frameImage(scene.base, opts, ids.frame, {}, NL * parts);
    // The bands, then (componentLayers) the same bands of each of SPECTRAL_COMPONENTS.
    std::vector<ChannelId>* components[] = {&ids.direct, &ids.single, &ids.field, &ids.emission};
    static_assert(std::size(components) == SPECTRAL_COMPONENT_COUNT);
    for (std::size_t b = 0; b < NL; ++b)
        ids.bands.push_back(img.addChannel(spectralChannelName(b, NL)));
    for (std::size_t k = 1; k < parts; ++k)
        for (std::size_t b = 0; b < NL; ++b) {
            components[k - 1]->push_back(
                img.addChannel(spectralChannelName(b, NL, SPECTRAL_COMPONENTS[k - 1])));
        }
    detail::forEachRowBand(scene.base, opts, integrator.starDepth(), 4, run, "nebrender", stats,
                           [&](int y0, int y1, RenderStats& band) {
                               SpectralScratch sc = integrator.scratch();
                               for (int py = y0; py < y1; ++py) {
                                   for (int px = 0; px < view.width; ++px) {
                                       integrator.renderPixel(px, py, sc, img, ids);
                                   }
                               }
                               band = sc.stats;
                           });
    if (opts.drawStars) integrator.drawSprites(img, ids);
    return img;
}

void validateSpectralOptions(const RenderOptions& opts)
{
    const SpectralOptions& so = opts.spectral;
    if (opts.integrator == Integrator::Path) {
        throw UsageError("--spectral is for the fast integrator (--integrator fast)");
    }
    if (opts.phaseTable) {
        throw UsageError("--spectral does not use --phase (the table's gain depends on the "
                         "wavelength through the voxel's optical thickness); its multiple "
                         "scattering comes from nebscatter --spectral's field");
    }
    if (opts.levels > 0) throw UsageError("--spectral does not use pyramid levels (--levels)");
    if (so.bands < 0 || so.bands > MAX_SPECTRAL_BANDS) {
        throw UsageError(fmt::format("--bands must be in [1, {}] (bands of 0.1 nm at the most; 0: "
                                     "piecewise-linear spectra), got {}",
                                     MAX_SPECTRAL_BANDS, so.bands));
    }
    if (!(so.continuumStep >= MIN_CONTINUUM_STEP && so.continuumStep <= 50.0)) {
        throw UsageError(fmt::format("--continuum-step must be in [{:g}, 50] nm, got {}",
                                     MIN_CONTINUUM_STEP, detail::numberText(so.continuumStep)));
    }
    if (!(so.lineWidth > 0.0) || !std::isfinite(so.lineWidth)) {
        throw UsageError("--line-width must be a finite number > 0 [km/s]");
    }
    if (!(so.exaggerateVelocity > 0.0) || !std::isfinite(so.exaggerateVelocity)) {
        throw UsageError("--exaggerate-velocity must be a finite number > 0 (1: true speeds)");
    }
    if (!(so.blackbodyScale >= 0.0) || !std::isfinite(so.blackbodyScale)) {
        throw UsageError("--blackbody-scale must be a finite number >= 0");
    }
    if (!(so.temperatureScale > 0.0) || !std::isfinite(so.temperatureScale)) {
        throw UsageError("--temperature-scale must be a finite number > 0");
    }
    if (so.layers < 0 || so.layers > 470) throw UsageError("--spectral-layers must be in [0, 470]");
}

namespace {

void checkSpectralInput(const IntegratorInput& input, const RenderOptions&, const Run& run)
{
    if (input.rgbField && !input.spectralField) {
        run.warn(input.source +
                 " has an R, G, B scattered-light field but no spectral one, "
                 "which --spectral needs: this image is single scattering (nebscatter "
                 "--spectral 6 adds one)");
    }
}

std::string describeSpectral(const RenderOptions& opts, const SpectralScene& scene)
{
    const SpectralOptions& so = opts.spectral;
    const std::string& field = scene.base.scatter.description;
    return (so.bands > 0 ? "spectral, " + std::to_string(so.bands) + " fixed bands"
                         : std::string("spectral, piecewise-linear")) +
           ", exaggerate-velocity " + std::to_string(so.exaggerateVelocity) +
           (so.relativistic ? ", relativistic Doppler" : ", first-order Doppler") +
           (field.empty() ? std::string() : ", single scattering + " + field) +
           (scene.absorbers.empty()
                ? std::string()
                : ", absorption lines of " + std::to_string(scene.absorbers.size()) + " grid(s)");
}

void reportSpectral(const RenderOptions& opts, const SpectralScene& scene, const RenderStats& stats,
                    double, const Run& run)
{
    const SpectralOptions& so = opts.spectral;
    const double rays = double(std::max<std::uint64_t>(stats.rays, 1));
    run.info(fmt::format("spectral: {}, {} emission grid(s), {} linear pieces projected "
                         "({:.6g} per ray)",
                         so.bands > 0 ? fmt::format("{} fixed bands", so.bands)
                                      : std::string("piecewise-linear"),
                         scene.emitters.size(), stats.pieces, double(stats.pieces) / rays));
    for (const auto& a : scene.absorbers) {
        run.info(fmt::format("spectral: absorption grid \"{}\" absorbs {}", a.grid,
                             lineListToString(a.lines)));
    }
    if (so.countPieces && so.bands == 0) {
        run.info(fmt::format("spectral: the rays' spectra have {:.6g} pieces on average "
                             "(largest {}), {:.6g} after merging at tolerance {}",
                             double(stats.spectrumPieces) / rays, stats.maxSpectrumPieces,
                             double(stats.mergedPieces) / rays, so.mergeTolerance));
    }
}

} // namespace

namespace detail {

const IntegratorType& spectralIntegrator()
{
    static const IntegratorType type = [] {
        IntegratorType t;
        t.name = "spectral";
        t.chosenBy = "--spectral";
        t.doc = "the fast integrator with spectra along each ray instead of three channels: "
                "piecewise-linear (exact Doppler trapezoids), or --bands";
        t.options = {"--spectral",
                     "--bands",
                     "--continuum-step",
                     "--exaggerate-velocity",
                     "--relativistic",
                     "--line-width",
                     "--lines",
                     "--blackbody-scale",
                     "--temperature-scale",
                     "--temperature-grid",
                     "--velocity-grid",
                     "--spectral-layers",
                     "--count-pieces",
                     "--merge-tolerance",
                     "--step",
                     "--interpolated-tau",
                     "--no-scatter-field"};
        t.calibrated = true;
        t.comment =
            "nebula spectral ray-cast render (DESIGN section 7); linear sRGB of CIE 1931 XYZ";
        // As the fast integrator's; the spectral checks are buildSpectralScene()'s.
        t.validate = requireTableForLevels;
        t.checkInput = checkSpectralInput;
        t.render = [](const SpectralScene& scene, const RenderOptions& opts, const Run* run,
                      RenderStats* stats) { return renderSpectral(scene, opts, run, stats); };
        t.describe = describeSpectral;
        t.report = reportSpectral;
        return t;
    }();
    return type;
}

} // namespace detail

} // namespace nebula
