// SPDX-License-Identifier: Apache-2.0
/// @file filters.cpp
/// Photometric passbands (DESIGN §13): filter files, the shipped standard filters, band
/// averages, Gaussian band quadrature, pivot wavelengths and AB magnitudes.

#include "nebula/physics/filters.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"

// Generated at configure time from libnebula/data/filters/*.csv (libnebula/CMakeLists.txt).
#include "nebula_filter_table.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>

namespace nebula {

namespace {

using detail::numberText;
using detail::printable;

// -------------------------------------------------------------------------------------------
// Filter files

bool isSeparator(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == ',';
}

/// The fields of a line: runs of characters other than blanks and commas.
std::vector<std::string_view> splitFields(std::string_view line)
{
    std::vector<std::string_view> fields;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && isSeparator(line[i]))
            ++i;
        const std::size_t start = i;
        while (i < line.size() && !isSeparator(line[i]))
            ++i;
        if (i > start) fields.push_back(line.substr(start, i - start));
    }
    return fields;
}

/// @p field as a double, if the whole field is a number.
bool parseNumber(std::string_view field, double& value)
{
    const char* end = field.data() + field.size();
    const auto [ptr, ec] = std::from_chars(field.data(), end, value);
    return ec == std::errc() && ptr == end;
}

std::string lowercase(std::string_view text)
{
    std::string out(text);
    for (char& c : out)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    return out;
}

/// Nanometres per unit of @p unit.
double nmPerUnit(FilterWavelengthUnit unit)
{
    switch (unit) {
    case FilterWavelengthUnit::Angstrom: return 0.1;
    case FilterWavelengthUnit::Micrometre: return 1000.0;
    case FilterWavelengthUnit::Nanometre: break;
    }
    return 1.0;
}

/// What the header lines ("unit, nm", "response, energy") set.
struct FilterHeader
{
    FilterWavelengthUnit unit;
    bool energy = false;
    int unitLine = 0, responseLine = 0; ///< the lines that set them (0: none yet)
};

/// Throws if a header line for @p key came before (at line @p seen): a second one would
/// silently win over the first.
void refuseRepeat(int& seen, int lineNumber, const std::string& key, const std::string& where)
{
    if (seen != 0) {
        throw Error(where + ": a second \"" + key + "\" line (line " + std::to_string(seen) +
                    " gave it already; a filter file names its " + key + " once)");
    }
    seen = lineNumber;
}

/// Reads a header line's key and value into @p header; throws for anything else and for a
/// key given twice.
void parseHeaderLine(const std::vector<std::string_view>& fields, FilterHeader& header,
                     const std::string& where, int lineNumber, std::string_view line)
{
    std::string key = fields.empty() ? std::string() : lowercase(fields[0]);
    if (!key.empty() && key.back() == ':') key.pop_back();
    const std::string value = fields.size() == 2 ? lowercase(fields[1]) : std::string();
    if (key == "unit" && fields.size() == 2) refuseRepeat(header.unitLine, lineNumber, key, where);
    if (key == "response" && fields.size() == 2)
        refuseRepeat(header.responseLine, lineNumber, key, where);
    if (key == "unit" && fields.size() == 2) {
        if (value == "nm") {
            header.unit = FilterWavelengthUnit::Nanometre;
            return;
        }
        if (value == "angstrom" || value == "a") {
            header.unit = FilterWavelengthUnit::Angstrom;
            return;
        }
        if (value == "um" || value == "micron") {
            header.unit = FilterWavelengthUnit::Micrometre;
            return;
        }
        throw Error(where + ": unknown wavelength unit \"" + printable(std::string(fields[1])) +
                    "\" (expected nm, Angstrom or um)");
    }
    if (key == "response" && fields.size() == 2) {
        if (value == "photon" || value == "energy") {
            header.energy = value == "energy";
            return;
        }
        throw Error(where + ": unknown response convention \"" + printable(std::string(fields[1])) +
                    "\" (expected photon or energy)");
    }
    throw Error(where + ": expected two numbers (wavelength, response), got \"" +
                printable(std::string(line)) + "\"");
}

