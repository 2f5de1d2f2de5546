// SPDX-License-Identifier: Apache-2.0
/// @file test_colour.cpp
/// The colour module (DESIGN §7): the shipped CIE 1931 table, exact XYZ of piecewise-linear
/// spectra (per spectrum, per piece, per hat function), black-body XYZ against published
/// Planckian-locus chromaticities, XYZ <-> linear sRGB, CIE L*a*b* and CIEDE2000 against
/// Sharma, Wu & Dalal's test data, and black-body colours.

#include "nebula/physics/colour.h"

#include "nebula/core/error.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/spectrum.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <iostream>
#include <iterator>
#include <random>
#include <vector>

namespace {

using nebula::Piece;
using nebula::Spectrum;
using nebula::XYZ;

/// Second radiation constant c2 = h c / k [m K] (CODATA 2018, exact), as planck() uses it.
constexpr double C2_CODATA = 6.62607015e-34 * 299792458.0 / 1.380649e-23; // 1.438776877e-2

/// Temperature [K] at which planck() (CODATA c2) has the shape of a black body of
/// temperature @p T under the older c2 = @p c2 [m K] of a published table: Planck's law
/// depends on T only through c2 / (lambda T), and chromaticity ignores c1.
double withC2(double T, double c2)
{
    return T * C2_CODATA / c2;
}

/// Expects @p got == @p want per component within @p relTol relative to |want| (exact 0
/// when want is 0).
void expectRelative(const XYZ& got, const XYZ& want, double relTol, const char* what)
{
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(got[k], want[k], relTol * std::fabs(want[k])) << what << ", component " << k;
    }
}

// ---------------------------------------------------------------------------------------------
// The shipped table

TEST(ColourTable, RowsRangeAndPeak)
{
    EXPECT_EQ(nebula::CMF_NODES, 471);
    EXPECT_EQ(nebula::CMF_LAMBDA_MIN, 360.0);
    EXPECT_EQ(nebula::CMF_LAMBDA_MAX, 830.0);
    EXPECT_EQ(nebula::CMF_STEP, 1.0);
    // One piece per 1 nm interval, from 360 to 830 nm.
    for (int k = 0; k < 3; ++k) {
        const Spectrum& s = nebula::cmf(k);
        ASSERT_EQ(s.size(), 470u) << k;
        EXPECT_EQ(s.pieces().front().x0, 360.0);
        EXPECT_EQ(s.pieces().back().x1, 830.0);
    }
    // CVRL rows, exactly (first, peak of ybar, last).
    EXPECT_EQ(nebula::cmfAt(360.0), (XYZ{0.000129900000, 0.000003917000, 0.000606100000}));
    EXPECT_EQ(nebula::cmfAt(555.0), (XYZ{0.512050100000, 1.000000000000, 0.005749999000}));
    EXPECT_EQ(nebula::cmfAt(830.0), (XYZ{0.000001251141, 0.000000451810, 0.000000000000}));
    // ybar peaks at 555 nm with 1.
    double peak = 0.0;
    int peakAt = 0;
    for (int nm = 360; nm <= 830; ++nm) {
        if (nebula::cmfAt(nm)[1] > peak) {
            peak = nebula::cmfAt(nm)[1];
            peakAt = nm;
        }
    }
    EXPECT_EQ(peakAt, 555);
    EXPECT_EQ(peak, 1.0);
    // Linear between nodes (to rounding, 1e-15), 0 outside.
    const XYZ a = nebula::cmfAt(600.0);
    const XYZ b = nebula::cmfAt(601.0);
    const XYZ m = nebula::cmfAt(600.25);
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(m[k], 0.75 * a[k] + 0.25 * b[k], 1e-15);
    }
    EXPECT_EQ(nebula::cmfAt(359.999), (XYZ{0.0, 0.0, 0.0}));
    EXPECT_EQ(nebula::cmfAt(830.001), (XYZ{0.0, 0.0, 0.0}));
    EXPECT_EQ(nebula::cmfAt(NAN), (XYZ{0.0, 0.0, 0.0}));
    // The piecewise-linear spectra agree with cmfAt() at nodes and between them (1e-15).
    for (double lambda : {360.0, 412.5, 555.0, 600.25, 829.75}) {
        const XYZ c = nebula::cmfAt(lambda);
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(nebula::cmf(k)(lambda), c[k], 1e-15) << lambda;
        }
    }
    EXPECT_THROW(nebula::cmf(3), nebula::UsageError);
    EXPECT_THROW(nebula::cmf(-1), nebula::UsageError);
}

TEST(ColourTable, ColumnSumsAndIntegrals)
{
    // Sums over the 471 rows. The CIE publishes these as the validation sums of its dataset
    // CIE_xyz_1931_2deg.csv (DOI 10.25039/CIE.DS.xvudnb9b): xbar 106.865469489595, ybar
    // 106.8569171011719, zbar 106.892251278636; CVRL's 12-decimal table gives exactly these.
    // (The often-quoted 106.856895, pbrt's CIE_Y_integral, is 2.2e-5 below the exact ybar
    // sum; it is not the sum of this table.) Tolerance 1e-12: the rounding of 471 doubles.
    XYZ sum = {0.0, 0.0, 0.0};
    for (int nm = 360; nm <= 830; ++nm) {
        const XYZ c = nebula::cmfAt(nm);
        for (int k = 0; k < 3; ++k) {
            sum[k] += c[k];
        }
    }
    EXPECT_NEAR(sum[0], 106.865469489595, 1e-12);
    EXPECT_NEAR(sum[1], 106.856917101172, 1e-12);
    EXPECT_NEAR(sum[2], 106.892251278636, 1e-12);

    // The integral of the piecewise-linear CMF is the trapezoid rule on the nodes: the sum
    // minus half the end values (1 nm steps). Exact up to rounding: 1e-13 relative.
    for (int k = 0; k < 3; ++k) {
        const double trapezoid = sum[k] - 0.5 * (nebula::cmfAt(360.0)[k] + nebula::cmfAt(830.0)[k]);
        EXPECT_NEAR(nebula::cmf(k).integral(), trapezoid, 1e-13 * trapezoid) << k;
        // The same through spectrumToXYZ() of a constant 1 over [300, 900] nm, and through
        // pieceToXYZ() of that one piece.
        Spectrum one;
        one.add(Piece{300.0, 900.0, 0.0, 1.0});
        EXPECT_NEAR(nebula::spectrumToXYZ(one)[k], trapezoid, 1e-13 * trapezoid) << k;
        EXPECT_NEAR(nebula::pieceToXYZ(Piece{300.0, 900.0, 0.0, 1.0})[k], trapezoid,
                    1e-13 * trapezoid)
            << k;
    }
}

