// SPDX-License-Identifier: Apache-2.0
/// @file fast.cpp
/// The fast integrator (DESIGN §3-5): a ray marched front to back through the dense fields;
/// at every step the gas emits, every star's light scatters towards the eye (single
/// scattering, or the effective phase function and the pyramid levels' terms), and the
/// segment attenuates what lies behind it. One pixel is renderPixel(); one step is
/// FastIntegrator::step(); the physics of a step is in the small functions it calls.

#include "nebula/render/fast.h"

#include "frame.h"
#include "near_star.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/integrator.h"
#include "nebula/render/sprites.h"
#include "nebula/render/star_depth.h"
#include "nebula/volume/block_walk.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

namespace nebula {

namespace {

/// Pyramid level k as the integrator looks it up: world -> index map and voxel size [pc].
struct LevelMap
{
    Affine w2i;
    double voxelWorld;
};

/// What one band of rows needs of its own (reused from pixel to pixel).
struct Scratch
{
    std::vector<float> f, fk;  ///< field samples at level 0 and at a pyramid level
    std::vector<double> starL; ///< per star and channel: the pixel's scattered light
    /// Per level, star and channel: the level's term (phase-factor change times the star's
    /// irradiance factor at that level), resampled every half level-k voxel along the ray
    /// (the level's own resolution) and held between.
    std::vector<double> held;
    std::vector<double> nextT;             ///< per level: ray distance of its next resample [pc]
    std::vector<detail::RayStar> rayStars; ///< per star: as the pixel's ray sees it
    detail::StarNodes nodes;               ///< one step's, for one star
    RenderStats stats;
};

/// The state of one ray: transmittance T and radiance L per channel.
struct RayState
{
    Vec3 oW; ///< world origin: the eye, or the orthographic camera's pixel on its plane
    Vec3 dW; ///< world direction
    /// a p_l Y_lm(-dW) per moment: the scattered-light field's weights towards the eye
    double fieldWeight[shCount(SH_MAX_DEGREE)] = {};
    /// The field cell (lower corner, index space) whose 8 corners' towards-the-eye sums
    /// fieldCorner[corner][c] = sum_k fieldWeight[k] c_k,c hold: a ray takes several samples
    /// in one cell, so each cell's moments are weighted once, not at every sample.
    int fieldCell[3] = {INT_MIN, INT_MIN, INT_MIN};
    double fieldCorner[8][3] = {};
    double T[3] = {1, 1, 1};
    double tauV = 0.0; ///< V optical depth from the eye (the line groups' extinction)
    double L[3] = {0, 0, 0};
    double Lfield[3] = {0, 0, 0};    ///< the part of L from the field (componentLayers)
    double Lemission[3] = {0, 0, 0}; ///< the part of L from the gas's glow (componentLayers)
};

/// The layers renderPixel() writes, looked up once per frame.
struct PixelLayers
{
    detail::FrameLayers frame;
    LayerId field, emission; ///< with RenderOptions::componentLayers
};

class FastIntegrator
{
public:
    FastIntegrator(const RenderScene& scene, const RenderOptions& opts)
        : mScene(scene), mOpts(opts), mDust(scene.dust), mCam(opts.camera),
          mLevel0(scene.fields, scene.blocks, scene.occupied, mCam.eye()),
          mTable(opts.phaseTable.get()),
          mEmitColour(scene.emission.colour.value_or(opts.emissionColor))
    {
        for (const auto& lv : scene.levels) {
            mLevels.push_back(
                {lv.fields.indexToWorld.inverse(), voxelSize(lv.fields.indexToWorld)});
        }
        mDFloor = detail::NEAR_STAR_FLOOR * mLevel0.voxelWorld;
        for (const auto& s : scene.stars) {
            mStarPos.emplace_back(s.position[0], s.position[1], s.position[2]);
        }
        if (opts.exactStarDepth) mDepth.emplace(scene);
        // Effective phase function (DESIGN §4): log t_c = log n + log(kappa_V r_c * voxel
        // size). Replace: the table's Phi; Gain: a p(mu) times Phi / Phi_1 (PhaseUse).
        if (mTable && opts.phaseUse == PhaseUse::Gain) {
            mGainTable = *mTable;
            mGainTable->phi = mTable->gain();
        }
        if (mTable) mLookup.emplace(mGainTable ? *mGainTable : *mTable);
        mGain = mGainTable.has_value();
        mLogTMax = mTable ? std::log(mTable->tMax) : 0.0;
        for (int c = 0; c < 3; ++c)
            mOff0[c] = mTable ? logTOffset(mLevel0.voxelWorld, c) : 0.0;
        if (scene.scatter.order >= 0) {
            mField = &scene.scatter.moments;
            mFieldW2I = mField->indexToWorld.inverse();
            mFieldMoments = shCount(scene.scatter.order);
            const auto p = phaseLegendreMoments(mDust.phase, mDust.g, scene.scatter.order);
            for (int l = 0; l <= scene.scatter.order; ++l)
                for (int m = -l; m <= l; ++m)
                    mFieldPl[shIndex(l, m)] = mDust.albedo * p[std::size_t(l)];
        }
        // Level of detail: the coarsest level any pixel of this frame reaches, built (or
        // taken from the scene's cache) up front. Not with the effective phase function,
        // whose table and pyramid levels are made for level 0's voxel.
        if (opts.lod > 0.0 && !mTable && scene.levels.empty() && detailPays(opts)) {
            mMaxDetail = limitDetail(detailLevelsNeeded(opts), opts.lodMaxDepth);
            const Affine& toWorld = scene.fields.indexToWorld;
            for (int L = 1; L <= mMaxDetail; ++L) {
                const SparseVolume& level = scene.detail.level(scene.fields, L);
                // Level 0's index space to level L's, from their transforms.
                const Affine toLevel = level.indexToWorld.inverse();
                Affine map;
                for (int c = 0; c < 3; ++c) {
                    const Vec3 column =
                        toLevel.applyLinear(toWorld.applyLinear(Vec3(c == 0, c == 1, c == 2)));
                    for (int r = 0; r < 3; ++r)
                        map.m[std::size_t(3 * r + c)] = column[r];
                }
                map.t = toLevel.apply(toWorld.t);
                mDetail.push_back({&level, map});
            }
        }
        mOffLevel.resize(mLevels.size());
        for (std::size_t k = 0; k < mLevels.size(); ++k)
            for (int c = 0; c < 3; ++c)
                mOffLevel[k][c] = logTOffset(mLevels[k].voxelWorld, c);
    }