/// Checks one data point (wavelength already in nm) against the previous one.
void checkPoint(double lambda_nm, double response, const Filter& filter, const std::string& where)
{
    if (!std::isfinite(response) || response < 0.0)
        throw Error(where + ": response " + numberText(response) + " is not a finite number >= 0");
    if (!std::isfinite(lambda_nm) || lambda_nm < MIN_FILTER_LAMBDA_NM ||
        lambda_nm >= MAX_FILTER_LAMBDA_NM)
        throw Error(where + ": wavelength " + numberText(lambda_nm) + " nm is outside [" +
                    numberText(MIN_FILTER_LAMBDA_NM) + ", " + numberText(MAX_FILTER_LAMBDA_NM) +
                    ") nm");
    if (!filter.lambda_nm.empty() && !(lambda_nm > filter.lambda_nm.back()))
        throw Error(where + ": not monotonic in wavelength: " + numberText(lambda_nm) +
                    " nm follows " + numberText(filter.lambda_nm.back()) +
                    " nm (wavelengths must increase strictly)");
}

/// An energy-response curve R_E as the photon-counting T = R_E / lambda, peak 1 (scaled by
/// R_E's peak first, so that neither step overflows).
void energyToPhoton(Filter& filter)
{
    const double peakE = *std::max_element(filter.response.begin(), filter.response.end());
    double peak = 0.0;
    for (std::size_t i = 0; i < filter.response.size(); ++i) {
        filter.response[i] = filter.response[i] / peakE / filter.lambda_nm[i];
        peak = std::max(peak, filter.response[i]);
    }
    for (double& t : filter.response)
        t /= peak;
}

// -------------------------------------------------------------------------------------------
// Integration over a band

/// 8-point Gauss-Legendre nodes and weights on [-1, 1] (exact for degree 15).
constexpr std::array<double, 8> GL_X = {
    -0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
    0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
constexpr std::array<double, 8> GL_W = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                        0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                        0.2223810344533745, 0.1012285362903763};

/// The longest piece [nm] a table interval is integrated over with one Gauss-Legendre rule,
/// and the fewest and most pieces a band is split into (so that every filter has enough nodes
/// for MAX_BAND_NODES, and a filter spanning 1e7 nm no more than ~65 k nodes).
constexpr double MAX_PIECE_NM = 1.0;
constexpr double MIN_PIECES = 64.0, MAX_PIECES = 8192.0;

/// The discretised band measure: nodes lambda [nm] and weights T(lambda) dlambda / lambda
/// (Gauss-Legendre on every table interval, split into pieces of at most MAX_PIECE_NM), so
/// that sum w f(lambda) approximates int f T dlambda/lambda. Nodes where T = 0 are dropped.
struct BandMeasure
{
    std::vector<double> lambda_nm, weight;
};

BandMeasure bandMeasure(const Filter& filter)
{
    BandMeasure m;
    const auto& x = filter.lambda_nm;
    const auto& t = filter.response;
    if (x.size() < 2 || t.size() != x.size())
        throw Error(filter.source + ": a filter needs at least 2 (wavelength, response) points");
    // T over its peak: the measure's scale cancels in every ratio, and a response of 1e300
    // must not overflow.
    const double peak = *std::max_element(t.begin(), t.end());
    if (!(peak > 0.0)) throw Error(filter.source + ": the response is 0 at every wavelength");
    const double span = x.back() - x.front();
    const double maxPiece = std::max(std::min(MAX_PIECE_NM, span / MIN_PIECES), span / MAX_PIECES);
    for (std::size_t i = 0; i + 1 < x.size(); ++i) {
        if (t[i] == 0.0 && t[i + 1] == 0.0) continue;
        const double width = x[i + 1] - x[i];
        const int pieces = std::max(1, int(std::ceil(width / maxPiece)));
        const double h = width / pieces;
        for (int p = 0; p < pieces; ++p) {
            const double a = x[i] + p * h;
            for (std::size_t k = 0; k < GL_X.size(); ++k) {
                const double lambda = a + 0.5 * h * (1.0 + GL_X[k]);
                const double s = (lambda - x[i]) / width;
                const double T = (1.0 - s) * (t[i] / peak) + s * (t[i + 1] / peak);
                if (T <= 0.0) continue;
                m.lambda_nm.push_back(lambda);
                m.weight.push_back(0.5 * h * GL_W[k] * T / lambda);
            }
        }
    }
    if (m.lambda_nm.empty()) throw Error(filter.source + ": the response is 0 at every wavelength");
    return m;
}