// ---------------------------------------------------------------------------------------------
// Exact XYZ of pieces and hat functions

TEST(ColourPiece, MatchesSpectrumToXYZ)
{
    // Random non-negative pieces inside, straddling either end of, and outside 360-830 nm,
    // widths from 1e-6 nm to 600 nm. pieceToXYZ() (prefix sums) must equal the generic
    // product integral of a one-piece spectrum to 1e-12 relative, per component. Relative to
    // what the piece itself can resolve: a line stored as m x + b is only known to about
    // 1e-16 (|m| x + |b|), which for a steep, narrow piece (m = 1e7 per nm over 1e-6 nm) is
    // far more than 1e-16 of its value; both methods evaluate it, at different points. So
    // the scale is max(|XYZ|, (|m| x1 + |b|) times the integral of the CMF over the piece).
    std::mt19937_64 rng(20240531);
    std::uniform_real_distribution<double> position(250.0, 950.0);
    std::uniform_real_distribution<double> logWidth(std::log(1e-6), std::log(600.0));
    std::uniform_real_distribution<double> value(0.0, 10.0);
    double worst = 0.0;
    int nonZero = 0;
    for (int i = 0; i < 4000; ++i) {
        double x0 = position(rng);
        // A quarter of the pieces start exactly at a node or an end of the table.
        if (i % 4 == 1) {
            x0 = std::floor(x0);
        }
        const double x1 = x0 + std::exp(logWidth(rng));
        const Piece p = nebula::pieceThrough(x0, value(rng), x1, value(rng));
        Spectrum s;
        s.add(p);
        const XYZ want = nebula::spectrumToXYZ(s);
        const XYZ got = nebula::pieceToXYZ(p);
        const XYZ cmfIntegral = nebula::pieceToXYZ(Piece{x0, x1, 0.0, 1.0});
        const double lineScale = std::fabs(p.m) * std::fabs(x1) + std::fabs(p.b);
        for (int k = 0; k < 3; ++k) {
            if (want[k] == 0.0) {
                EXPECT_EQ(got[k], 0.0) << "[" << x0 << ", " << x1 << "] component " << k;
                continue;
            }
            ++nonZero;
            const double scale = std::max(std::fabs(want[k]), lineScale * cmfIntegral[k]);
            const double rel = std::fabs(got[k] - want[k]) / scale;
            worst = std::max(worst, rel);
            EXPECT_LE(rel, 1e-12) << "[" << x0 << ", " << x1 << "] component " << k;
        }
    }
    EXPECT_GT(nonZero, 5000); // most pieces overlap the table
    std::cout << "pieceToXYZ vs spectrumToXYZ: worst relative difference " << worst << "\n";
}

TEST(ColourPiece, SignChangingAndDegeneratePieces)
{
    // A piece that changes sign: agreement to 1e-12 relative to the integral of |p| CMF
    // (the relative error of the result itself is unbounded when it nearly cancels).
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> position(300.0, 900.0);
    std::uniform_real_distribution<double> value(-5.0, 5.0);
    for (int i = 0; i < 1000; ++i) {
        const double a = position(rng);
        const double b = position(rng);
        const double y0 = value(rng);
        const double y1 = value(rng);
        const Piece p = nebula::pieceThrough(std::min(a, b), y0, std::max(a, b), y1);
        Spectrum s;
        s.add(p);
        const XYZ want = nebula::spectrumToXYZ(s);
        const XYZ got = nebula::pieceToXYZ(p);
        // Upper bound of the integral of |p| CMF: the trapezoid through |y0|, |y1|.
        const XYZ bound = nebula::pieceToXYZ(
            nebula::pieceThrough(std::min(a, b), std::fabs(y0), std::max(a, b), std::fabs(y1)));
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(got[k], want[k], 1e-12 * bound[k] + 1e-300) << i << " " << k;
        }
    }
    // Outside the table, reversed or empty: exactly 0.
    EXPECT_EQ(nebula::pieceToXYZ(Piece{100.0, 359.5, 1.0, 2.0}), (XYZ{0.0, 0.0, 0.0}));
    EXPECT_EQ(nebula::pieceToXYZ(Piece{830.0, 900.0, 1.0, 2.0}), (XYZ{0.0, 0.0, 0.0}));
    EXPECT_EQ(nebula::pieceToXYZ(Piece{600.0, 500.0, 0.0, 1.0}), (XYZ{0.0, 0.0, 0.0}));
    EXPECT_EQ(nebula::pieceToXYZ(Piece{600.0, 600.0, 0.0, 1.0}), (XYZ{0.0, 0.0, 0.0}));
    // zbar is 0 from 650 nm on: exactly 0 there.
    EXPECT_EQ(nebula::pieceToXYZ(Piece{650.0, 820.5, 0.0, 1.0})[2], 0.0);
    EXPECT_GT(nebula::pieceToXYZ(Piece{650.0, 820.5, 0.0, 1.0})[0], 0.0);
}

