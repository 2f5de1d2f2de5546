// SPDX-License-Identifier: Apache-2.0
/// @file lines.cpp
/// The emission-line catalogue, line lists, and checks of the spectral input grids.

#include "nebula/physics/lines.h"

#include "nebula/core/error.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace nebula {

namespace {

struct CatalogueLine
{
    const char* name;
    double wavelength; ///< rest wavelength in air [nm]
};

/// Rest wavelengths in air [nm], rounded to 0.01 nm: NIST Atomic Spectra Database (Kramida,
/// Ralchenko, Reader & NIST ASD Team), the values Osterbrock & Ferland 2006, "Astrophysics
/// of Gaseous Nebulae and Active Galactic Nuclei" (2nd ed.) use. Forbidden lines keep their
/// conventional Angstrom labels.
constexpr CatalogueLine CATALOGUE[] = {
    {"H-alpha", 656.28},     // Balmer 3-2, 6562.80 A
    {"H-beta", 486.13},      // Balmer 4-2, 4861.33 A
    {"H-gamma", 434.05},     // Balmer 5-2, 4340.47 A
    {"H-delta", 410.17},     // Balmer 6-2, 4101.74 A
    {"[O III]5007", 500.68}, // 5006.84 A
    {"[O III]4959", 495.89}, // 4958.91 A
    {"[N II]6583", 658.35},  // 6583.45 A
    {"[N II]6548", 654.80},  // 6548.05 A
    {"[S II]6716", 671.64},  // 6716.44 A
    {"[S II]6731", 673.08},  // 6730.82 A
    {"He I 5876", 587.56},   // 5875.62 A
    {"[O I]6300", 630.03},   // 6300.30 A
    {"[O I]6363", 636.38},   // 6363.78 A
    // Absorption lines of the interstellar medium (DESIGN §7.6), resonance lines from the
    // ground state, to 0.001 nm: NIST ASD air wavelengths (Kramida et al.), as in Morton
    // 2003, ApJS 149, 205 (vacuum 5897.558, 5891.583, 3934.777, 3969.591 A).
    {"Na I D1", 589.592}, // 3s 2S1/2 - 3p 2P1/2, 5895.924 A
    {"Na I D2", 588.995}, // 3s 2S1/2 - 3p 2P3/2, 5889.950 A
    {"Ca II K", 393.366}, // 4s 2S1/2 - 4p 2P3/2, 3933.663 A
    {"Ca II H", 396.847}, // 4s 2S1/2 - 4p 2P1/2, 3968.468 A
};

/// Lower-case letters and digits only: "[O III]5007" -> "oiii5007", "H-alpha" -> "halpha".
std::string normalised(const std::string& s)
{
    std::string out;
    for (unsigned char c : s) {
        if (std::isalnum(c)) out += char(std::tolower(c));
    }
    return out;
}

std::string inQuotes(const std::string& s)
{
    return "\"" + s + "\"";
}

std::string knownList()
{
    std::string out;
    for (const auto& l : CATALOGUE)
        out += (out.empty() ? "" : ", ") + inQuotes(l.name);
    return out;
}

/// " (did you mean ...?)" for catalogue names equal to @p name up to case, spaces,
/// brackets and hyphens, or starting with it that way ("OIII"); empty if none.
std::string didYouMean(const std::string& name)
{
    const std::string n = normalised(name);
    if (n.empty()) return {};
    std::vector<std::string> hits;
    for (const auto& l : CATALOGUE) {
        if (normalised(l.name) == n) return " (did you mean " + inQuotes(l.name) + "?)";
    }
    for (const auto& l : CATALOGUE) {
        if (normalised(l.name).rfind(n, 0) == 0) hits.push_back(inQuotes(l.name));
    }
    if (hits.empty()) return {};
    std::string out = " (did you mean ";
    for (std::size_t i = 0; i < hits.size(); ++i) {
        out += (i == 0 ? "" : i + 1 == hits.size() ? " or " : ", ") + hits[i];
    }
    return out + "?)";
}

const CatalogueLine* findLine(const std::string& name)
{
    for (const auto& l : CATALOGUE) {
        if (name == l.name) return &l;
    }
    return nullptr;
}

/// The shortest decimal text that reads back to exactly @p v (std::to_chars: fixed or
/// scientific, whichever is shorter, so 1000 stays "1000").
std::string shortest(double v)
{
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, res.ptr);
}

/// @p text as a finite double, or false if it is not entirely a number.
bool parseNumber(const std::string& text, double& value)
{
    if (text.empty()) return false;
    const char c = text[0];
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+')) {
        return false;
    }
    try {
        std::size_t used = 0;
        value = std::stod(text, &used);
        return used == text.size();
    } catch (const std::out_of_range&) {
        value = HUGE_VAL; // "1e999": a number, but not a finite one
        return true;
    } catch (const std::exception&) {
        return false;
    }
}

std::string trim(const std::string& s)
{
    const auto b = s.find_first_not_of(" \t");
    if (b == std::string::npos) return {};
    const auto e = s.find_last_not_of(" \t");
    return s.substr(b, e - b + 1);
}

} // namespace

double lineWavelength(const std::string& name)
{
    if (const auto* l = findLine(name)) return l->wavelength;
    throw Error("unknown emission line " + inQuotes(name) + didYouMean(name) +
                "; known lines: " + knownList() + ", or a rest wavelength in nm such as 587.56");
}

