// SPDX-License-Identifier: Apache-2.0
// The map statistics of physics/cloud_statistics.h against maps whose answers are known.
#include "nebula/core/error.h"
#include "nebula/physics/cloud_statistics.h"

#include <gtest/gtest.h>

#include <fftw3.h>

#include <cmath>
#include <random>
#include <vector>

using nebula::ColumnMap;

namespace {

ColumnMap mapOf(int n, const std::vector<double>& values)
{
    ColumnMap m;
    m.nu = m.nv = n;
    m.values = values;
    return m;
}

/// A 2-D Gaussian random field of power spectrum k^-slope (k >= 1), n x n, by inverse FFT.
ColumnMap gaussianField(int n, double slope, unsigned seed)
{
    const int nc = n / 2 + 1;
    std::vector<fftw_complex> modes(std::size_t(n) * nc);
    std::vector<double> out(std::size_t(n) * n);
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    for (int v = 0; v < n; ++v) {
        const int kv = v <= n / 2 ? v : v - n;
        for (int u = 0; u < nc; ++u) {
            const double k = std::hypot(double(u), double(kv));
            const double amp = k >= 1.0 ? std::pow(k, -0.5 * slope) : 0.0;
            modes[std::size_t(v) * nc + u][0] = amp * normal(rng);
            modes[std::size_t(v) * nc + u][1] = amp * normal(rng);
        }
    }
    fftw_plan plan = fftw_plan_dft_c2r_2d(n, n, modes.data(), out.data(), FFTW_ESTIMATE);
    fftw_execute(plan);
    fftw_destroy_plan(plan);
    return mapOf(n, out);
}

} // namespace

TEST(CloudStatistics, LognormalWidthOfALognormalMap)
{
    // 40,000 pixels of N = exp(sigma z), z standard normal: the fitted sigma within 5 %, its
    // peak at ln(N / <N>) = -sigma^2 / 2 within 0.05, no tail.
    for (double sigma : {0.3, 0.5, 1.0}) {
        std::mt19937 rng(1);
        std::normal_distribution<double> normal;
        std::vector<double> v(200 * 200);
        for (double& x : v)
            x = std::exp(sigma * normal(rng));
        const auto fit = nebula::fitColumnPdf(mapOf(200, v), 0.05);
        ASSERT_TRUE(fit.fitted);
        EXPECT_NEAR(fit.sigma, sigma, 0.05 * sigma);
        EXPECT_NEAR(fit.mu, -0.5 * sigma * sigma, 0.05);
        EXPECT_NEAR(fit.sampleSigma, sigma, 0.05 * sigma);
        EXPECT_FALSE(fit.tail) << "excess " << fit.tailExcess;
    }
}

TEST(CloudStatistics, PowerLawTailIsFoundWithItsSlope)
{
    // A lognormal of sigma 0.4 (36,000 pixels) plus 4,000 pixels drawn from p(eta) ~ N^-2
    // (eta = ln N from 0.5 to 3): the tail is found, its slope -2 within 0.3.
    std::mt19937 rng(2);
    std::normal_distribution<double> normal;
    std::uniform_real_distribution<double> uniform;
    std::vector<double> v;
    for (int i = 0; i < 36000; ++i)
        v.push_back(std::exp(0.4 * normal(rng)));
    for (int i = 0; i < 4000; ++i) {
        // Inverse CDF of p(eta) ~ exp(-2 eta) on [0.5, 3].
        const double a = std::exp(-2.0 * 0.5), b = std::exp(-2.0 * 3.0);
        v.push_back(std::exp(-0.5 * std::log(a - uniform(rng) * (a - b))));
    }
    const auto fit = nebula::fitColumnPdf(mapOf(200, v), 0.1);
    ASSERT_TRUE(fit.fitted);
    EXPECT_NEAR(fit.sigma, 0.4, 0.06);
    EXPECT_TRUE(fit.tail) << "excess " << fit.tailExcess;
    EXPECT_NEAR(fit.tailSlope, -2.0, 0.3);
}