TEST(ColourPiece, HatWeightsReproduceTheHatSpectrum)
{
    // Grids inside the table, straddling both ends, coarse and fine; random non-negative
    // node values v_j. sum_j v_j w_j must equal spectrumToXYZ() of the piecewise-linear
    // spectrum through (lambda_j, v_j) to 1e-12 relative.
    struct Grid
    {
        double lambda0, step;
        int n;
    };
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> value(0.0, 3.0);
    for (const Grid& g : {Grid{380.25, 2.5, 150}, Grid{340.0, 7.3, 80}, Grid{355.5, 0.37, 1300},
                          Grid{400.0, 40.0, 11}, Grid{700.0, 13.0, 20}}) {
        const std::vector<XYZ> w = nebula::hatWeights(g.lambda0, g.step, g.n);
        ASSERT_EQ(w.size(), static_cast<std::size_t>(g.n));
        std::vector<double> v(static_cast<std::size_t>(g.n));
        for (double& x : v) {
            x = value(rng);
        }
        Spectrum s;
        XYZ viaWeights = {0.0, 0.0, 0.0};
        XYZ unitSum = {0.0, 0.0, 0.0};
        for (int j = 0; j < g.n; ++j) {
            if (j + 1 < g.n) {
                s.addTrapezoid(g.lambda0 + j * g.step, g.lambda0 + (j + 1) * g.step,
                               v[static_cast<std::size_t>(j)], v[static_cast<std::size_t>(j + 1)]);
            }
            for (int k = 0; k < 3; ++k) {
                viaWeights[k] += v[static_cast<std::size_t>(j)] * w[static_cast<std::size_t>(j)][k];
                unitSum[k] += w[static_cast<std::size_t>(j)][k];
            }
        }
        expectRelative(viaWeights, nebula::spectrumToXYZ(s), 1e-12, "hat spectrum");
        // The hats are a partition of unity on the grid: the weights add up to the XYZ of the
        // constant 1 over [lambda0, lambda0 + (n - 1) step] (1e-12 relative).
        const Piece one{g.lambda0, g.lambda0 + (g.n - 1) * g.step, 0.0, 1.0};
        expectRelative(unitSum, nebula::pieceToXYZ(one), 1e-12, "partition of unity");
    }
    EXPECT_TRUE(nebula::hatWeights(500.0, 1.0, 0).empty());
    EXPECT_EQ(nebula::hatWeights(500.0, 1.0, 1), (std::vector<XYZ>{XYZ{0.0, 0.0, 0.0}}));
    EXPECT_THROW(nebula::hatWeights(500.0, 0.0, 3), nebula::UsageError);
    EXPECT_THROW(nebula::hatWeights(500.0, -1.0, 3), nebula::UsageError);
    EXPECT_THROW(nebula::hatWeights(500.0, 1.0, -1), nebula::UsageError);
    EXPECT_THROW(nebula::hatWeights(NAN, 1.0, 3), nebula::UsageError);
}

// ---------------------------------------------------------------------------------------------
// Black bodies

/// Reference XYZ of a black body: composite Simpson's rule with 200 steps per 1 nm interval
/// (the panels meet at the table nodes, where the CMFs have kinks) of planckPerNm() times
/// cmfAt(). Its own error is far below 1e-10 relative.
XYZ blackbodyReference(double T)
{
    XYZ sum = {0.0, 0.0, 0.0};
    constexpr int STEPS = 200;
    const double h = 1.0 / STEPS;
    for (int j = 0; j < 470; ++j) {
        for (int i = 0; i <= STEPS; ++i) {
            const double lambda = 360.0 + j + i * h;
            const double w = (i == 0 || i == STEPS) ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0);
            // cmfAt() at the right end of interval j: the node value, continuous.
            const XYZ c = nebula::cmfAt(lambda);
            const double B = nebula::planckPerNm(lambda, T);
            for (int k = 0; k < 3; ++k) {
                sum[k] += w * h / 3.0 * B * c[k];
            }
        }
    }
    return sum;
}

TEST(ColourBlackbody, MatchesQuadratureReference)
{
    // blackbodyXYZ() (3-point Gauss-Legendre per nm, scaled) against brute-force Simpson:
    // 1e-10 relative (the requirement is 1e-6; observed 4e-12 at 300 K, 2e-14 from 1000 K
    // up). 300 K gives XYZ ~ 1e-24: still representable and right; 1e6 K ~ 1e10.
    for (double T : {300.0, 1000.0, 2856.0, 5772.0, 25000.0, 1e6}) {
        const XYZ got = nebula::blackbodyXYZ(T);
        const XYZ want = blackbodyReference(T);
        expectRelative(got, want, 1e-10, "black body");
        // Scaled form: the same up to exp(logScale), largest component 1.
        double logScale = 0.0;
        const XYZ scaled = nebula::blackbodyXYZScaled(T, logScale);
        EXPECT_EQ(std::max({scaled[0], scaled[1], scaled[2]}), 1.0) << T;
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(scaled[k] * std::exp(logScale), got[k], 1e-13 * got[k]) << T;
        }
    }
}

