#pragma once
/// @file lines.h
/// Spectral emission inputs (DESIGN §2, §7): the catalogue of nebular emission lines, the
/// `nebula:lines` metadata that says which lines an emission grid emits, and the checks the
/// spectral renderer runs on the `temperature` grid.

#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace nebula {

/// One emission line of an emission grid.
struct SpectralLine
{
    std::string name;   ///< catalogue name ("H-alpha") or a custom wavelength ("587.56")
    double wavelength;  ///< rest wavelength in air [nm]
    double strength;    ///< relative energy of the line, > 0 (the grid's value times this)

    bool operator==(const SpectralLine& o) const
    {
        return name == o.name && wavelength == o.wavelength && strength == o.strength;
    }
};

/// String metadata on an emission grid: its lines as parseLineList() reads them.
inline constexpr const char* META_LINES = "nebula:lines";

/// The lines of nebgen's `emission` grid: H-alpha and H-beta in the Case B Balmer ratio
/// H-alpha/H-beta = 2.86 (T = 10^4 K, n_e = 10^2 cm^-3; Osterbrock & Ferland 2006): 1/2.86 = 0.35.
inline constexpr const char* DEFAULT_EMISSION_LINES = "H-alpha:1,H-beta:0.35";

/// The lines of nebgen's `emission.oiii` grid: the [O III] doublet in the ratio
/// I(5007)/I(4959) = 2.98 fixed by atomic data (Storey & Zeippen 2000, MNRAS 312, 813):
/// 1/2.98 = 0.336.
inline constexpr const char* OIII_EMISSION_LINES = "[O III]5007:1,[O III]4959:0.336";

/// Rest wavelength [nm] in air of a catalogue line. Names are case-sensitive:
/// "H-alpha", "H-beta", "H-gamma", "H-delta", "[O III]5007", "[O III]4959", "[N II]6583",
/// "[N II]6548", "[S II]6716", "[S II]6731", "He I 5876". Throws Error listing the known
/// names (with a "did you mean" hint for a name that differs only in case, spaces,
/// brackets or hyphens, e.g. "Halpha" or "OIII") otherwise.
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

/// The lines of the emission grid @p grid: its `nebula:lines` metadata parsed, or
/// @p fallback if it has none. Throws Error naming @p source and the grid if the metadata
/// is not a string or does not parse.
std::vector<SpectralLine> gridLines(const openvdb::GridBase& grid, const std::string& source,
                                    const std::vector<SpectralLine>& fallback);

/// Throws Error naming @p source and the grid if any active temperature value is negative,
/// NaN or infinite.
void requireValidTemperature(const openvdb::FloatGrid& grid, const std::string& source);

} // namespace nebula