TEST(CloudStatistics, FloorLeavesOutTheFaintPixels)
{
    // Half the pixels at 1, half at 0.01: with a floor of 0.25 <N> only the first half count.
    std::vector<double> v(100 * 100);
    for (std::size_t i = 0; i < v.size(); ++i)
        v[i] = i % 2 ? 1.0 : 0.01;
    const auto fit = nebula::fitColumnPdf(mapOf(100, v), 0.1, 0.25);
    EXPECT_EQ(fit.pixels, v.size() / 2);
}

TEST(CloudStatistics, PowerSpectrumSlopeOfAGaussianField)
{
    // Synthetic fields of known slope: the fitted slope within 0.15 over k = 4-32 (128^2).
    for (double slope : {2.0, 2.8, 3.5}) {
        const auto fit = nebula::powerSpectrum(gaussianField(128, slope, 4), 4.0, 32.0);
        ASSERT_TRUE(fit.fitted);
        EXPECT_NEAR(fit.slope, -slope, 0.15) << slope;
        EXPECT_GT(fit.bins, 20);
    }
    EXPECT_THROW(nebula::powerSpectrum(gaussianField(16, 3.0, 1), 20.0, 30.0), nebula::Error);
}

TEST(CloudStatistics, PerimeterAreaOfSquaresAndLines)
{
    // Squares: P = 4 sqrt(A) exactly, so D = 1. One-pixel lines of length L: A = L,
    // P = 2 L + 2, so D tends to 2 (1.9 for L = 4-48). Shapes at 2 on a background of 1: the
    // one level is the background's, and the shapes are the regions above it.
    const int n = 200;
    std::vector<double> squares(std::size_t(n) * n, 1.0), lines(std::size_t(n) * n, 1.0);
    int x = 2;
    for (int side = 2; side <= 20; side += 3) {
        for (int v = 10; v < 10 + side; ++v) {
            for (int u = x; u < x + side; ++u)
                squares[std::size_t(v) * n + u] = 2.0;
        }
        x += side + 3;
    }
    for (int i = 0; i < 12; ++i) {
        const int len = 4 + 4 * i;
        for (int u = 5; u < 5 + len; ++u)
            lines[std::size_t(5 + 4 * i) * n + u] = 2.0;
    }
    const auto sq = nebula::perimeterAreaDimension(mapOf(n, squares), 1, 1);
    ASSERT_TRUE(sq.fitted);
    EXPECT_NEAR(sq.dimension, 1.0, 1e-9);
    const auto ln = nebula::perimeterAreaDimension(mapOf(n, lines), 1, 1);
    ASSERT_TRUE(ln.fitted);
    EXPECT_GT(ln.dimension, 1.8);
    EXPECT_LT(ln.dimension, 2.0);
}

TEST(CloudStatistics, LogMomentsOfKnownValues)
{
    nebula::LogMoments m, a, b;
    for (double x : {1.0, std::exp(2.0), 0.0, -1.0, std::exp(-2.0)})
        m.add(x);
    EXPECT_EQ(m.count(), 3u);
    EXPECT_NEAR(m.mean(), 0.0, 1e-12);
    EXPECT_NEAR(m.sigma(), std::sqrt(8.0 / 3.0), 1e-12);
    a.add(1.0);
    b.add(std::exp(2.0));
    b.add(std::exp(-2.0));
    a.merge(b);
    EXPECT_NEAR(a.sigma(), m.sigma(), 1e-12);
    EXPECT_NEAR(a.mean(), m.mean(), 1e-12);
    // add(x, n): n voxels of one value at once (a tile), as n add(x).
    nebula::LogMoments once, each;
    once.add(std::exp(1.0));
    each.add(std::exp(1.0));
    once.add(std::exp(-1.0), 1000);
    once.add(-2.0, 5);
    once.add(3.0, 0);
    for (int i = 0; i < 1000; ++i)
        each.add(std::exp(-1.0));
    EXPECT_EQ(once.count(), 1001u);
    EXPECT_NEAR(once.mean(), each.mean(), 1e-12);
    EXPECT_NEAR(once.sigma(), each.sigma(), 1e-12);
}