    /// The exact star depth this integrator marches (null: --interpolated-tau).
    const StarDepth* starDepth() const { return mDepth ? &*mDepth : nullptr; }

    Scratch scratch() const
    {
        const auto C = std::size_t(mScene.fields.channels());
        const std::size_t S = mScene.stars.size();
        Scratch s;
        s.f.resize(C);
        s.fk.resize(C);
        s.starL.resize(S * 3);
        s.held.resize(mLevels.size() * S * 3);
        s.nextT.resize(mLevels.size());
        return s;
    }

    /// Renders pixel (px, py) into @p img's beauty and its layers @p ids.
    void renderPixel(int px, int py, Scratch& sc, Image& img, const PixelLayers& ids) const
    {
        const std::size_t S = mScene.stars.size();
        RayState ray;
        if (!mCam.direction(px + 0.5, py + 0.5, ray.dW)) return; // outside the view: black
        ray.oW = mCam.origin(px + 0.5, py + 0.5);
        if (mField) {
            // Scattered towards the eye: Y_lm of the light's travel direction, -dW.
            double Y[shCount(SH_MAX_DEGREE)];
            realSphericalHarmonics(-ray.dW, mScene.scatter.order, Y);
            for (int k = 0; k < mFieldMoments; ++k)
                ray.fieldWeight[k] = mFieldPl[k] * Y[k];
        }
        std::fill(sc.starL.begin(), sc.starL.end(), 0.0);
        detail::rayStars(mCam, px + 0.5, py + 0.5, ray.oW, ray.dW, mStarPos, mDFloor, sc.rayStars);
        std::fill(sc.nextT.begin(), sc.nextT.end(), -std::numeric_limits<double>::infinity());
        if (mMaxDetail > 0) {
            // A pixel's angular size spans this many pc per pc of distance. Near a star its
            // light falls as 1/r^2: steps of at most a quarter of the distance r to every star
            // there, so the coarse steps sample it as finely as level 0.
            const double footprint = mCam.pixelAngle(px + 0.5, py + 0.5);
            // The closest approaches (from the ray's origin; ODS: off the eye): sc.rayStars.
            const double stepWorld = mOpts.step * mLevel0.voxelWorld;
            const auto cap = [&](double t) {
                double r2 = std::numeric_limits<double>::infinity();
                for (std::size_t s = 0; s < S; ++s) {
                    const double dt = t - sc.rayStars[s].s0;
                    r2 = std::min(r2, sc.rayStars[s].b2 + dt * dt);
                }
                const double r = std::sqrt(r2);
                int level = 0;
                while (level < mMaxDetail && 4.0 * stepWorld * double(2 << level) <= r)
                    ++level;
                return level;
            };
            sc.stats.rays += mLevel0.marchDetail(
                ray.dW, mOpts.step, footprint, mOpts.lod, mMaxDetail, mScene.detailReach, mCoarsest,
                cap, [&](const Vec3& pI, double tm, double seg, int level) {
                    return step(pI, tm, seg, ray, sc, level);
                });
        } else {
            sc.stats.rays += mLevel0.marchFrom(mLevel0.w2i.apply(ray.oW), ray.dW, mOpts.step,
                                               [&](const Vec3& pI, double tm, double seg) {
                                                   return step(pI, tm, seg, ray, sc, 0);
                                               });
        }
        const std::size_t pix = std::size_t(py) * img.width + px;
        std::vector<float>& trans = img.rgb(ids.frame.transmittance);
        for (int c = 0; c < 3; ++c) {
            img.rgba[pix * 4 + c] = float(ray.L[c]);
            trans[pix * 3 + c] = float(ray.T[c]);
            for (std::size_t s = 0; s < S; ++s) {
                img.rgb(ids.frame.stars[s])[pix * 3 + c] = float(sc.starL[s * 3 + c]);
            }
        }
        img.rgba[pix * 4 + 3] = float(1.0 - ray.T[1]);
        if (mOpts.componentLayers) {
            std::vector<float>& field = img.rgb(ids.field);
            std::vector<float>& emission = img.rgb(ids.emission);
            for (int c = 0; c < 3; ++c) {
                field[pix * 3 + c] = float(ray.Lfield[c]);
                emission[pix * 3 + c] = float(ray.Lemission[c]);
            }
        }
    }

private:
    /// log(kappa_V r_c * voxel): added to log n it gives log t_c, the voxel's optical
    /// thickness in channel c.
    double logTOffset(double voxel, int c) const
    {
        return std::log(mDust.kappa_V * mDust.r[c] * voxel);
    }

