// SPDX-License-Identifier: Apache-2.0
// Spectral rendering (DESIGN §7): the spectral ray caster against closed forms, its
// fixed-band mode and the RGB mode. (The Doppler line profiles it draws, physics/lines.h,
// are tested in physics/test_lines.cpp.)
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/stars.h"
#include "nebula/render/camera.h"
#include "nebula/render/fast.h"
#include "nebula/render/spectral.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

namespace nebula {
namespace {

constexpr double H = 0.1; // voxel [pc]
constexpr int N = 21;     // lattice 0..20, fields on 1..19
constexpr double KAPPA = 1.5e-3;

/// A spectral test scene: fields on lattice 1..19 (2 pc cube of 0.1 pc voxels), channels
/// 0 density, 1 emission sum, 2.. tau of each star (0), then the emission grid, then the
/// velocity (3 channels, on the whole lattice). @p density(i,j,k), @p emission(i,j,k), @p
/// velocity(i,j,k).
template <class D, class E, class V>
SpectralScene makeScene(D density, E emission, V velocity, std::vector<Star> stars,
                        const std::vector<SpectralLine>& lines, const std::string& curve = "CCM89")
{
    SpectralScene s;
    const int S = int(stars.size());
    const int C = 2 + S + 1 + 3;
    s.base.fields = SparseVolume({0, 0, 0}, {N, N, N}, C);
    s.base.fields.indexToWorld.m = {H, 0, 0, 0, H, 0, 0, 0, H};
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                float* q = s.base.fields.writable(s.base.fields.index(i, j, k));
                // The velocity everywhere (also on the border, so that it does not ramp to 0).
                const auto v = velocity(i, j, k);
                for (int c = 0; c < 3; ++c)
                    q[2 + S + 1 + c] = float(v[c]);
                if (i == 0 || j == 0 || k == 0 || i == N - 1 || j == N - 1 || k == N - 1) continue;
                q[0] = float(density(i, j, k));
                q[1] = q[2 + S] = float(emission(i, j, k));
            }
    s.base.stars = stars;
    for (const auto& st : stars) {
        const auto rgb = blackbodyLinearSRGB(st.temperature);
        s.base.starColor.push_back(
            {rgb[0] * st.luminosity, rgb[1] * st.luminosity, rgb[2] * st.luminosity});
    }
    s.dust.kappa_V = KAPPA;
    s.dust.curve = curve;
    s.base.dust.kappa_V = KAPPA;
    for (int c = 0; c < 3; ++c)
        s.base.dust.r[std::size_t(c)] =
            extinctionRatio(s.dust, RenderOptions().wavelengths[std::size_t(c)]);
    s.base.buildOccupancy();
    SpectralEmitter e;
    e.grid = "emission";
    e.channel = 2 + S;
    e.lines = lines;
    e.unit = 1.0;
    s.emitters.push_back(e);
    s.velocityChannel = 2 + S + 1;
    return s;
}

/// A camera of W x W pixels looking along +z at the cube's centre (1, 1, 1) pc from z = -5.
RenderOptions zCamera(int W, double fov = 4.0)
{
    RenderOptions o;
    o.lod = 0.0; // compared with the RGB renderer at full resolution (no level of detail here)
    o.camera.eye = Vec3(1, 1, -5);
    o.camera.lookAt = Vec3(1, 1, 1);
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = W;
    o.camera.fovDeg = fov;
    o.drawStars = false;
    o.spectral.enabled = true;
    return o;
}

std::vector<SpectralLine> oneLine(double lambda)
{
    return {SpectralLine{"test", lambda, 1.0}};
}

/// Centroid [nm] and integral of pixel @p pix's spectral layers.
void layerMoments(const Image& img, std::size_t pix, double& centroid, double& integral)
{
    const double w = (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / double(img.channels.size());
    double m0 = 0.0, m1 = 0.0;
    for (std::size_t b = 0; b < img.channels.size(); ++b) {
        const double c = SPECTRAL_MIN_NM + (double(b) + 0.5) * w;
        m0 += img.channels[b].values[pix] * w;
        m1 += img.channels[b].values[pix] * w * c;
    }
    centroid = m1 / m0;
    integral = m0;
}

TEST(SpectralRender, UniformVelocityShiftsByExactlyLambdaVOverC)
{
    // Gas moving uniformly along the ray looks exactly like gas at rest whose line sits at
    // lambda0 (1 + v/c): same XYZ (the boxes' widths differ by the factor 1 + v/c, which
    // changes XYZ by ~(width/10 nm)^2 ~ 1e-5 relative at most).
    const double lambda0 = 550.0, v = 2000.0; // km/s along +z (away from the eye)
    auto none = [](int, int, int) { return 0.0; };
    auto gas = [](int, int, int) { return 1.0; };
    auto o = zCamera(1, 0.5);
    const auto XYZof = [](const Image& im) {
        return linearSRGBToXYZ({im.rgba[0], im.rgba[1], im.rgba[2]});
    };
    const auto atRest = [&](double lambda) {
        return XYZof(renderSpectral(makeScene(
                                        none, gas,
                                        [](int, int, int) {
                                            return std::array<double, 3>{0, 0, 0};
                                        },
                                        {}, oneLine(lambda)),
                                    o));
    };
    const XYZ rest = atRest(lambda0);
    // Energy: the line's Y over its CMF value is the emitted energy, 19 voxels of 0.1 pc
    // (18 + two half ramps), unit 1: float image, 1e-5.
    EXPECT_NEAR(rest[1] / cmfAt(lambda0)[1], 1.9, 1.9e-5);
    for (const double sign : {-1.0, 1.0}) {
        const XYZ moving =
            XYZof(renderSpectral(makeScene(
                                     none, gas,
                                     [&](int, int, int) {
                                         return std::array<double, 3>{0, 0, sign * v};
                                     },
                                     {}, oneLine(lambda0)),
                                 o));
        const XYZ shifted = atRest(lambda0 * (1.0 + sign * v / SPEED_OF_LIGHT_KMS));
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(moving[std::size_t(c)], shifted[std::size_t(c)], 2e-5 * rest[1])
                << sign << " " << c;
        }
        // Approaching (sign < 0) is bluer: a smaller chromaticity x on this part of the
        // spectral locus; receding is redder.
        const double x = chromaticity(moving)[0], x0 = chromaticity(rest)[0];
        if (sign < 0) {
            EXPECT_LT(x, x0 - 0.01);
        } else {
            EXPECT_GT(x, x0 + 0.01);
        }
    }
}

TEST(SpectralRender, RelativisticOptionRedshiftsTransverseMotionByGamma)
{
    // Gas moving at 0.2 c across the line of sight (along x; the ray runs along z): no shift
    // to first order; gamma = 1 / sqrt(1 - 0.04) = 1.0206 with --relativistic.
    const double lambda0 = 520.0, v = 0.2 * SPEED_OF_LIGHT_KMS;
    auto none = [](int, int, int) { return 0.0; };
    auto gas = [](int, int, int) { return 1.0; };
    const auto XYZof = [](const Image& im) {
        return linearSRGBToXYZ({im.rgba[0], im.rgba[1], im.rgba[2]});
    };
    auto o = zCamera(1, 0.5);
    const auto render = [&](double lambda, double vx, bool relativistic) {
        o.spectral.relativistic = relativistic;
        return XYZof(renderSpectral(makeScene(
                                        none, gas,
                                        [&](int, int, int) {
                                            return std::array<double, 3>{vx, 0, 0};
                                        },
                                        {}, oneLine(lambda)),
                                    o));
    };
    const double gamma = 1.0 / std::sqrt(1.0 - 0.04);
    const XYZ classic = render(lambda0, v, false), rest = render(lambda0, 0.0, false);
    const XYZ rel = render(lambda0, v, true), shifted = render(lambda0 * gamma, 0.0, false);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(classic[std::size_t(c)], rest[std::size_t(c)], 1e-5 * rest[1]);
        EXPECT_NEAR(rel[std::size_t(c)], shifted[std::size_t(c)], 1e-4 * rest[1]);
    }
    EXPECT_GT(chromaticity(rel)[0], chromaticity(rest)[0] + 0.01); // redder
}

