// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file colour.h
/// Colour (DESIGN §7): the CIE 1931 2-degree colour-matching functions (CMFs) shipped as a
/// data file (libnebula/data/cie1931_2deg_1nm.csv, CVRL's 1 nm table, embedded at build
/// time), exact XYZ of piecewise-linear spectra, black-body XYZ, XYZ <-> linear sRGB
/// (IEC 61966-2-1 primaries, D65), CIE L*a*b* and the CIEDE2000 colour difference.
///
/// The CMFs are taken as piecewise linear between the 1 nm table nodes and 0 outside
/// 360-830 nm, so the XYZ of a piecewise-linear spectrum is an exact integral (Alghamdi et
/// al. 2023, DESIGN §7.1): no sampling, no quadrature error.

#include "nebula/physics/lines.h"
#include "nebula/physics/spectrum.h"

#include <array>
#include <vector>

namespace nebula {

/// Range and node spacing of the shipped CMF table [nm].
inline constexpr double CMF_LAMBDA_MIN = 360.0, CMF_LAMBDA_MAX = 830.0, CMF_STEP = 1.0;

/// Number of table nodes (360-830 nm at 1 nm).
inline constexpr int CMF_NODES = 471;

/// CIE XYZ tristimulus values. Their unit is the spectrum's unit times nm (the CMFs are
/// dimensionless), e.g. W m^-2 sr^-1 for a spectral radiance per nm.
using XYZ = std::array<double, 3>;

/// The CMF x̄ (@p component 0), ȳ (1) or z̄ (2) as a piecewise-linear spectrum: linear
/// between the 1 nm table nodes, 0 outside [360, 830] nm; one piece per 1 nm interval (470
/// pieces). Built once, on first use (thread-safe static). Throws UsageError unless
/// @p component is 0, 1 or 2.
const Spectrum& cmf(int component);

/// The three CMFs at @p lambda_nm [nm], interpolated linearly between the table nodes; 0
/// outside [360, 830] nm. At a node this is the table value itself.
XYZ cmfAt(double lambda_nm);

/// Exact XYZ of the piecewise-linear spectrum @p s: the integral of s times each CMF, via
/// Spectrum::integral(const Spectrum&) (O(size of s + 470) per component). Unit: s's unit
/// times nm.
XYZ spectrumToXYZ(const Spectrum& s);

/// Exact integral of the linear piece @p p (its line on [p.x0, p.x1], 0 elsewhere) times each
/// CMF: the renderer's hot path (many small pieces per pixel). O(1): the piece is clipped to
/// [360, 830] nm; its partial 1 nm intervals at either end are integrated directly (Simpson's
/// rule, exact for the quadratic product), and the whole intervals in between come from
/// prefix sums of the CMFs' zeroth and first moments kept in double-double precision, so
/// that the difference of two prefix sums loses nothing to cancellation (not even in the
/// tails, where the CMFs are 1e-6 of their peak). The piece's line is written about its
/// midpoint. Agrees with spectrumToXYZ() of a one-piece spectrum to about 1e-14 relative
/// for a piece that does not change sign, up to the rounding of the piece's own line
/// m x + b (about 1e-16 (|m| x + |b|) per value, which matters only for steep, narrow
/// pieces). A piece with x1 <= x0 (or NaN ends, or outside 360-830 nm) gives 0. Unit: p's
/// unit times nm.
XYZ pieceToXYZ(const Piece& p);

/// Per-node XYZ weights of a "hat-function" spectrum on a uniform grid: for the nodes
/// lambda_j = @p lambda0 + j @p step [nm], j = 0 ... @p n - 1, the spectrum
/// sum_j v_j hat_j(lambda) (linear interpolation between the nodes, 0 outside
/// [lambda0, lambda0 + (n - 1) step]) has XYZ = sum_j v_j w_j. Returns the n weights w_j
/// [nm], each the pieceToXYZ() of the node's two half-hats (rising from 0 at lambda_{j-1} to
/// 1 at lambda_j, falling to 0 at lambda_{j+1}; the end nodes have one half-hat, and n = 1
/// gives the weight 0 of a zero-width spectrum). Exact, like pieceToXYZ(). Throws UsageError
/// unless @p step > 0, @p n >= 0 and @p lambda0 is finite.
std::vector<XYZ> hatWeights(double lambda0, double step, int n);

/// CIE XYZ -> linear sRGB (IEC 61966-2-1 primaries, D65 white). The white is the D65 of
/// CIE 15 (X, Y, Z) = (0.95047, 1, 1.08883), which is what the D65 spectrum gives with the
/// shipped CMFs, so a D65 spectrum maps to RGB (1, 1, 1) (within 2e-5): the matrix is
/// derived from the primaries' chromaticities (0.64, 0.33), (0.30, 0.60), (0.15, 0.06) and
/// that white, in double precision. It differs from the standard's 4-digit rounded matrix
/// by at most 4e-4 per entry.
std::array<double, 3> xyzToLinearSRGB(const XYZ& xyz);

/// Linear sRGB -> CIE XYZ: the exact inverse of xyzToLinearSRGB() (the product of the two
/// matrices is the identity to 1e-15). Its second row, (0.2126729, 0.7151522, 0.0721750),
/// gives the luminance Y of a linear sRGB colour.
XYZ linearSRGBToXYZ(const std::array<double, 3>& rgb);

/// XYZ of a mix of emission lines, each as narrow as a line is (DESIGN §3.4): the sum of its
/// strengths times the CMFs at its wavelength, sum_l s_l cmfAt(lambda_l). A line outside
/// 360-830 nm adds nothing. Unit: the strengths' (the CMFs are dimensionless; a line's
/// energy is its strength).
XYZ linesXYZ(const std::vector<SpectralLine>& lines);

/// The linear sRGB colour of the line mix @p lines at luminance Y = @p luminance: its
/// linesXYZ() times luminance / Y, then xyzToLinearSRGB(). Not clipped: a monochromatic
/// line lies outside the sRGB gamut, so a channel is negative (H-alpha's G and B, [O III]'s
/// R); the sum of mixes is then the colour the spectral renderer gives their sum, and the
/// PNG clips the pixel's negative channels as it clips the spectral renderer's. Returns
/// zeros if the mix has Y = 0 (every line outside 360-830 nm).
std::array<double, 3> linesLinearSRGB(const std::vector<SpectralLine>& lines, double luminance);

/// Chromaticity (x, y) = (X, Y) / (X + Y + Z). Throws Error unless X + Y + Z > 0.
std::array<double, 2> chromaticity(const XYZ& xyz);

/// XYZ of a black body of temperature @p T [K]: the integral over 360-830 nm of
/// B_lambda(T) [W m^-2 sr^-1 nm^-1] times the CMFs (linear between the table nodes) [nm], in
/// W m^-2 sr^-1. Method: on each 1 nm interval the exact product of B and the linear CMF is
/// integrated by 3-point Gauss-Legendre quadrature (degree 5), which is within 1e-11
/// relative of the exact integral from 300 K up (B changes by at most a factor e^0.4 per nm
/// there; the tests check 1e-10 against brute-force Simpson). Planck's law is evaluated in
/// logarithms and the sum is scaled by its largest term, so nothing over- or underflows
/// inside; the result itself is representable for any T from about 20 K up (Y is about
/// 1.5e-24 at 300 K and 1e10 at 1e6 K). Use blackbodyXYZScaled() for colours at any
/// temperature. Throws Error unless T is finite and > 0.
XYZ blackbodyXYZ(double T);

/// blackbodyXYZ(@p T) in scaled form: returns XYZ / exp(@p logScale), its largest component
/// of order 1, and sets @p logScale (natural logarithm). Never overflows or underflows for a
/// finite T > 0, so the chromaticity and the ratios are right at any temperature. Throws
/// Error unless T is finite and > 0.
XYZ blackbodyXYZScaled(double T, double& logScale);

/// CIE 1976 L*a*b* (CIE 15) of @p xyz relative to the reference white @p white (same unit,
/// e.g. {0.95047, 1, 1.08883} for D65 with Y = 1): L* in [0, 100] for Y in [0, Yn], with the
/// exact CIE 15 constants ((6/29)^3 and (29/6)^2 / 3 for the linear segment near black).
/// Throws Error unless every component of @p white is > 0.
std::array<double, 3> xyzToLab(const XYZ& xyz, const XYZ& white);

/// CIEDE2000 colour difference Delta E_00 between @p lab1 and @p lab2 (L*, a*, b*), with
/// kL = kC = kH = 1, in the formulation of Sharma, Wu & Dalal, "The CIEDE2000
/// Color-Difference Formula: Implementation Notes, Supplementary Test Data, and Mathematical
/// Observations", Color Res. Appl. 30(1), 2005 (eqs. 1-23). Hue angles in degrees on
/// [0, 360); a hue difference that is 180 degrees up to rounding (mirror-image colours,
/// Sharma's pairs 10 and 14) takes the |h1 - h2| <= 180 branch, as in exact arithmetic.
/// Symmetric in its arguments.
double deltaE2000(const std::array<double, 3>& lab1, const std::array<double, 3>& lab2);

/// Rec. 709 luminance weights of linear sRGB R, G, B.
inline constexpr std::array<double, 3> LUMINANCE_WEIGHTS{0.2126, 0.7152, 0.0722};

/// Luminance Y of linear sRGB (LUMINANCE_WEIGHTS): what the tone curve, the images'
/// comparisons and the path tracer's luminance variance use.
inline double linearSRGBLuminance(double r, double g, double b)
{
    return LUMINANCE_WEIGHTS[0] * r + LUMINANCE_WEIGHTS[1] * g + LUMINANCE_WEIGHTS[2] * b;
}

/// Variance of the luminance of R, G, B whose noise is independent, from their variances
/// @p v: sum_c w_c^2 v_c.
inline double independentLuminanceVariance(const float* v)
{
    double var = 0.0;
    for (int c = 0; c < 3; ++c)
        var += LUMINANCE_WEIGHTS[std::size_t(c)] * LUMINANCE_WEIGHTS[std::size_t(c)] * v[c];
    return var;
}

/// Linear sRGB (IEC 61966-2-1, D65) colour of a black body at @p T [K], normalised to
/// luminance Y = 1 (DESIGN §3): Planck's law integrated against the shipped CIE 1931
/// 2-degree colour-matching function table over 360-830 nm (blackbodyXYZScaled(), then
/// xyzToLinearSRGB(), colour.h). Below about 1900 K, where the black body is outside the
/// sRGB gamut, the negative channel is clipped to 0 and the luminance restored to 1 (Rec.
/// 709 weights 0.2126, 0.7152, 0.0722). Throws Error unless T is a finite number > 0.
std::array<double, 3> blackbodyLinearSRGB(double T);

} // namespace nebula
