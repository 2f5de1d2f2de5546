// SPDX-License-Identifier: Apache-2.0
/// @file test_spectrum.cpp
/// Piecewise-linear spectra (DESIGN §7.1): the 11 overlap cases of the paper's
/// table, random sums against brute force, exact integrals of products, merging and
/// multiplication by a smooth function.

#include "nebula/physics/spectrum.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iostream>
#include <random>
#include <vector>

namespace {

using nebula::Piece;
using nebula::Spectrum;

using nebula::test::contains;
using nebula::test::errorMessage;
using nebula::test::simpson;

// ---------------------------------------------------------------------------------------------
// Helpers

/// A trapezoid through (x0, y0) and (x1, y1), x0 < x1 [nm].
struct Trapezoid
{
    double x0, x1, y0, y1;

    /// Value of the trapezoid's line at x (no range check).
    double line(double x) const { return y0 + (y1 - y0) * (x - x0) / (x1 - x0); }
};

/// Sum of the lines on f [x1, x2] (slope 1/2, intercept 1) and g [y1, y2] (slope -1/4,
/// intercept 3): the coefficients are exact in binary, so the expected pieces are exact.
constexpr double M1 = 0.5, B1 = 1.0, M2 = -0.25, B2 = 3.0;

Piece f(double x1, double x2)
{
    return Piece{x1, x2, M1, B1};
}
Piece g(double y1, double y2)
{
    return Piece{y1, y2, M2, B2};
}
Piece fg(double lo, double hi)
{
    return Piece{lo, hi, M1 + M2, B1 + B2};
}

/// Checks that @p s holds exactly the pieces @p expected.
void expectPieces(const Spectrum& s, const std::vector<Piece>& expected)
{
    ASSERT_EQ(s.size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        const Piece& p = s.pieces()[i];
        EXPECT_EQ(p.x0, expected[i].x0) << "piece " << i;
        EXPECT_EQ(p.x1, expected[i].x1) << "piece " << i;
        EXPECT_EQ(p.m, expected[i].m) << "piece " << i;
        EXPECT_EQ(p.b, expected[i].b) << "piece " << i;
    }
}

/// Adds @p first then @p second, and in the other order, and checks both against
/// @p expected (the result does not depend on the order of adding).
void expectSum(const Piece& first, const Piece& second, const std::vector<Piece>& expected)
{
    Spectrum forward;
    forward.add(first);
    forward.add(second);
    expectPieces(forward, expected);

    Spectrum backward;
    backward.add(second);
    backward.add(first);
    expectPieces(backward, expected);
}

/// Checks sorting (x0 < x1) and no overlaps (x1 <= next x0).
void expectSortedDisjoint(const Spectrum& s)
{
    const std::vector<Piece>& p = s.pieces();
    for (std::size_t i = 0; i < p.size(); ++i) {
        ASSERT_LT(p[i].x0, p[i].x1) << "piece " << i;
        if (i + 1 < p.size()) {
            ASSERT_LE(p[i].x1, p[i + 1].x0) << "piece " << i;
        }
    }
}

/// n random trapezoids over the visible range, widths 0.5-60 nm, values in [-0.5, 2].
std::vector<Trapezoid> randomTrapezoids(std::mt19937_64& rng, int n)
{
    std::uniform_real_distribution<double> start(380.0, 720.0);
    std::uniform_real_distribution<double> width(0.5, 60.0);
    std::uniform_real_distribution<double> value(-0.5, 2.0);
    std::vector<Trapezoid> out;
    for (int i = 0; i < n; ++i) {
        const double x0 = start(rng);
        out.push_back(Trapezoid{x0, x0 + width(rng), value(rng), value(rng)});
    }
    return out;
}

Spectrum spectrumOf(const std::vector<Trapezoid>& traps)
{
    Spectrum s;
    for (const Trapezoid& t : traps) {
        s.addTrapezoid(t.x0, t.x1, t.y0, t.y1);
    }
    return s;
}

/// First moment, the integral of x s(x) [value * nm^2], as the product with the line x.
double firstMoment(const Spectrum& s)
{
    Spectrum x;
    x.add(Piece{0.0, 2000.0, 1.0, 0.0});
    return s.integral(x);
}

// ---------------------------------------------------------------------------------------------
// The 11 cases of the paper's table (f on [x1, x2], g on [y1, y2])

TEST(SpectrumAddCases, Case1And11Disjoint)
{
    expectSum(f(400, 450), g(500, 550), {f(400, 450), g(500, 550)}); // case 1: x2 < y1
    expectSum(f(500, 550), g(400, 450), {g(400, 450), f(500, 550)}); // case 11: y2 < x1
    // "meets": touching endpoints stay two pieces.
    expectSum(f(400, 500), g(500, 550), {f(400, 500), g(500, 550)});
}

TEST(SpectrumAddCases, Case2OverlapFFirst)
{
    // x1 < y1 < x2 < y2
    expectSum(f(400, 500), g(450, 550), {f(400, 450), fg(450, 500), g(500, 550)});
}

TEST(SpectrumAddCases, Case3OverlapGFirst)
{
    // y1 < x1 < y2 < x2
    expectSum(f(450, 550), g(400, 500), {g(400, 450), fg(450, 500), f(500, 550)});
}

TEST(SpectrumAddCases, Case4SameRightEndFLonger)
{
    // x1 < y1 < x2 = y2
    expectSum(f(400, 500), g(450, 500), {f(400, 450), fg(450, 500)});
}

TEST(SpectrumAddCases, Case5SameInterval)
{
    // x1 = y1 < x2 = y2
    expectSum(f(400, 500), g(400, 500), {fg(400, 500)});
}

TEST(SpectrumAddCases, Case6SameRightEndGLonger)
{
    // y1 < x1 < x2 = y2
    expectSum(f(450, 500), g(400, 500), {g(400, 450), fg(450, 500)});
}

TEST(SpectrumAddCases, Case7SameLeftEndGLonger)
{
    // x1 = y1 < x2 < y2
    expectSum(f(400, 450), g(400, 500), {fg(400, 450), g(450, 500)});
}

TEST(SpectrumAddCases, Case8SameLeftEndFLonger)
{
    // x1 = y1 < y2 < x2
    expectSum(f(400, 500), g(400, 450), {fg(400, 450), f(450, 500)});
}

TEST(SpectrumAddCases, Case9GInsideF)
{
    // x1 < y1 < y2 < x2
    expectSum(f(400, 550), g(450, 500), {f(400, 450), fg(450, 500), f(500, 550)});
}

TEST(SpectrumAddCases, Case10FInsideG)
{
    // y1 < x1 < x2 < y2
    expectSum(f(450, 500), g(400, 550), {g(400, 450), fg(450, 500), g(500, 550)});
}

TEST(SpectrumAddCases, PieceSpanningSeveralPiecesAndGaps)
{
    // g over two separate f pieces: the gap between them becomes a g piece.
    Spectrum s;
    s.add(f(400, 450));
    s.add(f(500, 550));
    s.add(g(425, 525));
    expectPieces(s, {f(400, 425), fg(425, 450), g(450, 500), fg(500, 525), f(525, 550)});
}

TEST(SpectrumAddCases, NearlyCoincidentBreakpointsLeaveNoSliver)
{
    Spectrum s;
    s.add(f(400, 500));
    s.add(g(500.0 * (1.0 + 1e-13), 600)); // touches 500 within 1e-12 relative
    expectPieces(s, {f(400, 500), g(500, 600)});
    s.add(g(400.0 * (1.0 - 1e-13), 450)); // starts at 400 within 1e-12 relative
    expectPieces(s, {fg(400, 450), f(450, 500), g(500, 600)});
}

// ---------------------------------------------------------------------------------------------
// Values, degenerate pieces, errors

TEST(SpectrumValue, HalfOpenAtSharedEndpoints)
{
    Spectrum s;
    s.add(Piece{400, 500, 0.0, 1.0});
    s.add(Piece{500, 600, 0.0, 2.0});
    EXPECT_EQ(s(400.0), 1.0);
    EXPECT_EQ(s(500.0), 2.0); // the right-hand piece, not the sum 3
    EXPECT_EQ(s(600.0), 2.0); // the last piece at its x1
    EXPECT_EQ(s(399.0), 0.0);
    EXPECT_EQ(s(600.5), 0.0);
}

TEST(SpectrumTrapezoid, ReversedEndpointsAreSwappedWithTheirValues)
{
    Spectrum s;
    s.addTrapezoid(500.0, 400.0, 3.0, 1.0);
    ASSERT_EQ(s.size(), 1u);
    EXPECT_EQ(s.pieces()[0].x0, 400.0);
    EXPECT_EQ(s.pieces()[0].x1, 500.0);
    EXPECT_NEAR(s(400.0), 1.0, 1e-13);
    EXPECT_NEAR(s(450.0), 2.0, 1e-13);
    EXPECT_NEAR(s(500.0), 3.0, 1e-13);
}

TEST(SpectrumTrapezoid, ZeroWidthPieceIsIgnored)
{
    Spectrum s;
    s.addTrapezoid(500.0, 500.0, 1.0, 2.0);
    s.add(Piece{500.0, 500.0, 1.0, 0.0});
    s.addTrapezoid(500.0, 500.0 * (1.0 + 1e-14), 1.0, 2.0);
    EXPECT_EQ(s.size(), 0u);
    EXPECT_EQ(s.integral(), 0.0);
}

TEST(SpectrumTrapezoid, NegativeWidthPieceThrows)
{
    Spectrum s;
    EXPECT_THROW(s.add(Piece{500.0, 400.0, 0.0, 1.0}), nebula::UsageError);
    EXPECT_TRUE(contains(errorMessage([&] {
                             s.add(Piece{500.0, 400.0, 0.0, 1.0});
                         }),
                         "spectrum piece with x0 > x1"));
    EXPECT_THROW(s.add(Piece{NAN, 400.0, 0.0, 1.0}), nebula::UsageError);
    EXPECT_EQ(s.size(), 0u);
}

TEST(SpectrumTrapezoid, DopplerBroadenedLineKeepsTheTrapezoidArea)
{
    // H-alpha line of integral I over a box of half width eps, its two ends shifted by the
    // velocities at the two samples (DESIGN §7.1, Algorithm 2). The y values are fixed by
    // the densities, so the area is (x2 - x1)(y1 + y2)/2, as in the paper.
    const double lambda = 656.28; // [nm]
    const double eps = 0.05;      // [nm]
    const double I = 1.0;         // line integral [value * nm]
    const double c = 299792.458;  // [km/s]
    const double rho1 = 0.8, rho2 = 1.3;
    for (double v2 : {-120.0, 0.0, 35.0, 250.0, -40000.0}) { // [km/s]; the last one reverses
        const double v1 = 30.0;
        const double x1 = (lambda - eps) * (1.0 - v1 / c);
        const double x2 = (lambda + eps) * (1.0 - v2 / c);
        const double y1 = rho1 * I / (2.0 * eps);
        const double y2 = rho2 * I / (2.0 * eps);
        Spectrum s;
        s.addTrapezoid(x1, x2, y1, y2);
        const double expected = std::fabs(x2 - x1) * (y1 + y2) / 2.0;
        EXPECT_NEAR(s.integral(), expected, 1e-12 * expected) << "v2 = " << v2;
    }
}

// ---------------------------------------------------------------------------------------------
// Random sums against brute force

TEST(SpectrumRandom, ManyTrapezoidsMatchBruteForce)
{
    std::mt19937_64 rng(20230417);
    const std::vector<Trapezoid> traps = randomTrapezoids(rng, 400);
    const Spectrum s = spectrumOf(traps);
    expectSortedDisjoint(s);

    double area = 0.0;
    double areaAbs = 0.0;
    for (const Trapezoid& t : traps) {
        area += (t.x1 - t.x0) * (t.y0 + t.y1) / 2.0;
        areaAbs += (t.x1 - t.x0) * (std::fabs(t.y0) + std::fabs(t.y1)) / 2.0;
    }
    EXPECT_NEAR(s.integral(), area, 1e-12 * areaAbs);

    // Values at random points (never on a breakpoint, almost surely).
    std::uniform_real_distribution<double> where(370.0, 790.0);
    for (int k = 0; k < 2000; ++k) {
        const double x = where(rng);
        double sum = 0.0;
        double sumAbs = 0.0;
        for (const Trapezoid& t : traps) {
            if (t.x0 <= x && x < t.x1) {
                sum += t.line(x);
                sumAbs += std::fabs(t.line(x));
            }
        }
        EXPECT_NEAR(s(x), sum, 1e-12 * std::max(sumAbs, 1.0)) << "x = " << x;
    }
    std::cout << "[ piece count ] 400 random trapezoids -> " << s.size() << " pieces\n";
}

TEST(SpectrumRandom, SumOfPiecesEqualsAddingThemOneByOne)
{
    std::mt19937_64 rng(11);
    const std::vector<Trapezoid> traps = randomTrapezoids(rng, 300);
    const Spectrum added = spectrumOf(traps);
    std::vector<Piece> pieces;
    for (const Trapezoid& t : traps) {
        if (t.x1 > t.x0) pieces.push_back(nebula::pieceThrough(t.x0, t.y0, t.x1, t.y1));
    }
    const Spectrum summed = Spectrum::sum(pieces);
    expectSortedDisjoint(summed);
    ASSERT_EQ(summed.size(), added.size());
    for (std::size_t i = 0; i < summed.size(); ++i) {
        const Piece& a = summed.pieces()[i];
        const Piece& b = added.pieces()[i];
        EXPECT_NEAR(a.x0, b.x0, 1e-12 * b.x0);
        EXPECT_NEAR(a.x1, b.x1, 1e-12 * b.x1);
        const double scale = std::fabs(b.at(b.x0)) + std::fabs(b.at(b.x1)) + 1.0;
        EXPECT_NEAR(a.at(a.x0), b.at(b.x0), 1e-9 * scale);
        EXPECT_NEAR(a.at(a.x1), b.at(b.x1), 1e-9 * scale);
    }
    // Gaps stay gaps; a reversed piece is refused.
    const Spectrum gap = Spectrum::sum(std::vector<Piece>{nebula::pieceThrough(400, 1, 410, 1),
                                                          nebula::pieceThrough(420, 2, 430, 2)});
    ASSERT_EQ(gap.size(), 2u);
    EXPECT_EQ(gap(415.0), 0.0);
    EXPECT_THROW(Spectrum::sum(std::vector<Piece>{Piece{410, 400, 0, 1}}), nebula::UsageError);
}

TEST(SpectrumRandom, AddOrderDoesNotChangeTheSum)
{
    std::mt19937_64 rng(7);
    std::vector<Trapezoid> traps = randomTrapezoids(rng, 100);
    const Spectrum a = spectrumOf(traps);
    std::reverse(traps.begin(), traps.end());
    const Spectrum b = spectrumOf(traps);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a.pieces()[i].x0, b.pieces()[i].x0);
        EXPECT_EQ(a.pieces()[i].x1, b.pieces()[i].x1);
        const double mid = 0.5 * (a.pieces()[i].x0 + a.pieces()[i].x1);
        EXPECT_NEAR(a(mid), b(mid), 1e-12 * std::max(1.0, std::fabs(a(mid))));
    }
}