/// Eigenvalues and first eigenvector components of the symmetric @p n x n matrix @p a (row
/// major, destroyed) by cyclic Jacobi rotations; n is small (<= MAX_BAND_NODES).
void jacobiEigen(std::vector<double>& a, int n, std::vector<double>& values,
                 std::vector<double>& firstComponents)
{
    std::vector<double> v(std::size_t(n) * n, 0.0);
    for (int i = 0; i < n; ++i)
        v[std::size_t(i) * n + i] = 1.0;
    auto A = [&](int r, int c) -> double& { return a[std::size_t(r) * n + c]; };
    for (int sweep = 0; sweep < 100; ++sweep) {
        double off = 0.0, diag = 0.0;
        for (int r = 0; r < n; ++r) {
            diag += A(r, r) * A(r, r);
            for (int c = r + 1; c < n; ++c)
                off += A(r, c) * A(r, c);
        }
        if (off <= 1e-32 * diag) break;
        for (int p = 0; p < n; ++p) {
            for (int q = p + 1; q < n; ++q) {
                if (A(p, q) == 0.0) continue;
                const double theta = (A(q, q) - A(p, p)) / (2.0 * A(p, q));
                const double tn = (theta >= 0.0 ? 1.0 : -1.0) /
                                  (std::abs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(tn * tn + 1.0), s = tn * c;
                for (int k = 0; k < n; ++k) { // columns p, q
                    const double akp = A(k, p), akq = A(k, q);
                    A(k, p) = c * akp - s * akq;
                    A(k, q) = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) { // rows p, q
                    const double apk = A(p, k), aqk = A(q, k);
                    A(p, k) = c * apk - s * aqk;
                    A(q, k) = s * apk + c * aqk;
                }
                for (int k = 0; k < n; ++k) {
                    const double vkp = v[std::size_t(k) * n + p], vkq = v[std::size_t(k) * n + q];
                    v[std::size_t(k) * n + p] = c * vkp - s * vkq;
                    v[std::size_t(k) * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    values.resize(n);
    firstComponents.resize(n);
    for (int i = 0; i < n; ++i) {
        values[i] = A(i, i);
        firstComponents[i] = v[i]; // row 0, column i
    }
}

} // namespace

Filter parseFilterFile(std::string_view text, const std::string& source, FilterWavelengthUnit unit)
{
    Filter filter;
    filter.name = source;
    filter.source = source;
    if (text.size() > MAX_FILTER_BYTES)
        throw Error(source + ": " + std::to_string(text.size()) +
                    " bytes, more than a filter file's " + std::to_string(MAX_FILTER_BYTES));
    FilterHeader header{unit};
    int lineNumber = 0;
    std::size_t pos = 0;
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        if (++lineNumber > MAX_FILTER_LINES)
            throw Error(source + ": more than " + std::to_string(MAX_FILTER_LINES) +
                        " lines (a filter file is a table of at most that many points)");
        const std::string where = source + ":" + std::to_string(lineNumber);
        line = line.substr(0, line.find('#'));
        const auto fields = splitFields(line);
        if (fields.empty()) continue;
        double lambda = 0.0, response = 0.0;
        const bool numeric = fields.size() == 2 && parseNumber(fields[0], lambda) &&
                             parseNumber(fields[1], response);
        if (!numeric) {
            if (!filter.lambda_nm.empty() || (!fields.empty() && parseNumber(fields[0], lambda)))
                throw Error(where + ": expected two numbers (wavelength, response), got \"" +
                            printable(std::string(line)) + "\"");
            parseHeaderLine(fields, header, where, lineNumber, line);
            continue;
        }
        const double lambda_nm = lambda * nmPerUnit(header.unit);
        checkPoint(lambda_nm, response, filter, where);
        filter.lambda_nm.push_back(lambda_nm);
        filter.response.push_back(response);
    }
    if (filter.lambda_nm.size() < 2)
        throw Error(source + ": " + std::to_string(filter.lambda_nm.size()) +
                    " data points, a filter needs at least 2 (wavelength, response)");
    if (*std::max_element(filter.response.begin(), filter.response.end()) <= 0.0)
        throw Error(source + ": the response is 0 at every wavelength");
    if (header.energy) energyToPhoton(filter);
    return filter;
}

const Filter& standardFilter(const std::string& name)
{
    // Parsed once (thread-safe static); a shipped file that does not parse is a build error
    // the unit tests catch.
    static const std::vector<Filter> filters = [] {
        std::vector<Filter> out;
        for (const auto& entry : detail::STANDARD_FILTER_TEXTS) {
            Filter f = parseFilterFile(entry.text, entry.file);
            f.name = entry.name;
            // The provenance: the file's leading comment lines, joined.
            std::string citation;
            std::string_view text = entry.text;
            while (!text.empty() && text.front() == '#') {
                const std::size_t end = std::min(text.find('\n'), text.size());
                std::string_view line = text.substr(1, end - 1);
                while (!line.empty() && line.front() == ' ')
                    line.remove_prefix(1);
                if (!citation.empty()) citation += ' ';
                citation += line;
                text.remove_prefix(std::min(end + 1, text.size()));
            }
            f.source = std::string(entry.file) + ": " + citation;
            out.push_back(std::move(f));
        }
        return out;
    }();
    for (const Filter& f : filters)
        if (f.name == name) return f;
    std::string known;
    for (const auto& n : standardFilterNames())
        known += (known.empty() ? "" : ", ") + n;
    throw UsageError("unknown filter \"" + printable(name) + "\" (known: " + known +
                     "; or a filter file)");
}

std::vector<std::string> standardFilterNames()
{
    std::vector<std::string> names;
    for (const auto& entry : detail::STANDARD_FILTER_TEXTS)
        names.emplace_back(entry.name);
    return names;
}

double pivotWavelength(const Filter& filter)
{
    // T linear on [a, b]: int T x dx and int T / x dx in closed form per interval.
    double num = 0.0, den = 0.0;
    const auto& x = filter.lambda_nm;
    const auto& t = filter.response;
    const double peak = *std::max_element(t.begin(), t.end()); // against overflow
    for (std::size_t i = 0; i + 1 < x.size(); ++i) {
        const double a = x[i], b = x[i + 1], ta = t[i] / peak, tb = t[i + 1] / peak;
        const double slope = (tb - ta) / (b - a), icpt = ta - slope * a; // T = icpt + slope x
        num += icpt * 0.5 * (b * b - a * a) + slope * (b * b * b - a * a * a) / 3.0;
        den += icpt * std::log(b / a) + slope * (b - a);
    }
    return std::sqrt(num / den);
}

double bandAverageFnu(const Filter& filter, const std::function<double(double lambda_nm)>& fnu)
{
    const BandMeasure m = bandMeasure(filter);
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < m.lambda_nm.size(); ++k) {
        num += m.weight[k] * fnu(m.lambda_nm[k]);
        den += m.weight[k];
    }
    return num / den;
}

BandQuadrature bandQuadrature(const Filter& filter, int n)
{
    if (n < 1 || n > MAX_BAND_NODES)
        throw UsageError("band quadrature of " + std::to_string(n) + " nodes: expected 1 to " +
                         std::to_string(MAX_BAND_NODES));
    const BandMeasure m = bandMeasure(filter);
    const std::size_t N = m.lambda_nm.size();
    // Work in t = (lambda - centre) / halfWidth in [-1, 1] for conditioning.
    const double lo = m.lambda_nm.front(), hi = m.lambda_nm.back();
    const double centre = 0.5 * (lo + hi), halfWidth = std::max(0.5 * (hi - lo), 1e-12);
    std::vector<double> t(N), w(N);
    double total = 0.0;
    for (std::size_t k = 0; k < N; ++k)
        total += m.weight[k];
    for (std::size_t k = 0; k < N; ++k) {
        t[k] = (m.lambda_nm[k] - centre) / halfWidth;
        w[k] = m.weight[k] / total;
    }
    // Discretised Stieltjes procedure on orthonormal polynomial values q_j(t_k) (the three-term
    // recurrence; stable for a measure of thousands of points and n <= 16, Gautschi 2004 §2.2).
    int nodes = int(std::min<std::size_t>(std::size_t(n), N));
    std::vector<double> alpha(nodes, 0.0), beta(nodes, 0.0);
    std::vector<double> qPrev(N, 0.0), q(N, 1.0), r(N);
    for (int j = 0; j < nodes; ++j) {
        double a = 0.0;
        for (std::size_t k = 0; k < N; ++k)
            a += w[k] * t[k] * q[k] * q[k];
        alpha[j] = a;
        if (j + 1 == nodes) break;
        for (std::size_t k = 0; k < N; ++k)
            r[k] = (t[k] - a) * q[k] - beta[j] * qPrev[k];
        double norm2 = 0.0;
        for (std::size_t k = 0; k < N; ++k)
            norm2 += w[k] * r[k] * r[k];
        beta[j + 1] = std::sqrt(norm2);
        if (!(beta[j + 1] > 1e-150)) { // the measure has only j + 1 distinct points
            nodes = j + 1;
            break;
        }
        for (std::size_t k = 0; k < N; ++k) {
            qPrev[k] = q[k];
            q[k] = r[k] / beta[j + 1];
        }
    }
    // Golub-Welsch: the nodes are the Jacobi matrix's eigenvalues, the weights the squared
    // first components of its normalised eigenvectors (the measure has total mass 1).
    std::vector<double> jacobi(std::size_t(nodes) * nodes, 0.0);
    for (int j = 0; j < nodes; ++j) {
        jacobi[std::size_t(j) * nodes + j] = alpha[j];
        if (j + 1 < nodes) {
            jacobi[std::size_t(j) * nodes + j + 1] = beta[j + 1];
            jacobi[std::size_t(j + 1) * nodes + j] = beta[j + 1];
        }
    }
    std::vector<double> values, first;
    jacobiEigen(jacobi, nodes, values, first);
    std::vector<std::pair<double, double>> pairs;
    for (int i = 0; i < nodes; ++i)
        pairs.emplace_back(centre + halfWidth * values[i], first[i] * first[i]);
    std::sort(pairs.begin(), pairs.end());
    BandQuadrature quad;
    double sum = 0.0;
    for (const auto& p : pairs)
        sum += p.second;
    for (const auto& p : pairs) {
        quad.lambda_nm.push_back(p.first);
        quad.weight.push_back(p.second / sum);
    }
    return quad;
}

double abMagnitude(double fnu_jy)
{
    if (!std::isfinite(fnu_jy) || fnu_jy <= 0.0)
        throw Error("AB magnitude of f_nu = " + numberText(fnu_jy) +
                    " Jy: expected a finite flux density > 0");
    return -2.5 * std::log10(fnu_jy / AB_ZERO_POINT_JY);
}

} // namespace nebula
