// SPDX-License-Identifier: Apache-2.0
// The reference path tracer (DESIGN §6) against closed forms and published slab results.
// Monte Carlo estimates are compared within 3 of their own standard errors (the variance
// layer) plus a stated allowance for what the closed form leaves out.
#include "nebula/physics/colour.h"
#include "nebula/render/fast.h"

#include "render_scenes.h"

#include <tbb/task_arena.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace nebula;
using namespace nebula::test;

namespace {

const ImageLayer& layer(const Image& img, const std::string& name)
{
    for (const auto& l : img.layers) {
        if (l.name == name) return l;
    }
    throw std::runtime_error("no layer " + name);
}

/// Standard error of channel @p c of pixel 0.
double sigma(const Image& img, int c)
{
    return std::sqrt(layer(img, "variance").rgb[c]);
}

RenderOptions pathOptions(const RenderOptions& base, int spp)
{
    RenderOptions o = base;
    o.integrator = Integrator::Path;
    o.spp = spp;
    return o;
}

} // namespace

// Nearly black dust (a = 0.02: second and higher orders add about a tau / 2 < 0.5 %): single
// scattering of a far star's light entering the cube's x = 0 face. Seen across the beam along
// the central ray (star light crosses half the cube, tau / 2, to reach it):
// L = a p(0) E e^(-tau/2) (1 - e^-tau); seen along the beam (mu = 1), every point's light
// crosses the whole cube: L = a p(1) E tau e^-tau.
TEST(PathTracer, ThinSingleScatteringMatchesClosedForm)
{
    const double n0 = 50.0; // tau_V = 0.29 across the cube
    auto scene = cube(n0, 0.0, {farStar(Vec3(-1, 0, 0))});
    scene.dust.albedo = 0.02;
    for (const bool across : {true, false}) {
        const Vec3 eye = across ? Vec3(2, 2, -20) : Vec3(24, 2, 2);
        const Image img = renderPathTraced(scene, pathOptions(axisCamera(eye, 0.5), 40000));
        for (int c = 0; c < 3; ++c) {
            const double tau = KAPPA * scene.dust.r[c] * n0 * 39 * H;
            const double expected =
                across
                    ? 0.02 * henyeyGreenstein(0.0, 0.6) * std::exp(-tau / 2) * (1 - std::exp(-tau))
                    : 0.02 * henyeyGreenstein(1.0, 0.6) * tau * std::exp(-tau);
            EXPECT_NEAR(img.rgba[c], expected, 3 * sigma(img, c) + 0.005 * expected)
                << (across ? "across" : "along") << " c " << c;
        }
    }
}

// The path tracer and the fast ray caster (with tau from nebillum's integrator) agree on a
// thin, dark cloud (single scattering in the limit), pixel by pixel within the path tracer's
// noise plus 1 % (the ray caster interpolates tau between lattice points).
TEST(PathTracer, AgreesWithTheFastIntegratorWhenThin)
{
    Star star;
    star.name = "near";
    star.position = {-6.0, 3.1, 2.6};  // 8 pc from the cube's centre, outside it
    star.luminosity = 4.0 * PI * 64.0; // irradiance ~1 at the cube
    auto scene = cube(20.0, 0.0, {star});
    scene.dust.albedo = 0.05;
    fillStarTau(scene);
    RenderOptions o = axisCamera(Vec3(2, 2, -20), 0.5);
    o.camera.width = o.camera.height = 4;
    o.camera.fovDeg = 8.0;
    const Image fast = renderFrame(scene, o);
    const Image path = renderPathTraced(scene, pathOptions(o, 20000));
    int checked = 0;
    for (std::size_t p = 0; p < 16; ++p) {
        for (int c = 0; c < 3; ++c) {
            const double f = fast.rgba[p * 4 + c];
            if (f <= 0.0) continue;
            const double s = std::sqrt(layer(path, "variance").rgb[p * 3 + c]);
            EXPECT_NEAR(path.rgba[p * 4 + c], f, 3.5 * s + 0.01 * f) << "pixel " << p << " c " << c;
            ++checked;
        }
    }
    EXPECT_GT(checked, 20);
}

