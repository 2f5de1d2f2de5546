// SPDX-License-Identifier: Apache-2.0
// Single scattering next to an embedded star (DESIGN §3.5). A uniform, optically thin sphere
// of dust (radius R, density n0) with its star at the centre sends a k R L / (4 pi) per
// steradian towards any observer, whatever the phase function: each shell dr scatters
// a k dr L of the star's light, and by symmetry it sends the same to every direction. So an
// orthographic image's radiance times pixel area, summed, is a k_c R L / (4 pi) in each
// channel (k_c = kappa_V r_c n0), and the dust within a voxel or two of the star, where the
// irradiance grows as 1/r^2, holds as much of it per unit of radius as any other shell.
// Checked for the fast and spectral integrators at three wavelengths and for the star at a
// voxel's centre (a lattice point) and off it; for the path tracer within its noise. Also
// the private pieces: the mean of 1/b over a pixel and a step's integral of 1/r^2.
#include "nebula/physics/dust.h"
#include "nebula/render/fast.h"
#include "nebula/render/frame_layers.h"
#include "nebula/render/path_tracer.h"
#include "nebula/render/spectral.h"

#include "near_star.h"
#include "render_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace nebula;

namespace {

constexpr double HV = 0.1;                ///< voxel [pc]
constexpr int NV = 64;                    ///< lattice points per axis
constexpr double RADIUS = 2.5, N0 = 0.02; ///< [pc], [cm^-3]: tau_V(R) = 7.5e-5
constexpr double LUM = 1e4;               ///< [L_sun] in every channel
constexpr double WAVELENGTHS[3] = {700.0, 546.1, 435.8};

/// The lattice point at the sphere's centre, and the star's offset from it [voxels] in the
/// off-centre case.
constexpr int MID = 32;
const Vec3 OFF_CENTRE(0.31, 0.17, 0.42);

/// The sphere of radius RADIUS around @p starI (index space), each voxel's density n0 times
/// the fraction of it inside (4^3 samples), the star's tau channel exact (thin: nearly 0).
RenderScene sphereScene(const Vec3& starI)
{
    RenderScene scene;
    scene.fields = SparseVolume({0, 0, 0}, {NV, NV, NV}, 3);
    scene.fields.indexToWorld.m = {HV, 0, 0, 0, HV, 0, 0, 0, HV};
    const double rI = RADIUS / HV;
    for (int k = 0; k < NV; ++k)
        for (int j = 0; j < NV; ++j)
            for (int i = 0; i < NV; ++i) {
                int inside = 0;
                for (int s = 0; s < 64; ++s) {
                    const Vec3 p(i - 0.5 + (s % 4 + 0.5) / 4, j - 0.5 + (s / 4 % 4 + 0.5) / 4,
                                 k - 0.5 + (s / 16 + 0.5) / 4);
                    inside += (p - starI).length() <= rI;
                }
                if (inside > 0)
                    scene.fields.writable(scene.fields.index(i, j, k))[0] =
                        float(N0 * inside / 64.0);
            }
    Star s;
    s.name = "embedded";
    const Vec3 w = starI * HV;
    s.position = {w.x, w.y, w.z};
    s.luminosity = LUM;
    s.temperature = 20000.0;
    scene.stars = {s};
    scene.starColor = {{LUM, LUM, LUM}};
    scene.dust.kappa_V = test::KAPPA;
    for (int c = 0; c < 3; ++c)
        scene.dust.r[std::size_t(c)] = extinctionRatio(scene.dust, WAVELENGTHS[c]);
    scene.buildOccupancy();
    test::fillStarTau(scene);
    return scene;
}

/// An orthographic camera of @p W x @p W pixels of @p pixel pc along +z, centred on the
/// sphere's lattice point (the star off-centre projects off the pixels' corners).
RenderOptions sphereCamera(int W, double pixel)
{
    RenderOptions o;
    o.lod = 0.0;
    o.camera.model = "orthographic";
    o.camera.eye = Vec3(MID * HV, MID * HV, -5.0);
    o.camera.lookAt = Vec3(MID * HV, MID * HV, MID * HV);
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = W;
    o.camera.pixelSizePc = pixel;
    o.camera.distancePc = 100.0;
    o.drawStars = false;
    return o;
}

/// a k_c R L / (4 pi) [L_sun sr^-1]: the scattered intensity of channel c.
double closedForm(const RenderScene& scene, int c)
{
    return scene.dust.albedo * scene.dust.kappa_V * scene.dust.r[std::size_t(c)] * N0 * RADIUS *
           LUM / (4.0 * PI);
}

} // namespace

