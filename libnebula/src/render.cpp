#include "nebula/render.h"

#include "json_parse.h"

#include "nebula/error.h"
#include "nebula/illumination.h"
#include "nebula/optical_depth.h"
#include "nebula/volume_vdb.h"

#include "marcher.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>

namespace nebula {

using detail::numberText;

namespace {

struct Basis
{
    Vec3 forward, right, up;
    double tanH;
};

Basis cameraBasis(const Camera& c)
{
    Basis b;
    b.forward = (c.lookAt - c.eye).normalized();
    b.right = b.forward.cross(c.up).normalized();
    b.up = b.right.cross(b.forward);
    b.tanH = std::tan(0.5 * c.fovDeg * PI / 180.0);
    return b;
}

} // namespace

void validateCamera(const Camera& c)
{
    const Vec3 f = c.lookAt - c.eye;
    if (!(f.length() > 0.0)) throw UsageError("--eye and --look-at must differ");
    if (!(c.up.length() > 0.0) || !(f.normalized().cross(c.up.normalized()).length() > 1e-6)) {
        throw UsageError("--up must be non-zero and not parallel to the view direction");
    }
}

Vec3 Camera::direction(double px, double py) const
{
    const Basis b = cameraBasis(*this);
    const double sx = (2.0 * px / width - 1.0) * b.tanH;
    const double sy = (1.0 - 2.0 * py / height) * b.tanH * height / width;
    return (b.forward + b.right * sx + b.up * sy).normalized();
}

double Camera::pixelSolidAngle(double px, double py) const
{
    const Basis b = cameraBasis(*this);
    const double du = 2.0 * b.tanH / width;  // square pixels on the image plane at distance 1
    const double sx = (2.0 * px / width - 1.0) * b.tanH;
    const double sy = (1.0 - 2.0 * py / height) * b.tanH * height / width;
    const double cosTheta = 1.0 / std::sqrt(1.0 + sx * sx + sy * sy);
    return du * du * cosTheta * cosTheta * cosTheta;
}

bool Camera::project(const Vec3& p, double& px, double& py) const
{
    const Basis b = cameraBasis(*this);
    const Vec3 v = p - eye;
    const double z = v.dot(b.forward);
    if (z <= 0.0) return false;
    const double sx = v.dot(b.right) / z, sy = v.dot(b.up) / z;
    px = (sx / b.tanH + 1.0) * 0.5 * width;
    py = (1.0 - sy / (b.tanH * height / width)) * 0.5 * height;
    return true;
}

RenderScene buildScene(const GridSet& grids, const CommonOptions& common,
                       const RenderOptions& opts, const DustParams& dust)
{
    RenderScene scene;
    const auto density = grids.floatGrid(common.densityGrid, "--density-grid");
    requireFiniteNonNegative(*density, grids.source);
    openvdb::FloatGrid::Ptr emission;
    if (grids.find(opts.emissionGrid)) {
        emission = grids.floatGrid(opts.emissionGrid, "--emission-grid");
        requireFiniteNonNegative(*emission, grids.source);
    }
    scene.stars = grids.stars();
    if (scene.stars.empty()) {
        throw Error(grids.source + ": no stars: the file has no " + std::string(META_STARS) +
                    " metadata (run nebgen and nebillum, or nebillum --star)");
    }
    if (!emission) {
        emission = openvdb::FloatGrid::create(0.0f);  // no emission: an empty grid
        emission->setTransform(density->transform().copy());
    }
    std::vector<openvdb::FloatGrid::ConstPtr> fields{density, emission};
    for (const auto& s : scene.stars) {
        const std::string name = tauGridName(s.name);
        if (!grids.find(name)) {
            throw Error(grids.source + ": no grid \"" + name + "\" for star \"" + s.name +
                        "\"; run nebillum on this file first");
        }
        auto tau = grids.floatGrid(name, "");
        if (const auto k = tau->getMetadata<openvdb::DoubleMetadata>("kappa_V")) {
            if (std::abs(k->value() - dust.kappa_V) > 1e-9 * dust.kappa_V) {
                throw Error(grids.source + ": grid \"" + name + "\" was computed with kappa_V = " +
                            std::to_string(k->value()) + " but the dust has kappa_V = " +
                            std::to_string(dust.kappa_V) + "; rerun nebillum");
            }
        }
        fields.push_back(tau);
    }
    scene.fields = denseFromGrids(fields, activeBounds({density, fields[1]}, 1), grids.source);

    for (const auto& s : scene.stars) {
        const auto c = blackbodyLinearSRGB(s.temperature);
        scene.starColor.push_back({c[0] * s.luminosity, c[1] * s.luminosity,
                                   c[2] * s.luminosity});
    }
    for (int c = 0; c < 3; ++c) scene.dust.r[c] = extinctionRatio(dust, opts.wavelengths[c]);
    scene.dust.kappa_V = dust.kappa_V;
    scene.dust.albedo = dust.albedo;
    scene.dust.g = dust.g;
    scene.dust.phase = dust.phase;

    if (const auto& table = opts.phaseTable) {
        const auto& m = table->medium;
        const bool same = std::abs(m.albedo - dust.albedo) <= 1e-9 &&
                          std::abs(m.g - dust.g) <= 1e-9 && m.phase == dust.phase;
        if (!same && !opts.phaseIgnoreDust) {
            throw Error(opts.phaseSource + ": the phase table was made for albedo " +
                        numberText(m.albedo) + ", g " + numberText(m.g) + ", phase " +
                        toString(m.phase) + " but " + grids.source + "'s dust has albedo " +
                        numberText(dust.albedo) + ", g " + numberText(dust.g) + ", phase " +
                        toString(dust.phase) +
                        "; rebuild it (nebphase -i " + grids.source +
                        " -o phase.vdb) or pass --phase-ignore-dust");
        }
    }

    scene.buildOccupancy();

    int levelCount = opts.levels;
    if (levelCount < 0) {  // auto: every level the input has, when there is a table
        levelCount = 0;
        while (opts.phaseTable &&
               grids.find(common.densityGrid + ".L" + std::to_string(levelCount + 1))) {
            ++levelCount;
        }
    }
    if (levelCount > 0 && !opts.phaseTable) {
        throw UsageError("--levels needs a phase table (--phase): each level adds the change "
                         "of the per-voxel scattering Phi as the voxel doubles");
    }
    const Affine& a0 = scene.fields.indexToWorld;
    for (int k = 1; k <= levelCount; ++k) {
        const std::string suffix = ".L" + std::to_string(k);
        const std::string dName = common.densityGrid + suffix;
        if (!grids.find(dName)) {
            throw Error(grids.source + ": no grid \"" + dName + "\" for level " +
                        std::to_string(k) + " of --levels " + std::to_string(opts.levels) +
                        "; run nebpyramid --levels " + std::to_string(opts.levels) + " first");
        }
        auto dk = grids.floatGrid(dName, "");
        requireFiniteNonNegative(*dk, grids.source);
        std::vector<openvdb::FloatGrid::ConstPtr> lf{dk, nullptr};
        auto empty = openvdb::FloatGrid::create(0.0f);
        empty->setTransform(dk->transform().copy());
        lf[1] = empty;
        for (const auto& st : scene.stars) {
            const std::string name = tauGridName(st.name) + suffix;
            if (!grids.find(name)) {
                throw Error(grids.source + ": no grid \"" + name + "\" for star \"" + st.name +
                            "\" at level " + std::to_string(k) + "; run nebpyramid on this file");
            }
            lf.push_back(grids.floatGrid(name, ""));
        }
        RenderLevel level;
        level.level = k;
        level.fields = denseFromGrids(lf, activeBounds({dk}, 1), grids.source);
        // Voxels 2^k times level 0's (same orientation): compare the linear maps.
        const auto& ak = level.fields.indexToWorld;
        const double scale = double(1 << k);
        double worst = 0.0, norm = 0.0;
        for (int i = 0; i < 9; ++i) {
            worst = std::max(worst, std::abs(ak.m[std::size_t(i)] - scale * a0.m[std::size_t(i)]));
            norm = std::max(norm, std::abs(scale * a0.m[std::size_t(i)]));
        }
        if (worst > 1e-6 * norm) {
            throw Error(grids.source + ": grid \"" + dName + "\" has voxels that are not " +
                        std::to_string(1 << k) + " times those of \"" + common.densityGrid +
                        "\" (level " + std::to_string(k) + "); rebuild the levels with nebpyramid");
        }
        scene.levels.push_back(std::move(level));
    }
    return scene;
}

void blockMaxima(const DenseVolume& v, std::array<int, 3>& blocks,
                 std::vector<std::array<float, 2>>& maxima)
{
    const int B = RenderScene::BLOCK;
    for (int a = 0; a < 3; ++a) blocks[a] = (v.dims()[a] + B - 1) / B;
    maxima.assign(std::size_t(blocks[0]) * blocks[1] * blocks[2], {0.0f, 0.0f});
    const auto& lo = v.lo();
    for (int k = 0; k < v.dims()[2]; ++k) {
        for (int j = 0; j < v.dims()[1]; ++j) {
            for (int i = 0; i < v.dims()[0]; ++i) {
                const float* q = v.voxel(v.index(lo[0] + i, lo[1] + j, lo[2] + k));
                if (q[0] <= 0.0f && q[1] <= 0.0f) continue;
                // Point (i,j,k) is a corner of cells i-1..i per axis: blocks (i-1)/B, i/B.
                for (int dk = -1; dk <= 0; ++dk)
                    for (int dj = -1; dj <= 0; ++dj)
                        for (int di = -1; di <= 0; ++di) {
                            const int ci = i + di, cj = j + dj, ck = k + dk;
                            if (ci < 0 || cj < 0 || ck < 0 || ci / B >= blocks[0] ||
                                cj / B >= blocks[1] || ck / B >= blocks[2]) {
                                continue;
                            }
                            auto& m = maxima[(std::size_t(ck / B) * blocks[1] + cj / B) *
                                                 blocks[0] + ci / B];
                            m[0] = std::max(m[0], q[0]);
                            m[1] = std::max(m[1], q[1]);
                        }
            }
        }
    }
}


double voxelSize(const Affine& indexToWorld)
{
    const auto& m = indexToWorld.m;
    const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                       m[2] * (m[3] * m[7] - m[4] * m[6]);
    return std::cbrt(std::abs(det));
}

void RenderScene::buildOccupancy()
{
    // A lattice cell is occupied if any of its 8 corners has dust or emission.
    std::vector<std::array<float, 2>> maxima;
    blockMaxima(fields, blocks, maxima);
    occupied.resize(maxima.size());
    for (std::size_t b = 0; b < maxima.size(); ++b) {
        occupied[b] = maxima[b][0] > 0.0f || maxima[b][1] > 0.0f;
    }
}

void drawStarSprites(Image& img, const RenderScene& scene, const RenderOptions& opts,
                     const std::function<std::array<double, 3>(std::size_t, double)>& colour,
                     const std::function<void(std::size_t, std::size_t, double)>& footprint)
{
    const Camera& cam = opts.camera;
    const int W = cam.width, H = cam.height;
    const std::size_t S = scene.stars.size();
    const DenseVolume& vol = scene.fields;
    const Affine& i2w = vol.indexToWorld;
    const Affine w2i = i2w.inverse();
    const auto& dust = scene.dust;
    const Vec3 eyeI = w2i.apply(cam.eye);
    std::vector<Vec3> starPos;
    for (const auto& s : scene.stars) starPos.emplace_back(s.position[0], s.position[1], s.position[2]);
    // Star sprites: the attenuated flux F_c = L_c / (4 pi d^2) e^(-r_c tau) spread over a
    // small Gaussian footprint whose radiance times pixel solid angle sums to F_c.
    if (S > 0) {
        // Column density eye -> star through the dust, exact; the density channel and the
        // integrator's cell occupancy are built once for all stars.
        DenseVolume density(vol.lo(), vol.dims(), 1);
        density.indexToWorld = i2w;
        for (std::size_t i = 0; i < vol.voxelCount(); ++i) density.voxel(i)[0] = vol.voxel(i)[0];
        const ColumnIntegrator column(density);
        for (std::size_t s = 0; s < S; ++s) {
            double sx, sy;
            if (!cam.project(starPos[s], sx, sy)) continue;
            const Vec3 toStar = starPos[s] - cam.eye;
            const double d2 = toStar.dot(toStar);
            const double tauV = dust.kappa_V * column(eyeI, w2i.apply(starPos[s]));
            const double sigma = std::max(0.3, 0.5 * opts.spriteRadius);
            const int R = int(std::ceil(2.0 * opts.spriteRadius)) + 1;
            const int cx = int(std::floor(sx)), cy = int(std::floor(sy));
            std::vector<double> w;
            double wsum = 0.0;
            for (int y = cy - R; y <= cy + R; ++y)
                for (int x = cx - R; x <= cx + R; ++x) {
                    const double dx = x + 0.5 - sx, dy = y + 0.5 - sy;
                    w.push_back(std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma)));
                    wsum += w.back();
                }
            std::array<double, 3> F;
            for (int c = 0; c < 3; ++c) {
                F[std::size_t(c)] = scene.starColor[s][c] / (4.0 * PI * d2) * std::exp(-dust.r[c] * tauV);
            }
            if (colour) {
                const auto col = colour(s, tauV);
                for (int c = 0; c < 3; ++c) F[std::size_t(c)] = col[std::size_t(c)] / (4.0 * PI * d2);
            }
            std::size_t wi = 0;
            for (int y = cy - R; y <= cy + R; ++y)
                for (int x = cx - R; x <= cx + R; ++x, ++wi) {
                    if (x < 0 || y < 0 || x >= W || y >= H) continue;
                    const double omega = cam.pixelSolidAngle(x + 0.5, y + 0.5);
                    const std::size_t pix = std::size_t(y) * W + x;
                    if (footprint) footprint(s, pix, w[wi] / wsum / omega / (4.0 * PI * d2));
                    for (int c = 0; c < 3; ++c) {
                        const float Lpix = float(F[std::size_t(c)] * w[wi] / wsum / omega);
                        img.rgba[pix * 4 + c] += Lpix;
                        img.layers[s].rgb[pix * 3 + c] += Lpix;
                    }
                }
        }
    }
}


Image renderFrame(const RenderScene& scene, const RenderOptions& opts, const Run* run,
                  RenderStats* stats)
{
    std::atomic<std::uint64_t> rayCount{0}, sampleCount{0}, clampedCount{0};
    const Camera& cam = opts.camera;
    if (cam.width <= 0 || cam.height <= 0) throw UsageError("--res must be WxH with W, H > 0");
    if (!(opts.step > 0.0)) throw UsageError("--step must be > 0 voxels");
    const int W = cam.width, H = cam.height;
    const std::size_t S = scene.stars.size();
    Image img(W, H);
    for (const auto& s : scene.stars) {
        img.layers.push_back({"star." + s.name, std::vector<float>(std::size_t(W) * H * 3, 0.0f)});
    }
    img.layers.push_back({"transmittance", std::vector<float>(std::size_t(W) * H * 3, 1.0f)});
    ImageLayer& transLayer = img.layers.back();

    const auto& dust = scene.dust;
    const Marcher level0(scene.fields, scene.blocks, scene.occupied, cam.eye);
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

    Progress bar(run ? *run : Run("nebrender", "", CommonOptions{}), "nebrender",
                 std::uint64_t(H));
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
                        const Vec3 xW = cam.eye + dW * tm;
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
