// SPDX-License-Identifier: Apache-2.0
/// @file test_lines.cpp
/// Spectral inputs: the emission-line catalogue, line lists, the Doppler factors, and the
/// Doppler-broadened line profiles (trapezoids) drawn along a ray segment. (The grid
/// metadata and temperature checks are in io/test_spectral_grids.cpp; nebgen's dust
/// temperature in stages/test_generate.cpp.)

#include "nebula/physics/lines.h"

#include "nebula/core/error.h"
#include "nebula/physics/spectrum.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

// ---- catalogue -------------------------------------------------------------------------

TEST(LineCatalogue, AirWavelengthsOfNistAsd)
{
    // Air wavelengths [nm] (NIST ASD; Osterbrock & Ferland 2006), to 0.01 nm.
    const std::pair<const char*, double> expected[] = {
        {"H-alpha", 656.28},
        {"H-beta", 486.13},
        {"H-gamma", 434.05},
        {"H-delta", 410.17},
        {"[O III]5007", 500.68},
        {"[O III]4959", 495.89},
        {"[N II]6583", 658.35},
        {"[N II]6548", 654.80},
        {"[S II]6716", 671.64},
        {"[S II]6731", 673.08},
        {"He I 5876", 587.56},
        {"[O I]6300", 630.03},
        {"[O I]6363", 636.38},
        // Absorption lines, to 0.001 nm.
        {"Na I D1", 589.592},
        {"Na I D2", 588.995},
        {"Ca II K", 393.366},
        {"Ca II H", 396.847},
    };
    for (const auto& [name, nm] : expected) {
        EXPECT_DOUBLE_EQ(nebula::lineWavelength(name), nm) << name;
    }
    const auto names = nebula::knownLines();
    ASSERT_EQ(names.size(), std::size(expected));
    for (std::size_t i = 0; i < names.size(); ++i)
        EXPECT_EQ(names[i], expected[i].first);
}

TEST(LineCatalogue, UnknownNamesListTheKnownOnesWithHints)
{
    std::string msg = errorMessage([] { nebula::lineWavelength("H-epsilon"); });
    EXPECT_TRUE(contains(msg, "unknown emission line \"H-epsilon\"")) << msg;
    for (const auto& name : nebula::knownLines())
        EXPECT_TRUE(contains(msg, name)) << msg;
    EXPECT_FALSE(contains(msg, "did you mean")) << msg;

    // Case-sensitive, but a case (or punctuation) slip gets a hint.
    msg = errorMessage([] { nebula::lineWavelength("h-alpha"); });
    EXPECT_TRUE(contains(msg, "did you mean \"H-alpha\"?")) << msg;
    msg = errorMessage([] { nebula::lineWavelength("Halpha"); });
    EXPECT_TRUE(contains(msg, "did you mean \"H-alpha\"?")) << msg;
    msg = errorMessage([] { nebula::lineWavelength("OIII"); });
    EXPECT_TRUE(contains(msg, "did you mean \"[O III]5007\" or \"[O III]4959\"?")) << msg;
    msg = errorMessage([] { nebula::lineWavelength("he i 5876"); });
    EXPECT_TRUE(contains(msg, "did you mean \"He I 5876\"?")) << msg;
}

// ---- line lists ------------------------------------------------------------------------

TEST(LineList, ParsesNamesStrengthsAndCustomWavelengths)
{
    auto lines = nebula::parseLineList(nebula::DEFAULT_EMISSION_LINES, "--lines");
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0], (nebula::SpectralLine{"H-alpha", 656.28, 1.0}));
    EXPECT_EQ(lines[1], (nebula::SpectralLine{"H-beta", 486.13, 0.35}));

    // Strength 1 when omitted, spaces around items ignored, names with spaces kept.
    lines = nebula::parseLineList(" [O III]5007 , He I 5876:0.2, 1000 ", "x");
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[0], (nebula::SpectralLine{"[O III]5007", 500.68, 1.0}));
    EXPECT_EQ(lines[1], (nebula::SpectralLine{"He I 5876", 587.56, 0.2}));
    EXPECT_EQ(lines[2], (nebula::SpectralLine{"1000", 1000.0, 1.0}));
}

