// SPDX-License-Identifier: Apache-2.0
/// @file colour.cpp
/// Colour (DESIGN §7): the shipped CIE 1931 CMF table, exact XYZ of piecewise-linear
/// spectra (per spectrum and per piece), black-body XYZ, XYZ <-> linear sRGB, CIE L*a*b* and
/// CIEDE2000.

#include "nebula/physics/colour.h"

#include "nebula/core/format.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/physics/blackbody.h"

// Generated at configure time from libnebula/data/cie1931_2deg_1nm.csv (libnebula/CMakeLists).
#include "nebula_cie1931_table.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

namespace nebula {

static_assert(detail::CIE1931_ROWS == CMF_NODES, "the CMF table must have 471 rows");
static_assert(detail::CIE1931_FIRST_NM == 360, "the CMF table must start at 360 nm");

namespace {

using detail::numberText;

/// Number of 1 nm intervals of the table.
constexpr int CMF_INTERVALS = CMF_NODES - 1;

/// Table value of component @p k at node @p j (0 = 360 nm).
inline double node(int j, int k)
{
    return detail::CIE1931_CMF[j][k];
}

/// Component @p k on interval @p j at the offset @p u in [0, 1] from its left node: linear
/// interpolation, exact at both nodes.
inline double interpolate(int j, int k, double u)
{
    return (1.0 - u) * node(j, k) + u * node(j + 1, k);
}

// ---------------------------------------------------------------------------------------------
// Double-double arithmetic (a value hi + lo with |lo| <= ulp(hi) / 2), for the prefix sums
// of pieceToXYZ(): Dekker / Knuth error-free transformations.

struct DoubleDouble
{
    double hi = 0.0;
    double lo = 0.0;
};

/// a + b = s + e exactly (Knuth's two-sum).
inline DoubleDouble twoSum(double a, double b)
{
    const double s = a + b;
    const double bb = s - a;
    const double e = (a - (s - bb)) + (b - bb);
    return {s, e};
}

/// a + b = s + e exactly, given |a| >= |b| or a = 0 (Dekker's fast two-sum).
inline DoubleDouble fastTwoSum(double a, double b)
{
    const double s = a + b;
    return {s, b - (s - a)};
}

inline DoubleDouble operator+(DoubleDouble x, DoubleDouble y)
{
    const DoubleDouble s = twoSum(x.hi, y.hi);
    const DoubleDouble t = twoSum(x.lo, y.lo);
    DoubleDouble r = fastTwoSum(s.hi, s.lo + t.hi);
    return fastTwoSum(r.hi, r.lo + t.lo);
}

inline DoubleDouble operator-(DoubleDouble x)
{
    return {-x.hi, -x.lo};
}

inline DoubleDouble operator-(DoubleDouble x, DoubleDouble y)
{
    return x + (-y);
}

/// x times the double @p t.
inline DoubleDouble operator*(DoubleDouble x, double t)
{
    const double p = x.hi * t;
    const double e = std::fma(x.hi, t, -p) + x.lo * t;
    return fastTwoSum(p, e);
}

/// x divided by the double @p d.
inline DoubleDouble operator/(DoubleDouble x, double d)
{
    const double q = x.hi / d;
    const double r = std::fma(-q, d, x.hi) + x.lo; // remainder x - q d
    return fastTwoSum(q, r / d);
}

/// Prefix sums over the table's 1 nm intervals, t = lambda - 360 nm: zeroth[k][j] is the
/// integral of CMF k over [0, j] and first[k][j] the integral of t times CMF k over [0, j]
/// (j = 0 ... 470), exact integrals of the piecewise-linear CMFs, accumulated in
/// double-double so that differences of two prefix sums lose nothing to cancellation.
struct PrefixSums
{
    DoubleDouble zeroth[3][CMF_NODES];
    DoubleDouble first[3][CMF_NODES];
};

const PrefixSums& prefixSums()
{
    static const PrefixSums sums = [] {
        PrefixSums s;
        for (int k = 0; k < 3; ++k) {
            s.zeroth[k][0] = {};
            s.first[k][0] = {};
            for (int j = 0; j < CMF_INTERVALS; ++j) {
                const double c0 = node(j, k);
                const double c1 = node(j + 1, k);
                // On [j, j + 1]: integral of c = (c0 + c1) / 2; integral of (t - j) c =
                // (c0 + 2 c1) / 6; integral of t c = j (c0 + c1) / 2 + (c0 + 2 c1) / 6.
                const DoubleDouble half = twoSum(c0, c1) * 0.5;
                const DoubleDouble moment = twoSum(c0, 2.0 * c1) / 6.0;
                s.zeroth[k][j + 1] = s.zeroth[k][j] + half;
                s.first[k][j + 1] = s.first[k][j] + (half * static_cast<double>(j) + moment);
            }
        }
        return s;
    }();
    return sums;
}

/// Adds to @p I0 the integral of CMF k over [@p a, @p b] and to @p Ic the integral of
/// (t - @p tc) CMF k over it, for every k, where [a, b] lies in interval @p j (t = lambda -
/// 360 nm). Simpson's rule: exact for the linear CMF and the quadratic (t - tc) CMF.
void addPartial(int j, double a, double b, double tc, XYZ& I0, XYZ& Ic)
{
    const double width = b - a;
    if (!(width > 0.0)) {
        return;
    }
    const double mid = 0.5 * (a + b);
    const double ua = a - j;
    const double um = mid - j;
    const double ub = b - j;
    for (int k = 0; k < 3; ++k) {
        const double ca = interpolate(j, k, ua);
        const double cm = interpolate(j, k, um);
        const double cb = interpolate(j, k, ub);
        I0[k] += width * cm;
        Ic[k] += width / 6.0 * ((a - tc) * ca + 4.0 * (mid - tc) * cm + (b - tc) * cb);
    }
}

// ---------------------------------------------------------------------------------------------
// sRGB matrices.

using Matrix3 = std::array<std::array<double, 3>, 3>;

Matrix3 inverse(const Matrix3& m)
{
    // Adjugate over determinant.
    Matrix3 adj{};
    adj[0][0] = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    adj[0][1] = m[0][2] * m[2][1] - m[0][1] * m[2][2];
    adj[0][2] = m[0][1] * m[1][2] - m[0][2] * m[1][1];
    adj[1][0] = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    adj[1][1] = m[0][0] * m[2][2] - m[0][2] * m[2][0];
    adj[1][2] = m[0][2] * m[1][0] - m[0][0] * m[1][2];
    adj[2][0] = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    adj[2][1] = m[0][1] * m[2][0] - m[0][0] * m[2][1];
    adj[2][2] = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    const double det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
    for (auto& row : adj) {
        for (double& v : row) {
            v /= det;
        }
    }
    return adj;
}

std::array<double, 3> matrixTimes(const Matrix3& m, const std::array<double, 3>& v)
{
    return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

struct SRGBMatrices
{
    Matrix3 rgbToXyz;
    Matrix3 xyzToRgb;
};

/// The sRGB matrices (see colour.h): columns of rgbToXyz are the primaries' XYZ, scaled so
/// that RGB (1, 1, 1) is the D65 white (0.95047, 1, 1.08883).
const SRGBMatrices& srgbMatrices()
{
    static const SRGBMatrices matrices = [] {
        // IEC 61966-2-1 primaries (x, y): red, green, blue.
        constexpr double PRIMARIES[3][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}};
        // D65, CIE 15 (2-degree observer), Y = 1.
        const std::array<double, 3> white = {0.95047, 1.0, 1.08883};
        Matrix3 P{};
        for (int c = 0; c < 3; ++c) {
            const double x = PRIMARIES[c][0];
            const double y = PRIMARIES[c][1];
            P[0][c] = x / y;
            P[1][c] = 1.0;
            P[2][c] = (1.0 - x - y) / y;
        }
        const std::array<double, 3> S = matrixTimes(inverse(P), white);
        SRGBMatrices m{};
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) {
                m.rgbToXyz[r][c] = P[r][c] * S[c];
            }
        }
        m.xyzToRgb = inverse(m.rgbToXyz);
        return m;
    }();
    return matrices;
}

