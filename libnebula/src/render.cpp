#include "nebula/render.h"

#include "json_parse.h"

#include "nebula/error.h"
#include "nebula/illumination.h"
#include "nebula/optical_depth.h"
#include "nebula/volume_vdb.h"

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
    for (int c = 0; c < 3; ++c) scene.dust.r[c] = ccmExtinction(opts.wavelengths[c], dust.R_V);
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
    return scene;
}

void RenderScene::buildOccupancy()
{
    // Occupancy: a lattice cell is occupied if any of its 8 corners has dust or emission.
    const auto& v = fields;
    const int B = BLOCK;
    for (int a = 0; a < 3; ++a) blocks[a] = (v.dims()[a] + B - 1) / B;
    occupied.assign(std::size_t(blocks[0]) * blocks[1] * blocks[2], 0);
    const auto& lo = v.lo();
    for (int k = 0; k < v.dims()[2]; ++k) {
        for (int j = 0; j < v.dims()[1]; ++j) {
            for (int i = 0; i < v.dims()[0]; ++i) {
                const float* q = v.voxel(v.index(lo[0] + i, lo[1] + j, lo[2] + k));
                if (q[0] <= 0.0f && q[1] <= 0.0f) continue;
                for (int dk = -1; dk <= 0; ++dk)
                    for (int dj = -1; dj <= 0; ++dj)
                        for (int di = -1; di <= 0; ++di) {
                            const int ci = i + di, cj = j + dj, ck = k + dk;
                            if (ci < 0 || cj < 0 || ck < 0) continue;
                            occupied[(std::size_t(ck / B) * blocks[1] + cj / B) *
                                               blocks[0] + ci / B] = 1;
                        }
            }
        }
    }
}