TEST(SpectralRender, BlackBodyEmissionFollowsKirchhoff)
{
    // A cube of grey dust (n0 on lattice 1..19, trilinear ramps: column 19 voxels) at
    // temperature T, no stars: L = (1 - a) B(T) (1 - e^-tau) at every wavelength (Kirchhoff's
    // law for a slab of uniform temperature), so XYZ = (1 - a)(1 - e^-tau) XYZ_B(T) in
    // L_sun pc^-2 sr^-1. The continuum nodes are 1 nm apart here (1e-5 from linear
    // interpolation of B); the trilinear ramps at the faces change nothing (uniform T).
    const double n0 = 2000.0, T = 5000.0;
    SpectralScene s;
    s.base.fields = SparseVolume({0, 0, 0}, {N, N, N}, 3); // density, emission sum, T
    s.base.fields.indexToWorld.m = {H, 0, 0, 0, H, 0, 0, 0, H};
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                float* q = s.base.fields.writable(s.base.fields.index(i, j, k));
                q[2] = float(T);
                const bool inside = i > 0 && j > 0 && k > 0 && i < N - 1 && j < N - 1 && k < N - 1;
                q[0] = inside ? float(n0) : 0.0f;
            }
    s.dust.kappa_V = KAPPA;
    s.dust.curve = "grey";
    s.base.dust.kappa_V = KAPPA;
    s.base.buildOccupancy();
    s.temperatureChannel = 2;
    auto o = zCamera(1, 0.5);
    o.spectral.continuumStep = 1.0;
    const Image img = renderSpectral(s, o);
    const XYZ got = linearSRGBToXYZ({img.rgba[0], img.rgba[1], img.rgba[2]});
    const double tau = KAPPA * n0 * 19 * H;
    const XYZ B = blackbodyXYZ(T);
    for (int c = 0; c < 3; ++c) {
        const double want =
            (1.0 - s.dust.albedo) * -std::expm1(-tau) * B[std::size_t(c)] * WM2_TO_LSUN_PC2;
        EXPECT_NEAR(got[std::size_t(c)], want, 1e-4 * want) << c;
    }
}

