// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file filters.h
/// Photometric passbands and synthetic photometry (DESIGN §13): the standard filters shipped
/// with the library (libnebula/data/filters/*.csv, each citing its source, compiled in at
/// build time), filter files parsed from text, band averages of f_nu, the Gaussian
/// quadrature of a band (the wavelengths a renderer renders at, and their weights), pivot
/// wavelengths and AB magnitudes.
///
/// A filter's response T(lambda) is photon-counting (the fraction of photons detected) and
/// piecewise linear between its nodes, 0 outside them. The band average of f_nu is
///   <f_nu> = int f_nu T dnu/nu / int T dnu/nu = int f_nu T dlambda/lambda / int T dlambda/lambda.

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace nebula {

/// A passband: photon-counting response @p response (dimensionless, >= 0) at the strictly
/// increasing wavelengths @p lambda_nm [nm], linear in between, 0 outside.
struct Filter
{
    std::string name;              ///< "V", "sdss_r", "F814W", or the file's name
    std::vector<double> lambda_nm; ///< wavelengths [nm], strictly increasing, >= 2
    std::vector<double> response;  ///< photon-counting response, >= 0, not all 0
    std::string source;            ///< provenance: the data file's citation, or the file name
};

/// Wavelength unit of a filter file's first column.
enum class FilterWavelengthUnit { Nanometre, Angstrom, Micrometre };

/// The most lines and bytes a filter file may have (parseFilterFile()).
inline constexpr int MAX_FILTER_LINES = 100000;
inline constexpr std::size_t MAX_FILTER_BYTES = std::size_t(8) << 20;

/// Wavelengths a filter may span [nm]: [MIN_FILTER_LAMBDA_NM, MAX_FILTER_LAMBDA_NM), from
/// 0.01 Angstrom (gamma rays; 1 / lambda stays far from overflow) to 1 cm.
inline constexpr double MIN_FILTER_LAMBDA_NM = 1e-3, MAX_FILTER_LAMBDA_NM = 1e7;

/// The most quadrature nodes bandQuadrature() computes.
inline constexpr int MAX_BAND_NODES = 16;

/// Parses a filter file's text. Lines: "#" starts a comment; data lines are two numbers,
/// wavelength and response, separated by commas and/or blanks. Before the first data line,
/// optional header lines "unit, U" (U = nm, Angstrom (or A), um (or micron)) and
/// "response, R" (R = photon (default) or energy: an energy-response curve R_E, converted to
/// the photon-counting T = R_E / lambda and scaled to a peak of 1); a colon may replace the
/// comma. @p unit is the wavelength unit when the file names none (a tool's --filter-unit).
/// Throws Error naming @p source and the line for: a header line given twice, a line that
/// is not two numbers, a
/// non-finite or negative response, a wavelength outside [0.001, 1e7) nm, wavelengths not
/// strictly increasing ("not monotonic in wavelength"), fewer than 2 points, a response that
/// is 0 everywhere, more than MAX_FILTER_LINES lines or MAX_FILTER_BYTES bytes. The Filter's
/// name and source are @p source.
Filter parseFilterFile(std::string_view text, const std::string& source,
                       FilterWavelengthUnit unit = FilterWavelengthUnit::Nanometre);

/// The standard filter @p name, parsed once from the compiled-in data (thread-safe): Johnson-
/// Cousins "U", "B", "V", "R", "I" (Bessell 1990), SDSS "sdss_u" ... "sdss_z" (Doi et al.
/// 2010, 1.3 airmasses), HST ACS/WFC "F435W", "F555W", "F814W" (STScI). Throws UsageError
/// listing the known names for any other name.
const Filter& standardFilter(const std::string& name);

/// The standard filters' names, in the order above.
std::vector<std::string> standardFilterNames();

/// Pivot wavelength [nm]: sqrt(int T lambda dlambda / int T dlambda / lambda), exact for the
/// piecewise-linear T. The wavelength at which <f_nu> and <f_lambda> convert like
/// monochromatic values: <f_nu> = <f_lambda> lambda_p^2 / c.
double pivotWavelength(const Filter& filter);

/// The band average <f_nu> (DESIGN §13) of the spectrum @p fnu (any unit per Hz; a
/// function of the wavelength [nm]) through @p filter: int f_nu T dlambda/lambda /
/// int T dlambda/lambda, by 8-point Gauss-Legendre rules on every interval of the filter's
/// table split into pieces of at most 1 nm (and 1/64 of the band; at most 8192 pieces over
/// a band more than 8192 nm wide) (exact for T, accurate to ~1e-12 for smooth f_nu
/// such as black bodies). The result has f_nu's unit.
double bandAverageFnu(const Filter& filter, const std::function<double(double lambda_nm)>& fnu);

/// Gaussian quadrature of a band: sum_i weight[i] * f_nu(lambda_nm[i]) approximates
/// <f_nu>; exact for polynomials in lambda of degree 2n - 1. Weights are > 0 and sum to 1;
/// nodes ascend inside the filter's range.
struct BandQuadrature
{
    std::vector<double> lambda_nm; ///< nodes [nm], ascending
    std::vector<double> weight;    ///< weights, > 0, summing to 1
};

/// The @p n-node Gaussian quadrature for the weight function T(lambda) / lambda on the
/// filter's range: the measure discretised by bandAverageFnu()'s Gauss-Legendre nodes,
/// its recurrence coefficients by the Stieltjes procedure (orthonormal polynomials), nodes
/// and weights from the Jacobi matrix's eigen-decomposition (Golub & Welsch 1969). A renderer
/// renders monochromatic images at the nodes and sums them with the weights (n = 3: three
/// channels). n nodes, fewer only for a measure of fewer distinct points. Throws UsageError
/// unless 1 <= n <= MAX_BAND_NODES.
BandQuadrature bandQuadrature(const Filter& filter, int n);

/// The AB magnitude of the flux density @p fnu_jy [Jy]: -2.5 log10(f_nu / 3631 Jy) (Oke &
/// Gunn 1983). Throws Error unless fnu_jy is finite and > 0.
double abMagnitude(double fnu_jy);

/// The AB zero point [Jy]: 3631 Jy (f_nu of magnitude 0).
inline constexpr double AB_ZERO_POINT_JY = 3631.0;

} // namespace nebula