// The ray caster: within 0.3 % of the closed form in each channel (700, 546.1, 435.8 nm),
// for the star at a lattice point (its image at a pixel corner) and off it.
TEST(EmbeddedStar, FastIntegratorMatchesTheThinSphere)
{
    for (const Vec3 offset : {Vec3(0, 0, 0), OFF_CENTRE}) {
        const RenderScene scene = sphereScene(Vec3(MID, MID, MID) + offset);
        const double pixel = 0.08;
        const RenderOptions o = sphereCamera(72, pixel);
        const Image img = renderFrame(scene, o);
        for (int c = 0; c < 3; ++c) {
            double sum = 0.0;
            for (std::size_t p = 0; p < std::size_t(72 * 72); ++p)
                sum += img.rgba[p * 4 + std::size_t(c)];
            const double ratio = sum * pixel * pixel / closedForm(scene, c);
            std::printf("fast, star offset (%.2f, %.2f, %.2f) voxel, %.1f nm: %.5f of the "
                        "closed form\n",
                        offset.x, offset.y, offset.z, WAVELENGTHS[c], ratio);
            EXPECT_NEAR(ratio, 1.0, 3e-3) << WAVELENGTHS[c] << " nm";
        }
    }
}

// The spectral renderer (calibrated, 47 layers of 10 nm): the single-scattered light of the
// layers at 435, 545 and 705 nm over the star's direct light (its sprite) in the same layer
// is a k(lambda) R, within 0.3 % (the layers' mean extinction ratio against their centre's
// adds < 1e-4; the sprite's e^-tau 1e-4).
TEST(EmbeddedStar, SpectralIntegratorMatchesTheThinSphere)
{
    for (const Vec3 offset : {Vec3(0, 0, 0), OFF_CENTRE}) {
        SpectralScene scene;
        scene.base = sphereScene(Vec3(MID, MID, MID) + offset);
        scene.dust = scene.base.dust;
        RenderOptions o = sphereCamera(72, 0.08);
        o.spectral.enabled = true;
        o.spectral.layers = 47;
        o.monochromatic = true;
        o.componentLayers = true;
        o.drawStars = true;
        const Image img = renderSpectral(scene, o);
        const std::size_t NL = 47;
        ASSERT_EQ(img.channels.size(), NL * (1 + SPECTRAL_COMPONENT_COUNT));
        for (const std::size_t b : {std::size_t(7), std::size_t(18), std::size_t(34)}) {
            const auto& direct = img.channels[NL + b].values;
            const auto& single = img.channels[2 * NL + b].values;
            double d = 0.0, s = 0.0;
            for (std::size_t p = 0; p < direct.size(); ++p) {
                d += direct[p];
                s += single[p];
            }
            const double lambda = SPECTRAL_MIN_NM + 10.0 * (double(b) + 0.5);
            const double expected = scene.dust.albedo * scene.dust.kappa_V *
                                    extinctionRatio(scene.dust, lambda) * N0 * RADIUS;
            const double ratio = s / d / expected;
            std::printf("spectral, star offset (%.2f, %.2f, %.2f) voxel, %.0f nm: %.5f of the "
                        "closed form\n",
                        offset.x, offset.y, offset.z, lambda, ratio);
            EXPECT_NEAR(ratio, 1.0, 3e-3) << lambda << " nm";
        }
    }
}