constexpr double DEG_PER_RAD = 57.295779513082320876798154814105;
constexpr double RAD_PER_DEG = 0.017453292519943295769236907684886;

} // namespace

// -------------------------------------------------------------------------------------------------

const Spectrum& cmf(int component)
{
    if (component < 0 || component > 2) {
        throw UsageError("cmf: component must be 0 (xbar), 1 (ybar) or 2 (zbar), got " +
                         std::to_string(component));
    }
    static const std::array<Spectrum, 3> spectra = [] {
        std::array<Spectrum, 3> s;
        for (int k = 0; k < 3; ++k) {
            for (int j = 0; j < CMF_INTERVALS; ++j) {
                const double x0 = CMF_LAMBDA_MIN + j;
                s[k].add(pieceThrough(x0, node(j, k), x0 + CMF_STEP, node(j + 1, k)));
            }
        }
        return s;
    }();
    return spectra[static_cast<std::size_t>(component)];
}

XYZ cmfAt(double lambda_nm)
{
    if (!(lambda_nm >= CMF_LAMBDA_MIN && lambda_nm <= CMF_LAMBDA_MAX)) {
        return {0.0, 0.0, 0.0};
    }
    const double t = lambda_nm - CMF_LAMBDA_MIN;
    const int j = std::min(static_cast<int>(t), CMF_INTERVALS - 1);
    const double u = t - j;
    return {interpolate(j, 0, u), interpolate(j, 1, u), interpolate(j, 2, u)};
}