    /// mu: cosine between the light's travel direction (star -> xW) and the direction to the
    /// eye (-dW); also the squared distance @p r2 [pc^2] to star s.
    double cosToStar(const Vec3& xW, const Vec3& dW, std::size_t s, double& r2) const
    {
        const Vec3 v = xW - mStarPos[s];
        r2 = v.dot(v);
        return r2 > 0.0 ? -v.dot(dW) / std::sqrt(r2) : 1.0;
    }

    /// Phase factor per channel at cosine @p mu: a p(mu) without a table; with one, Phi at
    /// the voxel thickness tPos (Replace) or a p(mu) times the gain (Gain), minus its value at
    /// tPrev if given (a level's change as the voxel doubles).
    void phaseFactors(double mu, const PhaseLookup::Pos* tPos, const PhaseLookup::Pos* tPrev,
                      double out[3]) const
    {
        const double ap = mDust.albedo * phaseFunction(mDust.phase, mu, mDust.g);
        if (!mTable) {
            out[0] = out[1] = out[2] = ap;
            return;
        }
        const auto muPos = mLookup->locateMu(mu);
        for (int c = 0; c < 3; ++c) {
            double v = mLookup->lookup(tPos[c], muPos);
            if (tPrev) v -= mLookup->lookup(tPrev[c], muPos);
            out[c] = mGain ? ap * v : v;
        }
    }

