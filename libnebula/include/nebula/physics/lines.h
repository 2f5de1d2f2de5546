// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file lines.h
/// Spectral lines (DESIGN §2, §7): the catalogue of nebular emission lines, line lists
/// ("NAME:STRENGTH,...", the text of an emission grid's `nebula:lines`), Doppler factors and
/// the exact Doppler-broadened line profile of a ray segment. Reading the lines from a grid's
/// metadata is io/spectral_grids.h.

#include "nebula/core/units.h"

#include <cmath>
#include <string>
#include <vector>

namespace nebula {

/// One emission line of an emission grid.
struct SpectralLine
{
    std::string name;  ///< catalogue name ("H-alpha") or a custom wavelength ("587.56")
    double wavelength; ///< rest wavelength in air [nm]
    double strength;   ///< relative energy of the line, > 0 (the grid's value times this)

    bool operator==(const SpectralLine& o) const
    {
        return name == o.name && wavelength == o.wavelength && strength == o.strength;
    }
};

/// The lines of nebgen's `emission` grid: H-alpha and H-beta in the Case B Balmer ratio
/// H-alpha/H-beta = 2.86 (T = 10^4 K, n_e = 10^2 cm^-3; Osterbrock & Ferland 2006): 1/2.86 = 0.35.
inline constexpr const char* DEFAULT_EMISSION_LINES = "H-alpha:1,H-beta:0.35";

/// The lines of nebgen's `emission.oiii` grid: the [O III] doublet in the ratio
/// I(5007)/I(4959) = 2.98 fixed by atomic data (Storey & Zeippen 2000, MNRAS 312, 813):
/// 1/2.98 = 0.336.
inline constexpr const char* OIII_EMISSION_LINES = "[O III]5007:1,[O III]4959:0.336";

/// Rest wavelength [nm] in air of a catalogue line. Names are case-sensitive:
/// "H-alpha", "H-beta", "H-gamma", "H-delta", "[O III]5007", "[O III]4959", "[N II]6583",
/// "[N II]6548", "[S II]6716", "[S II]6731", "He I 5876", "[O I]6300", "[O I]6363", and the
/// interstellar absorption lines "Na I D1", "Na I D2", "Ca II K", "Ca II H" (DESIGN §7.6).
/// Throws Error listing the known names (with a "did you mean" hint for a name that differs
/// only in case, spaces, brackets or hyphens, e.g. "Halpha" or "OIII") otherwise.
double lineWavelength(const std::string& name);

/// All catalogue names, in the catalogue's order (for --help and messages).
std::vector<std::string> knownLines();

/// Parses a line list "H-alpha:1,H-beta:0.35": comma-separated items NAME[:STRENGTH], the
/// strength 1 if omitted, spaces around names and strengths ignored. NAME is a catalogue
/// name or a custom rest wavelength in nm ("587.56:0.1"; the line's name is then the
/// wavelength as lineListToString() writes it). Throws Error starting with @p source
/// (e.g. "--lines") and naming the item on: an empty list or item, an unknown name, a
/// wavelength or strength that is not a finite number > 0, and a line listed twice (same
/// name or same wavelength).
std::vector<SpectralLine> parseLineList(const std::string& text, const std::string& source);

/// "NAME:STRENGTH,..." with the shortest decimals that read back to the same doubles, so
/// that parseLineList(lineListToString(l)) == l.
std::string lineListToString(const std::vector<SpectralLine>& lines);

/// Observed over emitted wavelength for radial velocity @p vr [km/s], v_r > 0 receding
/// (DESIGN §7, first order in v/c): lambda' / lambda = 1 + v_r / c.
inline double dopplerFactor(double vr)
{
    return 1.0 + vr / SPEED_OF_LIGHT_KMS;
}

/// The relativistic Doppler factor (DESIGN §7's option) for radial velocity @p vr [km/s]
/// and squared speed @p v2 [km^2/s^2]: lambda' / lambda = gamma (1 + v_r / c), gamma =
/// 1 / sqrt(1 - v^2/c^2): gas moving across the line of sight is red-shifted by gamma.
inline double relativisticDopplerFactor(double vr, double v2)
{
    const double c = SPEED_OF_LIGHT_KMS;
    return (1.0 + vr / c) / std::sqrt(1.0 - v2 / (c * c));
}

/// The observed profile of one spectral line emitted along one ray segment: a trapezoid
/// through (x[0], 0), (x[1], height), (x[2], height), (x[3], 0) [nm].
struct LineTrapezoid
{
    double x[4];
    double height; ///< [energy / nm]

    /// Value at @p lambda [nm] (0 outside [x[0], x[3]]).
    double at(double lambda) const;
    /// Integral from x[0] to @p lambda [energy]: 0 below x[0], the whole area above x[3].
    /// The integral over [a, b] is integralTo(b) - integralTo(a), exact for any a, b.
    double integralTo(double lambda) const;
};

/// The profile of a line of rest wavelength @p lambda0 [nm] and energy @p energy emitted
/// along a segment over which the emitter's density is constant and its radial velocity
/// varies linearly from @p vA to @p vB [km/s] (DESIGN §7). Every point of the segment emits
/// a box of half-width lambda0 * halfWidth / c (the rest-frame thermal and turbulent width,
/// @p halfWidth [km/s] > 0) centred on lambda0 (1 + v / c); the segment's points spread the
/// centres uniformly over [lambda0 (1 + vA/c), lambda0 (1 + vB/c)]. The sum is the
/// convolution of two boxes: a trapezoid whose ramps are as wide as the narrower box (a box
/// when vA == vB). Its integral is @p energy and its centroid lambda0 (1 + (vA + vB) / 2c),
/// both exactly (to rounding): Doppler broadening moves energy, never makes or loses it.
/// Works for either order of vA and vB.
LineTrapezoid lineTrapezoid(double lambda0, double vA, double vB, double halfWidth, double energy);

/// The same with the Doppler factors lambda'/lambda at the segment's ends given, @p dA and
/// @p dB > 0 (e.g. relativisticDopplerFactor()).
LineTrapezoid lineTrapezoidFactors(double lambda0, double dA, double dB, double halfWidth,
                                   double energy);

} // namespace nebula