XYZ spectrumToXYZ(const Spectrum& s)
{
    return {s.integral(cmf(0)), s.integral(cmf(1)), s.integral(cmf(2))};
}

XYZ pieceToXYZ(const Piece& p)
{
    // Clip to the table, in t = lambda - 360 nm (exact: both lie in [360, 830]).
    const double lo = std::max(p.x0, CMF_LAMBDA_MIN);
    const double hi = std::min(p.x1, CMF_LAMBDA_MAX);
    if (!(hi > lo)) {
        return {0.0, 0.0, 0.0};
    }
    const double a = lo - CMF_LAMBDA_MIN;
    const double b = hi - CMF_LAMBDA_MIN;
    const double tc = 0.5 * (a + b);
    // The piece's line about its midpoint: pc + m (t - tc).
    const double pc = p.at(0.5 * (lo + hi));

    // Intervals touched: j0 ... j1.
    const int j0 = std::min(static_cast<int>(a), CMF_INTERVALS - 1);
    const int j1 = std::max(static_cast<int>(std::ceil(b)) - 1, j0);
    XYZ I0 = {0.0, 0.0, 0.0}; // integral of the CMF over the piece
    XYZ Ic = {0.0, 0.0, 0.0}; // integral of (t - tc) CMF over the piece
    if (j0 == j1) {
        addPartial(j0, a, b, tc, I0, Ic);
    } else {
        addPartial(j0, a, j0 + 1.0, tc, I0, Ic);
        addPartial(j1, static_cast<double>(j1), b, tc, I0, Ic);
        // Whole intervals j0 + 1 ... j1 - 1, i.e. t in [j0 + 1, j1].
        if (j1 > j0 + 1) {
            const PrefixSums& s = prefixSums();
            for (int k = 0; k < 3; ++k) {
                const DoubleDouble zeroth = s.zeroth[k][j1] - s.zeroth[k][j0 + 1];
                const DoubleDouble first = s.first[k][j1] - s.first[k][j0 + 1];
                const DoubleDouble centred = first - zeroth * tc;
                I0[k] += zeroth.hi + zeroth.lo;
                Ic[k] += centred.hi + centred.lo;
            }
        }
    }
    return {pc * I0[0] + p.m * Ic[0], pc * I0[1] + p.m * Ic[1], pc * I0[2] + p.m * Ic[2]};
}

