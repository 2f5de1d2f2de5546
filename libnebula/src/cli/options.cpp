// SPDX-License-Identifier: Apache-2.0
#include "nebula/cli/options.h"
#include "nebula/core/format.h"
#include "nebula/core/input.h"

#include "nebula/cli/cli.h"

#include "nebula/core/error.h"

#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace nebula {

DustParams DustOptions::apply(DustParams d) const
{
    if (kappa_V) d.kappa_V = *kappa_V;
    if (albedo) d.albedo = *albedo;
    if (g) d.g = *g;
    if (R_V) d.R_V = *R_V;
    if (phase) d.phase = phaseModelFromString(*phase);
    if (curve) d.curve = *curve;
    d.validate();
    return d;
}

namespace cli {

namespace {

/// @p text split at every @p sep, empty fields (also a trailing one) kept.
std::vector<std::string> split(const std::string& text, char sep)
{
    std::vector<std::string> parts(1);
    for (char c : text) {
        if (c == sep) {
            parts.emplace_back();
        } else {
            parts.back() += c;
        }
    }
    return parts;
}

/// The whole of @p text as a finite double; UsageError @p expected otherwise.
double finiteNumber(const std::string& text, const std::string& expected)
{
    try {
        std::size_t used = 0;
        const double v = std::stod(text, &used);
        if (used == text.size() && std::isfinite(v)) return v;
    } catch (const std::exception&) { // invalid_argument, or out_of_range ("1e999")
    }
    throw UsageError(expected);
}

} // namespace

void addStars(CLI::App& app, StarOptions& opts)
{
    app.add_option("--star", opts.star,
                   "A star NAME:X,Y,Z:LUMINOSITY:CLASS, position in pc, luminosity in L_sun, "
                   "a spectral class (B3V) or a temperature in K (repeatable)");
    inputFile(app.add_option("--stars", opts.starsFile,
                             "JSON file: [{\"name\", \"position\":[x,y,z], \"luminosity\", "
                             "\"temperature\" or \"class\"}]")
                  ->check(CLI::ExistingFile));
}

Star parseStarOption(const std::string& text)
{
    const std::string expected =
        "--star \"" + detail::printable(text, 80) +
        "\": expected NAME:X,Y,Z:LUMINOSITY:CLASS (e.g. alpha:0,0,0:1000:B2V)";
    const std::vector<std::string> parts = split(text, ':');
    if (parts.size() != 4) throw UsageError(expected);
    // Build the JSON form so that every check lives in parseStars().
    nlohmann::json j;
    j["name"] = parts[0];
    std::vector<double> pos;
    const std::string badPosition =
        expected + ": \"position\" must be three finite numbers X,Y,Z [pc]";
    for (const auto& c : split(parts[1], ','))
        pos.push_back(finiteNumber(c, badPosition));
    if (pos.size() != 3) throw UsageError(badPosition);
    j["position"] = pos;
    j["luminosity"] =
        finiteNumber(parts[2], expected + ": \"luminosity\" must be a finite number [L_sun]");
    // A number is a temperature [K]; anything else a spectral class.
    const auto& last = parts[3];
    const bool numeric =
        !last.empty() && last.find_first_not_of("0123456789.eE+-") == std::string::npos;
    if (numeric) {
        j["temperature"] =
            finiteNumber(last, expected + ": the temperature [K] must be a finite number");
    } else {
        j["class"] = last;
    }
    try {
        return parseStars(nlohmann::json::array({j}).dump(), "--star").front();
    } catch (const Error& e) {
        throw UsageError(e.what());
    }
}

std::vector<Star> loadStars(const StarOptions& opts)
{
    std::vector<Star> stars;
    if (!opts.starsFile.empty()) {
        InputSpec spec;
        spec.option = "--stars";
        spec.format = "a JSON file";
        spec.head = jsonHead("[", "a JSON array of stars");
        stars = parseStars(readInput(opts.starsFile, spec), inputName(opts.starsFile));
        if (stars.empty()) {
            throw Error(opts.starsFile + " (--stars) holds no stars: an empty list; give at " +
                        "least one star, or leave out --stars");
        }
    }
    for (const auto& s : opts.star) {
        stars.push_back(parseStarOption(s));
        for (std::size_t i = 0; i + 1 < stars.size(); ++i) {
            if (stars[i].name == stars.back().name) {
                throw UsageError("--star: duplicate star name \"" + stars.back().name + "\"");
            }
        }
    }
    return stars;
}

void addEmissionAndStars(CLI::App& app, RenderOptions& opts, bool& noStars)
{
    app.add_option("--emission-grid", opts.emissionGrid,
                   "Gas emission grid; RGB mode adds every other grid with nebula:lines, each\n"
                   "in its lines' colour")
        ->capture_default_str();
    app.add_option("--emission-scale", opts.emissionScale,
                   "Emission multiplier [L_sun pc^-3 sr^-1 per grid unit]")
        ->capture_default_str()
        ->check(nonNegative());
    // Given, it paints the emission grid in it as before line colours (DESIGN §3.4).
    addVec3(app, "--emission-color", opts.emissionColor,
            "Colour of an emission grid without nebula:lines, linear sRGB R,G,B (H-alpha\n"
            "with some H-beta); its luminance sets a line grid's brightness. Given, it paints\n"
            "the emission grid in it and leaves out the other line grids (true line colours\n"
            "otherwise)")
        ->each([&opts](const std::string&) { opts.lineColours = false; });
    app.add_flag("--no-stars", noStars, "Do not draw the stars themselves");
    app.add_option("--sprite-radius", opts.spriteRadius,
                   "Star sprite radius [pixels], as far as its footprint fits in memory")
        ->capture_default_str()
        ->check(positive());
    app.add_option("--min-star-distance", opts.minStarDistance,
                   "Distance below which 1/r^2 is clamped in multiple scattering (nebscatter's "
                   "field, the path tracer's later bounces); single scattering integrates it "
                   "exactly [voxels]")
        ->capture_default_str()
        ->check(positive());
}

void addTone(CLI::App& app, ToneParams& tone, ToneOptions& opts, const std::string& prefix)
{
    opts.exposureOption = app.add_option("--exposure", opts.exposure,
                                         prefix + "fixed exposure in stops (white = 2^-E); turns "
                                                  "off the automatic tone curve")
                              ->check(numberIn(-1000.0, 1000.0));
    opts.gammaOption = app.add_option("--gamma", tone.gamma,
                                      prefix + "gamma with --exposure; alone, a fixed gamma with "
                                               "the automatic white point (default: fitted to "
                                               "the frame)")
                           ->capture_default_str()
                           ->check(positive());
    app.add_option("--percentile", tone.percentile,
                   prefix + "automatic white point = this luminance percentile")
        ->capture_default_str()
        ->check(numberIn(1.0, 100.0));
    app.add_flag("--tone-stars", tone.stars,
                 prefix + "let the pixels that are mostly a star's sprite count in the\n"
                          "automatic white point (default: the nebula sets it)");
}

} // namespace cli