    /// Emission of a segment of length @p seg [pc] with gas @p em (channel 1 of the sample
    /// @p f) and optical depths @p x (per channel): the fraction (1 - e^-x)/x of it reaches
    /// the segment's front, dimmed by the transmittance in front of it. With several
    /// emission grids (SceneEmission::gridChannel), emitGrids() instead.
    void emit(double em, const float* f, const double* x, const double* oneMinus, double seg,
              RayState& ray) const
    {
        if (mScene.emission.gridChannel >= 0) {
            if (em > 0.0) emitGrids(f, x, oneMinus, seg, ray);
            return;
        }
        for (int c = 0; c < 3; ++c) {
            const double emitLen = x[c] > 1e-7 ? oneMinus[c] / x[c] * seg : seg;
            const double add = ray.T[c] * em * mOpts.emissionScale * mEmitColour[c] * emitLen;
            ray.L[c] += add;
            ray.Lemission[c] += add;
        }
    }

    /// The emission grids' line groups (DESIGN §3.4), each dimmed at its own wavelength:
    /// by exp(-ratio tau_V) in front of the segment and (1 - e^-y)/y inside it, y = ratio
    /// times the segment's V optical depth, as the spectral renderer dims a line; a painted
    /// grid per channel, as emit() does.
    void emitGrids(const float* f, const double* x, const double* oneMinus, double seg,
                   RayState& ray) const
    {
        const SceneEmission& se = mScene.emission;
        const double xV = mDust.kappa_V * double(f[0]) * seg; // V optical depth
        for (const SceneEmission::Line& line : se.lines) {
            const double e = f[se.gridChannel + line.grid];
            if (e == 0.0) continue;
            if (line.painted) {
                for (int c = 0; c < 3; ++c) {
                    const double emitLen = x[c] > 1e-7 ? oneMinus[c] / x[c] * seg : seg;
                    const double add =
                        ray.T[c] * e * mOpts.emissionScale * line.colour[c] * emitLen;
                    ray.L[c] += add;
                    ray.Lemission[c] += add;
                }
                continue;
            }
            const double y = line.ratio * xV;
            const double emitLen = y > 1e-7 ? -std::expm1(-y) / y * seg : seg;
            const double w = std::exp(-line.ratio * ray.tauV) * e * mOpts.emissionScale * emitLen;
            for (int c = 0; c < 3; ++c) {
                ray.L[c] += w * line.colour[c];
                ray.Lemission[c] += w * line.colour[c];
            }
        }
    }

    /// Resamples the pyramid levels' terms near xW at ray distance @p tm (DESIGN §5): level
    /// k's density sets its voxel thickness t_k; its term is the change of the phase factor
    /// as a voxel of that density doubles, from t_k / 2 to t_k, times the star's irradiance
    /// through level k's optical depth.
    void resampleLevels(const Vec3& xW, double tm, const Vec3& dW, Scratch& sc) const
    {
        const std::size_t S = mScene.stars.size();
        for (std::size_t k = 0; k < mLevels.size(); ++k) {
            if (tm < sc.nextT[k]) continue;
            const LevelMap& lv = mLevels[k];
            sc.nextT[k] = tm + mOpts.step * lv.voxelWorld;
            mScene.levels[k].fields.sample(lv.w2i.apply(xW), sc.fk.data());
            ++sc.stats.samples;
            double* h = &sc.held[k * S * 3];
            if (!(sc.fk[0] > 0.0f)) {
                std::fill(h, h + S * 3, 0.0);
                continue;
            }
            PhaseLookup::Pos tk[3], tHalf[3];
            const double logNk = std::log(double(sc.fk[0]));
            for (int c = 0; c < 3; ++c) {
                const double lt = logNk + mOffLevel[k][c];
                tk[c] = mLookup->locateLogT(lt);
                tHalf[c] = mLookup->locateLogT(lt - std::log(2.0));
                sc.stats.phaseClamped += lt > mLogTMax;
            }
            for (std::size_t st = 0; st < S; ++st) {
                double r2, phi[3];
                phaseFactors(cosToStar(xW, dW, st, r2), tk, tHalf, phi);
                for (int c = 0; c < 3; ++c) {
                    h[st * 3 + c] = phi[c] * std::exp(-mDust.r[c] * sc.fk[2 + st]);
                }
            }
        }
    }