TEST(SpectralRender, LineEnergyUnchangedByAVelocityGradient)
{
    auto none = [](int, int, int) { return 0.0; };
    auto gas = [](int, int, int) { return 1.0; };
    auto still = [](int, int, int) { return std::array<double, 3>{0, 0, 0}; };
    auto shear = [](int, int, int k) { return std::array<double, 3>{0, 0, 300.0 * (k - 10)}; };
    auto o = zCamera(1, 0.5);
    o.spectral.layers = 47;
    o.spectral.exaggerateVelocity = 5.0; // +-15000 km/s: +-27 nm across the cube
    double c0, I0, c1, I1;
    layerMoments(renderSpectral(makeScene(none, gas, still, {}, oneLine(605.0)), o), 0, c0, I0);
    layerMoments(renderSpectral(makeScene(none, gas, shear, {}, oneLine(605.0)), o), 0, c1, I1);
    EXPECT_NEAR(I1, I0, 1e-6 * I0); // energy moved, not made or lost
    // The gradient is antisymmetric about the centre: the centroid stays put (to the
    // symmetric sampling's rounding), while the line spreads over many 10 nm layers.
    EXPECT_NEAR(c1, c0, 1e-3);
    int lit0 = 0, lit1 = 0;
    const Image a = renderSpectral(makeScene(none, gas, still, {}, oneLine(605.0)), o);
    const Image b = renderSpectral(makeScene(none, gas, shear, {}, oneLine(605.0)), o);
    for (std::size_t k = 0; k < a.channels.size(); ++k) {
        lit0 += a.channels[k].values[0] > 1e-6f;
        lit1 += b.channels[k].values[0] > 1e-6f;
    }
    EXPECT_EQ(lit0, 1);
    EXPECT_GE(lit1, 5);
}