TEST(ColourBlackbody, NoOverflowOrUnderflow)
{
    // Chromaticity is finite from 1 K to 1e12 K, where B itself under- or overflows a double,
    // and x falls monotonically from the red end of the spectrum locus (cold) towards the
    // Rayleigh-Jeans limit (hot) from 100 K up (below, it sits at the 830 nm end, where the
    // table's x wobbles by 1e-7).
    double previousX = 1.0;
    for (double T : {1.0, 10.0, 100.0, 300.0, 1000.0, 1e4, 1e5, 1e6, 1e8, 1e12}) {
        double logScale = 0.0;
        const XYZ s = nebula::blackbodyXYZScaled(T, logScale);
        ASSERT_TRUE(std::isfinite(logScale)) << T;
        const auto xy = nebula::chromaticity(s);
        EXPECT_TRUE(std::isfinite(xy[0]) && std::isfinite(xy[1])) << T;
        EXPECT_GT(xy[0], 0.2) << T;
        EXPECT_LT(xy[0], 0.74) << T;
        if (T >= 100.0) {
            EXPECT_LT(xy[0], previousX) << T;
        }
        previousX = xy[0];
    }
    // Very cold: the chromaticity of the table's last node (830 nm), x = 0.7347 (1e-4).
    double logScale = 0.0;
    const auto cold = nebula::chromaticity(nebula::blackbodyXYZScaled(1.0, logScale));
    const XYZ c830 = nebula::cmfAt(830.0);
    EXPECT_NEAR(cold[0], c830[0] / (c830[0] + c830[1] + c830[2]), 1e-4);
    // Hot limits agree: 1e8 K and 1e12 K are both Rayleigh-Jeans (1e-5 in x and y).
    const auto hot8 = nebula::chromaticity(nebula::blackbodyXYZScaled(1e8, logScale));
    const auto hot12 = nebula::chromaticity(nebula::blackbodyXYZScaled(1e12, logScale));
    EXPECT_NEAR(hot8[0], hot12[0], 1e-5);
    EXPECT_NEAR(hot8[1], hot12[1], 1e-5);

    EXPECT_THROW(nebula::blackbodyXYZ(0.0), nebula::Error);
    EXPECT_THROW(nebula::blackbodyXYZ(-5.0), nebula::Error);
    EXPECT_THROW(nebula::blackbodyXYZ(NAN), nebula::Error);
    EXPECT_THROW(nebula::blackbodyXYZ(INFINITY), nebula::Error);
}

TEST(ColourBlackbody, IlluminantA)
{
    // CIE standard illuminant A: a Planckian radiator at 2856 K with c2 = 1.4388e-2 m K
    // (CIE 15:2004 / CIE 15:2018, ISO 11664-2), chromaticity (0.44757, 0.40745) for the 1931
    // observer. Tolerance 5e-4 (observed: 3e-5). With the CODATA c2 = 1.438776877e-2 m K
    // instead, 2856 K moves by 5e-6 in x and y: negligible here, but withC2() honours the
    // definition.
    const auto xy = nebula::chromaticity(nebula::blackbodyXYZ(withC2(2856.0, 1.4388e-2)));
    EXPECT_NEAR(xy[0], 0.44757, 5e-4);
    EXPECT_NEAR(xy[1], 0.40745, 5e-4);
}

TEST(ColourBlackbody, PlanckianLocusMatchesPublishedTable)
{
    // Chromaticities of black bodies, CIE 1931 2-degree observer, from Judd & Wyszecki,
    // "Color in Business, Science and Industry", 3rd ed., Wiley 1975, p. 164, as reproduced
    // in ColorPy (github.com/markkness/ColorPy, colorpy/test_blackbody.py, book_chrom_table).
    // The book predates the 1990 temperature scale, so c2 = 1.4388e-2 m K (withC2()); with
    // the CODATA c2 the temperatures shift by 1.6e-5 relative, under 1e-5 in x and y.
    // Tolerance 5e-4 (observed: 1.1e-4, the book's 4-digit rounding and its coarser CMF
    // sampling).
    struct Row
    {
        double T, x, y;
    };
    const Row table[] = {
        {1000.0, 0.6528, 0.3444}, {1400.0, 0.5985, 0.3858},  {1600.0, 0.5732, 0.3993},
        {1800.0, 0.5493, 0.4082}, {2000.0, 0.5267, 0.4133},  {2200.0, 0.5056, 0.4152},
        {2400.0, 0.4862, 0.4147}, {2600.0, 0.4682, 0.4123},  {2800.0, 0.4519, 0.4086},
        {3000.0, 0.4369, 0.4041}, {3200.0, 0.4234, 0.3990},  {3400.0, 0.4110, 0.3935},
        {3600.0, 0.3999, 0.3879}, {3800.0, 0.3897, 0.3823},  {4200.0, 0.3720, 0.3714},
        {4500.0, 0.3608, 0.3636}, {4800.0, 0.3510, 0.3562},  {5200.0, 0.3397, 0.3472},
        {5800.0, 0.3260, 0.3354}, {6500.0, 0.3135, 0.3237},  {7500.0, 0.3004, 0.3103},
        {8500.0, 0.2908, 0.3000}, {10000.0, 0.2807, 0.2884}, {30000.0, 0.2501, 0.2489},
    };
    for (const Row& r : table) {
        const auto xy = nebula::chromaticity(nebula::blackbodyXYZ(withC2(r.T, 1.4388e-2)));
        EXPECT_NEAR(xy[0], r.x, 5e-4) << r.T << " K";
        EXPECT_NEAR(xy[1], r.y, 5e-4) << r.T << " K";
    }
}

// ---------------------------------------------------------------------------------------------
// sRGB and chromaticity