    /// Every star's light scattered towards the eye from the step [tm - seg/2, tm + seg/2]
    /// (level-0 optical depths @p tauV): the phase factors times the star's
    /// irradiance, plus the held level terms, times the step's mean of 1/(4 pi r^2) and its
    /// 1 - e^-x. Near the star the phase factors are averaged over the step's nodes at equal
    /// angles (DESIGN §3.5).
    void scatterStars(double tm, double seg, const float* tauV, const double* oneMinus,
                      const PhaseLookup::Pos* tPos, RayState& ray, Scratch& sc) const
    {
        const std::size_t S = mScene.stars.size();
        detail::StarNodes& nodes = sc.nodes;
        for (std::size_t s = 0; s < S; ++s) {
            detail::starNodes(sc.rayStars[s], tm - 0.5 * seg, tm + 0.5 * seg, nodes);
            double phi[3] = {0, 0, 0}, src[3];
            for (int i = 0; i < nodes.n; ++i) {
                double p[3];
                phaseFactors(nodes.mu[i], tPos, nullptr, p);
                for (int c = 0; c < 3; ++c)
                    phi[c] += p[c] / nodes.n;
            }
            for (int c = 0; c < 3; ++c)
                src[c] = phi[c] * std::exp(-mDust.r[c] * tauV[s]);
            for (std::size_t k = 0; k < mLevels.size(); ++k) {
                for (int c = 0; c < 3; ++c)
                    src[c] += sc.held[(k * S + s) * 3 + c];
            }
            const double geom = nodes.total / (4.0 * PI * seg);
            for (int c = 0; c < 3; ++c) {
                const double add = ray.T[c] * mScene.starColor[s][c] * geom * src[c] * oneMinus[c];
                ray.L[c] += add;
                sc.starL[s * 3 + c] += add;
            }
        }
    }

    /// The light scattered at least once before (nebscatter's field, DESIGN §5b) scattered
    /// towards the eye at xW: k a sum_l p_l sum_m c_lm Y_lm(-d), the k cancelled by the
    /// segment's (1 - e^-x) / k. A negative sum (noise, truncation) counts as none.
    void scatterField(const Vec3& xW, const double* oneMinus, RayState& ray) const
    {
        // Trilinear in the cell around p (zero outside the lattice, as SparseVolume::sample)
        // of the corners' weighted sums: the same as weighting the interpolated moments.
        int ijk[3];
        double frac[3];
        if (!mField->cellAt(mFieldW2I.apply(xW), ijk, frac)) return;
        const int i = ijk[0], j = ijk[1], k = ijk[2];
        if (i != ray.fieldCell[0] || j != ray.fieldCell[1] || k != ray.fieldCell[2]) {
            std::copy(ijk, ijk + 3, ray.fieldCell);
            // 24 independent sums side by side (one sum at a time waits on each addition).
            const float* m[8];
            mField->cellCorners(i, j, k, m);
            double acc[8][3] = {};
            for (int n = 0; n < mFieldMoments; ++n) {
                const double wn = ray.fieldWeight[n];
                for (int q = 0; q < 8; ++q)
                    for (int c = 0; c < 3; ++c)
                        acc[q][c] += wn * double(m[q][n * 3 + c]);
            }
            std::copy(&acc[0][0], &acc[0][0] + 24, &ray.fieldCorner[0][0]);
        }
        const double u = frac[0], v = frac[1], w = frac[2];
        for (int c = 0; c < 3; ++c) {
            const auto& f = ray.fieldCorner;
            const double c00 = f[0][c] + u * (f[1][c] - f[0][c]);
            const double c10 = f[2][c] + u * (f[3][c] - f[2][c]);
            const double c01 = f[4][c] + u * (f[5][c] - f[4][c]);
            const double c11 = f[6][c] + u * (f[7][c] - f[6][c]);
            const double c0 = c00 + v * (c10 - c00), c1 = c01 + v * (c11 - c01);
            const double src = c0 + w * (c1 - c0);
            if (src > 0.0) {
                ray.L[c] += ray.T[c] * src * oneMinus[c];
                ray.Lfield[c] += ray.T[c] * src * oneMinus[c];
            }
        }
    }

