// SPDX-License-Identifier: Apache-2.0
// Absorption lines in the spectral renderer (DESIGN §7.6): a uniform absorbing slab in front
// of a continuum against the closed-form equivalent width of a box profile,
// EW = 2 eps (1 - e^-tau0), tau0 = column * strength / (2 eps), its Doppler shift, its thin
// limit EW = column * strength, its colour, and the lines and starlight it dims.
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/stars.h"
#include "nebula/render/spectral.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <utility>

namespace nebula {
namespace {

constexpr double H = 0.1; // voxel [pc]
constexpr int N = 21;     // lattice 0..20
constexpr double KAPPA = 1.5e-3;
constexpr double COLUMN = 0.8; // the absorber's column per unit value: 8 voxels [pc]
constexpr double WIDTH = 10.0; // --line-width [km/s]
constexpr int LAYERS = 470;    // 1 nm layers

/// What absorbingSlab() builds.
struct Slab
{
    explicit Slab(std::vector<SpectralLine> lines = {}, double speed = 0.0)
        : absorbs(std::move(lines)), v(speed)
    {}
    std::vector<SpectralLine> absorbs; ///< the absorber's lines (none: no absorber)
    double v = 0.0;                    ///< the gas's uniform velocity along +z [km/s]
    bool continuum = true;             ///< grey dust glowing at 6000 K behind (k >= 12)
    double lineAt = 0.0;               ///< an emission line behind, energy 1 per pc (0: none)
    std::vector<Star> stars;           ///< stars (their tau 0) lighting the dust
    bool mixed = false;                ///< the absorber in the glowing dust (k >= 12) instead
};

/// Seen along +z through the cube's centre: the absorber (value 1 on lattice k = 1..8:
/// column COLUMN, seven voxels and two half ramps), then from k = 12 on the continuum's dust
/// and the emission line. Channels: 0 density, 1 occupancy, 2.. tau of the stars, then
/// temperature, absorber, emission, velocity (3).
SpectralScene absorbingSlab(const Slab& slab)
{
    SpectralScene s;
    const int S = int(slab.stars.size()), T = 2 + S, A = T + 1, E = T + 2, V = T + 3;
    s.base.fields = SparseVolume({0, 0, 0}, {N, N, N}, V + 3);
    s.base.fields.indexToWorld.m = {H, 0, 0, 0, H, 0, 0, 0, H};
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                float* q = s.base.fields.writable(s.base.fields.index(i, j, k));
                q[V + 2] = float(slab.v); // velocity and temperature on the border too: no ramps
                q[T] = 6000.0f;
                if (i == 0 || j == 0 || k == 0 || i == N - 1 || j == N - 1 || k == N - 1) continue;
                const bool front = k <= 8, back = k >= 12;
                q[0] = back && slab.continuum ? 2000.0f : 0.0f;
                q[A] = (slab.mixed ? back : front) && !slab.absorbs.empty() ? 1.0f : 0.0f;
                q[E] = back && slab.lineAt > 0.0 ? 1.0f : 0.0f;
                q[1] = q[A] + q[E];
            }
    s.dust.kappa_V = KAPPA;
    s.dust.curve = "grey";
    s.base.dust.kappa_V = KAPPA;
    s.base.stars = slab.stars;
    for (const auto& st : slab.stars) {
        const auto rgb = blackbodyLinearSRGB(st.temperature);
        s.base.starColor.push_back(
            {rgb[0] * st.luminosity, rgb[1] * st.luminosity, rgb[2] * st.luminosity});
    }
    s.base.buildOccupancy();
    if (slab.continuum) s.temperatureChannel = T;
    if (!slab.absorbs.empty()) s.absorbers.push_back({"absorption.test", A, slab.absorbs});
    if (slab.lineAt > 0.0) {
        s.emitters.push_back({"emission", E, {SpectralLine{"test", slab.lineAt, 1.0}}, 1.0});
    }
    s.velocityChannel = V;
    s.maxSpeed = std::abs(slab.v);
    return s;
}

RenderOptions zRay(double exaggerate = 1.0)
{
    RenderOptions o;
    o.camera.eye = Vec3(1, 1, -5);
    o.camera.lookAt = Vec3(1, 1, 1);
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = 1;
    o.camera.fovDeg = 0.5;
    o.drawStars = false;
    o.spectral.enabled = true;
    o.spectral.layers = LAYERS;
    o.spectral.lineWidth = WIDTH;
    o.spectral.exaggerateVelocity = exaggerate;
    return o;
}

/// One absorption line at @p lambda0 whose box (half-width eps) reaches the optical depth
/// @p tau0 at its centre through the slab's column.
SpectralLine lineOfDepth(double lambda0, double tau0, double exaggerate = 1.0)
{
    const double eps = lambda0 * WIDTH * exaggerate / SPEED_OF_LIGHT_KMS;
    return SpectralLine{"test", lambda0, tau0 * 2.0 * eps / COLUMN};
}

double layer(const Image& img, std::size_t b)
{
    return double(img.channels[b].values[0]);
}

/// The continuum of @p ref at @p lambda [nm]: its 1 nm layer there, moved along the slope of
/// its neighbours (the continuum is linear between its 10 nm nodes).
double continuumAt(const Image& ref, double lambda)
{
    const std::size_t b = std::size_t(lambda - SPECTRAL_MIN_NM);
    const double centre = SPECTRAL_MIN_NM + double(b) + 0.5;
    return layer(ref, b) + (lambda - centre) * 0.5 * (layer(ref, b + 1) - layer(ref, b - 1));
}

/// The energy per nm missing from @p img against @p ref, summed over the layers [nm x].
double deficit(const Image& ref, const Image& img)
{
    double d = 0.0;
    for (std::size_t b = 0; b < LAYERS; ++b)
        d += layer(ref, b) - layer(img, b);
    return d;
}

double boxWidth(double tau0, double eps)
{
    return 2.0 * eps * -std::expm1(-tau0);
}

TEST(SpectralAbsorption, EquivalentWidthOfAUniformSlabIsTheClosedForm)
{
    // At rest, from unsaturated to saturated: EW = 2 eps (1 - e^-tau0), within 1 %.
    const double lambda0 = 393.366; // Ca II K
    const double eps = lambda0 * WIDTH / SPEED_OF_LIGHT_KMS;
    const Image ref = renderSpectral(absorbingSlab(Slab()), zRay());
    for (const double tau0 : {0.3, 1.0, 3.0, 10.0}) {
        const Image img = renderSpectral(absorbingSlab(Slab({lineOfDepth(lambda0, tau0)})), zRay());
        const double ew = deficit(ref, img) / continuumAt(ref, lambda0);
        std::printf("absorption: at rest, tau0 %g: EW %.7g nm, closed form %.7g nm (%+.2g %%)\n",
                    tau0, ew, boxWidth(tau0, eps), 100.0 * (ew / boxWidth(tau0, eps) - 1.0));
        EXPECT_NEAR(ew, boxWidth(tau0, eps), 0.01 * boxWidth(tau0, eps)) << tau0;
    }
}

TEST(SpectralAbsorption, AbsorberMixedWithTheGlowingDust)
{
    // Absorber and black-body dust in one slab, in proportion: the source function is
    // B tau_d / (tau_d + tau_l), so inside the box I = B tau_d / (tau_d + tau0) (1 -
    // e^-(tau_d + tau0)) against B (1 - e^-tau_d) outside, and EW = 2 eps (1 - I_in / I_out).
    // Each step dims its own light by the dust's and the line's escape fractions in turn,
    // not by their sum's: +0.2 % at the default step (16 through the slab), +0.05 % at half
    // of it, 0.01 % at a fifth.
    const double lambda0 = 393.366, tau0 = 1.0, tauD = KAPPA * 2000.0 * COLUMN;
    const double eps = lambda0 * WIDTH / SPEED_OF_LIGHT_KMS;
    Slab slab;
    slab.mixed = true;
    const Image ref = renderSpectral(absorbingSlab(slab), zRay());
    slab.absorbs = {lineOfDepth(lambda0, tau0)};
    const Image img = renderSpectral(absorbingSlab(slab), zRay());
    const double inside = tauD / (tauD + tau0) * -std::expm1(-(tauD + tau0));
    const double want = 2.0 * eps * (1.0 - inside / -std::expm1(-tauD));
    const double ew = deficit(ref, img) / continuumAt(ref, lambda0);
    std::printf("absorption: mixed with the dust, tau_d %g, tau0 %g: EW %.7g nm, closed form "
                "%.7g nm (%+.2g %%)\n",
                tauD, tau0, ew, want, 100.0 * (ew / want - 1.0));
    EXPECT_NEAR(ew, want, 0.01 * want);
}

TEST(SpectralAbsorption, ThinLimitIsColumnTimesStrength)
{
    // tau0 = 1e-3: EW = column * strength (to tau0 / 2 = 0.05 %), within 1 %. The lines are
    // 50 times wider (--exaggerate-velocity 50) so that the float layers resolve the dip.
    const double lambda0 = 588.995; // Na I D2
    const SpectralLine line = lineOfDepth(lambda0, 1e-3, 50.0);
    const Image ref = renderSpectral(absorbingSlab(Slab()), zRay(50.0));
    const Image img = renderSpectral(absorbingSlab(Slab({line})), zRay(50.0));
    const double ew = deficit(ref, img) / continuumAt(ref, lambda0);
    std::printf("absorption: thin, tau0 1e-3: EW %.7g nm, column * strength %.7g nm (%+.2g %%), "
                "closed form %+.2g %%\n",
                ew, COLUMN * line.strength, 100.0 * (ew / (COLUMN * line.strength) - 1.0),
                100.0 * (ew / boxWidth(1e-3, lambda0 * WIDTH * 50.0 / SPEED_OF_LIGHT_KMS) - 1.0));
    EXPECT_NEAR(ew, COLUMN * line.strength, 0.01 * COLUMN * line.strength);
}

TEST(SpectralAbsorption, UniformVelocityShiftsTheDipByVOverC)
{
    // Rest wavelengths chosen so that the dip of gas at v lands on 394 nm, the edge between
    // two 1 nm layers: the deficit splits evenly between them if it is centred on
    // lambda0 (1 + v/c); a shift d moves the fraction (1 + d/eps)/2 to the upper layer, so
    // |2 f - 1| <= 0.01 is the centroid to 1 % of eps. At rest the same line stays in the
    // lower layer. The EW is the same closed form (bins no longer aligned with the box).
    const double tau0 = 2.0, v = 40.0, c = SPEED_OF_LIGHT_KMS;
    for (const double sign : {1.0, -1.0}) {
        const double lambda0 = 394.0 / (1.0 + sign * v / c);
        const double eps = lambda0 * WIDTH / c;
        const SpectralLine line = lineOfDepth(lambda0, tau0);
        const Image ref = renderSpectral(absorbingSlab(Slab({}, sign * v)), zRay());
        const Image img = renderSpectral(absorbingSlab(Slab({line}, sign * v)), zRay());
        const double lower = layer(ref, 33) - layer(img, 33);
        const double upper = layer(ref, 34) - layer(img, 34);
        const double f = upper / (lower + upper);
        std::printf(
            "absorption: v %+g km/s: deficit above 394 nm %.6f, centroid offset %+.2g eps\n",
            sign * v, f, 2.0 * f - 1.0);
        EXPECT_NEAR(2.0 * f - 1.0, 0.0, 0.01) << sign;
        const double ew = deficit(ref, img) / continuumAt(ref, 394.0);
        std::printf("absorption: v %+g km/s, tau0 %g: EW %.7g nm, closed form %.7g nm (%+.2g %%)\n",
                    sign * v, tau0, ew, boxWidth(tau0, eps),
                    100.0 * (ew / boxWidth(tau0, eps) - 1.0));
        EXPECT_NEAR(ew, boxWidth(tau0, eps), 0.01 * boxWidth(tau0, eps)) << sign;

        const Image rest = renderSpectral(absorbingSlab(Slab({line}, 0.0)), zRay());
        const Image rest0 = renderSpectral(absorbingSlab(Slab({}, 0.0)), zRay());
        EXPECT_GT(layer(rest0, 33 + (sign < 0)) - layer(rest, 33 + (sign < 0)), 0.0);
        EXPECT_EQ(layer(rest0, 34 - (sign < 0)), layer(rest, 34 - (sign < 0))) << sign;
    }
}

TEST(SpectralAbsorption, ColourSeesTheDip)
{
    // Y loses the integral of C(lambda) ybar(lambda) (1 - e^-tau(lambda)) over the box
    // (lines 50 times wider, moving at 40 km/s), C from the reference's layers: 1 %.
    const double lambda0 = 588.995, tau0 = 1.5, ex = 50.0, v = 40.0;
    const double centre = lambda0 * (1.0 + v * ex / SPEED_OF_LIGHT_KMS);
    const double eps = lambda0 * WIDTH * ex / SPEED_OF_LIGHT_KMS;
    const Image ref = renderSpectral(absorbingSlab(Slab({}, v)), zRay(ex));
    const Image img =
        renderSpectral(absorbingSlab(Slab({lineOfDepth(lambda0, tau0, ex)}, v)), zRay(ex));
    const auto Y = [](const Image& im) {
        return linearSRGBToXYZ({im.rgba[0], im.rgba[1], im.rgba[2]})[1];
    };
    double want = 0.0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        const double lam = centre - eps + 2.0 * eps * (i + 0.5) / n;
        want += continuumAt(ref, lam) * cmfAt(lam)[1] * -std::expm1(-tau0) * 2.0 * eps / n;
    }
    EXPECT_NEAR(Y(ref) - Y(img), want, 0.01 * want);
}