std::vector<XYZ> hatWeights(double lambda0, double step, int n)
{
    if (!(step > 0.0) || !std::isfinite(step) || !std::isfinite(lambda0) || n < 0) {
        throw UsageError("hatWeights: need a finite lambda0, a finite step > 0 [nm] and n >= 0, "
                         "got lambda0 = " +
                         numberText(lambda0) + ", step = " + numberText(step) +
                         ", n = " + std::to_string(n));
    }
    std::vector<XYZ> weights(static_cast<std::size_t>(n), XYZ{0.0, 0.0, 0.0});
    const auto at = [&](int j) { return lambda0 + j * step; };
    for (int j = 0; j < n; ++j) {
        XYZ& w = weights[static_cast<std::size_t>(j)];
        if (j > 0) {
            const XYZ rising = pieceToXYZ(pieceThrough(at(j - 1), 0.0, at(j), 1.0));
            for (int k = 0; k < 3; ++k) {
                w[k] += rising[k];
            }
        }
        if (j + 1 < n) {
            const XYZ falling = pieceToXYZ(pieceThrough(at(j), 1.0, at(j + 1), 0.0));
            for (int k = 0; k < 3; ++k) {
                w[k] += falling[k];
            }
        }
    }
    return weights;
}

std::array<double, 3> xyzToLinearSRGB(const XYZ& xyz)
{
    return matrixTimes(srgbMatrices().xyzToRgb, xyz);
}

XYZ linearSRGBToXYZ(const std::array<double, 3>& rgb)
{
    return matrixTimes(srgbMatrices().rgbToXyz, rgb);
}

XYZ linesXYZ(const std::vector<SpectralLine>& lines)
{
    XYZ xyz{0.0, 0.0, 0.0};
    for (const auto& l : lines) {
        const XYZ c = cmfAt(l.wavelength);
        for (std::size_t i = 0; i < 3; ++i)
            xyz[i] += l.strength * c[i];
    }
    return xyz;
}

std::array<double, 3> linesLinearSRGB(const std::vector<SpectralLine>& lines, double luminance)
{
    XYZ xyz = linesXYZ(lines);
    if (!(xyz[1] > 0.0)) return {0.0, 0.0, 0.0};
    const double f = luminance / xyz[1];
    for (auto& v : xyz)
        v *= f;
    return xyzToLinearSRGB(xyz);
}

std::array<double, 2> chromaticity(const XYZ& xyz)
{
    const double sum = xyz[0] + xyz[1] + xyz[2];
    if (!(sum > 0.0)) {
        throw Error("chromaticity: X + Y + Z must be > 0, got " + numberText(sum));
    }
    return {xyz[0] / sum, xyz[1] / sum};
}

XYZ blackbodyXYZScaled(double T, double& logScale)
{
    if (!(T > 0.0) || !std::isfinite(T)) {
        throw Error("black-body XYZ: temperature must be a finite number > 0 [K], got " +
                    numberText(T));
    }
    // 3-point Gauss-Legendre on [0, 1]: nodes 1/2 -+ sqrt(3/5)/2 and 1/2, weights 5/18, 8/18.
    constexpr int NG = 3;
    const double offset = 0.5 * std::sqrt(0.6);
    const double nodes[NG] = {0.5 - offset, 0.5, 0.5 + offset};
    constexpr double weights[NG] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};

    // log B_lambda per nm at every quadrature node: log(2 h c^2) - 5 log(lambda) -
    // log(e^x - 1) - log(1e9), x = h c / (lambda k T), in forms that neither overflow nor
    // lose accuracy for small or large x.
    const double log2hc2 = std::log(2.0 * PLANCK_H * SPEED_OF_LIGHT * SPEED_OF_LIGHT);
    const double logPerNm = std::log(1e-9);
    const double c2OverT = PLANCK_H * SPEED_OF_LIGHT / (BOLTZMANN_K * T); // [m]
    std::array<double, CMF_INTERVALS * NG> logB{};
    double logMax = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < CMF_INTERVALS; ++j) {
        for (int g = 0; g < NG; ++g) {
            const double lambda_m = (CMF_LAMBDA_MIN + j + nodes[g]) * 1e-9;
            const double x = c2OverT / lambda_m;
            const double logDenominator =
                x < 1.0 ? std::log(std::expm1(x)) : x + std::log1p(-std::exp(-x));
            const double value = log2hc2 - 5.0 * std::log(lambda_m) - logDenominator + logPerNm;
            logB[static_cast<std::size_t>(j * NG + g)] = value;
            logMax = std::max(logMax, value);
        }
    }

    // Sum of weight B / B_max CMF over the nodes (interval width 1 nm).
    XYZ sum = {0.0, 0.0, 0.0};
    for (int j = 0; j < CMF_INTERVALS; ++j) {
        for (int g = 0; g < NG; ++g) {
            const double w =
                weights[g] * std::exp(logB[static_cast<std::size_t>(j * NG + g)] - logMax);
            for (int k = 0; k < 3; ++k) {
                sum[k] += w * interpolate(j, k, nodes[g]);
            }
        }
    }
    // Rescale so that the largest component is 1 (x̄ > 0 everywhere in the table, so the
    // sum is > 0).
    const double largest = std::max({sum[0], sum[1], sum[2]});
    for (double& v : sum) {
        v /= largest;
    }
    logScale = logMax + std::log(largest);
    return sum;
}