void drawStarSprites(Image& img, const RenderScene& scene, const RenderOptions& opts)
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
            std::size_t wi = 0;
            for (int y = cy - R; y <= cy + R; ++y)
                for (int x = cx - R; x <= cx + R; ++x, ++wi) {
                    if (x < 0 || y < 0 || x >= W || y >= H) continue;
                    const double omega = cam.pixelSolidAngle(x + 0.5, y + 0.5);
                    const std::size_t pix = std::size_t(y) * W + x;
                    for (int c = 0; c < 3; ++c) {
                        const double F = scene.starColor[s][c] / (4.0 * PI * d2) *
                                         std::exp(-dust.r[c] * tauV);
                        const float Lpix = float(F * w[wi] / wsum / omega);
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
    std::atomic<std::uint64_t> rayCount{0}, sampleCount{0};
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

    const DenseVolume& vol = scene.fields;
    const Affine& i2w = vol.indexToWorld;
    const Affine w2i = i2w.inverse();
    const auto& m = i2w.m;
    const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                       m[2] * (m[3] * m[7] - m[4] * m[6]);
    const double voxelWorld = std::cbrt(std::abs(det));
    const double rmin2 = std::pow(opts.minStarDistance * voxelWorld, 2);
    const auto& dust = scene.dust;
    const int C = vol.channels();
    const int B = RenderScene::BLOCK;
    std::vector<Vec3> starPos;
    for (const auto& s : scene.stars) starPos.emplace_back(s.position[0], s.position[1], s.position[2]);
    const Vec3 boxLo(vol.lo()[0], vol.lo()[1], vol.lo()[2]);
    const Vec3 boxHi(vol.lo()[0] + vol.dims()[0] - 1, vol.lo()[1] + vol.dims()[1] - 1,
                     vol.lo()[2] + vol.dims()[2] - 1);
    const Vec3 eyeI = w2i.apply(cam.eye);
    // Effective phase function: log t_c = log n + log(kappa_V r_c * voxel size).
    const PhaseTable* table = opts.phaseTable.get();
    std::optional<PhaseLookup> lookup;
    double logTOffset[3] = {0, 0, 0};
    double tMaxDensity = std::numeric_limits<double>::infinity();  // n above it: t > t_max
    if (table) {
        lookup.emplace(*table);
        for (int c = 0; c < 3; ++c) logTOffset[c] = std::log(dust.kappa_V * dust.r[c] * voxelWorld);
        const double rMax = std::max({dust.r[0], dust.r[1], dust.r[2]});
        tMaxDensity = table->tMax / (dust.kappa_V * rMax * voxelWorld);
    }
    std::atomic<std::uint64_t> clampedCount{0};

    Progress bar(run ? *run : Run("nebrender", "", CommonOptions{}), "nebrender",
                 std::uint64_t(H));
    tbb::parallel_for(tbb::blocked_range<int>(0, H, 4), [&](const tbb::blocked_range<int>& rows) {
        std::vector<float> f(static_cast<std::size_t>(C));
        std::vector<double> starL(S * 3);
        std::uint64_t rays = 0, samples = 0, clamped = 0;
        for (int py = rows.begin(); py != rows.end(); ++py) {
            for (int px = 0; px < W; ++px) {
                const Vec3 dW = cam.direction(px + 0.5, py + 0.5);
                const Vec3 dI = w2i.applyLinear(dW);
                // Ray parameter t is world distance from the eye; clip to the lattice box.
                double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
                for (int a = 0; a < 3; ++a) {
                    if (std::abs(dI[a]) < 1e-300) {
                        if (eyeI[a] < boxLo[a] || eyeI[a] > boxHi[a]) t1 = -1.0;
                        continue;
                    }
                    double ta = (boxLo[a] - eyeI[a]) / dI[a], tb = (boxHi[a] - eyeI[a]) / dI[a];
                    if (ta > tb) std::swap(ta, tb);
                    t0 = std::max(t0, ta);
                    t1 = std::min(t1, tb);
                }
                double T[3] = {1, 1, 1}, L[3] = {0, 0, 0};
                std::fill(starL.begin(), starL.end(), 0.0);
                const double dt = opts.step / dI.length();
                rays += t0 < t1;
                for (double t = t0; t < t1;) {
                    const double seg = std::min(dt, t1 - t);
                    const double tm = t + 0.5 * seg;
                    const Vec3 pI = eyeI + dI * tm;
                    // Empty-space skipping: jump to the exit of an empty occupancy block.
                    const int bi = int(std::floor(pI.x - boxLo.x)) / B,
                              bj = int(std::floor(pI.y - boxLo.y)) / B,
                              bk = int(std::floor(pI.z - boxLo.z)) / B;
                    if (bi >= 0 && bj >= 0 && bk >= 0 && bi < scene.blocks[0] &&
                        bj < scene.blocks[1] && bk < scene.blocks[2] &&
                        !scene.occupied[(std::size_t(bk) * scene.blocks[1] + bj) *
                                            scene.blocks[0] + bi]) {
                        double tExit = t1;
                        const int bb[3] = {bi, bj, bk};
                        for (int a = 0; a < 3; ++a) {
                            if (std::abs(dI[a]) < 1e-300) continue;
                            const double face = boxLo[a] + B * (bb[a] + (dI[a] > 0 ? 1 : 0));
                            tExit = std::min(tExit, (face - eyeI[a]) / dI[a]);
                        }
                        t = std::max(tExit, t + 1e-6 * dt);
                        continue;
                    }
                    vol.sample(pI, f.data());
                    ++samples;
                    const double n = f[0], em = f[1];
                    if (n <= 0.0 && em <= 0.0) {
                        t += seg;
                        continue;
                    }
                    const Vec3 xW = cam.eye + dW * tm;
                    // Exact attenuation of a segment of constant k_c: the fraction 1 - e^-x
                    // of its source function reaches the segment's front.
                    double x[3], oneMinus[3], emitLen[3];
                    for (int c = 0; c < 3; ++c) {
                        x[c] = dust.kappa_V * dust.r[c] * n * seg;
                        oneMinus[c] = -std::expm1(-x[c]);
                        emitLen[c] = x[c] > 1e-7 ? oneMinus[c] / x[c] * seg : seg;
                        L[c] += T[c] * em * opts.emissionScale * opts.emissionColor[c] *
                                emitLen[c];
                    }
                    if (n > 0.0) {
                        PhaseLookup::Pos tPos[3];
                        if (table) {
                            const double logN = std::log(n);
                            for (int c = 0; c < 3; ++c) tPos[c] = lookup->locateLogT(logN + logTOffset[c]);
                            if (n > tMaxDensity) {
                                for (int c = 0; c < 3; ++c) {
                                    clamped += logN + logTOffset[c] > std::log(table->tMax);
                                }
                            }
                        }
                        for (std::size_t s = 0; s < S; ++s) {
                            // Scattering of star s: source = Phi_c(t_c, mu) E_s,c, Phi -> a p(mu)
                            // without a table (single scattering, DESIGN §3-4).
                            const Vec3 v = xW - starPos[s];
                            const double r2 = v.dot(v);
                            const double mu = r2 > 0.0 ? -v.dot(dW) / std::sqrt(r2) : 1.0;
                            double phi[3];
                            if (table) {
                                const auto muPos = lookup->locateMu(mu);
                                for (int c = 0; c < 3; ++c) phi[c] = lookup->lookup(tPos[c], muPos);
                            } else {
                                phi[0] = phi[1] = phi[2] =
                                    dust.albedo * phaseFunction(dust.phase, mu, dust.g);
                            }
                            const double geom = 1.0 / (4.0 * PI * std::max(r2, rmin2));
                            const double tauV = f[2 + s];
                            for (int c = 0; c < 3; ++c) {
                                const double E = scene.starColor[s][c] * geom * phi[c] *
                                                 std::exp(-dust.r[c] * tauV);
                                const double add = T[c] * E * oneMinus[c];
                                L[c] += add;
                                starL[s * 3 + c] += add;
                            }
                        }
                    }
                    for (int c = 0; c < 3; ++c) T[c] *= 1.0 - oneMinus[c];
                    if (T[0] < opts.minTransmittance && T[1] < opts.minTransmittance &&
                        T[2] < opts.minTransmittance) {
                        break;
                    }
                    t += seg;
                }
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