TEST(LineList, CustomWavelengthsAndRoundTrip)
{
    const auto lines = nebula::parseLineList("H-alpha:2.5,372.71:0.125,[S II]6731:1e-3", "t");
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[1], (nebula::SpectralLine{"372.71", 372.71, 0.125}));
    const std::string text = nebula::lineListToString(lines);
    EXPECT_EQ(text, "H-alpha:2.5,372.71:0.125,[S II]6731:0.001");
    EXPECT_EQ(nebula::parseLineList(text, "t"), lines);

    // Awkward doubles survive the round trip exactly (shortest round-trip decimals).
    const std::vector<nebula::SpectralLine> odd = {{"H-beta", 486.13, 1.0 / 3.0},
                                                   {"0.1", 0.1, 2.0 / 7.0}};
    EXPECT_EQ(nebula::parseLineList(nebula::lineListToString(odd), "t"), odd);
    // A custom line written under another name is written as its wavelength.
    EXPECT_EQ(nebula::lineListToString({{"mine", 501.5, 1.0}}), "501.5:1");
    EXPECT_EQ(nebula::lineListToString(nebula::parseLineList(nebula::OIII_EMISSION_LINES, "t")),
              nebula::OIII_EMISSION_LINES);
}

TEST(LineList, EachErrorNamesSourceAndItem)
{
    struct Case
    {
        const char* text;
        const char* mention;
    };
    const Case cases[] = {
        {"", "empty line list"},
        {"   ", "empty line list"},
        {"H-alpha,", "item 2 is empty"},
        {",H-alpha", "item 1 is empty"},
        {"H-alpha,,H-beta", "item 2 is empty"},
        {"H-alfa:1", "item 1 (\"H-alfa:1\"): unknown emission line \"H-alfa\""},
        {"H-beta,h-alpha", "did you mean \"H-alpha\"?"},
        {"H-alpha:", "no strength after ':'"},
        {":0.5", "no line name before ':'"},
        {"H-alpha:abc", "strength \"abc\" is not a number"},
        {"H-alpha:1x", "strength \"1x\" is not a number"},
        {"H-alpha:0", "strength must be a finite number > 0, got 0"},
        {"H-alpha:-1", "strength must be a finite number > 0, got -1"},
        {"H-alpha:1e999", "strength must be a finite number > 0, got 1e999"},
        {"H-alpha:nan", "strength \"nan\" is not a number"},
        {"H-alpha:inf", "strength \"inf\" is not a number"},
        {"0:1", "custom wavelength must be a finite number > 0 [nm], got 0"},
        {"-500:1", "custom wavelength must be a finite number > 0 [nm], got -500"},
        {"1e999", "custom wavelength must be a finite number > 0 [nm], got 1e999"},
        {"H-alpha,H-beta,H-alpha:2", "item 3 (\"H-alpha:2\"): \"H-alpha\" (656.28 nm) is listed "
                                     "twice, also as item 1"},
        {"H-alpha,656.28:0.1", "listed twice, also as item 1"},
        {"500.5,500.50", "listed twice, also as item 1"},
    };
    for (const auto& c : cases) {
        const std::string msg = errorMessage([&] { nebula::parseLineList(c.text, "--lines"); });
        EXPECT_EQ(msg.rfind("--lines \"" + std::string(c.text) + "\": ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, c.mention)) << "for \"" << c.text << "\": " << msg;
    }
    // An unknown name lists the catalogue and the custom-wavelength form.
    const std::string msg = errorMessage([] { nebula::parseLineList("Lyman-alpha", "cfg"); });
    EXPECT_TRUE(contains(msg, "\"[S II]6716\"")) << msg;
    EXPECT_TRUE(contains(msg, "rest wavelength in nm")) << msg;
}

} // namespace

namespace nebula {
namespace {

// ---- Doppler factors and line profiles ---------------------------------------------------

TEST(SpectralLine, DopplerFactors)
{
    // First order: lambda'/lambda = 1 + v_r/c; receding (v_r > 0) is redder.
    EXPECT_EQ(dopplerFactor(0.0), 1.0);
    EXPECT_DOUBLE_EQ(dopplerFactor(SPEED_OF_LIGHT_KMS * 0.01), 1.01);
    EXPECT_DOUBLE_EQ(dopplerFactor(-299.792458), 0.999);
    // Relativistic: gamma (1 + v_r/c). Purely radial motion (v^2 = v_r^2) gives the
    // longitudinal factor sqrt((1 + b)/(1 - b)); purely transverse motion (v_r = 0) gamma.
    for (double b : {-0.6, -0.1, 0.0, 0.3, 0.8}) {
        const double vr = b * SPEED_OF_LIGHT_KMS;
        EXPECT_NEAR(relativisticDopplerFactor(vr, vr * vr), std::sqrt((1 + b) / (1 - b)), 1e-12)
            << b;
        EXPECT_NEAR(relativisticDopplerFactor(0.0, vr * vr), 1.0 / std::sqrt(1 - b * b), 1e-12)
            << b;
    }
    // Slow gas: the two agree to second order in v/c.
    EXPECT_NEAR(relativisticDopplerFactor(30.0, 900.0), dopplerFactor(30.0), 1e-8);
    // Moved from the spectral render test: approaching at 0.6 c.
    EXPECT_NEAR(relativisticDopplerFactor(-0.6 * SPEED_OF_LIGHT_KMS,
                                          0.36 * SPEED_OF_LIGHT_KMS * SPEED_OF_LIGHT_KMS),
                0.5, 1e-12); // approaching at 0.6 c: sqrt((1 - b)/(1 + b)) = 0.5
}

/// Integral and centroid of a trapezoid from its pieces, via Spectrum::sum.
void moments(const LineTrapezoid& t, double& integral, double& centroid)
{
    std::vector<Piece> p;
    for (int i = 0; i < 3; ++i) {
        const double ya = (i == 0) ? 0.0 : t.height, yb = (i == 2) ? 0.0 : t.height;
        if (t.x[i + 1] > t.x[i]) p.push_back(pieceThrough(t.x[i], ya, t.x[i + 1], yb));
    }
    const Spectrum s = Spectrum::sum(p);
    integral = s.integral();
    Spectrum x;
    x.add(Piece{t.x[0] - 1.0, t.x[3] + 1.0, 1.0, 0.0}); // the identity, x
    centroid = s.integral(x) / integral;
}

TEST(SpectralLine, EnergyAndCentroidExactUnderLinearVelocity)
{
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> v(-3000.0, 3000.0), w(1.0, 60.0), e(0.1, 10.0);
    for (int i = 0; i < 200; ++i) {
        const double vA = v(rng), vB = i % 7 == 0 ? vA : v(rng), width = w(rng), E = e(rng);
        const auto t = lineTrapezoid(656.28, vA, vB, width, E);
        double I, c;
        moments(t, I, c);
        // Energy: exact up to rounding (the paper's unnormalised trapezoid grows with the
        // spread; this one does not). Rounding: the pieces' m x + b form loses
        // log10(lambda / width) ~ 4 digits for a 0.04 nm box at 656 nm.
        EXPECT_NEAR(I, E, 1e-10 * E) << vA << " " << vB;
        EXPECT_NEAR(c, 656.28 * (1.0 + 0.5 * (vA + vB) / SPEED_OF_LIGHT_KMS), 1e-9 * 656.28);
        EXPECT_LE(t.x[0], t.x[1]);
        EXPECT_LE(t.x[1], t.x[2]);
        EXPECT_LE(t.x[2], t.x[3]);
    }
}

TEST(SpectralLine, UniformVelocityShiftsByLambdaVOverC)
{
    const double lambda0 = 500.68, v = -123.4, width = 10.0;
    const auto t = lineTrapezoid(lambda0, v, v, width, 2.0);
    const double eps = lambda0 * width / SPEED_OF_LIGHT_KMS;
    const double centre = lambda0 + lambda0 * v / SPEED_OF_LIGHT_KMS;
    EXPECT_NEAR(t.x[0], centre - eps, 1e-12 * lambda0);
    EXPECT_NEAR(t.x[3], centre + eps, 1e-12 * lambda0);
    EXPECT_NEAR(t.height, 2.0 / (2.0 * eps), 1e-9 * t.height);
    // Approaching gas (v < 0) is bluer.
    EXPECT_LT(0.5 * (t.x[0] + t.x[3]), lambda0);
    const auto r = lineTrapezoid(lambda0, -v, -v, width, 2.0);
    EXPECT_GT(0.5 * (r.x[0] + r.x[3]), lambda0);
}

TEST(SpectralLine, GradientMakesATrapezoidWithBoxWideRamps)
{
    // Centres spread over 2 nm, box half-width 0.1 nm: ramps 0.2 nm wide, top 1.8 nm.
    const double lambda0 = 600.0;
    const double vB = 2.0 / lambda0 * SPEED_OF_LIGHT_KMS;
    const double width = 0.1 / lambda0 * SPEED_OF_LIGHT_KMS;
    const auto t = lineTrapezoid(lambda0, 0.0, vB, width, 1.0);
    EXPECT_NEAR(t.x[1] - t.x[0], 0.2, 1e-9);
    EXPECT_NEAR(t.x[2] - t.x[1], 1.8, 1e-9);
    EXPECT_NEAR(t.x[3] - t.x[2], 0.2, 1e-9);
    EXPECT_NEAR(t.height, 1.0 / 2.0, 1e-9);
    // Reversed order of the end velocities: the same profile.
    const auto u = lineTrapezoid(lambda0, vB, 0.0, width, 1.0);
    for (int i = 0; i < 4; ++i)
        EXPECT_DOUBLE_EQ(t.x[i], u.x[i]);
}

TEST(SpectralLine, TrapezoidValueAndTheFactorsForm)
{
    // at(): 0 outside [x0, x3], the height on the top, linear on the ramps.
    const double lambda0 = 600.0;
    const double vB = 2.0 / lambda0 * SPEED_OF_LIGHT_KMS;
    const double width = 0.1 / lambda0 * SPEED_OF_LIGHT_KMS;
    const auto t = lineTrapezoid(lambda0, 0.0, vB, width, 1.0);
    EXPECT_EQ(t.at(t.x[0] - 1e-6), 0.0);
    EXPECT_EQ(t.at(t.x[3] + 1e-6), 0.0);
    EXPECT_NEAR(t.at(0.5 * (t.x[1] + t.x[2])), t.height, 1e-12);
    EXPECT_NEAR(t.at(0.5 * (t.x[0] + t.x[1])), 0.5 * t.height, 1e-9 * t.height);
    EXPECT_NEAR(t.at(t.x[2] + 0.25 * (t.x[3] - t.x[2])), 0.75 * t.height, 1e-9 * t.height);

    // lineTrapezoidFactors() with the first-order factors is lineTrapezoid().
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> v(-2000.0, 2000.0);
    for (int i = 0; i < 50; ++i) {
        const double a = v(rng), b = v(rng);
        const auto p = lineTrapezoid(486.13, a, b, 12.0, 3.0);
        const auto q = lineTrapezoidFactors(486.13, dopplerFactor(a), dopplerFactor(b), 12.0, 3.0);
        for (int k = 0; k < 4; ++k)
            EXPECT_NEAR(p.x[k], q.x[k], 1e-12 * 486.13) << a << " " << b;
        EXPECT_NEAR(p.height, q.height, 1e-9 * p.height) << a << " " << b;
    }
}

TEST(SpectralLine, IntegralToAgreesWithFineQuadratureAndTheEnergy)
{
    // integralTo(): 0 below x0, the energy above x3, and in between the midpoint rule's
    // sum (1e5 cells; a box's edge may fall inside a cell: one cell's height at most), for a
    // trapezoid, a box and a triangle.
    const double lambda0 = 589.0, width = 10.0, E = 2.5;
    const double dv[] = {40.0, 0.0, 2.0 * width};
    for (const double v : dv) {
        const auto t = lineTrapezoid(lambda0, -0.5 * v, 0.5 * v, width, E);
        EXPECT_EQ(t.integralTo(t.x[0] - 1e-3), 0.0);
        EXPECT_NEAR(t.integralTo(t.x[3] + 1e-3), E, 1e-10 * E) << v;
        const int n = 100000;
        const double a = t.x[0] - 0.01, h = (t.x[3] + 0.01 - a) / n;
        double sum = 0.0;
        for (int i = 0; i < n; ++i) {
            sum += t.at(a + (i + 0.5) * h) * h;
            if (i % 9973 == 0) {
                EXPECT_NEAR(t.integralTo(a + (i + 1) * h), sum, 2.0 * h * t.height)
                    << v << " " << i;
            }
        }
    }
}

} // namespace
} // namespace nebula