TEST(ColourSRGB, D65IsWhite)
{
    // CIE 15 D65 (2-degree), Y = 1: linear sRGB (1, 1, 1) within 1e-4 (by construction of
    // the matrix it is 1e-15).
    const auto rgb = nebula::xyzToLinearSRGB({0.95047, 1.0, 1.08883});
    for (double c : rgb) {
        EXPECT_NEAR(c, 1.0, 1e-4);
    }
    // The D65 spectrum itself (CIE relative SPD, 300-830 nm at 5 nm, linear between the
    // samples; values from the CIE selected colorimetric tables, as in the Android filament
    // tool's CIE_D65[107]) through the shipped CMFs: XYZ / Y = (0.95047, 1, 1.08883) within
    // 2e-5 and RGB (1, 1, 1) within 1e-4 (observed 1.6e-5), xy = (0.31272, 0.32903), the
    // CIE 15 value, within 1e-5.
    const double D65[107] = {
        0.0341,  1.6643,  3.2945,  11.7652, 20.2360, 28.6447, 37.0535, 38.5011, 39.9488, 42.4302,
        44.9117, 45.7750, 46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015,
        82.7549, 87.1204, 91.4860, 92.4589, 93.4318, 90.0570, 86.6823, 95.7736, 104.865, 110.936,
        117.008, 117.410, 117.812, 116.336, 114.861, 115.392, 115.923, 112.367, 108.811, 109.082,
        109.354, 108.578, 107.802, 106.296, 104.790, 106.239, 107.689, 106.047, 104.405, 104.225,
        104.046, 102.023, 100.000, 98.1671, 96.3342, 96.0611, 95.7880, 92.2368, 88.6856, 89.3459,
        90.0062, 89.8026, 89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.8630,
        80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.2810, 78.2842, 74.0027, 69.7213, 70.6652,
        71.6091, 72.9790, 74.3490, 67.9765, 61.6040, 65.7448, 69.8856, 72.4863, 75.0870, 69.3398,
        63.5927, 55.0054, 46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.3040, 61.8779,
        59.4519, 55.7054, 51.9590, 54.6998, 57.4406, 58.8765, 60.3125};
    Spectrum d65;
    for (int i = 0; i + 1 < 107; ++i) {
        d65.addTrapezoid(300.0 + 5 * i, 305.0 + 5 * i, D65[i], D65[i + 1]);
    }
    const XYZ xyz = nebula::spectrumToXYZ(d65);
    const XYZ white = {xyz[0] / xyz[1], 1.0, xyz[2] / xyz[1]};
    EXPECT_NEAR(white[0], 0.95047, 2e-5);
    EXPECT_NEAR(white[2], 1.08883, 2e-5);
    for (double c : nebula::xyzToLinearSRGB(white)) {
        EXPECT_NEAR(c, 1.0, 1e-4);
    }
    const auto xy = nebula::chromaticity(xyz);
    EXPECT_NEAR(xy[0], 0.31272, 1e-5);
    EXPECT_NEAR(xy[1], 0.32903, 1e-5);
}

TEST(ColourSRGB, MatricesAreInverseAndCloseToTheStandard)
{
    // M^-1 M = M M^-1 = identity to 1e-12 (observed ~1e-16).
    for (int i = 0; i < 3; ++i) {
        std::array<double, 3> e = {0.0, 0.0, 0.0};
        e[i] = 1.0;
        const auto there = nebula::linearSRGBToXYZ(nebula::xyzToLinearSRGB(e));
        const auto back = nebula::xyzToLinearSRGB(nebula::linearSRGBToXYZ(e));
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(there[k], e[k], 1e-12) << i << " " << k;
            EXPECT_NEAR(back[k], e[k], 1e-12) << i << " " << k;
        }
    }
    // Within 4e-4 of the 4-digit IEC 61966-2-1 matrix (observed 3.7e-4: the standard's
    // rounding, and its white (0.3127, 0.3290) versus CIE 15's D65 (0.31272, 0.32903)).
    const double IEC[3][3] = {
        {3.2406, -1.5372, -0.4986}, {-0.9689, 1.8758, 0.0415}, {0.0557, -0.2040, 1.0570}};
    for (int c = 0; c < 3; ++c) {
        XYZ e = {0.0, 0.0, 0.0};
        e[c] = 1.0;
        const auto column = nebula::xyzToLinearSRGB(e);
        for (int r = 0; r < 3; ++r) {
            EXPECT_NEAR(column[r], IEC[r][c], 4e-4) << r << " " << c;
        }
    }
    // Luminance row: (0.2126, 0.7152, 0.0722) within 1e-4.
    const double Y[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 3; ++c) {
        std::array<double, 3> e = {0.0, 0.0, 0.0};
        e[c] = 1.0;
        EXPECT_NEAR(nebula::linearSRGBToXYZ(e)[1], Y[c], 1e-4) << c;
    }
}

TEST(ColourSRGB, Chromaticity)
{
    const auto xy = nebula::chromaticity({0.95047, 1.0, 1.08883});
    EXPECT_NEAR(xy[0], 0.312727, 1e-6);
    EXPECT_NEAR(xy[1], 0.329023, 1e-6);
    EXPECT_EQ(nebula::chromaticity({1.0, 1.0, 2.0}), (std::array<double, 2>{0.25, 0.25}));
    EXPECT_THROW(nebula::chromaticity({0.0, 0.0, 0.0}), nebula::Error);
    EXPECT_THROW(nebula::chromaticity({1.0, -2.0, 0.5}), nebula::Error);
    EXPECT_THROW(nebula::chromaticity({NAN, 1.0, 1.0}), nebula::Error);
}

// ---------------------------------------------------------------------------------------------
// Line colours (RGB mode's emission, DESIGN §3.4)

/// The 4-digit IEC 61966-2-1 matrix times @p xyz: an independent XYZ -> linear sRGB.
std::array<double, 3> iecSRGB(const XYZ& xyz)
{
    const double M[3][3] = {
        {3.2406, -1.5372, -0.4986}, {-0.9689, 1.8758, 0.0415}, {0.0557, -0.2040, 1.0570}};
    std::array<double, 3> rgb{};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            rgb[std::size_t(r)] += M[r][c] * xyz[std::size_t(c)];
    return rgb;
}