    /// One ray step: the sample at index point @p pI, ray distance @p tm, length @p seg [pc].
    /// Returns false once the ray is opaque in every channel.
    bool step(const Vec3& pI, double tm, double seg, RayState& ray, Scratch& sc, int level) const
    {
        if (level == 0) {
            mScene.fields.sample(pI, sc.f.data());
        } else {
            const Detail& d = mDetail[std::size_t(level - 1)];
            d.fields->sample(d.fromLevel0.apply(pI), sc.f.data());
        }
        ++sc.stats.samples;
        const double n = sc.f[0], em = sc.f[1];
        if (n <= 0.0 && em <= 0.0) return true;
        // tau exact where it bends (level 0: coarser levels average the bends away)
        if (level == 0 && n > 0.0 && mDepth && mDepth->anyCurved(pI)) {
            for (std::size_t s = 0; s < mScene.stars.size(); ++s)
                if (mDepth->curved(s, pI)) sc.f[2 + s] = float(mDepth->march(s, pI));
        }
        // Exact attenuation of a segment of constant k_c: the fraction 1 - e^-x of its source
        // function reaches the segment's front.
        double x[3], oneMinus[3];
        for (int c = 0; c < 3; ++c) {
            x[c] = mDust.kappa_V * mDust.r[c] * n * seg;
            oneMinus[c] = -std::expm1(-x[c]);
        }
        emit(em, sc.f.data(), x, oneMinus, seg, ray);
        if (n > 0.0) {
            PhaseLookup::Pos tPos[3];
            const Vec3 xW = ray.oW + ray.dW * tm;
            if (mTable) {
                const double logN = std::log(n);
                for (int c = 0; c < 3; ++c) {
                    tPos[c] = mLookup->locateLogT(logN + mOff0[c]);
                    sc.stats.phaseClamped += logN + mOff0[c] > mLogTMax;
                }
                resampleLevels(xW, tm, ray.dW, sc);
            }
            scatterStars(tm, seg, &sc.f[2], oneMinus, tPos, ray, sc);
            if (mField) scatterField(xW, oneMinus, ray);
        }
        for (int c = 0; c < 3; ++c)
            ray.T[c] *= 1.0 - oneMinus[c];
        ray.tauV += mDust.kappa_V * n * seg;
        return !(ray.T[0] < mOpts.minTransmittance && ray.T[1] < mOpts.minTransmittance &&
                 ray.T[2] < mOpts.minTransmittance);
    }