TEST(SpectralAbsorption, AnEmissionLineBehindLosesOneMinusExpTau)
{
    // The same box in emission behind the absorber (both at 40 km/s): e^-tau0 of its energy
    // gets through (1 % here; the bins at the box's edges straddle it).
    const double lambda0 = 589.592, tau0 = 1.0, v = 40.0;
    Slab slab({}, v);
    slab.continuum = false;
    slab.lineAt = lambda0;
    const Image ref = renderSpectral(absorbingSlab(slab), zRay());
    slab.absorbs = {lineOfDepth(lambda0, tau0)};
    const Image img = renderSpectral(absorbingSlab(slab), zRay());
    double e0 = 0.0, e1 = 0.0;
    for (std::size_t b = 0; b < LAYERS; ++b) {
        e0 += layer(ref, b);
        e1 += layer(img, b);
    }
    EXPECT_NEAR(e0, 0.8, 1e-5); // the line's energy: 8 voxels of 0.1 pc, unit 1
    EXPECT_NEAR(e1 / e0, std::exp(-tau0), 0.01 * std::exp(-tau0));
}

TEST(SpectralAbsorption, StarlightAndGasLoseAlikeComponentByComponent)
{
    // A star between the slabs lights the glowing dust: both the scattered starlight
    // ("single") and the black body ("emission") lose EW times their continuum, each within
    // 1 %; the components still add up to the total; the star's own layer loses its share.
    const double lambda0 = 588.995, tau0 = 1.0;
    const double eps = lambda0 * WIDTH / SPEED_OF_LIGHT_KMS;
    Star star;
    star.name = "s";
    star.position = {1.0, 1.0, 1.0};
    star.luminosity = 5.0;
    star.temperature = 20000.0;
    Slab slab;
    slab.stars = {star};
    auto o = zRay();
    o.componentLayers = true;
    const Image ref = renderSpectral(absorbingSlab(slab), o);
    slab.absorbs = {lineOfDepth(lambda0, tau0)};
    const Image img = renderSpectral(absorbingSlab(slab), o);
    const auto part = [](const Image& im, std::size_t k) {
        Image one;
        for (std::size_t b = 0; b < LAYERS; ++b)
            one.channels.push_back(im.channels[k * LAYERS + b]);
        return one;
    };
    for (const std::size_t k : {2u, 4u}) { // single, emission
        const Image r = part(ref, k), a = part(img, k);
        ASSERT_GT(continuumAt(r, lambda0), 0.0) << k;
        const double ew = deficit(r, a) / continuumAt(r, lambda0);
        EXPECT_NEAR(ew, boxWidth(tau0, eps), 0.01 * boxWidth(tau0, eps)) << k;
    }
    for (std::size_t b = 225; b < 235; ++b) {
        double sum = 0.0;
        for (std::size_t k = 1; k <= 4; ++k)
            sum += double(img.channels[k * LAYERS + b].values[0]);
        EXPECT_NEAR(sum, layer(img, b), 1e-6 * layer(img, b)) << b;
    }
    const auto starY = [](const Image& im) {
        const auto& rgb = im.rgb(*im.findLayer("star.s"));
        return linearSRGBToXYZ({rgb[0], rgb[1], rgb[2]})[1];
    };
    const Image single = part(ref, 2);
    const double want = continuumAt(single, lambda0) * cmfAt(lambda0)[1] * boxWidth(tau0, eps);
    EXPECT_NEAR(starY(ref) - starY(img), want, 0.01 * want);
}