TEST(SpectralRender, DustReddensLinesByTheExtinctionCurve)
{
    // Dust in the near half (k <= 8), gas in the far half (k >= 12): the lines cross the whole
    // dust column, tau_V, and are dimmed by exp(-tau_V A(lambda)/A_V).
    auto dust = [](int, int, int k) { return k <= 8 ? 3000.0 : 0.0; };
    auto gas = [](int, int, int k) { return k >= 12 ? 1.0 : 0.0; };
    auto still = [](int, int, int) { return std::array<double, 3>{0, 0, 0}; };
    auto clear = [](int, int, int) { return 0.0; };
    auto o = zCamera(1, 0.5);
    for (const double lambda : {440.0, 550.0, 656.28}) {
        const Image dim = renderSpectral(makeScene(dust, gas, still, {}, oneLine(lambda)), o);
        const Image bright = renderSpectral(makeScene(clear, gas, still, {}, oneLine(lambda)), o);
        // tau_V from the transmittance layer's green channel (546.1 nm).
        const double rG = ccmExtinction(546.1, 3.1);
        const double tauV = -std::log(double(dim.layers.back().rgb[1])) / rG;
        EXPECT_GT(tauV, 0.5);
        const auto Y = [](const Image& im) {
            return linearSRGBToXYZ({im.rgba[0], im.rgba[1], im.rgba[2]})[1];
        };
        // 1e-4 relative: float images; the line's 0.02 nm box sees a constant curve.
        EXPECT_NEAR(Y(dim) / Y(bright), std::exp(-tauV * ccmExtinction(lambda, 3.1)), 1e-4)
            << lambda << " nm";
    }
}

/// A Doppler scene with dust, a star and two lines, for mode comparisons.
SpectralScene dopplerScene(const std::string& curve = "CCM89")
{
    Star star;
    star.name = "s";
    star.position = {1.0, 1.0, 1.0};
    star.luminosity = 50.0;
    star.temperature = 12000.0;
    auto dust = [](int i, int j, int k) {
        return 400.0 * (1.0 + 0.5 * std::sin(0.7 * i + 0.3 * j + 0.5 * k));
    };
    auto gas = [](int i, int, int k) { return 0.5 + 0.4 * std::cos(0.4 * i - 0.6 * k); };
    auto flow = [](int i, int j, int k) {
        return std::array<double, 3>{40.0 * (i - 10), 40.0 * (j - 10), 40.0 * (k - 10)};
    };
    return makeScene(
        dust, gas, flow, {star},
        {SpectralLine{"H-alpha", 656.28, 1.0}, SpectralLine{"[O III]5007", 500.68, 0.8}}, curve);
}

TEST(SpectralRender, FixedBandsConvergeToPiecewiseLinear)
{
    const SpectralScene scene = dopplerScene();
    auto o = zCamera(4, 20.0);
    o.spectral.exaggerateVelocity = 10.0; // lines spread over +-5 nm
    o.spectral.continuumStep = 1.0;       // continuum nodes every 1 nm: its error ~1e-6
    const Image pl = renderSpectral(scene, o);
    double prev = std::numeric_limits<double>::infinity();
    for (const int bands : {47, 470, 4700, 47000}) {
        o.spectral.bands = bands;
        const Image fb = renderSpectral(scene, o);
        double err = 0.0, ref = 0.0;
        for (std::size_t p = 0; p < 16; ++p)
            for (int c = 0; c < 3; ++c) {
                err = std::max(err, std::abs(double(fb.rgba[p * 4 + std::size_t(c)]) -
                                             pl.rgba[p * 4 + std::size_t(c)]));
                ref = std::max(ref, std::abs(double(pl.rgba[p * 4 + std::size_t(c)])));
            }
        const double rel = err / ref;
        std::printf("%d bands: largest difference %.3g of the largest value\n", bands, rel);
        EXPECT_LT(rel, prev) << bands << " bands";
        prev = rel;
        // Measured: 0.35, 7.1e-3, 6.5e-5, 1.2e-6 (about 1/N^2 once the bands resolve the
        // 0.2 nm line boxes).
        if (bands == 4700) {
            EXPECT_LT(rel, 2e-4);
        }
        if (bands == 47000) {
            EXPECT_LT(rel, 1e-5);
        }
    }
}