// Transmittance through a uniform cube along an axis: exp(-k 3.9 pc); ratio tracking.
TEST(PathTracer, TransmittanceMatchesClosedForm)
{
    const double n0 = 400.0; // tau_V = 2.3
    const auto scene = cube(n0, 0.0, {});
    const Image img = renderPathTraced(scene, pathOptions(axisCamera(Vec3(2, 2, -20), 0.5), 4000));
    const auto& T = layer(img, "transmittance");
    for (int c = 0; c < 3; ++c) {
        const double expected = std::exp(-KAPPA * scene.dust.r[c] * n0 * 39 * H);
        // Ratio tracking at twice the majorant in a uniform medium: variance per walk
        // e^-1.5tau - e^-2tau (the edge ramps change it a little); 4000 walks, 4 sigma.
        const double tau = -std::log(expected);
        const double sd = std::sqrt((std::exp(-1.5 * tau) - std::exp(-2 * tau)) / 4000);
        EXPECT_NEAR(T.rgb[c], expected, 4 * sd + 2e-3 * expected) << "c " << c;
    }
    EXPECT_NEAR(img.rgba[3], 1.0 - T.rgb[1], 1e-6);
}

// Emission in absorbing dust (albedo 0): S = e / k constant, L = S (1 - e^-tau); and
// emission where there is no dust at all, L = e * length.
TEST(PathTracer, EmissionMatchesClosedForms)
{
    const double n0 = 600.0, e0 = 2.0;
    auto scene = cube(n0, e0, {});
    scene.dust.albedo = 0.0;
    RenderOptions o = pathOptions(axisCamera(Vec3(2, 2, -20), 0.5), 4000);
    o.emissionColor = {1.0, 0.5, 0.25};
    Image img = renderPathTraced(scene, o);
    for (int c = 0; c < 3; ++c) {
        const double k = KAPPA * scene.dust.r[c] * n0;
        const double expected = e0 * o.emissionColor[c] / k * (1 - std::exp(-k * 39 * H));
        EXPECT_NEAR(img.rgba[c], expected, 3 * sigma(img, c) + 2e-3 * expected) << "c " << c;
    }
    auto gas = cube(0.0, e0, {});
    img = renderPathTraced(gas, o);
    for (int c = 0; c < 3; ++c) {
        const double expected = e0 * o.emissionColor[c] * 39 * H;
        EXPECT_NEAR(img.rgba[c], expected, 3 * sigma(img, c) + 2e-3 * expected) << "c " << c;
        EXPECT_GT(sigma(img, c), 0.0);
    }
}

// A far star above a wide uniform slab: the reflected and transmitted radiance at exit cosine
// 0.5 for normal incidence, I = R(mu, 1) E / pi and T(mu, 1) E / pi, against published values
// (the same ones the Monte Carlo core's slab tests use): van de Hulst 1980 Vol. 1 Table 12
// (isotropic, a = 0.8, b = 2: R(0.5, 1) = 0.28616, T(0.5, 1) = 0.14864) and DISORT test
// problem 3A (HG g = 0.75, a = 1, b = 1: UU at mu 0.5 = 0.101103 up, 0.266648 down, for
// incident flux pi). 1 % allowance for the slab's finite width (20 optical depths).
TEST(PathTracer, WideSlabMatchesPublishedRadiances)
{
    struct Case
    {
        double tau, albedo, g, up, down; // radiance per unit irradiance at mu = 0.5
    };
    for (const Case& k : {Case{2.0, 0.8, 0.0, 0.28616 / PI, 0.14864 / PI},
                          Case{1.0, 1.0, 0.75, 0.101103 / PI, 0.266648 / PI}}) {
        const auto scene = slab(k.tau, k.albedo, k.g);
        const Image up = renderPathTraced(scene, pathOptions(slabCamera(0.5, true, k.tau), 6000));
        const Image down =
            renderPathTraced(scene, pathOptions(slabCamera(0.5, false, k.tau), 6000));
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(up.rgba[c], k.up, 3 * sigma(up, c) + 0.01 * k.up)
                << "reflected, a " << k.albedo << " g " << k.g << " c " << c;
            EXPECT_NEAR(down.rgba[c], k.down, 3 * sigma(down, c) + 0.01 * k.down)
                << "transmitted, a " << k.albedo << " g " << k.g << " c " << c;
        }
    }
}

TEST(PathTracer, SameSeedSameImageWhateverTheThreadCount)
{
    const auto scene = cube(200.0, 1.0, {farStar(Vec3(-1, 0, 0))});
    RenderOptions o = pathOptions(axisCamera(Vec3(2, 2, -20), 0.5), 16);
    o.camera.width = o.camera.height = 6;
    o.camera.fovDeg = 10.0;
    Image one, two;
    tbb::task_arena(1).execute([&] { one = renderPathTraced(scene, o); });
    tbb::task_arena(2).execute([&] { two = renderPathTraced(scene, o); });
    EXPECT_EQ(one.rgba, two.rgba);
    o.seed = 2;
    EXPECT_NE(renderPathTraced(scene, o).rgba, one.rgba);
}

