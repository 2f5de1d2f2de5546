// SPDX-License-Identifier: Apache-2.0
/// @file path_tracer.cpp
/// nebrender's reference integrator (DESIGN §6): unbiased volumetric path tracing with delta
/// and ratio tracking against a block-wise constant majorant; see render.h.

#include "nebula/render/path_tracer.h"

#include "frame.h"
#include "near_star.h"

#include "nebula/core/units.h"
#include "nebula/physics/colour.h"
#include "nebula/render/sprites.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/rng.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nebula {

namespace {

constexpr double INF = std::numeric_limits<double>::infinity();
constexpr double RATIO_TRACKING_SCALE = 2.0; ///< majorant multiple for transmittance

/// What a walk needs: density and emission only (2 channels, or 5 with per-channel emission:
/// then 2 + c holds channel c's), the majorant per occupancy block and channel, and the stars.
struct PathScene
{
    SparseVolume fields; ///< 0 density n_H, 1 emission, [2 + c emission of channel c]
    Affine w2i;
    std::array<int, 3> blocks{0, 0, 0};
    std::vector<std::array<float, 3>> majorant; ///< per block: per channel [1/pc]
    std::vector<Vec3> starPos;
    const RenderScene* scene = nullptr;
    double emissionScale = 1.0;
    std::array<double, 3> emissionColor{1, 1, 1};
    double rmin2 = 0.0;
};

PathScene buildPathScene(const RenderScene& scene, const RenderOptions& opts)
{
    PathScene ps;
    ps.scene = &scene;
    const SparseVolume& v = scene.fields;
    // Several emission grids (DESIGN §3.4): each channel's emissivity, every line group
    // dimmed by the channels' extinction (a walk has no per-line transmittance).
    const SceneEmission& se = scene.emission;
    ps.fields = SparseVolume(v.lo(), v.dims(), se.gridChannel < 0 ? 2 : 5);
    ps.fields.indexToWorld = v.indexToWorld;
    v.forEachStoredBrick([&](std::size_t first) {
        for (std::size_t i = first; i < first + SparseVolume::BRICK_VOXELS; ++i) {
            float* q = ps.fields.writable(i);
            const float* p = v.voxel(i);
            q[0] = p[0];
            q[1] = p[1];
            if (se.gridChannel < 0) continue;
            for (int c = 0; c < 3; ++c) {
                double sum = 0.0;
                for (const auto& line : se.lines)
                    sum += line.colour[std::size_t(c)] * double(p[se.gridChannel + line.grid]);
                q[2 + c] = float(sum);
            }
        }
    });
    ps.w2i = v.indexToWorld.inverse();
    const double voxelWorld = voxelSize(v.indexToWorld);
    ps.rmin2 = std::pow(opts.minStarDistance * voxelWorld, 2);
    ps.emissionScale = opts.emissionScale;
    ps.emissionColor = scene.emission.colour.value_or(opts.emissionColor);
    for (const auto& s : scene.stars)
        ps.starPos.emplace_back(s.position[0], s.position[1], s.position[2]);

    // Majorant per block of BLOCK^3 cells from the largest density (emission) at its cells'
    // corners: the trilinear field inside a cell never exceeds its corners.
    std::vector<std::array<float, 2>> maxima;
    blockMaxima(v, ps.blocks, maxima);
    const std::size_t nb = maxima.size();
    // Where there is gas, at least two tentative collisions per voxel length, so that the
    // collision estimator samples the emission finely enough to have little variance.
    const double emissionFloor = 2.0 / voxelWorld;
    ps.majorant.resize(nb);
    for (std::size_t b = 0; b < nb; ++b) {
        for (int c = 0; c < 3; ++c) {
            double mu = scene.dust.kappa_V * scene.dust.r[c] * maxima[b][0];
            if (maxima[b][1] > 0.0f) mu = std::max(mu, emissionFloor);
            // A little headroom against float rounding of the trilinear interpolation.
            ps.majorant[b][c] = float(mu * (1.0 + 1e-5));
        }
    }
    return ps;
}

/// A ray (world origin @p o, unit world direction @p d) walked through the majorant blocks
/// (the shared BlockRay); world distance t is the parameter.
struct Tracker
{
    const PathScene& ps;
    BlockRay ray;
    double t0, t1; ///< clipped to the lattice box

