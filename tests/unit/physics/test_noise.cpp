// SPDX-License-Identifier: Apache-2.0
/// @file test_noise.cpp
/// Perlin's improved noise against his reference code, properties of fBm, the analytic
/// noise gradients, and curl noise.

#include "nebula/physics/noise.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace {

struct ReferenceValue
{
    double x, y, z;
    double noise;
};

// Values of Ken Perlin's published Java reference code "ImprovedNoise" (2002, the class
// with the 256-entry permutation table p[] repeated, fade, lerp and grad with h & 15),
// run under OpenJDK 17 and printed with 17 significant digits (String.format "%.16e"),
// at exactly these points.
constexpr ReferenceValue REFERENCE[] = {
    {3.7, 1.2, 0.5, 1.5058103423999997e-01},
    {-2.31, 7.77, 13.1, -1.0023021429573040e-01},
    {0.5, 0.5, 0.5, -2.5000000000000000e-01},
    {0.25, 0.75, 0.125, -7.0603896980173890e-02},
    {10.9, -3.3, 2.2, -3.2908034630554424e-02},
    {-0.1, -0.2, -0.3, -4.1573493932994576e-01},
    {123.456, 78.9, -45.6, -1.7889880557350868e-01},
    {300.3, 257.7, -511.25, 4.5866956092191435e-02},
    {1.5, 2.5, 3.5, 1.2500000000000000e-01},
    {0.999, 0.001, 0.5, -5.0099998500252030e-01},
};

TEST(PerlinNoise, MatchesPerlinsJavaReference)
{
    for (const auto& r : REFERENCE) {
        EXPECT_NEAR(nebula::perlinNoise(r.x, r.y, r.z), r.noise, 1e-12)
            << "at (" << r.x << ", " << r.y << ", " << r.z << ")";
    }
}

TEST(PerlinNoise, ZeroAtIntegerLatticePoints)
{
    for (int x = -300; x <= 300; x += 37) {
        for (int y = -5; y <= 5; ++y) {
            for (int z = -260; z <= 260; z += 65) {
                EXPECT_EQ(nebula::perlinNoise(x, y, z), 0.0) << x << " " << y << " " << z;
            }
        }
    }
}

TEST(PerlinNoise, StaysWithinRange)
{
    // Improved noise reaches about +-1.04 at most; 1.1 leaves a margin.
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> coord(-500.0, 500.0);
    double lo = 0.0;
    double hi = 0.0;
    for (int i = 0; i < 200000; ++i) {
        const double n = nebula::perlinNoise(coord(rng), coord(rng), coord(rng));
        ASSERT_LE(std::fabs(n), 1.1);
        lo = std::min(lo, n);
        hi = std::max(hi, n);
    }
    // Not degenerate: it spans a good part of the range.
    EXPECT_LT(lo, -0.6);
    EXPECT_GT(hi, 0.6);
}

TEST(PerlinNoise, PeriodicWith256)
{
    // Equal up to the rounding of the shifted coordinates' fractional parts.
    EXPECT_NEAR(nebula::perlinNoise(3.7, 1.2, 0.5), nebula::perlinNoise(259.7, 1.2, 0.5), 1e-12);
    EXPECT_NEAR(nebula::perlinNoise(3.7, 1.2, 0.5), nebula::perlinNoise(3.7, -254.8, 0.5), 1e-12);
}

TEST(PerlinNoise, NonFiniteInputGivesNaN)
{
    EXPECT_TRUE(std::isnan(nebula::perlinNoise(NAN, 0.5, 0.5)));
    EXPECT_TRUE(std::isnan(nebula::perlinNoise(0.5, INFINITY, 0.5)));
}

TEST(Fbm, IsDeterministic)
{
    const nebula::FbmParams params;
    for (double t = -3.0; t < 3.0; t += 0.37) {
        EXPECT_EQ(nebula::fbm(t, 2 * t, -t, params, 42), nebula::fbm(t, 2 * t, -t, params, 42));
    }
}

TEST(Fbm, DifferentSeedsDiffer)
{
    const nebula::FbmParams params;
    const std::uint64_t seeds[] = {0, 1, 2, 42, 0xFFFFFFFFFFFFFFFFull};
    for (std::uint64_t a : seeds) {
        for (std::uint64_t b : seeds) {
            if (a == b) continue;
            // Compare over a set of points: they must not agree.
            double diff = 0.0;
            for (int i = 0; i < 50; ++i) {
                const double t = 0.173 * i;
                diff += std::fabs(nebula::fbm(t, 0.5 * t, 1.3, params, a) -
                                  nebula::fbm(t, 0.5 * t, 1.3, params, b));
            }
            EXPECT_GT(diff / 50, 0.05) << "seeds " << a << " and " << b;
        }
    }
}

TEST(Fbm, SeedZeroWorks)
{
    // Seed 0 still shifts the octaves: fBm is not zero at lattice points.
    const nebula::FbmParams params;
    double sum = 0.0;
    for (int i = 0; i < 20; ++i) {
        sum += std::fabs(nebula::fbm(i, 2 * i, 3 * i, params, 0));
    }
    EXPECT_GT(sum, 0.1);
}