// The variance layer is the squared standard error: across independent seeds, the spread of
// the pixel means agrees with it (within the scatter of a variance estimated from 12 runs).
TEST(PathTracer, VarianceLayerMatchesTheSpreadAcrossSeeds)
{
    const auto scene = cube(200.0, 0.0, {farStar(Vec3(-1, 0, 0))});
    RenderOptions o = pathOptions(axisCamera(Vec3(2, 2, -20), 0.5), 200);
    double sum = 0, sumSq = 0, reported = 0;
    const int runs = 12;
    for (int r = 0; r < runs; ++r) {
        o.seed = 100 + r;
        const Image img = renderPathTraced(scene, o);
        sum += img.rgba[1];
        sumSq += img.rgba[1] * double(img.rgba[1]);
        reported += layer(img, "variance").rgb[1];
    }
    const double mean = sum / runs;
    const double spread = (sumSq - runs * mean * mean) / (runs - 1);
    const double ratio = spread / (reported / runs);
    EXPECT_GT(ratio, 0.3); // chi-squared with 11 degrees of freedom: 99.9 % within [0.25, 2.9]
    EXPECT_LT(ratio, 2.9);
}

// The luminance has its own variance channel (variance.Y): one walk carries all three
// channels, so their noise is correlated and Y's variance is not the weighted sum of theirs.
// Across seeds the spread of Y agrees with it; and it is clearly above what independent
// channels would give (fully correlated here: about 1.8 times).
TEST(PathTracer, LuminanceVarianceMatchesTheSpreadAcrossSeeds)
{
    const auto scene = cube(200.0, 0.0, {farStar(Vec3(-1, 0, 0))});
    RenderOptions o = pathOptions(axisCamera(Vec3(2, 2, -20), 0.5), 200);
    double sum = 0, sumSq = 0, reported = 0, independent = 0;
    const int runs = 12;
    for (int r = 0; r < runs; ++r) {
        o.seed = 200 + r;
        const Image img = renderPathTraced(scene, o);
        const double Y = linearSRGBLuminance(img.rgba[0], img.rgba[1], img.rgba[2]);
        sum += Y;
        sumSq += Y * Y;
        const auto it = std::find_if(img.channels.begin(), img.channels.end(),
                                     [](const ImageChannel& c) { return c.name == "variance.Y"; });
        ASSERT_NE(it, img.channels.end());
        reported += it->values[0];
        independent += independentLuminanceVariance(layer(img, "variance").rgb.data());
    }
    const double mean = sum / runs;
    const double spread = (sumSq - runs * mean * mean) / (runs - 1);
    const double ratio = spread / (reported / runs);
    EXPECT_GT(ratio, 0.3); // chi-squared with 11 degrees of freedom, as above
    EXPECT_LT(ratio, 2.9);
    EXPECT_GT(reported / independent, 1.5);
}

// The path tracer renders every camera model: from inside a glowing cube (no dust), an
// equirect panorama's flux matches the fast ray caster's within the noise, and a fisheye's
// corners stay black.
TEST(PathTracer, EveryCameraModel)
{
    const auto gas = cube(0.0, 1.0, {});
    RenderOptions o = axisCamera(Vec3(2.03, 1.98, 2.01), 0.25);
    o.camera.lookAt = Vec3(2.03, 1.98, 10);
    o.camera.up = Vec3(0, 1, 0);
    o.emissionColor = {1, 1, 1};
    o.camera.model = "equirect";
    o.camera.width = 32;
    o.camera.height = 16;
    const Projection p(o.camera);
    double fast = 0.0, path = 0.0;
    const Image f = renderFrame(gas, o), t = renderPathTraced(gas, pathOptions(o, 64));
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 32; ++x) {
            const std::size_t i = (std::size_t(y) * 32 + x) * 4 + 1;
            fast += f.rgba[i] * p.pixelSolidAngle(x + 0.5, y + 0.5);
            path += t.rgba[i] * p.pixelSolidAngle(x + 0.5, y + 0.5);
        }
    EXPECT_NEAR(path, fast, 1e-2 * fast);
    o.camera.model = "fisheye";
    o.camera.width = 16;
    o.camera.fovDeg = 180;
    const Image dome = renderPathTraced(gas, pathOptions(o, 16));
    EXPECT_EQ(dome.rgba[0], 0.0f);
    EXPECT_EQ(dome.rgba[3], 0.0f);
    EXPECT_GT(dome.rgba[(8 * 16 + 8) * 4 + 1], 0.0f);
}