    Tracker(const PathScene& s, const Vec3& o, const Vec3& d, double tMax)
        : ps(s), ray(s.fields, s.w2i, s.blocks, o, d, tMax), t0(ray.t0), t1(ray.t1)
    {}

    /// The block holding point t along the ray and the t where the ray leaves it. Returns
    /// false outside the block grid.
    bool block(double t, int& b, double& tExit) const
    {
        int bb[3];
        if (!ray.blockAt(ray.oI + ray.dI * t, b, bb)) return false;
        tExit = ray.blockExit(bb);
        return true;
    }

    /// Calls @p visit(t, majorant) at each tentative collision of channel @p c in (t0, t1),
    /// with the majorant times @p scale, until it returns false; returns true if the ray left
    /// the box (no stop).
    template <class Visit>
    bool track(int c, Pcg32& rng, std::uint64_t& collisions, Visit&& visit,
               double scale = 1.0) const
    {
        double t = t0;
        while (t < t1) {
            int b;
            double tExit;
            if (!block(t + 1e-9 * (1.0 + std::abs(t)), b, tExit)) return true;
            tExit = std::max(tExit, t + 1e-9 * (1.0 + std::abs(t)));
            const double mu = scale * ps.majorant[b][c];
            if (mu <= 0.0) {
                t = tExit;
                continue;
            }
            for (;;) {
                t += -std::log1p(-rng.uniformDouble()) / mu;
                if (t >= tExit) break;
                ++collisions;
                if (!visit(t, mu)) return false;
            }
            t = tExit;
        }
        return true;
    }
};

/// Ratio-tracked transmittance @p T of all three channels at once from @p x along unit @p d
/// over world length @p len (infinite: through the whole volume), against twice channel
/// @p cmax's majorant (the largest): each tentative collision multiplies channel c's
/// estimate by 1 - k_c / (2 majorant), at least 1/2 instead of nearly 0, so the estimate is
/// not all-or-nothing; its variance in a uniform medium falls from e^-tau - e^-2tau to
/// e^-1.5tau - e^-2tau for twice the lookups.
void transmittance(const PathScene& ps, int cmax, const Vec3& x, const Vec3& d, double len,
                   Pcg32& rng, std::uint64_t& collisions, double T[3])
{
    const Tracker tr(ps, x, d, len);
    const auto& dust = ps.scene->dust;
    T[0] = T[1] = T[2] = 1.0;
    tr.track(
        cmax, rng, collisions,
        [&](double t, double mu) {
            const double n = ps.fields.sample0(tr.ray.oI + tr.ray.dI * t);
            for (int c = 0; c < 3; ++c)
                T[c] *= std::max(0.0, 1.0 - dust.kappa_V * dust.r[c] * n / mu);
            return T[0] > 1e-12 || T[1] > 1e-12 || T[2] > 1e-12;
        },
        RATIO_TRACKING_SCALE);
}

/// One random walk from the eye along @p d0 for the three channels: adds each channel's
/// radiance to @p L[c] (and each star's share to @p Ls[s * 3 + c]) and sets the primary
/// ray's ratio-tracked transmittance @p Tprim[c]. Free flights against the majorant of
/// channel @p cmax, the most extinguished. In @p grey dust the channels share every
/// decision: a tentative collision is real with probability k / k_maj. In coloured dust the
/// walk is spectrally tracked (Kutz et al. 2017): it scatters with probability
/// P = sum_c beta_c k_c / (majorant sum_c beta_c) (the channels' mean, weighted by their
/// throughput), and each channel's throughput beta_c is multiplied by its own
/// (k_c / majorant) / P, or (1 - k_c / majorant) / (1 - P) at a null collision: unbiased for
/// every channel, with one walk instead of three.
void walk(const PathScene& ps, int cmax, bool grey, const Vec3& eye, const Vec3& d0, Pcg32& rng,
          double* L, double* Ls, double* Tprim, std::uint64_t& collisions)
{
    const auto& dust = ps.scene->dust;
    const bool perChannel = ps.fields.channels() == 5;
    double emitC[3], k0[3];
    for (int c = 0; c < 3; ++c) {
        emitC[c] = ps.emissionScale * ps.emissionColor[c];
        k0[c] = dust.kappa_V * dust.r[c];
    }
    Vec3 x = eye, d = d0;
    double beta[3] = {1.0, 1.0, 1.0};
    // The primary ray's transmittance (alpha and the transmittance layer), ratio tracked.
    transmittance(ps, cmax, eye, d0, INF, rng, collisions, Tprim);
    for (int depth = 0;; ++depth) {
        const Tracker tr(ps, x, d, INF);
        bool scattered = false;
        double tHit = 0.0;
        float f[5];
        tr.track(cmax, rng, collisions, [&](double t, double mu) {
            ps.fields.sample(tr.ray.oI + tr.ray.dI * t, f);
            // Collision estimator of emission: j / majorant at every tentative collision.
            if (f[1] > 0.0f) {
                for (int c = 0; c < 3; ++c)
                    L[c] += perChannel ? beta[c] * ps.emissionScale * f[2 + c] / mu
                                       : beta[c] * emitC[c] * f[1] / mu;
            }
            if (grey) {
                if (rng.uniformDouble() * mu < k0[cmax] * f[0]) {
                    scattered = true;
                    tHit = t;
                    return false;
                }
                return true;
            }
            double sumB = 0.0, sumBK = 0.0;
            for (int c = 0; c < 3; ++c) {
                sumB += beta[c];
                sumBK += beta[c] * std::min(k0[c] * f[0], double(mu));
            }
            const double P = sumB > 0.0 ? sumBK / (mu * sumB) : 0.0;
            if (rng.uniformDouble() < P) {
                for (int c = 0; c < 3; ++c)
                    beta[c] *= std::min(k0[c] * f[0], double(mu)) / mu / P;
                scattered = true;
                tHit = t;
                return false;
            }
            for (int c = 0; c < 3; ++c)
                beta[c] *= std::max(0.0, 1.0 - k0[c] * f[0] / mu) / (1.0 - P);
            return true;
        });
        if (!scattered) return;
        // Real collision: absorb (1 - albedo) of the weight, light it from every star (next
        // event estimation; from the second collision on).
        x = x + d * tHit;
        for (double& b : beta)
            b *= dust.albedo;
        if (!(beta[0] > 0.0 || beta[1] > 0.0 || beta[2] > 0.0)) return;
        // The first collision's light from the stars is singleScattering()'s.
        for (std::size_t s = 0; depth > 0 && s < ps.starPos.size(); ++s) {
            const Vec3 v = ps.starPos[s] - x;
            const double r2 = v.dot(v);
            const double r = std::sqrt(r2);
            const double mu = r > 0.0 ? v.dot(d) / r : 1.0; // light travel . (-d) = toStar . d
            const double p = phaseFunction(dust.phase, mu, dust.g);
            double Tr[3] = {1.0, 1.0, 1.0};
            if (r > 0.0) transmittance(ps, cmax, x, v * (1.0 / r), r, rng, collisions, Tr);
            for (int c = 0; c < 3; ++c) {
                const double w = beta[c] * p * Tr[c] / (4.0 * PI * std::max(r2, ps.rmin2));
                const double add = w * ps.scene->starColor[s][c];
                L[c] += add;
                Ls[s * 3 + c] += add;
            }
        }
        // Continue in a phase-sampled direction (weight p / pdf = 1).
        const double mu = samplePhaseCosine(dust.phase, dust.g, rng.uniformDouble());
        const double in[3] = {d.x, d.y, d.z};
        double out[3];
        sampleDirection(mu, 2.0 * PI * rng.uniformDouble(), in, out);
        d = Vec3(out[0], out[1], out[2]).normalized();
        // Russian roulette after 3 bounces, on the largest weight.
        if (depth >= 3) {
            const double q = std::min(1.0, std::max({beta[0], beta[1], beta[2]}) / 0.25);
            if (rng.uniformDouble() >= q) return;
            for (double& b : beta)
                b /= q;
        }
    }
}

/// Bins of the phase function along the ray in singleScattering().
constexpr int PHASE_BINS = 32;

/// A point (u, v) of pixel (px, py) [image coordinates] at which to sample a star's
/// scattered light, and its weight 1 / pdf; false: a point outside the pixel, which counts
/// nothing. The pixel's centre, as the walks and the fast integrator sample every pixel
/// (singleScattering() then averages the star's 1/b over the pixel as the fast integrator
/// does); but near the star's image (sx, sy) its light grows as 1/rho (rho the distance to
/// the image) within the pixel: in a pixel within half a pixel of the image (@p near) the
/// point is drawn with pdf
/// proportional to 1/rho over the smallest rectangle holding the pixel and the image,
/// exactly (the four rectangles with a corner at the image, each in polar coordinates:
/// dA / rho = drho dphi), so that the estimate averages the pixel with bounded variance (a
/// uniform point's would diverge).
bool pixelPoint(double px, double py, bool near, double sx, double sy, Pcg32& rng, double& u,
                double& v, double& weight)
{
    weight = 1.0;
    if (!near) {
        u = px + 0.5;
        v = py + 0.5;
        return true;
    }
    const double x0 = std::min(px, sx), x1 = std::max(px + 1.0, sx);
    const double y0 = std::min(py, sy), y1 = std::max(py + 1.0, sy);
    const double ext[4][2] = {
        {x1 - sx, y1 - sy}, {sx - x0, y1 - sy}, {sx - x0, sy - y0}, {x1 - sx, sy - y0}};
    const double sign[4][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
    double m[4], total = 0.0;
    for (int q = 0; q < 4; ++q)
        total += m[q] = detail::inverseDistanceIntegral(ext[q][0], ext[q][1]);
    double pick = rng.uniformDouble() * total;
    int q = 0;
    while (q < 3 && pick >= m[q])
        pick -= m[q++];
    const double a = ext[q][0], b = ext[q][1];
    // Below the diagonal (phi < atan(b/a), rho up to a / cos phi): measure a asinh(b/a),
    // tan phi = sinh of a uniform number in [0, asinh(b/a)]; above it the same with x, y swapped.
    const bool below = rng.uniformDouble() * m[q] < a * std::asinh(b / a);
    const double along = below ? a : b, across = below ? b : a;
    const double phi = std::atan(std::sinh(rng.uniformDouble() * std::asinh(across / along)));
    const double rho = rng.uniformDouble() * along / std::cos(phi);
    const double x = rho * std::cos(phi), y = rho * std::sin(phi);
    u = sx + sign[q][0] * (below ? x : y);
    v = sy + sign[q][1] * (below ? y : x);
    weight = rho * total;
    return u >= px && u < px + 1.0 && v >= py && v < py + 1.0;
}

/// Every star's light scattered once towards the eye in pixel (@p px, @p py) (its corner),
/// along the ray through pixelPoint(), by equiangular sampling about
/// the star (Kulla & Fajardo 2012, DESIGN §6): a point at ray distance t = s0 + b tan(theta)
/// with theta between the angles of the lattice box's entry and exit has ds / r^2 =
/// dtheta / b, so the 1/r^2 of the star's irradiance cancels and the estimate is bounded
/// along the ray, however close to the star it passes; theta is drawn from the phase
/// function tabulated in equal bins of angle (its forward peak would otherwise dominate the
/// noise). Both transmittances ratio tracked. Adds to @p L[c] and @p Ls[s * 3 + c].
void singleScattering(const PathScene& ps, int cmax, const Projection& cam, double px, double py,
                      Pcg32& rng, double* L, double* Ls, std::uint64_t& collisions)
{
    const auto& dust = ps.scene->dust;
    for (std::size_t s = 0; s < ps.starPos.size(); ++s) {
        double sx = 0.0, sy = 0.0, u, v, weight;
        const bool near = cam.project(ps.starPos[s], sx, sy) &&
                          std::hypot(std::max({px - sx, 0.0, sx - px - 1.0}),
                                     std::max({py - sy, 0.0, sy - py - 1.0})) < 0.5;
        if (!pixelPoint(px, py, near, sx, sy, rng, u, v, weight)) continue;
        Vec3 d;
        if (!cam.direction(u, v, d)) continue;
        const Vec3 o = cam.origin(u, v);
        const Tracker tr(ps, o, d, INF);
        if (!(tr.t1 > tr.t0)) continue;
        const Vec3 toStar = ps.starPos[s] - o;
        double s0 = toStar.dot(d), b = (toStar - d * s0).length();
        if (!near) {
            // The pixel's mean of the 1/b of a line near the star (DESIGN §3.5), as the fast
            // integrator: the closest approach b becomes the effective one.
            const auto rs = detail::rayStar(o, d, ps.starPos[s],
                                            detail::pixelFootprint(cam, px + 0.5, py + 0.5), 0.0);
            s0 = rs.s0;
            b = rs.d;
        }
        if (!(b > 0.0)) continue; // the ray through the star: measure zero
        // theta from the phase function tabulated in PHASE_BINS equal bins between the box's
        // entry and exit angles (piecewise constant); the point's cosine is -sin(theta).
        const double thA = std::atan((tr.t0 - s0) / b), thB = std::atan((tr.t1 - s0) / b);
        const double dTh = (thB - thA) / PHASE_BINS;
        double cdf[PHASE_BINS + 1] = {0.0};
        for (int i = 0; i < PHASE_BINS; ++i) {
            const double mid = -std::sin(thA + (i + 0.5) * dTh);
            cdf[i + 1] = cdf[i] + phaseFunction(dust.phase, mid, dust.g);
        }
        const double pick = rng.uniformDouble() * cdf[PHASE_BINS];
        const int bin = std::min(
            PHASE_BINS - 1, int(std::upper_bound(cdf + 1, cdf + PHASE_BINS + 1, pick) - cdf - 1));
        const double theta = thA + (bin + rng.uniformDouble()) * dTh;
        const double t = s0 + b * std::tan(theta);
        const double n = ps.fields.sample0(tr.ray.oI + tr.ray.dI * t);
        if (!(n > 0.0)) continue;
        const Vec3 x = o + d * t, w = ps.starPos[s] - x;
        const double r = w.length(); // the star's distance (b: the effective one, DESIGN §3.5)
        // 1 / pdf(theta) = sum_j p_j dTh / p_bin; ds / r^2 = dtheta / b.
        const double g = weight * dust.albedo *
                         phaseFunction(dust.phase, -std::sin(theta), dust.g) * cdf[PHASE_BINS] *
                         dTh / ((cdf[bin + 1] - cdf[bin]) * 4.0 * PI * b);
        double Te[3], Ts[3] = {1.0, 1.0, 1.0};
        transmittance(ps, cmax, o, d, t, rng, collisions, Te);
        if (r > 0.0) transmittance(ps, cmax, x, w * (1.0 / r), r, rng, collisions, Ts);
        for (int c = 0; c < 3; ++c) {
            const double add =
                dust.kappa_V * dust.r[c] * n * g * Te[c] * Ts[c] * ps.scene->starColor[s][c];
            L[c] += add;
            Ls[s * 3 + c] += add;
        }
    }
}

} // namespace

void requirePathWalks(const RenderOptions& opts)
{
    if (opts.spp <= 0) throw UsageError("--spp must be > 0, got " + std::to_string(opts.spp));
    const double walks = double(opts.spp) * double(opts.camera.width) * double(opts.camera.height);
    if (walks > MAX_PATH_WALKS) {
        throw UsageError(fmt::format(
            "--spp {} at {}x{} is {:.3g} random walks per frame; at most {:g} (the README's "
            "reference, 256 spp at 512x512, is 6.7e+07); use fewer samples or pixels",
            opts.spp, opts.camera.width, opts.camera.height, walks, MAX_PATH_WALKS));
    }
}

Image renderPathTraced(const RenderScene& scene, const RenderOptions& opts, const Run* run,
                       RenderStats* stats)
{
    const Camera& view = opts.camera;
    if (view.width <= 0 || view.height <= 0) throw UsageError("--res must be WxH with W, H > 0");
    requirePathWalks(opts);
    const Projection cam(view);
    const int W = view.width, H = view.height;
    const std::size_t S = scene.stars.size();
    const PathScene ps = buildPathScene(scene, opts);

    detail::FrameLayers ids;
    Image img = detail::frameImage(scene, opts, ids, {VARIANCE_LAYER}, 1);
    std::vector<float>& transLayer = img.rgb(ids.transmittance);
    std::vector<float>& varLayer = img.rgb(img.layerId(VARIANCE_LAYER));
    // The luminance's own variance: one walk carries all three channels, so their noise is
    // correlated and the Y variance is not the weighted sum of theirs.
    std::vector<float>& varY = img.values(img.addChannel(std::string(VARIANCE_LAYER) + ".Y"));

    // Grey dust (equal extinction ratios): one walk serves all three channels; coloured dust:
    // one spectrally tracked walk against the most extinguished channel's majorant.
    const auto& r = scene.dust.r;
    const bool grey =
        std::abs(r[0] - r[1]) <= 1e-12 * r[1] && std::abs(r[2] - r[1]) <= 1e-12 * r[1];
    const int cmax = int(std::max_element(r.begin(), r.end()) - r.begin());
    // The progress weighs rows by their steps through the dust; the path tracer marches no
    // star's optical depth exactly (no StarDepth).
    detail::forEachRowBand(
        scene, opts, nullptr, 1, run, "nebrender path", stats,
        [&](int y0, int y1, RenderStats& band) {
            std::vector<double> Ls(S * 3), starSum(S * 3);
            for (int py = y0; py < y1; ++py) {
                for (int px = 0; px < W; ++px) {
                    const std::size_t pix = std::size_t(py) * W + px;
                    Vec3 d;
                    if (!cam.direction(px + 0.5, py + 0.5, d)) continue; // not in view
                    const Vec3 origin = cam.origin(px + 0.5, py + 0.5);
                    double mean[4] = {0, 0, 0, 0}, m2[4] = {0, 0, 0, 0}, trans[3] = {0, 0, 0};
                    std::fill(starSum.begin(), starSum.end(), 0.0);
                    for (int sample = 0; sample < opts.spp; ++sample) {
                        // One stream per (pixel, sample); the seed picks the family.
                        Pcg32 rng(pix * 0x9E3779B97F4A7C15ULL + std::uint64_t(sample), opts.seed);
                        double L[3] = {0, 0, 0}, T[3] = {1, 1, 1};
                        std::fill(Ls.begin(), Ls.end(), 0.0);
                        walk(ps, cmax, grey, origin, d, rng, L, Ls.data(), T, band.collisions);
                        singleScattering(ps, cmax, cam, px, py, rng, L, Ls.data(), band.collisions);
                        ++band.paths;
                        const double Lc[4] = {L[0], L[1], L[2],
                                              linearSRGBLuminance(L[0], L[1], L[2])};
                        for (int c = 0; c < 4; ++c) {
                            // Welford's running mean and sum of squared deviations.
                            const double delta = Lc[c] - mean[c];
                            mean[c] += delta / (sample + 1);
                            m2[c] += delta * (Lc[c] - mean[c]);
                        }
                        for (int c = 0; c < 3; ++c) {
                            trans[c] += T[c];
                            for (std::size_t s = 0; s < S; ++s)
                                starSum[s * 3 + c] += Ls[s * 3 + c];
                        }
                    }
                    const double n = opts.spp;
                    for (int c = 0; c < 3; ++c) {
                        img.rgba[pix * 4 + c] = float(mean[c]);
                        transLayer[pix * 3 + c] = float(trans[c] / n);
                        varLayer[pix * 3 + c] = n > 1 ? float(m2[c] / (n - 1) / n) : 0.0f;
                        for (std::size_t s = 0; s < S; ++s) {
                            img.rgb(ids.stars[s])[pix * 3 + c] = float(starSum[s * 3 + c] / n);
                        }
                    }
                    varY[pix] = n > 1 ? float(m2[3] / (n - 1) / n) : 0.0f;
                    img.rgba[pix * 4 + 3] = float(1.0 - trans[1] / n);
                }
            }
        });
    if (stats) stats->rays += std::uint64_t(W) * H;
    if (opts.drawStars) drawStarSprites(img, scene, opts);
    return img;
}

namespace {

/// The path tracer simulates every order of scattering itself: no phase table, no levels.
void validatePath(const RenderOptions& opts)
{
    requirePathWalks(opts);
    if (opts.levels > 0) {
        throw UsageError("--levels is for the fast integrator; --integrator path simulates "
                         "multiple scattering itself");
    }
    if (opts.phaseTable) {
        throw UsageError("--phase is for the fast integrator; --integrator path simulates "
                         "multiple scattering itself");
    }
}

void checkPathInput(const IntegratorInput& input, const RenderOptions& opts, const Run& run)
{
    if (input.rgbField || input.spectralField) {
        run.warn(input.source +
                 " has a scattered-light field (nebscatter), which --integrator "
                 "path does not need: it simulates every order of scattering itself");
    }
    detail::warnUnusedLevels(input, opts, input.rgbField, run);
}

void reportPath(const RenderOptions&, const SpectralScene&, const RenderStats& stats,
                double seconds, const Run& run)
{
    run.info(fmt::format("path tracing: {} walks, {} tentative collisions, {:.4g} ns wall "
                         "per walk",
                         stats.paths, stats.collisions,
                         1e9 * seconds / double(std::max<std::uint64_t>(stats.paths, 1))));
}

} // namespace

namespace detail {

const IntegratorType& pathIntegrator()
{
    static const IntegratorType type = [] {
        IntegratorType t;
        t.name = "path";
        t.chosenBy = "--integrator path";
        t.doc = "reference Monte Carlo path tracer, all orders of scattering (--spp, --seed)";
        t.options = {"--spp", "--seed"};
        t.comment = "nebula reference path-traced render (DESIGN section 6); linear radiance";
        t.validate = validatePath;
        t.checkInput = checkPathInput;
        t.render = [](const SpectralScene& scene, const RenderOptions& opts, const Run* run,
                      RenderStats* stats) {
            return renderPathTraced(scene.base, opts, run, stats);
        };
        t.describe = [](const RenderOptions& opts, const SpectralScene&) {
            return "path tracing (reference), spp " + std::to_string(opts.spp) + ", seed " +
                   std::to_string(opts.seed);
        };
        t.report = reportPath;
        return t;
    }();
    return type;
}

} // namespace detail

} // namespace nebula