TEST(SpectralRender, AgreesWithRgbModeForGreyDustAndABlackBodyStar)
{
    for (const double T : {3500.0, 5772.0, 9000.0, 20000.0}) {
        Star star;
        star.name = "s";
        star.position = {1.0, 1.0, 1.0};
        star.luminosity = 50.0;
        star.temperature = T;
        auto dust = [](int i, int j, int k) {
            return 300.0 * (1.0 + 0.5 * std::sin(0.7 * i + 0.3 * j + 0.5 * k));
        };
        auto none = [](int, int, int) { return 0.0; };
        auto still = [](int, int, int) { return std::array<double, 3>{0, 0, 0}; };
        SpectralScene scene = makeScene(dust, none, still, {star}, oneLine(600.0), "grey");
        // tau from the star: the grey dust's optical depth along the ray to the star.
        {
            RenderScene& b = scene.base;
            for (int k = 0; k < N; ++k)
                for (int j = 0; j < N; ++j)
                    for (int i = 0; i < N; ++i) {
                        float* q = b.fields.writable(b.fields.index(i, j, k));
                        const double d = std::sqrt(std::pow(i - 10, 2) + std::pow(j - 10, 2) +
                                                   std::pow(k - 10, 2));
                        q[2] = float(KAPPA * 300.0 * d * H); // a plausible optical depth
                    }
        }
        auto o = zCamera(6, 25.0);
        o.drawStars = true;
        const Image spec = renderSpectral(scene, o);
        const Image rgb = renderFrame(scene.base, o);
        for (std::size_t p = 0; p < 36; ++p) {
            const double Y =
                linearSRGBToXYZ({rgb.rgba[p * 4], rgb.rgba[p * 4 + 1], rgb.rgba[p * 4 + 2]})[1];
            ASSERT_GT(Y, 0.0);
            for (int c = 0; c < 3; ++c) {
                // 5e-3 of the pixel's luminance: the RGB mode's colour integrates Planck at
                // 1 nm, the spectral mode at its 10 nm continuum nodes (and clips no channel
                // for these temperatures).
                EXPECT_NEAR(spec.rgba[p * 4 + std::size_t(c)], rgb.rgba[p * 4 + std::size_t(c)],
                            5e-3 * Y)
                    << "T " << T << " pixel " << p << " channel " << c;
            }
        }
    }
}