// ---------------------------------------------------------------------------------------------
// Integral of a product

TEST(SpectrumIntegral, SinglePieceExactly)
{
    Spectrum s;
    s.add(Piece{0.0, 2.0, 1.0, 0.0});
    EXPECT_DOUBLE_EQ(s.integral(), 2.0);
    EXPECT_DOUBLE_EQ(s.integral(s), 8.0 / 3.0); // int_0^2 x^2 dx
    Spectrum t;
    t.add(Piece{1.0, 3.0, -2.0, 5.0});
    // int_1^2 x (5 - 2x) dx = 5 * 3/2 - 2 * 7/3 = 17/6
    EXPECT_DOUBLE_EQ(s.integral(t), 17.0 / 6.0);
    EXPECT_DOUBLE_EQ(t.integral(s), 17.0 / 6.0);
}

TEST(SpectrumIntegral, ProductMatchesSimpsonOverRandomSpectra)
{
    std::mt19937_64 rng(99);
    const std::vector<Trapezoid> ta = randomTrapezoids(rng, 30);
    const std::vector<Trapezoid> tb = randomTrapezoids(rng, 25);
    const Spectrum a = spectrumOf(ta);
    const Spectrum b = spectrumOf(tb);

    // Brute force from the raw trapezoids: on each interval between consecutive breakpoints
    // of either list the product is one quadratic; fine Simpson there.
    std::vector<double> breaks;
    for (const auto* traps : {&ta, &tb}) {
        for (const Trapezoid& t : *traps) {
            breaks.push_back(t.x0);
            breaks.push_back(t.x1);
        }
    }
    std::sort(breaks.begin(), breaks.end());
    const auto sumOver = [](const std::vector<Trapezoid>& traps, double u, double v, double x) {
        double sum = 0.0;
        for (const Trapezoid& t : traps) {
            if (t.x0 <= u && v <= t.x1) {
                sum += t.line(x);
            }
        }
        return sum;
    };
    double expected = 0.0;
    double expectedAbs = 0.0;
    for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
        const double u = breaks[i];
        const double v = breaks[i + 1];
        if (v <= u) {
            continue;
        }
        const auto product = [&](double x) { return sumOver(ta, u, v, x) * sumOver(tb, u, v, x); };
        const double part = simpson(product, u, v, 64);
        expected += part;
        expectedAbs += std::fabs(part);
    }
    EXPECT_NEAR(a.integral(b), expected, 1e-12 * expectedAbs);
    EXPECT_NEAR(b.integral(a), expected, 1e-12 * expectedAbs);
}

