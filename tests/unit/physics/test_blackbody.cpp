// SPDX-License-Identifier: Apache-2.0
/// @file test_blackbody.cpp
/// Planck's law (physics/blackbody.h) against Wien's and Stefan-Boltzmann's laws, its closed
/// form, the per-nm and unchecked forms, and its argument checks.

#include "nebula/physics/blackbody.h"

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace {

// ---------------------------------------------------------------------------------------------
// Planck's law

/// Maximiser of f on [a, b] by golden-section search.
double argMax(const std::function<double(double)>& f, double a, double b)
{
    const double r = 0.5 * (std::sqrt(5.0) - 1.0);
    double c = b - r * (b - a);
    double d = a + r * (b - a);
    for (int i = 0; i < 200; ++i) {
        if (f(c) > f(d)) {
            b = d;
        } else {
            a = c;
        }
        c = b - r * (b - a);
        d = a + r * (b - a);
    }
    return 0.5 * (a + b);
}

TEST(Planck, WienDisplacement)
{
    // Wien's displacement constant b = 2.897771955e-3 m K (CODATA 2018).
    for (double T : {3000.0, 5772.0, 30000.0}) {
        const double peak = argMax([&](double l) { return nebula::planck(l, T); }, 1e-8, 1e-5);
        EXPECT_NEAR(peak / (2.897771955e-3 / T), 1.0, 1e-4) << T;
    }
}

TEST(Planck, StefanBoltzmann)
{
    // int_0^inf B_lambda dlambda = sigma T^4 / pi, sigma = 5.670374419e-8 W m^-2 K^-4
    // (CODATA 2018). Simpson's rule in ln(lambda) over 1e-2 ... 1e3 times the peak; the
    // tails beyond hold less than 1e-8 of the total.
    for (double T : {3000.0, 5772.0, 30000.0}) {
        const double peak = 2.897771955e-3 / T;
        const double a = std::log(1e-2 * peak);
        const double b = std::log(1e3 * peak);
        const int n = 20000;
        const double h = (b - a) / n;
        double sum = 0.0;
        for (int i = 0; i <= n; ++i) {
            const double lambda = std::exp(a + i * h);
            const double w = (i == 0 || i == n) ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0);
            sum += w * nebula::planck(lambda, T) * lambda;
        }
        const double integral = sum * h / 3.0;
        const double expected = 5.670374419e-8 * std::pow(T, 4) / 3.14159265358979323846;
        EXPECT_NEAR(integral / expected, 1.0, 1e-4) << T;
    }
}

TEST(Planck, RejectsNonPositiveInput)
{
    EXPECT_THROW(nebula::planck(0.0, 5000.0), nebula::Error);
    EXPECT_THROW(nebula::planck(5e-7, 0.0), nebula::Error);
    EXPECT_THROW(nebula::planck(5e-7, NAN), nebula::Error);
}

TEST(Planck, PerNmIsPlanckOver1e9)
{
    // Moved from ColourBlackbody.NoOverflowOrUnderflow (test_colour.cpp).
    EXPECT_THROW(nebula::planckPerNm(0.0, 5000.0), nebula::Error);
    EXPECT_THROW(nebula::planckPerNm(500.0, 0.0), nebula::Error);
    EXPECT_NEAR(nebula::planckPerNm(500.0, 5772.0), nebula::planck(500e-9, 5772.0) * 1e-9,
                1e-15 * nebula::planck(500e-9, 5772.0) * 1e-9);
    // Also at other wavelengths and temperatures, and the unchecked form is the same law.
    for (double T : {300.0, 3000.0, 5772.0, 30000.0}) {
        for (double nm : {200.0, 500.0, 2000.0}) {
            const double perNm = nebula::planckPerNm(nm, T);
            EXPECT_NEAR(perNm, nebula::planck(nm * 1e-9, T) * 1e-9, 1e-13 * perNm)
                << nm << " " << T;
            EXPECT_NEAR(nebula::planckPerNmUnchecked(nm, T), perNm, 1e-13 * perNm)
                << nm << " " << T;
        }
    }
    EXPECT_THROW(nebula::planckPerNm(-500.0, 5000.0), nebula::Error);
    EXPECT_THROW(nebula::planckPerNm(500.0, INFINITY), nebula::Error);
    EXPECT_THROW(nebula::planck(INFINITY, 5000.0), nebula::Error);
    EXPECT_THROW(nebula::planck(5e-7, -1.0), nebula::Error);
}

TEST(Planck, ClosedFormAtOnePoint)
{
    // B_lambda(T) = 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1) with the CODATA 2018
    // constants, written out here at 500 nm, 5772 K.
    const double h = 6.62607015e-34, c = 299792458.0, k = 1.380649e-23;
    const double l = 500e-9, T = 5772.0;
    const double expected = 2.0 * h * c * c / std::pow(l, 5) / std::expm1(h * c / (l * k * T));
    EXPECT_NEAR(nebula::planck(l, T), expected, 1e-13 * expected);
    // Rayleigh-Jeans limit (h c << lambda k T): B ~ 2 c k T / lambda^4.
    const double lr = 1.0; // 1 m at 1e4 K: h c / (lambda k T) = 1.4e-6
    EXPECT_NEAR(nebula::planck(lr, 1e4), 2.0 * c * k * 1e4 / std::pow(lr, 4),
                1e-5 * 2.0 * c * k * 1e4);
}

} // namespace