// Calibrated components (RenderOptions::monochromatic, componentLayers): a star in dust
// with a glowing line at 603 nm. The component channels follow the total's N layers in the
// order of SPECTRAL_COMPONENTS and add up to it; "emission" holds the line alone (its band,
// 600-610 nm at 47 layers, and nothing elsewhere here); "direct" the sprite; "field" is 0
// without a field. The calibrated star is the black body of bolometric L: in a dust-free
// line of sight its sprite's layers, seen by an orthographic camera from D = 100 pc, sum to
// the flux of L pi B_lambda / (sigma T^4) over 360-830 nm, L_sun / (4 pi D^2) per nm, within
// 2e-3 (the spectrum is linear between 10 nm nodes).
TEST(SpectralRender, CalibratedComponentsAddUpAndStarsAreBolometric)
{
    Star star;
    star.name = "s";
    star.position = {1.0, 1.0, -2.0}; // in front of the cube: its sprite unattenuated
    star.luminosity = 50.0;
    star.temperature = 8000.0;
    auto dust = [](int i, int j, int k) {
        return 200.0 * (1.0 + 0.5 * std::sin(0.7 * i + 0.3 * j + 0.5 * k));
    };
    auto gas = [](int i, int, int) { return i > 10 ? 2.0 : 0.0; };
    auto still = [](int, int, int) { return std::array<double, 3>{0, 0, 0}; };
    const SpectralScene scene = makeScene(dust, gas, still, {star}, oneLine(603.0));
    auto o = zCamera(32, 25.0);
    o.camera.model = "orthographic"; // a telescope 100 pc away: fluxes L / (4 pi D^2)
    o.camera.pixelSizePc = 0.0625;   // the sprite well inside the image
    o.camera.distancePc = 100.0;
    o.drawStars = true;
    o.monochromatic = true;
    o.componentLayers = true;
    o.spectral.layers = 47;
    const Image img = renderSpectral(scene, o);
    const std::size_t NL = 47, P = 32 * 32;
    ASSERT_EQ(img.channels.size(), NL * (1 + SPECTRAL_COMPONENT_COUNT));
    EXPECT_EQ(img.channels[NL].name, "direct." + img.channels[0].name);
    EXPECT_EQ(img.channels[4 * NL + 3].name, "emission." + img.channels[3].name);
    const Projection proj(o.camera);
    double emissionOutside = 0.0, emissionIn = 0.0, direct = 0.0;
    for (std::size_t b = 0; b < NL; ++b)
        for (std::size_t p = 0; p < P; ++p) {
            const auto ch = [&](std::size_t k) {
                return double(img.channels[k * NL + b].values[p]);
            };
            const double sum = ch(1) + ch(2) + ch(3) + ch(4);
            ASSERT_NEAR(ch(0), sum, 1e-5 * std::max(std::abs(ch(0)), 1e-30)) << b << " " << p;
            EXPECT_EQ(ch(3), 0.0); // no field
            (b == 24 ? emissionIn : emissionOutside) += ch(4);
            // The sprite's flux: radiance times the band [nm] and the pixel's solid angle.
            direct +=
                ch(1) * 10.0 * proj.pixelSolidAngle(double(p % 32) + 0.5, double(p / 32) + 0.5);
        }
    EXPECT_GT(emissionIn, 0.0);
    EXPECT_EQ(emissionOutside, 0.0);
    // The sprite's flux is the star's in 360-830 nm: the sum over bands of
    // L pi B / (sigma T^4) / (4 pi D^2).
    double flux = 0.0;
    for (int l = 0; l < 4700; ++l) { // 0.1 nm steps
        const double lam = 360.0 + 0.1 * (l + 0.5);
        flux += 0.1 * blackbodySpectralLuminosity(50.0, 8000.0, lam);
    }
    flux /= 4.0 * PI * 100.0 * 100.0;
    EXPECT_NEAR(direct, flux, 2e-3 * flux);
}

// The spectral mode renders every camera model: a fisheye's centre pixel looks where a
// perspective camera's centre pixel does and gets the same colour; its corners stay black.
TEST(SpectralRender, FisheyeAndEquirectCameras)
{
    const auto none = [](int, int, int) { return 0.0; };
    const auto gas = [](int, int, int) { return 1.0; };
    const auto still = [](int, int, int) { return std::array<double, 3>{0, 0, 0}; };
    const SpectralScene scene = makeScene(none, gas, still, {}, oneLine(656.3));
    RenderOptions o = zCamera(5, 10.0);
    const Image persp = renderSpectral(scene, o);
    o.camera.model = "fisheye";
    o.camera.fovDeg = 180;
    const Image dome = renderSpectral(scene, o);
    const std::size_t centre = (2 * 5 + 2) * 4;
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(dome.rgba[centre + c], persp.rgba[centre + c],
                    1e-6 * std::abs(persp.rgba[centre + c]) + 1e-12);
    EXPECT_GT(std::abs(dome.rgba[centre]), 0.0f);
    EXPECT_EQ(dome.rgba[0], 0.0f);
    o.camera.model = "equirect";
    o.camera.width = 90;
    o.camera.height = 45;
    const Image pano = renderSpectral(scene, o);
    const std::size_t front = (22 * 90 + 44) * 4; // 2 degrees left of the view direction
    EXPECT_NEAR(pano.rgba[front], persp.rgba[centre], 2e-2 * std::abs(persp.rgba[centre]));
}

} // namespace
} // namespace nebula
