// SPDX-License-Identifier: Apache-2.0
// physics/spherical_harmonics.h: the real harmonics' orthonormality and addition theorem by
// quadrature, the phase functions' Legendre moments (closed forms for Henyey-Greenstein and
// Rayleigh, brute force for the Mie approximations), and the identity the scattered-light
// field rests on: integral of p(w_i . w_o) f(w_i) dw_i = sum p_l c_lm Y_lm(w_o).
#include "nebula/physics/spherical_harmonics.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace nebula;

namespace {

/// Quadrature over the sphere: Gauss-Legendre in cos(theta) (n nodes, by Newton) times 2n
/// equal steps in phi; exact for polynomials of degree < 2n on the sphere.
struct SphereRule
{
    std::vector<Vec3> dirs;
    std::vector<double> weights;
    explicit SphereRule(int n)
    {
        for (int i = 0; i < n; ++i) {
            double t = std::cos(PI * (i + 0.75) / (n + 0.5)), dp = 0.0;
            for (int it = 0; it < 100; ++it) {
                dp = n * (t * legendre(n, t) - legendre(n - 1, t)) / (t * t - 1.0);
                t -= legendre(n, t) / dp;
            }
            dp = n * (t * legendre(n, t) - legendre(n - 1, t)) / (t * t - 1.0);
            const double w = 2.0 / ((1.0 - t * t) * dp * dp);
            const double s = std::sqrt(1.0 - t * t);
            for (int j = 0; j < 2 * n; ++j) {
                const double phi = 2.0 * PI * (j + 0.5) / (2 * n);
                dirs.emplace_back(s * std::cos(phi), s * std::sin(phi), t);
                weights.push_back(w * PI / n);
            }
        }
    }
};

Vec3 randomDirection(std::mt19937& rng)
{
    std::normal_distribution<double> n;
    return Vec3(n(rng), n(rng), n(rng)).normalized();
}

} // namespace

TEST(SphericalHarmonics, OrthonormalOnTheSphere)
{
    const SphereRule rule(12);
    const int K = shCount(SH_MAX_DEGREE);
    std::vector<double> gram(std::size_t(K) * std::size_t(K), 0.0);
    std::vector<double> y(static_cast<std::size_t>(K));
    for (std::size_t q = 0; q < rule.dirs.size(); ++q) {
        realSphericalHarmonics(rule.dirs[q], SH_MAX_DEGREE, y.data());
        for (int a = 0; a < K; ++a)
            for (int b = 0; b < K; ++b)
                gram[std::size_t(a * K + b)] +=
                    rule.weights[q] * y[std::size_t(a)] * y[std::size_t(b)];
    }
    for (int a = 0; a < K; ++a)
        for (int b = 0; b < K; ++b)
            EXPECT_NEAR(gram[std::size_t(a * K + b)], a == b ? 1.0 : 0.0, 1e-12) << a << "," << b;
    EXPECT_NEAR(y[0], 0.5 / std::sqrt(PI), 1e-16);
    double z[25];
    realSphericalHarmonics(Vec3(0, 0, 1), 2, z);
    EXPECT_NEAR(z[shIndex(1, 0)], std::sqrt(3.0 / (4.0 * PI)), 1e-15);
    EXPECT_NEAR(z[shIndex(1, 1)], 0.0, 1e-15);
    EXPECT_THROW(realSphericalHarmonics(Vec3(0, 0, 1), 5, z), Error);
}

// sum_m Y_lm(a) Y_lm(b) = (2l + 1) / (4 pi) P_l(a . b) for random directions.
TEST(SphericalHarmonics, AdditionTheorem)
{
    std::mt19937 rng(3);
    double ya[25], yb[25];
    for (int trial = 0; trial < 50; ++trial) {
        const Vec3 a = randomDirection(rng), b = randomDirection(rng);
        realSphericalHarmonics(a, 4, ya);
        realSphericalHarmonics(b, 4, yb);
        for (int l = 0; l <= 4; ++l) {
            double sum = 0.0;
            for (int m = -l; m <= l; ++m)
                sum += ya[shIndex(l, m)] * yb[shIndex(l, m)];
            EXPECT_NEAR(sum, (2 * l + 1) / (4 * PI) * legendre(l, a.dot(b)), 1e-13) << "l " << l;
        }
    }
}

// p_0 = 1 for every model (normalisation); Henyey-Greenstein g^l; Rayleigh 1, 0, 1/10, 0, 0;
// the Mie approximations against Simpson's rule on 20000 intervals.
TEST(SphericalHarmonics, PhaseLegendreMoments)
{
    const auto hg = phaseLegendreMoments(PhaseModel::HenyeyGreenstein, 0.6, 4);
    for (int l = 0; l <= 4; ++l)
        EXPECT_NEAR(hg[std::size_t(l)], std::pow(0.6, l), 1e-15);
    const auto ray = phaseLegendreMoments(PhaseModel::Rayleigh, 0.0, 4);
    const double expected[] = {1.0, 0.0, 0.1, 0.0, 0.0};
    for (int l = 0; l <= 4; ++l)
        EXPECT_NEAR(ray[std::size_t(l)], expected[l], 1e-14) << l;
    for (const auto model : {PhaseModel::MieHazy, PhaseModel::MieMurky}) {
        const auto p = phaseLegendreMoments(model, 0.0, 4);
        const int n = 20000;
        for (int l = 0; l <= 4; ++l) {
            double s = 0.0;
            for (int i = 0; i <= n; ++i) {
                const double mu = -1.0 + 2.0 * i / n;
                const double wgt = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
                s += wgt * phaseFunction(model, mu, 0.0) * legendre(l, mu);
            }
            s *= 2.0 / n / 3.0 * 2.0 * PI;
            EXPECT_NEAR(p[std::size_t(l)], s, 1e-9) << toString(model) << " l " << l;
        }
        EXPECT_NEAR(p[0], 1.0, 1e-12);
        EXPECT_GT(p[1], 0.3); // forward scattering
    }
}

// The field identity: for a band-limited radiance f = sum c_lm Y_lm, the light a phase
// function scatters into w_o, integral of p(w_i . w_o) f(w_i) dw_i, is sum_l p_l sum_m c_lm
// Y_lm(w_o), whatever p's higher moments (brute-force quadrature on 64 x 128 points).
TEST(SphericalHarmonics, PhaseConvolutionOfAField)
{
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<double> c(25);
    for (auto& x : c)
        x = u(rng);
    const SphereRule rule(64);
    double y[25];
    for (const auto model :
         {PhaseModel::HenyeyGreenstein, PhaseModel::Rayleigh, PhaseModel::MieHazy}) {
        const double g = 0.3;
        const auto p = phaseLegendreMoments(model, g, 4);
        for (int trial = 0; trial < 5; ++trial) {
            const Vec3 wo = randomDirection(rng);
            double brute = 0.0;
            for (std::size_t q = 0; q < rule.dirs.size(); ++q) {
                realSphericalHarmonics(rule.dirs[q], 4, y);
                double f = 0.0;
                for (int k = 0; k < 25; ++k)
                    f += c[std::size_t(k)] * y[k];
                brute += rule.weights[q] * phaseFunction(model, rule.dirs[q].dot(wo), g) * f;
            }
            realSphericalHarmonics(wo, 4, y);
            double field = 0.0;
            for (int l = 0; l <= 4; ++l)
                for (int m = -l; m <= l; ++m)
                    field += p[std::size_t(l)] * c[std::size_t(shIndex(l, m))] * y[shIndex(l, m)];
            EXPECT_NEAR(field, brute, 1e-9) << toString(model);
        }
    }
}