TEST(ColourLines, XYZIsTheCmfsAtTheLines)
{
    // Lines at table nodes that the CIE's 5 nm table also lists (CIE 15, Table T.4):
    // 500 nm (0.004900, 0.323000, 0.272000), 650 nm (0.283500, 0.107000, 0.000000). A mix
    // is their strength-weighted sum; a line beyond 830 nm adds nothing.
    using nebula::SpectralLine;
    const XYZ a = nebula::linesXYZ({SpectralLine{"500", 500.0, 1.0}});
    const XYZ b = nebula::linesXYZ({SpectralLine{"650", 650.0, 1.0}});
    const XYZ want500{0.0049, 0.323, 0.272}, want650{0.2835, 0.107, 0.0};
    for (std::size_t c = 0; c < 3; ++c) {
        EXPECT_NEAR(a[c], want500[c], 1e-6) << c;
        EXPECT_NEAR(b[c], want650[c], 1e-6) << c;
    }
    const XYZ mix =
        nebula::linesXYZ({SpectralLine{"500", 500.0, 2.0}, SpectralLine{"650", 650.0, 0.5},
                          SpectralLine{"1083", 1083.0, 7.0}});
    for (std::size_t c = 0; c < 3; ++c)
        EXPECT_NEAR(mix[c], 2.0 * want500[c] + 0.5 * want650[c], 1e-6) << c;
    // Between nodes, linear: [O III] 500.68 nm is 0.68 of the way from 500 to 501 nm.
    const XYZ o3 = nebula::linesXYZ(nebula::parseLineList("[O III]5007:1", "test"));
    const XYZ n0 = nebula::cmfAt(500.0), n1 = nebula::cmfAt(501.0);
    for (std::size_t c = 0; c < 3; ++c)
        EXPECT_NEAR(o3[c], n0[c] + 0.68 * (n1[c] - n0[c]), 1e-12) << c;
}

TEST(ColourLines, SRGBAtTheGivenLuminance)
{
    // Independent check: the IEC matrix on the published CMF values, scaled to Y = 0.3
    // (within 1e-3 of the largest channel: the matrix's 4-digit rounding).
    using nebula::SpectralLine;
    const auto rgb = nebula::linesLinearSRGB({SpectralLine{"500", 500.0, 3.0}}, 0.3);
    const XYZ xyz{0.0049 * 0.3 / 0.323, 0.3, 0.272 * 0.3 / 0.323};
    const auto want = iecSRGB(xyz);
    for (std::size_t c = 0; c < 3; ++c)
        EXPECT_NEAR(rgb[c], want[c], 1e-3) << c;
    // Its luminance is the one asked for (the matrices' second row), whatever the strengths.
    for (const char* lines : {"H-alpha:1,H-beta:0.35", "[O III]5007:1,[O III]4959:0.34",
                              "[S II]6716:1,[S II]6731:0.7", "[O I]6300:3"}) {
        const auto c = nebula::linesLinearSRGB(nebula::parseLineList(lines, "test"), 0.25);
        EXPECT_NEAR(nebula::linearSRGBToXYZ(c)[1], 0.25, 1e-12) << lines;
    }
    // All lines outside 360-830 nm: no colour.
    EXPECT_EQ(nebula::linesLinearSRGB({SpectralLine{"1083", 1083.0, 1.0}}, 1.0),
              (std::array<double, 3>{0.0, 0.0, 0.0}));
}

TEST(ColourLines, HueOfTheNebularLines)
{
    // Monochromatic lines lie outside the sRGB gamut: unclipped, a channel is negative.
    const auto of = [](const char* lines) {
        return nebula::linesLinearSRGB(nebula::parseLineList(lines, "test"), 1.0);
    };
    const auto ha = of("H-alpha:1");
    EXPECT_GT(ha[0], 0.0);
    EXPECT_LT(ha[1], 0.0); // deep red: beyond the sRGB red primary
    EXPECT_GT(ha[0], 10.0 * std::abs(ha[2]));
    const auto o3 = of("[O III]5007:1");
    EXPECT_GT(o3[1], 0.0);
    EXPECT_GT(o3[2], 0.0);
    EXPECT_LT(o3[0], 0.0); // teal-green: R negative, G > B > 0
    EXPECT_GT(o3[1], o3[2]);
    const auto hb = of("H-beta:1");
    EXPECT_GT(hb[1], 0.0);
    EXPECT_GT(hb[2], hb[1]); // blue-green, bluer than [O III]
    EXPECT_LT(hb[0], 0.0);
    for (const char* red : {"[N II]6583:1", "[S II]6716:1", "[O I]6300:1"})
        EXPECT_GT(of(red)[0], 0.0) << red;
}

// ---------------------------------------------------------------------------------------------
// L*a*b* and CIEDE2000

/// XYZ (Y = 1) of the chromaticity (x, y).
XYZ whiteOf(double x, double y)
{
    return {x / y, 1.0, (1.0 - x - y) / y};
}