XYZ blackbodyXYZ(double T)
{
    double logScale = 0.0;
    XYZ xyz = blackbodyXYZScaled(T, logScale);
    const double scale = std::exp(logScale);
    for (double& v : xyz) {
        v *= scale;
    }
    return xyz;
}

std::array<double, 3> xyzToLab(const XYZ& xyz, const XYZ& white)
{
    for (double w : white) {
        if (!(w > 0.0) || !std::isfinite(w)) {
            throw Error("L*a*b*: every component of the reference white must be a finite "
                        "number > 0, got (" +
                        numberText(white[0]) + ", " + numberText(white[1]) + ", " +
                        numberText(white[2]) + ")");
        }
    }
    // CIE 15: f(t) = t^(1/3) above (6/29)^3, else t (29/6)^2 / 3 + 4/29.
    constexpr double EPSILON = 216.0 / 24389.0; // (6/29)^3
    constexpr double SLOPE = 841.0 / 108.0;     // (29/6)^2 / 3
    const auto f = [&](double t) { return t > EPSILON ? std::cbrt(t) : SLOPE * t + 4.0 / 29.0; };
    const double fx = f(xyz[0] / white[0]);
    const double fy = f(xyz[1] / white[1]);
    const double fz = f(xyz[2] / white[2]);
    return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

double deltaE2000(const std::array<double, 3>& lab1, const std::array<double, 3>& lab2)
{
    // Sharma, Wu & Dalal 2005, eqs. (1)-(23); angles in degrees.
    const double L1 = lab1[0], a1 = lab1[1], b1 = lab1[2];
    const double L2 = lab2[0], a2 = lab2[1], b2 = lab2[2];

    // (2)-(7): a', C', h'.
    const double C1 = std::hypot(a1, b1);
    const double C2 = std::hypot(a2, b2);
    const double Cbar = 0.5 * (C1 + C2);
    const double Cbar7 = std::pow(Cbar, 7.0);
    const double G = 0.5 * (1.0 - std::sqrt(Cbar7 / (Cbar7 + 6103515625.0))); // 25^7
    const double a1p = (1.0 + G) * a1;
    const double a2p = (1.0 + G) * a2;
    const double C1p = std::hypot(a1p, b1);
    const double C2p = std::hypot(a2p, b2);
    const auto hue = [](double b, double ap) {
        if (b == 0.0 && ap == 0.0) {
            return 0.0;
        }
        double h = std::atan2(b, ap) * DEG_PER_RAD;
        if (h < 0.0) {
            h += 360.0;
        }
        return h;
    };
    const double h1p = hue(b1, a1p);
    const double h2p = hue(b2, a2p);

    // A hue difference within rounding of 180 degrees is 180 (mirror-image pairs).
    constexpr double HUE_ROUNDING = 1e-9; // [deg]
    const double hueDiff = h2p - h1p;
    const bool within180 = std::fabs(hueDiff) <= 180.0 + HUE_ROUNDING;

    // (8)-(10): differences.
    const double dLp = L2 - L1;
    const double dCp = C2p - C1p;
    const double productC = C1p * C2p;
    double dhp = 0.0;
    if (productC != 0.0) {
        if (within180) {
            dhp = hueDiff;
        } else if (hueDiff > 180.0) {
            dhp = hueDiff - 360.0;
        } else {
            dhp = hueDiff + 360.0;
        }
    }
    const double dHp = 2.0 * std::sqrt(productC) * std::sin(0.5 * dhp * RAD_PER_DEG);

    // (12)-(22): means, weights and rotation.
    const double Lbarp = 0.5 * (L1 + L2);
    const double Cbarp = 0.5 * (C1p + C2p);
    double hbarp = h1p + h2p;
    if (productC != 0.0) {
        if (within180) {
            hbarp = 0.5 * (h1p + h2p);
        } else if (h1p + h2p < 360.0) {
            hbarp = 0.5 * (h1p + h2p + 360.0);
        } else {
            hbarp = 0.5 * (h1p + h2p - 360.0);
        }
    }
    const double Tfactor = 1.0 - 0.17 * std::cos((hbarp - 30.0) * RAD_PER_DEG) +
                           0.24 * std::cos(2.0 * hbarp * RAD_PER_DEG) +
                           0.32 * std::cos((3.0 * hbarp + 6.0) * RAD_PER_DEG) -
                           0.20 * std::cos((4.0 * hbarp - 63.0) * RAD_PER_DEG);
    const double dTheta = 30.0 * std::exp(-std::pow((hbarp - 275.0) / 25.0, 2.0));
    const double Cbarp7 = std::pow(Cbarp, 7.0);
    const double RC = 2.0 * std::sqrt(Cbarp7 / (Cbarp7 + 6103515625.0));
    const double Lm50sq = (Lbarp - 50.0) * (Lbarp - 50.0);
    const double SL = 1.0 + 0.015 * Lm50sq / std::sqrt(20.0 + Lm50sq);
    const double SC = 1.0 + 0.045 * Cbarp;
    const double SH = 1.0 + 0.015 * Cbarp * Tfactor;
    const double RT = -std::sin(2.0 * dTheta * RAD_PER_DEG) * RC;

    // (23), kL = kC = kH = 1.
    const double tL = dLp / SL;
    const double tC = dCp / SC;
    const double tH = dHp / SH;
    return std::sqrt(tL * tL + tC * tC + tH * tH + RT * tC * tH);
}

std::array<double, 3> blackbodyLinearSRGB(double T)
{
    if (!(T > 0.0) || !std::isfinite(T)) {
        throw Error("black-body colour: temperature must be a finite number > 0 [K], got " +
                    numberText(T));
    }

    // XYZ: Planck's law integrated against the shipped CIE 1931 table (colour.h), in scaled
    // form so that neither very cold nor very hot bodies under- or overflow; then Y = 1.
    double logScale = 0.0;
    XYZ xyz = blackbodyXYZScaled(T, logScale);
    xyz = {xyz[0] / xyz[1], 1.0, xyz[2] / xyz[1]};
    std::array<double, 3> rgb = xyzToLinearSRGB(xyz);

    // Below about 1900 K the black body lies outside the sRGB gamut (blue < 0): clip the
    // negative channel, since negative light has no meaning to a renderer, and restore the
    // luminance (Rec. 709 / sRGB weights) to 1. These 4-digit weights differ from the Y row
    // of the matrix (0.2126729, 0.7151522, 0.0721750) by < 1e-4, so Y is 1 within 4e-4 here.
    if (rgb[0] < 0.0 || rgb[1] < 0.0 || rgb[2] < 0.0) {
        for (double& c : rgb) {
            c = std::max(c, 0.0);
        }
        const double luminance = linearSRGBLuminance(rgb[0], rgb[1], rgb[2]);
        for (double& c : rgb) {
            c /= luminance;
        }
    }
    return rgb;
}

} // namespace nebula
