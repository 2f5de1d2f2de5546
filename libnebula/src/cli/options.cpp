#include "nebula/cli/options.h"

#include "nebula/core/error.h"

#include <cmath>
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

void addStars(CLI::App& app, StarOptions& opts)
{
    app.add_option("--star", opts.star,
                   "A star NAME:X,Y,Z:LUMINOSITY:CLASS, position in pc, luminosity in L_sun, "
                   "a spectral class (B3V) or a temperature in K (repeatable)");
    app.add_option("--stars", opts.starsFile,
                   "JSON file: [{\"name\", \"position\":[x,y,z], \"luminosity\", "
                   "\"temperature\" or \"class\"}]")
        ->check(CLI::ExistingFile);
}

Star parseStarOption(const std::string& text)
{
    const std::string expected =
        "--star \"" + text + "\": expected NAME:X,Y,Z:LUMINOSITY:CLASS (e.g. alpha:0,0,0:1000:B2V)";
    std::vector<std::string> parts;
    std::istringstream in(text);
    for (std::string item; std::getline(in, item, ':');) parts.push_back(item);
    if (parts.size() != 4) throw UsageError(expected);
    // Build the JSON form so that every check lives in parseStars().
    nlohmann::json j;
    j["name"] = parts[0];
    std::vector<double> pos;
    {
        std::istringstream p(parts[1]);
        for (std::string c; std::getline(p, c, ',');) {
            try {
                std::size_t used = 0;
                pos.push_back(std::stod(c, &used));
                if (used != c.size()) throw UsageError(expected);
            } catch (const std::exception&) {
                throw UsageError(expected);
            }
        }
    }
    if (pos.size() != 3) throw UsageError(expected);
    j["position"] = pos;
    try {
        std::size_t used = 0;
        j["luminosity"] = std::stod(parts[2], &used);
        if (used != parts[2].size()) throw UsageError(expected);
    } catch (const std::exception&) {
        throw UsageError(expected);
    }
    try {
        std::size_t used = 0;
        const double T = std::stod(parts[3], &used);
        if (used != parts[3].size()) throw std::invalid_argument(parts[3]);
        j["temperature"] = T;
    } catch (const std::invalid_argument&) {
        j["class"] = parts[3];
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
        std::ifstream in(opts.starsFile);
        if (!in) throw Error(opts.starsFile + ": cannot open file");
        std::stringstream text;
        text << in.rdbuf();
        stars = parseStars(text.str(), opts.starsFile);
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

void addDust(CLI::App& app, DustOptions& opts, bool withKappa)
{
    const DustParams d;
    auto* grp = app.add_option_group(
        "Dust", "Dust model, carried as nebula:dust (nebillum, nebrender: default the input's)");
    if (withKappa) {
        grp->add_option("--kappa-v", opts.kappa_V,
                        "V-band extinction per n_H per pc [pc^-1 cm^3] (default " +
                            std::to_string(d.kappa_V) + ")");
    }
    grp->add_option("--albedo", opts.albedo, "Single-scattering albedo in [0,1] (default 0.6)");
    grp->add_option("--g", opts.g, "Henyey-Greenstein asymmetry in (-1,1) (default 0.6)");
    grp->add_option("--phase-function", opts.phase, "Phase function: hg, rayleigh, hazy, murky (default hg)");
    grp->add_option("--rv", opts.R_V, "Extinction curve R_V = A_V/E(B-V) (default 3.1)");
    grp->add_option("--extinction-curve", opts.curve,
                    "Extinction curve: CCM89 (default) or grey (the same at every wavelength)");
}

} // namespace cli
} // namespace nebula