TEST(ColourLab, MatchesPublishedValues)
{
    // colour-science (github.com/colour-science/colour, colour/models/tests/test_cie_lab.py):
    // XYZ (0.20654008, 0.12197225, 0.05136952) against the whites of the chromaticities
    // D65 (0.3127, 0.3290), A (0.44757, 0.40745) and D50 (0.3457, 0.3585). Their tolerance,
    // 1e-7.
    const XYZ xyz = {0.20654008, 0.12197225, 0.05136952};
    struct Case
    {
        double x, y;
        std::array<double, 3> lab;
    };
    for (const Case& c : {Case{0.3127, 0.3290, {41.52787529, 52.63858304, 26.92317922}},
                          Case{0.44757, 0.40745, {41.52787529, 38.48089305, -5.73295122}},
                          Case{0.3457, 0.3585, {41.52787529, 51.19354174, 19.91843098}}}) {
        const auto lab = nebula::xyzToLab(xyz, whiteOf(c.x, c.y));
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(lab[k], c.lab[k], 1e-7) << c.x << " " << k;
        }
    }
    // The white is L* = 100, a* = b* = 0; near black the linear segment: L* = (29/3)^3 Y/Yn
    // (CIE 15), 1e-12.
    const XYZ d65 = {0.95047, 1.0, 1.08883};
    const auto white = nebula::xyzToLab(d65, d65);
    EXPECT_NEAR(white[0], 100.0, 1e-12);
    EXPECT_NEAR(white[1], 0.0, 1e-12);
    EXPECT_NEAR(white[2], 0.0, 1e-12);
    const auto dark = nebula::xyzToLab({0.95047e-3, 1e-3, 1.08883e-3}, d65);
    EXPECT_NEAR(dark[0], 24389.0 / 27.0 * 1e-3, 1e-12);
    // Continuous at the junction (6/29)^3: 1e-9.
    const double t = 216.0 / 24389.0;
    EXPECT_NEAR(nebula::xyzToLab({0, t * (1 + 1e-12), 0}, d65)[0],
                nebula::xyzToLab({0, t * (1 - 1e-12), 0}, d65)[0], 1e-9);
    EXPECT_THROW(nebula::xyzToLab(d65, {0.95, 0.0, 1.0}), nebula::Error);
}

TEST(ColourDeltaE2000, SharmaWuDalalTestData)
{
    // The 34 pairs of Sharma, Wu & Dalal (2005), Table 1 ("CIEDE2000 test data",
    // ciede2000testdata.txt at hajim.rochester.edu/ece/sites/gsharma/ciede2000/), as
    // reproduced in several public test suites. Each within 1e-4 (the table's 4 decimals),
    // and symmetric to 1e-12. Pairs 10 and 14 sit exactly on the 180-degree hue
    // discontinuity (mirror images), 9-12 and 13-15 test either side of it. (Some public
    // copies add a 35th pair, (-0.0010, 2.4900) vs (0.0012, -2.4900); it is not in the
    // table.)
    struct Pair
    {
        std::array<double, 3> lab1, lab2;
        double dE;
    };
    const Pair pairs[] = {
        {{50.0000, 2.6772, -79.7751}, {50.0000, 0.0000, -82.7485}, 2.0425},
        {{50.0000, 3.1571, -77.2803}, {50.0000, 0.0000, -82.7485}, 2.8615},
        {{50.0000, 2.8361, -74.0200}, {50.0000, 0.0000, -82.7485}, 3.4412},
        {{50.0000, -1.3802, -84.2814}, {50.0000, 0.0000, -82.7485}, 1.0000},
        {{50.0000, -1.1848, -84.8006}, {50.0000, 0.0000, -82.7485}, 1.0000},
        {{50.0000, -0.9009, -85.5211}, {50.0000, 0.0000, -82.7485}, 1.0000},
        {{50.0000, 0.0000, 0.0000}, {50.0000, -1.0000, 2.0000}, 2.3669},
        {{50.0000, -1.0000, 2.0000}, {50.0000, 0.0000, 0.0000}, 2.3669},
        {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0009}, 7.1792},
        {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0010}, 7.1792},
        {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0011}, 7.2195},
        {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0012}, 7.2195},
        {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0009, -2.4900}, 4.8045},
        {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0010, -2.4900}, 4.8045},
        {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0011, -2.4900}, 4.7461},
        {{50.0000, 2.5000, 0.0000}, {50.0000, 0.0000, -2.5000}, 4.3065},
        {{50.0000, 2.5000, 0.0000}, {73.0000, 25.0000, -18.0000}, 27.1492},
        {{50.0000, 2.5000, 0.0000}, {61.0000, -5.0000, 29.0000}, 22.8977},
        {{50.0000, 2.5000, 0.0000}, {56.0000, -27.0000, -3.0000}, 31.9030},
        {{50.0000, 2.5000, 0.0000}, {58.0000, 24.0000, 15.0000}, 19.4535},
        {{50.0000, 2.5000, 0.0000}, {50.0000, 3.1736, 0.5854}, 1.0000},
        {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2972, 0.0000}, 1.0000},
        {{50.0000, 2.5000, 0.0000}, {50.0000, 1.8634, 0.5757}, 1.0000},
        {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2592, 0.3350}, 1.0000},
        {{60.2574, -34.0099, 36.2677}, {60.4626, -34.1751, 39.4387}, 1.2644},
        {{63.0109, -31.0961, -5.8663}, {62.8187, -29.7946, -4.0864}, 1.2630},
        {{61.2901, 3.7196, -5.3901}, {61.4292, 2.2480, -4.9620}, 1.8731},
        {{35.0831, -44.1164, 3.7933}, {35.0232, -40.0716, 1.5901}, 1.8645},
        {{22.7233, 20.0904, -46.6940}, {23.0331, 14.9730, -42.5619}, 2.0373},
        {{36.4612, 47.8580, 18.3852}, {36.2715, 50.5065, 21.2231}, 1.4146},
        {{90.8027, -2.0831, 1.4410}, {91.1528, -1.6435, 0.0447}, 1.4441},
        {{90.9257, -0.5406, -0.9208}, {88.6381, -0.8985, -0.7239}, 1.5381},
        {{6.7747, -0.2908, -2.4247}, {5.8714, -0.0985, -2.2286}, 0.6377},
        {{2.0776, 0.0795, -1.1350}, {0.9033, -0.0636, -0.5514}, 0.9082},
    };
    ASSERT_EQ(std::size(pairs), 34u);
    for (std::size_t i = 0; i < std::size(pairs); ++i) {
        const Pair& p = pairs[i];
        const double dE = nebula::deltaE2000(p.lab1, p.lab2);
        EXPECT_NEAR(dE, p.dE, 1e-4) << "pair " << i + 1;
        EXPECT_NEAR(nebula::deltaE2000(p.lab2, p.lab1), dE, 1e-12) << "pair " << i + 1;
    }
    EXPECT_EQ(nebula::deltaE2000({50.0, 10.0, -20.0}, {50.0, 10.0, -20.0}), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Black-body colours (blackbodyLinearSRGB())

TEST(ColourStars, BlackbodySRGB)
{
    // 3000 K is orange: R > G > B.
    const auto warm = nebula::blackbodyLinearSRGB(3000.0);
    EXPECT_GT(warm[0], warm[1]);
    EXPECT_GT(warm[1], warm[2]);
    EXPECT_GT(warm[2], 0.0);

    // 6504 K is near white, but not white: D65 lies off the Planckian locus (published: the
    // 6500 K black body is (0.3135, 0.3237), D65 (0.3127, 0.3290), 0.0032 in uv towards
    // green), so the black body is slightly magenta in sRGB: green lowest, red and blue
    // within 1% of each other, all channels within 7% of each other (observed 6.0%). No
    // black body of any temperature is closer to white than 5.5% (the least spread, 5.8%,
    // is at 6530 K), so "within 3%" would be unphysical.
    const auto white = nebula::blackbodyLinearSRGB(6504.0);
    const double hi = std::max({white[0], white[1], white[2]});
    const double lo = std::min({white[0], white[1], white[2]});
    EXPECT_LT(hi / lo, 1.07);
    EXPECT_EQ(lo, white[1]);
    EXPECT_NEAR(white[0] / white[2], 1.0, 0.01);
    double bestSpread = INFINITY;
    double bestT = 0.0;
    for (double T = 5000.0; T <= 9000.0; T += 10.0) {
        const auto rgb = nebula::blackbodyLinearSRGB(T);
        const double spread =
            std::max({rgb[0], rgb[1], rgb[2]}) / std::min({rgb[0], rgb[1], rgb[2]});
        if (spread < bestSpread) {
            bestSpread = spread;
            bestT = T;
        }
    }
    EXPECT_NEAR(bestT, 6500.0, 200.0);
    EXPECT_GT(bestSpread, 1.055);

    // Through the module: linear sRGB of the black body's XYZ, normalised to Y = 1 (1e-12).
    const XYZ xyz = nebula::blackbodyXYZ(4000.0);
    const auto rgb = nebula::xyzToLinearSRGB({xyz[0] / xyz[1], 1.0, xyz[2] / xyz[1]});
    const auto viaStars = nebula::blackbodyLinearSRGB(4000.0);
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(viaStars[k], rgb[k], 1e-12) << k;
    }
}