TEST(Fbm, NormalisedRange)
{
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> coord(-50.0, 50.0);
    for (int octaves : {1, 3, 6, 16}) {
        for (double gain : {0.3, 0.5, 0.8}) {
            nebula::FbmParams params;
            params.octaves = octaves;
            params.gain = gain;
            double sumSq = 0.0;
            constexpr int N = 5000;
            for (int i = 0; i < N; ++i) {
                const double v = nebula::fbm(coord(rng), coord(rng), coord(rng), params, 99);
                ASSERT_LE(std::fabs(v), 1.1);
                sumSq += v * v;
            }
            // Not collapsed to zero by the normalisation.
            EXPECT_GT(std::sqrt(sumSq / N), 0.05) << octaves << " octaves, gain " << gain;
        }
    }
}

TEST(Fbm, OneOctaveIsShiftedNoise)
{
    nebula::FbmParams params;
    params.octaves = 1;
    // One octave: noise at the point plus an offset, so within noise's range and smooth.
    const double a = nebula::fbm(1.0, 2.0, 3.0, params, 5);
    const double b = nebula::fbm(1.0 + 1e-7, 2.0, 3.0, params, 5);
    EXPECT_NEAR(a, b, 1e-5);
}

TEST(Fbm, RejectsBadParameters)
{
    nebula::FbmParams params;
    params.octaves = 0;
    EXPECT_THROW(nebula::fbm(0.1, 0.2, 0.3, params, 1), nebula::UsageError);
    params.octaves = 17;
    EXPECT_THROW(nebula::fbm(0.1, 0.2, 0.3, params, 1), nebula::UsageError);
    params = {};
    params.gain = 0.0;
    EXPECT_THROW(nebula::fbm(0.1, 0.2, 0.3, params, 1), nebula::UsageError);
    params = {};
    params.lacunarity = -2.0;
    EXPECT_THROW(nebula::fbm(0.1, 0.2, 0.3, params, 1), nebula::UsageError);
}

// ---- helpers for the gradient and curl tests -------------------------------------------

using nebula::test::frobenius;
using nebula::test::jacobian;
using nebula::test::randomPoints;
using Vec = nebula::test::Vec;

// ---- noise gradients and curl noise ----------------------------------------------------

TEST(NoiseGradient, MatchesPerlinNoiseAndCentralDifferences)
{
    const double h = 1e-6;
    for (const auto& p : randomPoints(2000, 300.0, 7)) {
        const auto g = nebula::perlinNoiseGradient(p[0], p[1], p[2]);
        EXPECT_EQ(g.value, nebula::perlinNoise(p[0], p[1], p[2]));
        for (int a = 0; a < 3; ++a) {
            Vec pp = p, pm = p;
            pp[a] += h;
            pm[a] -= h;
            const double fd = (nebula::perlinNoise(pp[0], pp[1], pp[2]) -
                               nebula::perlinNoise(pm[0], pm[1], pm[2])) /
                              (2.0 * h);
            // Central differences: O(h^2) truncation plus 1e-16/h rounding.
            ASSERT_NEAR(g.gradient[a], fd, 1e-7)
                << "axis " << a << " at " << p[0] << "," << p[1] << "," << p[2];
        }
    }
    EXPECT_TRUE(std::isnan(nebula::perlinNoiseGradient(NAN, 0, 0).gradient[1]));
}

TEST(NoiseGradient, FbmGradientMatchesFbm)
{
    const nebula::FbmParams params{5, 2.0, 0.5};
    const double h = 1e-6;
    for (const auto& p : randomPoints(300, 3.0, 8)) {
        const auto g = nebula::fbmGradient(p[0], p[1], p[2], params, 42);
        EXPECT_EQ(g.value, nebula::fbm(p[0], p[1], p[2], params, 42));
        for (int a = 0; a < 3; ++a) {
            Vec pp = p, pm = p;
            pp[a] += h;
            pm[a] -= h;
            const double fd = (nebula::fbm(pp[0], pp[1], pp[2], params, 42) -
                               nebula::fbm(pm[0], pm[1], pm[2], params, 42)) /
                              (2.0 * h);
            ASSERT_NEAR(g.gradient[a], fd, 1e-6);
        }
    }
    EXPECT_THROW(nebula::fbmGradient(0, 0, 0, {0, 2.0, 0.5}, 1), nebula::UsageError);
}

TEST(CurlNoise, DivergenceFreeAndDeterministic)
{
    const nebula::FbmParams params{4, 2.0, 0.4};
    const auto v = [&](const Vec& x) { return nebula::curlNoise(x[0], x[1], x[2], params, 3); };
    double maxRatio = 0.0;
    for (const auto& p : randomPoints(500, 5.0, 9)) {
        const auto J = jacobian(v, p, 1e-5);
        const double div = J[0][0] + J[1][1] + J[2][2];
        maxRatio = std::max(maxRatio, std::fabs(div) / frobenius(J));
        EXPECT_EQ(v(p), v(p));
    }
    // Analytic curl: div v = 0 up to the finite-difference check's own error (~1e-9 here).
    EXPECT_LT(maxRatio, 1e-6);
    // Different seeds, different fields.
    EXPECT_NE(nebula::curlNoise(0.3, 0.2, 0.1, params, 3),
              nebula::curlNoise(0.3, 0.2, 0.1, params, 4));
}

} // namespace