    const RenderScene& mScene;
    const RenderOptions& mOpts;
    const ChannelDust& mDust;
    const Projection mCam;
    const Marcher mLevel0;
    std::vector<LevelMap> mLevels;
    double mDFloor = 0.0; ///< the least closest approach to a star [pc] (DESIGN §3.5)
    std::vector<Vec3> mStarPos;
    const PhaseTable* mTable;
    /// The colour of channel 1's emission (SceneEmission::colour, or --emission-color).
    const std::array<double, 3> mEmitColour;
    std::optional<PhaseTable> mGainTable;
    std::optional<PhaseLookup> mLookup;
    bool mGain = false;
    double mLogTMax = 0.0;
    double mOff0[3] = {0, 0, 0};
    std::vector<std::array<double, 3>> mOffLevel;
    /// The largest level of detail a pixel of this frame can reach (DESIGN §9): a pixel's
    /// span at the farthest corner of the lattice, in voxels, times RenderOptions::lod (the
    /// pixels a level's voxel may span).
    int detailLevelsNeeded(const RenderOptions& opts) const
    {
        const SparseVolume& f = mScene.fields;
        double far = 0.0;
        for (int c = 0; c < 8; ++c)
            far = std::max(far, (f.cornerWorld(c) - mCam.eye()).length());
        // The largest pixel: the centre and the corners of the image (perspective pixels
        // shrink away from the centre; fisheye and equirect ones vary less than 2x).
        const Camera& cam = opts.camera;
        double pixel = 0.0;
        for (const auto& [x, y] :
             {std::pair{0.5 * cam.width, 0.5 * cam.height}, std::pair{0.5, 0.5},
              std::pair{cam.width - 0.5, 0.5}, std::pair{0.5, cam.height - 0.5},
              std::pair{cam.width - 0.5, cam.height - 0.5}}) {
            const double angle = mCam.pixelAngle(x, y);
            if (std::isfinite(angle)) pixel = std::max(pixel, angle);
        }
        const double spanVoxels = opts.lod * far * pixel / mLevel0.voxelWorld;
        int level = 0;
        while (level < RenderScene::MAX_DETAIL_LEVEL && spanVoxels >= double(2 << level))
            ++level;
        return level;
    }

    /// Fills mCoarsest, per block the coarsest level up to @p maxLevel whose voxel is
    /// optically thin there: level L where the densest dust a level-L sample in the block can
    /// average (RenderScene::detailDensity) has optical depth at most @p maxDepth across a
    /// level-L voxel in the most opaque channel. Returns the coarsest level any block samples
    /// (one whose dust a level reaches, RenderScene::detailReach), or 0 where fewer than a
    /// tenth of the occupied blocks may coarsen: the levels would not pay for the steps they
    /// add round the dust (the presets whose dust is thick then cost what --lod 0 does,
    /// not up to 1.7x it). Infinite @p maxDepth: none is limited.
    int limitDetail(int maxLevel, double maxDepth)
    {
        if (maxLevel == 0 || maxDepth == std::numeric_limits<double>::infinity()) return maxLevel;
        const double perDensity = mDust.kappa_V * std::max({mDust.r[0], mDust.r[1], mDust.r[2]}) *
                                  mLevel0.voxelWorld; // a voxel's optical depth per unit n_H
        const auto& density = mScene.detailDensity;
        mCoarsest.assign(density.size(), 0);
        int used = 0;
        std::size_t occupied = 0, coarse = 0;
        for (std::size_t b = 0; b < density.size(); ++b) {
            int L = maxLevel;
            while (L > 0 && perDensity * double(1 << L) * double(density[b][L >= 3]) > maxDepth)
                --L;
            mCoarsest[b] = std::uint8_t(L);
            if (mScene.detailReach[b] <= L) used = std::max(used, L);
            occupied += mScene.occupied[b];
            coarse += mScene.occupied[b] && L > 0;
        }
        return 10 * coarse < occupied ? 0 : used;
    }

    /// Whether building the levels can pay: the frame's samples at full resolution (at most
    /// a step per --step voxels of the lattice's diagonal per pixel; a sample costs about 100
    /// ns) against the stored voxels a level's build reads once (about 10 ns each). A 32x18
    /// frame of the 512^3 example does not pay; a 512x512 one does. A scene that has its
    /// levels already takes them.
    bool detailPays(const RenderOptions& opts) const
    {
        const double samples = double(opts.camera.width) * double(opts.camera.height) *
                               latticeDiagonal(mScene) / opts.step;
        const double voxels =
            double(mScene.fields.storedBricks()) * double(SparseVolume::BRICK_VOXELS);
        return 10.0 * samples > voxels || mScene.detail.built() > 0;
    }