void ToneOptions::apply(ToneParams& tone) const
{
    if (exposureOption && exposureOption->count() > 0) {
        tone.automatic = false;
        tone.exposure = exposure;
    } else if (gammaOption && gammaOption->count() > 0) {
        tone.fixedGamma = true;
    }
}

namespace cli {

void addFilter(CLI::App& app, FilterOptions& opts, const std::string& what)
{
    std::string names;
    for (const auto& n : standardFilterNames())
        names += (names.empty() ? "" : " ") + n;
    auto* name =
        app.add_option("--filter", opts.name, "A standard passband (" + what + "): " + names);
    inputFile(app.add_option("--filter-file", opts.file,
                             "A passband of your own: lines of wavelength and photon-counting "
                             "response\n(see the README), strictly increasing in wavelength")
                  ->excludes(name));
    app.add_option("--filter-unit", opts.unit,
                   "--filter-file's wavelength unit when the file names none: nm, Angstrom, um")
        ->check(CLI::IsMember({"nm", "Angstrom", "A", "um", "micron"}))
        ->capture_default_str();
}

std::optional<Filter> loadFilter(const FilterOptions& opts)
{
    if (!opts.name.empty()) return standardFilter(opts.name);
    if (opts.file.empty()) return std::nullopt;
    InputSpec spec;
    spec.option = "--filter-file";
    spec.format = "a filter file";
    spec.limit = MAX_FILTER_BYTES;
    const FilterWavelengthUnit unit = opts.unit == "nm" ? FilterWavelengthUnit::Nanometre
                                      : opts.unit == "um" || opts.unit == "micron"
                                          ? FilterWavelengthUnit::Micrometre
                                          : FilterWavelengthUnit::Angstrom;
    return parseFilterFile(readInput(opts.file, spec), inputName(opts.file) + " (--filter-file)",
                           unit);
}

std::array<double, 3> filterWavelengths(const Filter& filter, bool wavelengthsGiven)
{
    if (wavelengthsGiven) {
        throw UsageError("--filter and --filter-file set the channels' wavelengths (the band's "
                         "quadrature nodes): leave out --wavelengths");
    }
    const BandQuadrature q = bandQuadrature(filter, 3);
    if (q.lambda_nm.size() != 3) {
        throw UsageError("the filter " + filter.name +
                         " has too few distinct wavelengths for a "
                         "three-node quadrature");
    }
    return {q.lambda_nm[0], q.lambda_nm[1], q.lambda_nm[2]};
}

void addDust(CLI::App& app, DustOptions& opts, bool withKappa)
{
    const DustParams d;
    auto* grp = app.add_option_group(
        "Dust", "Dust model, carried as nebula:dust (nebillum, nebrender: default the input's)");
    if (withKappa) {
        grp->add_option("--kappa-v", opts.kappa_V, "V-band extinction per n_H per pc [pc^-1 cm^3]")
            ->check(numberIn(0.0, MAX_KAPPA_V, true))
            ->default_str(fmt::format("{}", d.kappa_V));
    }
    grp->add_option("--albedo", opts.albedo, "Single-scattering albedo")
        ->check(numberIn(0.0, 1.0))
        ->default_str(fmt::format("{}", d.albedo));
    grp->add_option("--g", opts.g, "Henyey-Greenstein asymmetry")
        ->check(numberIn(-1.0, 1.0, true, true))
        ->default_str(fmt::format("{}", d.g));
    grp->add_option("--phase-function", opts.phase, "Phase function")
        ->check(CLI::IsMember({"hg", "rayleigh", "hazy", "murky"}))
        ->default_str(toString(d.phase));
    grp->add_option("--rv", opts.R_V, "Extinction curve R_V = A_V/E(B-V)")
        ->check(numberIn(MIN_R_V, MAX_R_V))
        ->default_str(fmt::format("{}", d.R_V));
    grp->add_option("--extinction-curve", opts.curve,
                    "Extinction curve: CCM89 (Cardelli, Clayton & Mathis 1989) or grey (the same "
                    "at every wavelength)")
        ->check(CLI::IsMember({"CCM89", "grey"}))
        ->default_str(d.curve);
}

} // namespace cli
} // namespace nebula