// ---------------------------------------------------------------------------------------------
// Merging

TEST(SpectrumMerge, CollinearNeighboursBecomeOnePiece)
{
    Spectrum s;
    s.addTrapezoid(400.0, 450.0, 1.0, 2.0);
    s.addTrapezoid(450.0, 500.0, 2.0, 3.0);
    const double before = s.integral();
    s.merge(1e-6);
    ASSERT_EQ(s.size(), 1u);
    EXPECT_EQ(s.pieces()[0].x0, 400.0);
    EXPECT_EQ(s.pieces()[0].x1, 500.0);
    EXPECT_NEAR(s.pieces()[0].m, 0.02, 1e-14);
    EXPECT_NEAR(s(400.0), 1.0, 1e-12);
    EXPECT_NEAR(s(500.0), 3.0, 1e-12);
    EXPECT_NEAR(s.integral(), before, 1e-12 * before);
}

TEST(SpectrumMerge, DifferentSlopesBeyondToleranceStaySeparate)
{
    Spectrum s;
    s.addTrapezoid(400.0, 450.0, 1.0, 2.0); // slope 0.02 /nm
    s.addTrapezoid(450.0, 500.0, 2.0, 4.0); // slope 0.04 /nm, same value at the join
    s.merge(1e-3);
    EXPECT_EQ(s.size(), 2u);

    Spectrum gap; // collinear but 10 nm apart: does not touch
    gap.addTrapezoid(400.0, 450.0, 1.0, 2.0);
    gap.addTrapezoid(460.0, 500.0, 2.2, 3.0);
    gap.merge(1e-3);
    EXPECT_EQ(gap.size(), 2u);
}

