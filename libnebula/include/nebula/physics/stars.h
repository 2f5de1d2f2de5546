// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file stars.h
/// Stars: the `nebula:stars` JSON (DESIGN §2), spectral classes, black-body colours.

#include <array>
#include <string>
#include <vector>

namespace nebula {

/// The longest star name [characters]. Every name derived from it stays unique and within its
/// format's limits: grids (tau.<name>, scatter.spectral.<name>.c4_4.780nm) and EXR channels
/// (star.<name>.R, within OpenEXR's 255).
inline constexpr std::size_t MAX_STAR_NAME_LENGTH = 64;

/// A point source. Travels as the file metadata `nebula:stars`.
struct Star
{
    std::string name;                        ///< [A-Za-z0-9_-]{1,64}, used in grid names tau.<name>
    std::array<double, 3> position{0, 0, 0}; ///< world position [pc]
    double luminosity = 1.0;                 ///< bolometric-free scale [L_sun], > 0
    double temperature = 5772.0;             ///< effective temperature [K], > 0
    /// Hydrogen-ionising photons per second Q(H0) [s^-1] ("Q"); 0: from the black body of
    /// the luminosity and temperature (physics/photoionization.h).
    double ionizingRate = 0.0;
    /// Photons per second above 35.1 eV (O+ -> O++) [s^-1] ("Q_OIII"); 0: in the black body's
    /// proportion to Q(H0).
    double oiiiRate = 0.0;
};

/// Limits parseStars() enforces on every star, so that nothing derived from a star
/// overflows: a coordinate's magnitude [pc] (distances are computed from squares), the
/// luminosity [L_sun] (radiance L / (4 pi r^2) per pixel solid angle stays within a float),
/// and the temperature [K] (Planck's law times the luminosity stays finite).
inline constexpr double MAX_STAR_COORDINATE = 1e150;
inline constexpr double MAX_STAR_LUMINOSITY = 1e30;
inline constexpr double MAX_STAR_TEMPERATURE = 1e9;

/// Parses a JSON array of {"name", "position":[x,y,z], "luminosity", "temperature"} where a
/// "class" (e.g. "B3V") may stand in for "temperature", with optional ionising photon rates
/// "Q" and "Q_OIII" [s^-1] (finite, > 0, "Q_OIII" at most "Q"; they need the temperature,
/// which sets how hard the photons are). @p source names the file (or
/// "nebula:stars metadata") in error messages. Throws Error on a parse error, a missing or
/// mistyped field, a non-positive luminosity or temperature, a value above the limits
/// above, a bad or duplicate name, or a star with both "temperature" and "class". Messages start
/// with the source and name the star (counted from 1) and the field: `stars.json: star 2 ("beta"):
/// "luminosity" must be > 0 [L_sun], got -1`. Unknown fields are ignored.
std::vector<Star> parseStars(const std::string& json, const std::string& source);

/// The JSON array parseStars() reads (always with "temperature").
std::string starsToJson(const std::vector<Star>& stars);

/// Effective temperature [K] of a main-sequence spectral class "O5" ... "M5", with an
/// optional subclass digit and the dwarf luminosity class V ("B3V", "G2 V", "A0"). Other
/// luminosity classes (IV, III, II, I, Iab, Ia, Ib) are refused with an Error that asks for
/// the temperature in kelvin: the table is the main sequence's, and a giant is cooler than
/// a dwarf of the same type. The subclass may have decimals ("B0.5"); a bare letter ("G") means
/// the middle of its class (G5). Interpolates a standard table (documented in the
/// implementation) linearly between tabulated subtypes. Throws Error on anything else.
double spectralClassTemperature(const std::string& spectralClass);

} // namespace nebula