    int mMaxDetail = 0; ///< levels of detail 1 .. this are sampled
    /// Per block, the coarsest level of detail sampled there (limitDetail(); empty: no limit).
    std::vector<std::uint8_t> mCoarsest;
    struct Detail
    {
        const SparseVolume* fields;
        Affine fromLevel0; ///< level 0's index space to this level's
    };
    std::vector<Detail> mDetail;          ///< level L at [L - 1]
    const SparseVolume* mField = nullptr; ///< the scattered-light field, if any
    std::optional<StarDepth> mDepth;      ///< with RenderOptions::exactStarDepth
    Affine mFieldW2I;
    int mFieldMoments = 0;
    double mFieldPl[shCount(SH_MAX_DEGREE)] = {}; ///< a p_l per moment index
};

} // namespace

Image renderFrame(const RenderScene& scene, const RenderOptions& opts, const Run* run,
                  RenderStats* stats)
{
    const Camera& view = opts.camera;
    if (view.width <= 0 || view.height <= 0) throw UsageError("--res must be WxH with W, H > 0");
    requireRayStep(scene, opts.step);
    PixelLayers ids;
    Image img = opts.componentLayers
                    ? detail::frameImage(scene, opts, ids.frame,
                                         {FIELD_LAYER, EMISSION_LAYER, DIRECT_LAYER})
                    : detail::frameImage(scene, opts, ids.frame);
    if (opts.componentLayers) {
        ids.field = img.layerId(FIELD_LAYER);
        ids.emission = img.layerId(EMISSION_LAYER);
    }
    const FastIntegrator integrator(scene, opts);
    detail::forEachRowBand(scene, opts, integrator.starDepth(), 4, run, "nebrender", stats,
                           [&](int y0, int y1, RenderStats& bandStats) {
                               Scratch sc = integrator.scratch();
                               for (int py = y0; py < y1; ++py) {
                                   for (int px = 0; px < view.width; ++px) {
                                       integrator.renderPixel(px, py, sc, img, ids);
                                   }
                               }
                               bandStats = sc.stats;
                           });
    if (opts.drawStars) {
        // With the component layers, the sprites alone (the direct starlight) into "direct".
        drawStarSprites(img, scene, opts, {}, {},
                        opts.componentLayers ? &img.rgb(img.layerId(DIRECT_LAYER)) : nullptr);
    }
    return img;
}

namespace {

void checkFastInput(const IntegratorInput& input, const RenderOptions& opts, const Run& run)
{
    if (input.spectralField && !input.rgbField) {
        run.warn(input.source +
                 " has a spectral scattered-light field but no R, G, B one: "
                 "this image is single scattering (render with --spectral, or run nebscatter "
                 "without --spectral to add one)");
    }
    detail::warnUnusedLevels(input, opts, input.rgbField, run);
}

std::string describeFast(const RenderOptions& opts, const SpectralScene& scene)
{
    const RenderScene& rgb = scene.base;
    if (!rgb.scatter.description.empty()) return "single scattering + " + rgb.scatter.description;
    if (!opts.phaseTable) return "single-scattering";
    return std::string("effective phase function (") +
           (opts.phaseUse == PhaseUse::Gain ? "gain" : "replace") + "), levels " +
           std::to_string(rgb.levels.size());
}

} // namespace

namespace detail {

const IntegratorType& fastIntegrator()
{
    static const IntegratorType type = [] {
        IntegratorType t;
        t.name = "fast";
        t.chosenBy = "--integrator fast";
        t.doc = "ray caster (single scattering, or --phase)";
        t.options = {"--step",
                     "--lod",
                     "--phase",
                     "--phase-use",
                     "--levels",
                     "--phase-ignore-dust",
                     "--interpolated-tau",
                     "--no-scatter-field"};
        t.calibrated = true;
        t.comment = "nebula ray-cast render (DESIGN sections 3-4); linear radiance";
        t.validate = detail::requireTableForLevels;
        t.checkInput = checkFastInput;
        t.render = [](const SpectralScene& scene, const RenderOptions& opts, const Run* run,
                      RenderStats* stats) { return renderFrame(scene.base, opts, run, stats); };
        t.describe = describeFast;
        return t;
    }();
    return type;
}

} // namespace detail

} // namespace nebula