// The path tracer (single scattering by equiangular sampling along a ray through a point of
// the pixel, drawn near the star's image with pdf ~ 1/rho, DESIGN §6), 48x48 pixels at 512
// spp: within 4 standard errors of the closed form, the standard error (from the variance
// layer, summed over the pixels) below 0.3 % (measured 0.19 %); multiple scattering adds
// ~ tau a = 5e-5.
TEST(EmbeddedStar, PathTracerMatchesTheThinSphereWithinItsNoise)
{
    const RenderScene scene = sphereScene(Vec3(MID, MID, MID) + OFF_CENTRE);
    const int W = 48;
    const double pixel = 0.12;
    RenderOptions o = sphereCamera(W, pixel);
    o.spp = 512;
    const Image img = renderPathTraced(scene, o);
    const auto& var = img.rgb(img.layerId(VARIANCE_LAYER));
    for (int c = 0; c < 3; ++c) {
        double sum = 0.0, v = 0.0;
        for (std::size_t p = 0; p < std::size_t(W * W); ++p) {
            sum += img.rgba[p * 4 + std::size_t(c)];
            v += var[p * 3 + std::size_t(c)];
        }
        const double expected = closedForm(scene, c);
        const double ratio = sum * pixel * pixel / expected;
        const double sigma = std::sqrt(v) * pixel * pixel / expected;
        std::printf("path, %.1f nm: %.5f +- %.5f of the closed form\n", WAVELENGTHS[c], ratio,
                    sigma);
        EXPECT_LT(sigma, 3e-3);
        EXPECT_NEAR(ratio, 1.0, 4.0 * sigma) << WAVELENGTHS[c] << " nm";
    }
}

// The mean of 1/b over a square pixel against a 2000^2 midpoint sum, where the pixel holds
// the star's image (at its corner, its centre, inside it) and beside it; and the far series.
TEST(EmbeddedStar, MeanInverseDistanceOverAPixel)
{
    for (const auto& [x, y] : {std::pair{0.5, 0.5}, std::pair{0.0, 0.0}, std::pair{0.2, -0.37},
                               std::pair{1.5, 0.5}, std::pair{-3.0, 2.2}}) {
        const int n = 2000;
        double sum = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                const double u = x - 0.5 + (i + 0.5) / n, v = y - 0.5 + (j + 0.5) / n;
                sum += 1.0 / std::sqrt(u * u + v * v);
            }
        const double brute = sum / (double(n) * n);
        // The midpoint sum converges slowly where the pixel holds the singularity.
        const double tol = std::hypot(x, y) < 0.75 ? 2e-3 : 1e-6;
        EXPECT_NEAR(detail::meanInverseDistance(x, y, 1.0), brute, tol * brute) << x << " " << y;
    }
    const double b = 16.0;
    EXPECT_NEAR(detail::meanInverseDistance(b, 0.0, 1.0), (1.0 + 1.0 / (24.0 * b * b)) / b,
                1e-7 / b);
}

// A step's integral of 1/r^2 against a fine midpoint sum, far from the star (the series) and
// across it (the arctangent), and the nodes' phase function against the step's mean.
TEST(EmbeddedStar, StepIntegralOfInverseSquareDistance)
{
    detail::RayStar rs;
    rs.s0 = 1.3;
    for (const double d : {0.02, 0.3, 5.0}) {
        rs.d = d;
        for (const auto& [a, b] :
             {std::pair{1.0, 1.5}, std::pair{-4.0, -3.5}, std::pair{1.25, 1.3}}) {
            detail::StarNodes nodes;
            detail::starNodes(rs, a, b, nodes);
            const int n = 200000;
            double sum = 0.0, ph = 0.0;
            for (int i = 0; i < n; ++i) {
                const double s = a + (b - a) * (i + 0.5) / n,
                             r2 = d * d + (s - rs.s0) * (s - rs.s0);
                sum += (b - a) / n / r2;
                ph +=
                    (b - a) / n / r2 *
                    phaseFunction(PhaseModel::HenyeyGreenstein, -(s - rs.s0) / std::sqrt(r2), 0.6);
            }
            EXPECT_NEAR(nodes.total, sum, 1e-8 * sum) << d << " " << a;
            if (nodes.n > 1) {
                double p = 0.0;
                for (int i = 0; i < nodes.n; ++i)
                    p += phaseFunction(PhaseModel::HenyeyGreenstein, nodes.mu[i], 0.6) / nodes.n;
                EXPECT_NEAR(p * nodes.total, ph, 5e-3 * ph) << d << " " << a;
            }
        }
    }
}