TEST(SpectralAbsorption, AStarBehindTheSlabLosesItsLinesToo)
{
    // The sprite of a star between the slabs (nothing glowing): its layers lose EW times its
    // spectrum, at 40 km/s, within 1 %.
    const double lambda0 = 396.847, tau0 = 2.0, v = 40.0; // Ca II H
    const double eps = lambda0 * WIDTH / SPEED_OF_LIGHT_KMS;
    const double centre = lambda0 * (1.0 + v / SPEED_OF_LIGHT_KMS);
    Star star;
    star.name = "s";
    star.position = {1.0, 1.0, 1.0};
    star.luminosity = 5.0;
    star.temperature = 9000.0;
    Slab slab({}, v);
    slab.continuum = false;
    slab.stars = {star};
    auto o = zRay();
    o.drawStars = true;
    const Image ref = renderSpectral(absorbingSlab(slab), o);
    slab.absorbs = {lineOfDepth(lambda0, tau0)};
    const Image img = renderSpectral(absorbingSlab(slab), o);
    ASSERT_GT(continuumAt(ref, centre), 0.0);
    const double ew = deficit(ref, img) / continuumAt(ref, centre);
    EXPECT_NEAR(ew, boxWidth(tau0, eps), 0.01 * boxWidth(tau0, eps));
}

} // namespace
} // namespace nebula