TEST(SpectrumMerge, PreservesIntegralAndFirstMoment)
{
    // A smooth curve sampled as touching trapezoids with small noise: many merge.
    std::mt19937_64 rng(3);
    std::normal_distribution<double> noise(0.0, 1e-4);
    for (double tolerance : {1e-4, 1e-3, 1e-2, 0.1, 1.0}) {
        Spectrum s;
        double x = 380.0;
        double y = 1.0;
        while (x < 780.0) {
            const double x1 = x + 2.0;
            const double y1 = y * (1.0 + 0.002 + noise(rng)); // slowly rising, noisy slope
            s.addTrapezoid(x, x1, y, y1);
            x = x1;
            y = y1;
        }
        const std::size_t before = s.size();
        const double I0 = s.integral();
        const double I1 = firstMoment(s);
        s.merge(tolerance);
        expectSortedDisjoint(s);
        EXPECT_NEAR(s.integral(), I0, 1e-12 * std::fabs(I0)) << "tolerance " << tolerance;
        EXPECT_NEAR(firstMoment(s), I1, 1e-12 * std::fabs(I1)) << "tolerance " << tolerance;
        std::cout << "[ piece count ] merge(" << tolerance << "): " << before << " -> " << s.size()
                  << " pieces\n";
    }
}

