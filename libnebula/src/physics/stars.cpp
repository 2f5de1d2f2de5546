// SPDX-License-Identifier: Apache-2.0
/// @file stars.cpp
/// Stars (DESIGN §2-3): the `nebula:stars` JSON, spectral class -> temperature, Planck's law
/// and black-body colours in linear sRGB (through the shipped CIE 1931 table, colour.h).

#include "nebula/physics/stars.h"

#include "nebula/core/format.h"

#include "nebula/core/error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

namespace nebula {

namespace {

// ---------------------------------------------------------------------------------------------
// Spectral classes.

/// Main-sequence effective temperatures [K] from E. Mamajek, "A Modern Mean Dwarf Stellar
/// Color and Effective Temperature Sequence", version 2024.05.15 (the table behind Pecaut &
/// Mamajek 2013, ApJS 208, 9, Table 5), O5V-M5V with the half subtypes it lists. Key =
/// subtype number: 10 * class index (O=0, B=1, A=2, F=3, G=4, K=5, M=6) + subclass.
const std::map<double, double>& mainSequenceTable()
{
    static const std::map<double, double> table = {
        // O
        {5.0, 41400},
        {5.5, 40400},
        {6.0, 39800},
        {6.5, 38000},
        {7.0, 37900},
        {7.5, 36100},
        {8.0, 35100},
        {8.5, 34300},
        {9.0, 33300},
        {9.5, 31900},
        // B
        {10.0, 31400},
        {10.5, 29000},
        {11.0, 26000},
        {11.5, 24500},
        {12.0, 20600},
        {12.5, 18500},
        {13.0, 17000},
        {14.0, 16400},
        {15.0, 15700},
        {16.0, 14500},
        {17.0, 14000},
        {18.0, 12300},
        {19.0, 10700},
        {19.5, 10400},
        // A
        {20.0, 9700},
        {21.0, 9300},
        {22.0, 8840},
        {23.0, 8600},
        {24.0, 8250},
        {25.0, 8100},
        {26.0, 7910},
        {27.0, 7760},
        {28.0, 7590},
        {29.0, 7400},
        // F
        {30.0, 7220},
        {31.0, 7020},
        {32.0, 6820},
        {33.0, 6750},
        {34.0, 6670},
        {35.0, 6550},
        {36.0, 6350},
        {37.0, 6280},
        {38.0, 6180},
        {39.0, 6050},
        {39.5, 5990},
        // G
        {40.0, 5930},
        {41.0, 5860},
        {42.0, 5770},
        {43.0, 5720},
        {44.0, 5680},
        {45.0, 5660},
        {46.0, 5600},
        {47.0, 5550},
        {48.0, 5480},
        {49.0, 5380},
        // K
        {50.0, 5290},
        {51.0, 5170},
        {52.0, 5100},
        {53.0, 4870},
        {54.0, 4600},
        {55.0, 4440},
        {56.0, 4300},
        {57.0, 4090},
        {58.0, 3990},
        {59.0, 3930},
        // M
        {60.0, 3850},
        {60.5, 3770},
        {61.0, 3660},
        {61.5, 3620},
        {62.0, 3560},
        {62.5, 3470},
        {63.0, 3430},
        {63.5, 3270},
        {64.0, 3210},
        {64.5, 3110},
        {65.0, 3060},
    };
    return table;
}

constexpr const char* SPECTRAL_CLASS_LETTERS = "OBAFGKM";

/// Error for a spectral class that does not parse, naming what is accepted.
Error badSpectralClass(const std::string& spectralClass, const std::string& why)
{
    return Error("spectral class \"" + spectralClass + "\": " + why +
                 "; expected a main-sequence class O5-M5 such as \"B3V\" or \"G2\": a letter "
                 "OBAFGKM, a subclass 0-9 (decimals like \"B0.5\" allowed), and optionally the "
                 "dwarf luminosity class V");
}

// ---------------------------------------------------------------------------------------------
// JSON helpers.

using detail::numberText;

/// A JSON value as it appears in the file, shortened for an error message.
std::string shown(const nlohmann::json& value)
{
    if (value.is_number()) {
        return numberText(value.get<double>());
    }
    std::string text = value.dump();
    if (text.size() > 40) {
        text = text.substr(0, 37) + "...";
    }
    return text;
}

/// True for a non-empty name of at most MAX_STAR_NAME_LENGTH characters of [A-Za-z0-9_-]
/// only (grid names tau.<name> and EXR channels star.<name>.R rely on it).
bool isValidStarName(const std::string& name)
{
    return !name.empty() && name.size() <= MAX_STAR_NAME_LENGTH &&
           std::all_of(name.begin(), name.end(), [](char c) {
               return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                      c == '_' || c == '-';
           });
}

} // namespace

// -------------------------------------------------------------------------------------------------

double spectralClassTemperature(const std::string& spectralClass)
{
    // Letter: the class.
    const std::string letters = SPECTRAL_CLASS_LETTERS;
    if (spectralClass.empty()) {
        throw badSpectralClass(spectralClass, "empty");
    }
    const auto classIndex = letters.find(spectralClass[0]);
    if (classIndex == std::string::npos) {
        throw badSpectralClass(spectralClass, "unknown class letter");
    }

    // Optional subclass: one digit, optionally with decimals. A bare letter means the
    // middle of its class (X5).
    std::size_t pos = 1;
    double subclass = 5.0;
    const auto isDigitAt = [&](std::size_t i) {
        return i < spectralClass.size() &&
               std::isdigit(static_cast<unsigned char>(spectralClass[i])) != 0;
    };
    if (isDigitAt(pos)) {
        subclass = spectralClass[pos] - '0';
        ++pos;
        if (pos < spectralClass.size() && spectralClass[pos] == '.') {
            ++pos;
            double scale = 0.1;
            const std::size_t decimalsStart = pos;
            while (isDigitAt(pos)) {
                subclass += scale * (spectralClass[pos] - '0');
                scale *= 0.1;
                ++pos;
            }
            if (pos == decimalsStart) {
                throw badSpectralClass(spectralClass, "no digit after the decimal point");
            }
        }
    }

    // Optional luminosity class (one space allowed before it). The table is the main
    // sequence's, so only dwarfs (V, or no class) are accepted: a giant or supergiant of the
    // same spectral type is several hundred to a few thousand kelvin cooler, and giving it a
    // dwarf's temperature would be silently wrong.
    std::string rest = spectralClass.substr(pos);
    if (!rest.empty() && rest[0] == ' ') {
        rest.erase(0, 1);
        if (rest.empty()) {
            throw badSpectralClass(spectralClass, "trailing space");
        }
    }
    static const char* const OTHER_LUMINOSITY_CLASSES[] = {"IV",  "III", "II", "I",
                                                           "Iab", "Ia",  "Ib"};
    if (std::find(std::begin(OTHER_LUMINOSITY_CLASSES), std::end(OTHER_LUMINOSITY_CLASSES), rest) !=
        std::end(OTHER_LUMINOSITY_CLASSES)) {
        const std::string kind = rest == "IV"    ? "subgiant"
                                 : rest == "III" ? "giant"
                                 : rest == "II"  ? "bright giant"
                                                 : "supergiant";
        throw badSpectralClass(spectralClass,
                               "luminosity class " + rest + " (" + kind +
                                   ") is not supported: the temperature table is the main "
                                   "sequence's (class V); give the star's temperature in kelvin "
                                   "instead");
    }
    if (!rest.empty() && rest != "V") {
        throw badSpectralClass(spectralClass, "unexpected \"" + rest + "\" after the subclass");
    }

    // Linear interpolation in subtype number between the tabulated subtypes.
    const double subtype = 10.0 * static_cast<double>(classIndex) + subclass;
    const auto& table = mainSequenceTable();
    if (subtype < table.begin()->first || subtype > table.rbegin()->first) {
        throw badSpectralClass(spectralClass, "outside the table");
    }
    auto hi = table.lower_bound(subtype);
    if (hi->first == subtype) {
        return hi->second;
    }
    auto lo = std::prev(hi);
    const double t = (subtype - lo->first) / (hi->first - lo->first);
    return lo->second + t * (hi->second - lo->second);
}

namespace {

/// An optional photon rate [s^-1]: finite and > 0 (at most 1e60), or 0 when absent.
double photonRate(const nlohmann::json& item, const char* field, const std::string& where)
{
    const auto it = item.find(field);
    if (it == item.end()) return 0.0;
    if (!it->is_number() || !(it->get<double>() > 0.0) || !(it->get<double>() <= 1e60)) {
        throw Error(where + ": \"" + field + "\" must be a number of photons per second, > 0 " +
                    "and at most 1e60 [s^-1], got " + shown(*it));
    }
    return it->get<double>();
}

} // namespace

std::vector<Star> parseStars(const std::string& json, const std::string& source)
{
    const nlohmann::json root = detail::parseJson(json, source);
    if (!root.is_array()) {
        throw Error(source + ": expected a JSON array of stars, got " + shown(root));
    }

    std::vector<Star> stars;
    std::map<std::string, std::size_t> firstIndexOfName;
    for (std::size_t i = 0; i < root.size(); ++i) {
        const nlohmann::json& item = root[i];
        // Stars are counted from 1 in messages: `star 2 ("beta")` is the second element.
        std::string where = source + ": star " + std::to_string(i + 1);
        if (!item.is_object()) {
            throw Error(where +
                        ": expected an object {\"name\", \"position\", \"luminosity\", "
                        "\"temperature\" or \"class\"}, got " +
                        shown(item));
        }
        const auto missing = [&](const char* field) {
            return Error(where + ": missing \"" + field + "\"");
        };
        Star star;

        // name: [A-Za-z0-9_-]+, unique.
        const auto name = item.find("name");
        if (name == item.end()) {
            throw missing("name");
        }
        if (!name->is_string() || !isValidStarName(name->get<std::string>())) {
            throw Error(
                where + ": \"name\" must be a string of 1 to " +
                std::to_string(MAX_STAR_NAME_LENGTH) + " letters, digits, '_' and '-', got " +
                shown(*name) +
                (name->is_string()
                     ? " (" + std::to_string(name->get<std::string>().size()) + " characters)"
                     : std::string()));
        }
        star.name = name->get<std::string>();
        where += " (\"" + star.name + "\")";
        const auto [previous, inserted] = firstIndexOfName.emplace(star.name, i);
        if (!inserted) {
            throw Error(where + ": \"name\" must be unique, but star " +
                        std::to_string(previous->second + 1) + " has the same name");
        }

        // position: three finite numbers [pc].
        const auto position = item.find("position");
        if (position == item.end()) {
            throw missing("position");
        }
        const bool positionOk = position->is_array() && position->size() == 3 &&
                                std::all_of(position->begin(), position->end(), [](const auto& v) {
                                    return v.is_number() && std::isfinite(v.template get<double>());
                                });
        if (!positionOk) {
            throw Error(where + ": \"position\" must be an array of 3 finite numbers [pc], got " +
                        shown(*position));
        }
        for (const auto& v : *position) {
            if (std::fabs(v.get<double>()) > MAX_STAR_COORDINATE) {
                throw Error(where + ": \"position\" " + shown(*position) +
                            ": each coordinate must be at most " + numberText(MAX_STAR_COORDINATE) +
                            " pc in magnitude (distances are computed from squares, which "
                            "would overflow)");
            }
        }
        for (int k = 0; k < 3; ++k) {
            star.position[k] = (*position)[k].get<double>();
        }

        // luminosity: finite, > 0 [L_sun].
        const auto luminosity = item.find("luminosity");
        if (luminosity == item.end()) {
            throw missing("luminosity");
        }
        if (!luminosity->is_number() || !(luminosity->get<double>() > 0.0) ||
            !std::isfinite(luminosity->get<double>())) {
            throw Error(where + ": \"luminosity\" must be > 0 [L_sun], got " + shown(*luminosity));
        }
        if (luminosity->get<double>() > MAX_STAR_LUMINOSITY) {
            throw Error(where + ": \"luminosity\" " + shown(*luminosity) +
                        " is above the limit of " + numberText(MAX_STAR_LUMINOSITY) +
                        " L_sun (larger values overflow the rendered radiance)");
        }
        star.luminosity = luminosity->get<double>();

        // temperature [K], or a spectral class standing in for it; not both.
        const auto temperature = item.find("temperature");
        const auto spectralClass = item.find("class");
        if (temperature != item.end() && spectralClass != item.end()) {
            throw Error(where + ": give either \"temperature\" or \"class\", not both");
        }
        if (temperature != item.end()) {
            if (!temperature->is_number() || !(temperature->get<double>() > 0.0) ||
                !std::isfinite(temperature->get<double>())) {
                throw Error(where + ": \"temperature\" must be > 0 [K], got " +
                            shown(*temperature));
            }
            if (temperature->get<double>() > MAX_STAR_TEMPERATURE) {
                throw Error(where + ": \"temperature\" " + shown(*temperature) +
                            " is above the limit of " + numberText(MAX_STAR_TEMPERATURE) +
                            " K (the hottest stars are about 2e5 K)");
            }
            star.temperature = temperature->get<double>();
        } else if (spectralClass != item.end()) {
            if (!spectralClass->is_string()) {
                throw Error(where +
                            ": \"class\" must be a spectral class string such as "
                            "\"B3V\", got " +
                            shown(*spectralClass));
            }
            try {
                star.temperature = spectralClassTemperature(spectralClass->get<std::string>());
            } catch (const Error& e) {
                throw Error(where + ": \"class\": " + e.what());
            }
        } else if (item.contains("Q") || item.contains("Q_OIII")) {
            throw Error(where + ": \"Q\" needs the star's \"temperature\" (or a spectral "
                                "\"class\"): it sets how many of the ionising photons are hard "
                                "enough for He and O++");
        } else {
            throw Error(where + ": missing \"temperature\" (or a spectral \"class\")");
        }
        star.ionizingRate = photonRate(item, "Q", where);
        star.oiiiRate = photonRate(item, "Q_OIII", where);
        if (star.oiiiRate > 0 && star.ionizingRate > 0 && star.oiiiRate > star.ionizingRate) {
            throw Error(where + ": \"Q_OIII\" " + numberText(star.oiiiRate) +
                        " must be at most \"Q\" " + numberText(star.ionizingRate) +
                        " (photons above 35.1 eV are also above 13.6 eV)");
        }

        stars.push_back(std::move(star));
    }
    return stars;
}

std::string starsToJson(const std::vector<Star>& stars)
{
    // nlohmann::json writes doubles with the fewest digits that read back exactly.
    nlohmann::json root = nlohmann::json::array();
    for (const Star& star : stars) {
        nlohmann::json item = {{"name", star.name},
                               {"position", {star.position[0], star.position[1], star.position[2]}},
                               {"luminosity", star.luminosity},
                               {"temperature", star.temperature}};
        if (star.ionizingRate > 0) item["Q"] = star.ionizingRate;
        if (star.oiiiRate > 0) item["Q_OIII"] = star.oiiiRate;
        root.push_back(std::move(item));
    }
    return root.dump();
}

} // namespace nebula