// ---------------------------------------------------------------------------------------------
// Black-body colours (moved from test_stars.cpp)

double luminance(const std::array<double, 3>& rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

TEST(BlackbodyColour, UnitLuminance)
{
    // Y = 1 up to the rounding of the 4-digit IEC 61966-2-1 matrix.
    for (double T : {1000.0, 1500.0, 3000.0, 5772.0, 10000.0, 42000.0, 1e6}) {
        const auto rgb = nebula::blackbodyLinearSRGB(T);
        EXPECT_NEAR(luminance(rgb), 1.0, 1e-4) << T;
        for (double c : rgb) {
            EXPECT_GE(c, 0.0) << T;
        }
    }
}

TEST(BlackbodyColour, HotIsBlueCoolIsRed)
{
    const auto hot = nebula::blackbodyLinearSRGB(30000.0);
    EXPECT_GT(hot[2], hot[0]);
    const auto cool = nebula::blackbodyLinearSRGB(3000.0);
    EXPECT_GT(cool[0], cool[2]);
}

TEST(BlackbodyColour, NearWhiteAt6500K)
{
    const auto rgb = nebula::blackbodyLinearSRGB(6500.0);
    const double hi = std::max({rgb[0], rgb[1], rgb[2]});
    const double lo = std::min({rgb[0], rgb[1], rgb[2]});
    EXPECT_LT(hi / lo, 1.10);
}

TEST(BlackbodyColour, MatchesCieIntegratedRatios)
{
    // DESIGN §3.2, "CIE-1931-integrated linear sRGB", normalised so
    // that the largest channel is 1.
    struct Case
    {
        double T;
        std::array<double, 3> rgb;
    };
    for (const Case& c : {Case{42000, {0.34, 0.48, 1.00}}, Case{30000, {0.36, 0.50, 1.00}},
                          Case{9600, {0.63, 0.71, 1.00}}, Case{7300, {0.86, 0.86, 1.00}},
                          Case{5778, {1.00, 0.88, 0.82}}, Case{5200, {1.00, 0.82, 0.68}},
                          Case{3800, {1.00, 0.63, 0.33}}}) {
        const auto rgb = nebula::blackbodyLinearSRGB(c.T);
        const double max = std::max({rgb[0], rgb[1], rgb[2]});
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(rgb[k] / max, c.rgb[k], 0.03) << "T = " << c.T << ", channel " << k;
        }
    }
}

TEST(BlackbodyColour, RejectsNonPositiveTemperature)
{
    // Moved from Planck.RejectsNonPositiveInput (test_stars.cpp).
    EXPECT_THROW(nebula::blackbodyLinearSRGB(-1.0), nebula::Error);
    EXPECT_THROW(nebula::blackbodyLinearSRGB(0.0), nebula::Error);
    EXPECT_THROW(nebula::blackbodyLinearSRGB(NAN), nebula::Error);
    EXPECT_THROW(nebula::blackbodyLinearSRGB(INFINITY), nebula::Error);
}

} // namespace