std::vector<std::string> knownLines()
{
    std::vector<std::string> names;
    for (const auto& l : CATALOGUE)
        names.emplace_back(l.name);
    return names;
}

std::vector<SpectralLine> parseLineList(const std::string& text, const std::string& source)
{
    const std::string where = source + " " + inQuotes(text);
    if (trim(text).empty()) {
        throw Error(where + ": empty line list; expected NAME[:STRENGTH],... such as " +
                    std::string(DEFAULT_EMISSION_LINES));
    }
    std::vector<std::string> items;
    {
        std::string item;
        for (char c : text) {
            if (c == ',') {
                items.push_back(item);
                item.clear();
            } else {
                item += c;
            }
        }
        items.push_back(item);
    }

    std::vector<SpectralLine> lines;
    for (std::size_t i = 0; i < items.size(); ++i) {
        const std::string itemWhere = where + ": item " + std::to_string(i + 1);
        const std::string item = trim(items[i]);
        if (item.empty()) {
            throw Error(itemWhere + " is empty; expected NAME[:STRENGTH] between commas");
        }
        // No catalogue name holds a ':', so the last one separates the strength.
        const auto colon = item.rfind(':');
        const std::string name = trim(item.substr(0, colon));
        const std::string at = itemWhere + " (" + inQuotes(item) + ")";
        if (name.empty()) throw Error(at + ": no line name before ':'");

        SpectralLine line;
        line.strength = 1.0;
        if (colon != std::string::npos) {
            const std::string s = trim(item.substr(colon + 1));
            if (s.empty()) throw Error(at + ": no strength after ':'");
            if (!parseNumber(s, line.strength)) {
                throw Error(at + ": strength " + inQuotes(s) + " is not a number");
            }
            if (!(line.strength > 0.0) || !std::isfinite(line.strength)) {
                throw Error(at + ": strength must be a finite number > 0, got " + s);
            }
        }
        if (const auto* known = findLine(name)) {
            line.name = known->name;
            line.wavelength = known->wavelength;
        } else if (parseNumber(name, line.wavelength)) {
            if (!(line.wavelength > 0.0) || !std::isfinite(line.wavelength)) {
                throw Error(at + ": a custom wavelength must be a finite number > 0 [nm], got " +
                            name);
            }
            line.name = shortest(line.wavelength);
        } else {
            throw Error(at + ": unknown emission line " + inQuotes(name) + didYouMean(name) +
                        "; known lines: " + knownList() +
                        ", or a rest wavelength in nm such as 587.56");
        }
        for (std::size_t j = 0; j < lines.size(); ++j) {
            if (lines[j].name == line.name || lines[j].wavelength == line.wavelength) {
                throw Error(at + ": " + inQuotes(line.name) + " (" + shortest(line.wavelength) +
                            " nm) is listed twice, also as item " + std::to_string(j + 1));
            }
        }
        lines.push_back(line);
    }
    return lines;
}

std::string lineListToString(const std::vector<SpectralLine>& lines)
{
    std::string out;
    for (const auto& l : lines) {
        if (!out.empty()) out += ',';
        // A custom line is written as its wavelength, so that it reads back the same.
        out += (findLine(l.name) ? l.name : shortest(l.wavelength)) + ":" + shortest(l.strength);
    }
    return out;
}

double LineTrapezoid::integralTo(double lambda) const
{
    if (!(lambda > x[0])) return 0.0;
    const double left = x[1] - x[0], right = x[3] - x[2];
    const double whole = height * (0.5 * (left + right) + (x[2] - x[1]));
    if (lambda >= x[3]) return whole;
    if (lambda < x[1]) return 0.5 * height * (lambda - x[0]) * (lambda - x[0]) / left;
    if (lambda <= x[2]) return height * (0.5 * left + (lambda - x[1]));
    return whole - 0.5 * height * (x[3] - lambda) * (x[3] - lambda) / right;
}

double LineTrapezoid::at(double lambda) const
{
    if (!(lambda > x[0] && lambda < x[3])) return 0.0;
    if (lambda < x[1]) return height * (lambda - x[0]) / (x[1] - x[0]);
    if (lambda <= x[2]) return height;
    return height * (x[3] - lambda) / (x[3] - x[2]);
}

LineTrapezoid lineTrapezoid(double lambda0, double vA, double vB, double halfWidth, double energy)
{
    return lineTrapezoidFactors(lambda0, dopplerFactor(vA), dopplerFactor(vB), halfWidth, energy);
}

LineTrapezoid lineTrapezoidFactors(double lambda0, double dA, double dB, double halfWidth,
                                   double energy)
{
    const double cA = lambda0 * dA, cB = lambda0 * dB;
    const double lo = std::min(cA, cB), hi = std::max(cA, cB);
    const double eps = lambda0 * halfWidth / SPEED_OF_LIGHT_KMS;
    const double spread = hi - lo;
    // Convolution of a box of width `spread` (the centres) with one of width 2 eps.
    const double ramp = std::min(spread, 2.0 * eps);
    LineTrapezoid t;
    t.x[0] = lo - eps;
    t.x[1] = t.x[0] + ramp;
    t.x[3] = hi + eps;
    t.x[2] = t.x[3] - ramp;
    t.height = energy / std::max(spread, 2.0 * eps);
    return t;
}

} // namespace nebula