// ---------------------------------------------------------------------------------------------
// Multiplication by a smooth function

TEST(SpectrumMultiply, ExponentialExtinctionMatchesClosedForm)
{
    // Flat spectrum 1 on [400, 700] nm times exp(-k (x - 400)):
    // integral = (1 - exp(-300 k)) / k.
    for (double relTol : {1e-3, 1e-4, 1e-6}) {
        const double k = 0.01; // [1/nm]
        Spectrum s;
        s.addTrapezoid(400.0, 550.0, 1.0, 1.0);
        s.addTrapezoid(550.0, 700.0, 1.0, 1.0);
        s.multiply([k](double x) { return std::exp(-k * (x - 400.0)); }, relTol);
        expectSortedDisjoint(s);
        const double exact = (1.0 - std::exp(-300.0 * k)) / k;
        EXPECT_NEAR(s.integral(), exact, relTol * exact) << "relTol " << relTol;
        EXPECT_LT(s.size(), 3000u);
        std::cout << "[ piece count ] multiply by exp(-0.01 (x - 400)), relTol " << relTol
                  << ": 2 -> " << s.size() << " pieces, relative integral error "
                  << std::fabs(s.integral() - exact) / exact << "\n";
    }
}

TEST(SpectrumMultiply, SlopedPieceTimesExponential)
{
    // (x - 400)/100 on [400, 600] times exp(-k (x - 400)); with t = x - 400:
    // int_0^200 t e^{-kt} dt / 100 = (1 - e^{-200k}(1 + 200k)) / (100 k^2).
    const double k = 0.02;
    const double relTol = 1e-5;
    Spectrum s;
    s.addTrapezoid(400.0, 600.0, 0.0, 2.0);
    s.multiply([k](double x) { return std::exp(-k * (x - 400.0)); }, relTol);
    const double exact = (1.0 - std::exp(-200.0 * k) * (1.0 + 200.0 * k)) / (100.0 * k * k);
    EXPECT_NEAR(s.integral(), exact, relTol * exact);
    std::cout << "[ piece count ] sloped piece times exp(-0.02 (x - 400)), relTol " << relTol
              << ": 1 -> " << s.size() << " pieces\n";
}

} // namespace
