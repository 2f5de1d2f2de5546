#include "nebula/render/fast.h"


#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/render/sprites.h"

#include "nebula/volume/block_walk.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>

namespace nebula {

Image renderFrame(const RenderScene& scene, const RenderOptions& opts, const Run* run,
                  RenderStats* stats)
{
    std::atomic<std::uint64_t> rayCount{0}, sampleCount{0}, clampedCount{0};
    const Camera& view = opts.camera;
    if (view.width <= 0 || view.height <= 0) throw UsageError("--res must be WxH with W, H > 0");
    if (!(opts.step > 0.0)) throw UsageError("--step must be > 0 voxels");
    const PinholeProjection cam(view);
    const int W = view.width, H = view.height;
    const std::size_t S = scene.stars.size();
    Image img(W, H);
    for (const auto& s : scene.stars) {
        img.layers.push_back({"star." + s.name, std::vector<float>(std::size_t(W) * H * 3, 0.0f)});
    }
    img.layers.push_back({"transmittance", std::vector<float>(std::size_t(W) * H * 3, 1.0f)});
    ImageLayer& transLayer = img.layers.back();

    const auto& dust = scene.dust;
    const Marcher level0(scene.fields, scene.blocks, scene.occupied, cam.eye());
    // Pyramid levels: world -> index map and voxel size of each.
    struct LevelMap
    {
        Affine w2i;
        double voxelWorld;
    };
    std::vector<LevelMap> levels;
    for (const auto& lv : scene.levels) {
        levels.push_back({lv.fields.indexToWorld.inverse(), voxelSize(lv.fields.indexToWorld)});
    }
    const double rmin2 = std::pow(opts.minStarDistance * level0.voxelWorld, 2);
    const int C = scene.fields.channels();
    std::vector<Vec3> starPos;
    for (const auto& s : scene.stars) starPos.emplace_back(s.position[0], s.position[1], s.position[2]);

    // Effective phase function (DESIGN §4): log t_c = log n + log(kappa_V r_c * voxel size).
    // Replace: the table's Phi; Gain: a p(mu) times Phi / Phi_1 (PhaseUse).
    const PhaseTable* table = opts.phaseTable.get();
    std::optional<PhaseTable> gainTable;
    if (table && opts.phaseUse == PhaseUse::Gain) {
        gainTable = *table;
        gainTable->phi = table->gain();
    }
    std::optional<PhaseLookup> lookup;
    if (table) lookup.emplace(gainTable ? *gainTable : *table);
    const bool gain = gainTable.has_value();
    const double logTMax = table ? std::log(table->tMax) : 0.0;
    auto logTOffset = [&](double voxel, int c) { return std::log(dust.kappa_V * dust.r[c] * voxel); };

    Progress bar(run, "nebrender", std::uint64_t(H));
    tbb::parallel_for(tbb::blocked_range<int>(0, H, 4), [&](const tbb::blocked_range<int>& rows) {
        std::vector<float> f(static_cast<std::size_t>(C)), fk(static_cast<std::size_t>(C));
        std::vector<double> starL(S * 3);
        // Per level, star and channel: the level's term (phase-factor change times the
        // star's irradiance factor at that level), resampled every half level-k voxel along
        // the ray (the level's own resolution) and held between.
        std::vector<double> held(levels.size() * S * 3), nextT(levels.size());
        std::uint64_t rays = 0, samples = 0, clamped = 0;
        double off0[3];
        for (int c = 0; c < 3; ++c) off0[c] = table ? logTOffset(level0.voxelWorld, c) : 0.0;
        std::vector<std::array<double, 3>> offLevel(levels.size());
        for (std::size_t k = 0; k < levels.size(); ++k)
            for (int c = 0; c < 3; ++c) offLevel[k][c] = logTOffset(levels[k].voxelWorld, c);

        // Scattering source of star s per channel at a sample: phase factor per channel.
        auto phaseFactors = [&](double mu, const PhaseLookup::Pos* tPos,
                                const PhaseLookup::Pos* tPrev, double out[3]) {
            const double ap = dust.albedo * phaseFunction(dust.phase, mu, dust.g);
            if (!table) {
                out[0] = out[1] = out[2] = ap;
                return;
            }
            const auto muPos = lookup->locateMu(mu);
            for (int c = 0; c < 3; ++c) {
                double v = lookup->lookup(tPos[c], muPos);
                if (tPrev) v -= lookup->lookup(tPrev[c], muPos);
                out[c] = gain ? ap * v : v;
            }
        };

        for (int py = rows.begin(); py != rows.end(); ++py) {
            for (int px = 0; px < W; ++px) {
                const Vec3 dW = cam.direction(px + 0.5, py + 0.5);
                double T[3] = {1, 1, 1}, L[3] = {0, 0, 0};
                std::fill(starL.begin(), starL.end(), 0.0);
                // Adds every star's scattered light at world point xW (level-0 density n):
                // for each star the phase factors at level 0 (t_0) times its irradiance from
                // level 0's tau, plus per pyramid level k the change of the factor from
                // t_k / 2 to t_k times the irradiance from level k's tau (DESIGN §5).
                std::fill(nextT.begin(), nextT.end(), -std::numeric_limits<double>::infinity());
                auto cosToStar = [&](const Vec3& xW, std::size_t s, double& r2) {
                    const Vec3 v = xW - starPos[s];
                    r2 = v.dot(v);
                    return r2 > 0.0 ? -v.dot(dW) / std::sqrt(r2) : 1.0;
                };
                auto scatter = [&](const Vec3& xW, const float* tauV, const double* oneMinus,
                                   const double* Tv, const PhaseLookup::Pos* tPos) {
                    for (std::size_t s = 0; s < S; ++s) {
                        double r2;
                        const double mu = cosToStar(xW, s, r2);
                        double phi[3], src[3];
                        phaseFactors(mu, tPos, nullptr, phi);
                        for (int c = 0; c < 3; ++c) src[c] = phi[c] * std::exp(-dust.r[c] * tauV[s]);
                        for (std::size_t k = 0; k < levels.size(); ++k) {
                            for (int c = 0; c < 3; ++c) src[c] += held[(k * S + s) * 3 + c];
                        }
                        const double geom = 1.0 / (4.0 * PI * std::max(r2, rmin2));
                        for (int c = 0; c < 3; ++c) {
                            const double add = Tv[c] * scene.starColor[s][c] * geom * src[c] * oneMinus[c];
                            L[c] += add;
                            starL[s * 3 + c] += add;
                        }
                    }
                };

                // Level 0: emission and scattering with the full detail.
                rays += level0.march(dW, opts.step, [&](const Vec3& pI, double tm, double seg) {
                    scene.fields.sample(pI, f.data());
                    ++samples;
                    const double n = f[0], em = f[1];
                    if (n <= 0.0 && em <= 0.0) return true;
                    // Exact attenuation of a segment of constant k_c: the fraction 1 - e^-x
                    // of its source function reaches the segment's front.
                    double x[3], oneMinus[3];
                    for (int c = 0; c < 3; ++c) {
                        x[c] = dust.kappa_V * dust.r[c] * n * seg;
                        oneMinus[c] = -std::expm1(-x[c]);
                        const double emitLen = x[c] > 1e-7 ? oneMinus[c] / x[c] * seg : seg;
                        L[c] += T[c] * em * opts.emissionScale * opts.emissionColor[c] * emitLen;
                    }
                    if (n > 0.0) {
                        PhaseLookup::Pos tPos[3];
                        const Vec3 xW = cam.eye() + dW * tm;
                        if (table) {
                            const double logN = std::log(n);
                            for (int c = 0; c < 3; ++c) {
                                tPos[c] = lookup->locateLogT(logN + off0[c]);
                                clamped += logN + off0[c] > logTMax;
                            }
                            // The coarse levels near this point: level k's density sets its
                            // voxel thickness t_k; its term is the change of the phase factor as
                            // a voxel of that density doubles, from t_k / 2 to t_k, times the
                            // star's irradiance through level k's optical depth.
                            for (std::size_t k = 0; k < levels.size(); ++k) {
                                if (tm < nextT[k]) continue;
                                const LevelMap& lv = levels[k];
                                nextT[k] = tm + opts.step * lv.voxelWorld;
                                scene.levels[k].fields.sample(lv.w2i.apply(xW), fk.data());
                                ++samples;
                                double* h = &held[k * S * 3];
                                if (!(fk[0] > 0.0f)) {
                                    std::fill(h, h + S * 3, 0.0);
                                    continue;
                                }
                                PhaseLookup::Pos tk[3], tHalf[3];
                                const double logNk = std::log(double(fk[0]));
                                for (int c = 0; c < 3; ++c) {
                                    const double lt = logNk + offLevel[k][c];
                                    tk[c] = lookup->locateLogT(lt);
                                    tHalf[c] = lookup->locateLogT(lt - std::log(2.0));
                                    clamped += lt > logTMax;
                                }
                                for (std::size_t st = 0; st < S; ++st) {
                                    double r2, phi[3];
                                    phaseFactors(cosToStar(xW, st, r2), tk, tHalf, phi);
                                    for (int c = 0; c < 3; ++c) {
                                        h[st * 3 + c] = phi[c] * std::exp(-dust.r[c] * fk[2 + st]);
                                    }
                                }
                            }
                        }
                        scatter(xW, &f[2], oneMinus, T, tPos);
                    }
                    for (int c = 0; c < 3; ++c) T[c] *= 1.0 - oneMinus[c];
                    return !(T[0] < opts.minTransmittance && T[1] < opts.minTransmittance &&
                             T[2] < opts.minTransmittance);
                });

                const std::size_t pix = std::size_t(py) * W + px;
                for (int c = 0; c < 3; ++c) {
                    img.rgba[pix * 4 + c] = float(L[c]);
                    transLayer.rgb[pix * 3 + c] = float(T[c]);
                    for (std::size_t s = 0; s < S; ++s) {
                        img.layers[s].rgb[pix * 3 + c] = float(starL[s * 3 + c]);
                    }
                }
                img.rgba[pix * 4 + 3] = float(1.0 - T[1]);
            }
        }
        bar.add(std::uint64_t(rows.size()));
        rayCount += rays;
        sampleCount += samples;
        clampedCount += clamped;
    });
    if (stats) {
        stats->rays = rayCount;
        stats->samples = sampleCount;
        stats->phaseClamped = clampedCount;
    }
    if (opts.drawStars) drawStarSprites(img, scene, opts);
    return img;
}

} // namespace nebula
