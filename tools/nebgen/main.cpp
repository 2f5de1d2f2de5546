// SPDX-License-Identifier: Apache-2.0
// nebgen - procedural reflection nebula: fBm dust density, gas emission, stars, and with
// --spectral temperature, velocity and [O III] emission.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/core/error.h"
#include "nebula/stages/generate.h"
#include "nebula/stages/presets.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

/// The catalogue's names with their wavelengths, wrapped for --help.
std::string knownLinesHelp()
{
    std::string out, row = " ";
    for (const auto& name : nebula::knownLines()) {
        char wl[32];
        std::snprintf(wl, sizeof wl, " %.2f", nebula::lineWavelength(name));
        const std::string item = " " + name + wl + ",";
        if (row.size() + item.size() > 80) {
            out += row + "\n";
            row = " ";
        }
        row += item;
    }
    row.back() = '\n';
    return out + row;
}

/// The presets, a line each, for --help.
std::string presetsHelp()
{
    std::string out;
    for (const auto& p : nebula::nebulaPresets()) {
        std::string name = p.name;
        name.resize(12, ' ');
        out += "  " + name + p.summary + "\n";
    }
    return out;
}

/// The value of --preset on the command line, if any (read before the options are defined, so
/// that the preset's values are their defaults and every option overrides them).
std::string presetArgument(int argc, char** argv)
{
    std::string name;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--") == 0) break;
        if (std::strcmp(argv[i], "--preset") == 0 && i + 1 < argc) {
            name = argv[i + 1];
        } else if (std::strncmp(argv[i], "--preset=", 9) == 0) {
            name = argv[i] + 9;
        }
    }
    return name;
}

} // namespace

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    // Every default lives in NebulaParams, or in the preset's parameters (presets.cpp).
    const std::string presetArg = presetArgument(argc, argv);
    nebula::NebulaParams params;
    for (const auto& p : nebula::nebulaPresets()) {
        if (presetArg == p.name) params = nebula::presetParams(p.id);
    }
    std::string presetName = nebula::presetName(params.preset);
    nebula::StarOptions starOpts;
    nebula::DustOptions dustOpts;
    bool noStars = false;
    std::string lines = nebula::lineListToString(params.lines);
    std::string shape = "sphere";
    std::string centre;

    const std::string description =
        std::string(
            "nebgen - generate a procedural nebula (dust density, gas emission, stars)\n\n"
            "Examples:\n"
            "  nebgen --preset reflection -o nebula.vdb     # the README's example nebula\n"
            "  nebgen --preset pillars --res 256 --mach 8 -o m16.vdb\n"
            "  nebgen --res 256 --seed 7 --cavity 0.5 -o big.vdb\n"
            "  nebgen --star a:0,0,0:5000:O9V --star b:2,1,0:30:A0V -o two.vdb\n"
            "  nebgen -o - | nebillum -i - -o - | nebrender -i - -o frame.exr\n"
            "  nebgen --spectral --expansion 40 --emission-shape shell -o shell.vdb\n"
            "  nebgen --spectral --rotation 20 --rotation-axis 0,0,1 --turbulence 5 \\\n"
            "         --oiii 0.5 --gas-temperature 8000 \\\n"
            "         --lines 'H-alpha,H-beta:0.35,[N II]6583:0.3' -o spec.vdb\n\n"
            "Presets (--preset; its values are the defaults --help shows, options override\n"
            "them; all but fbm are lognormal turbulence, s = ln(n / n0) Gaussian with\n"
            "sigma_s^2 = ln(1 + b^2 M^2), power spectrum ~ k^-index, in a geometry):\n") +
        presetsHelp() +
        "Grids: density (n_H [cm^-3], fog volume), emission (linear units; its lines\n"
        "in the grid metadata nebula:lines).\n"
        "With --spectral also:\n"
        "  temperature [K]: dust in radiative equilibrium with the unattenuated stars,\n"
        "    T = 16.4 K (1 + U)^(1/6), U = sum_s L_s / (4 pi r_s^2 c u_ISRF),\n"
        "    u_ISRF = 8.64e-13 erg cm^-3, r_s >= half a voxel (Draine 2011,\n"
        "    eqs. 24.19-24.20, 0.1 um grains); --gas-temperature K sets T = K where\n"
        "    emission > 0. On every voxel with dust or emission.\n"
        "  velocity [km/s], world axes, same voxels: expansion v = E (x - c) / R,\n"
        "    rotation v = W (axis x (x - c)) / R (right-handed), plus divergence-free\n"
        "    curl-noise turbulence of RMS speed --turbulence over the cube;\n"
        "    c = --motion-centre, R = --motion-radius. Blender reads `velocity` for\n"
        "    motion blur in scene units (pc) per second: keep motion blur off.\n"
        "  emission.oiii with --oiii R: the [O III] 5007/4959 doublet, R times emission\n"
        "    in the inner part of the ionised region (1 inside 50%, 0 beyond 80% of the\n"
        "    emission's radial extent, measured from the motion centre).\n"
        "Lines (case-sensitive; or a rest wavelength in nm such as 587.56):\n" +
        knownLinesHelp() +
        "Metadata: nebula:stars (JSON), nebula:dust (JSON). Next step: nebillum.";
    CLI::App app{description, "nebgen"};
    nebula::cli::addCommon(app, common, nebula::cli::OUTPUT);
    std::string presetNames;
    for (const auto& p : nebula::nebulaPresets())
        presetNames += std::string(presetNames.empty() ? "" : ", ") + p.name;
    app.add_option("--preset", presetName,
                   "The kind of nebula: " + presetNames +
                       " (each in man nebgen and docs/presets.md; fbm: the seeds' cloud)")
        ->capture_default_str()
        ->check([](const std::string& name) {
            try {
                nebula::parsePreset(name);
            } catch (const nebula::UsageError& e) {
                return std::string(e.what()).substr(std::strlen("--preset: "));
            }
            return std::string();
        });
    app.add_option("--res", params.res,
                   "Voxels along each axis (at most what fits in memory: about 16 bytes a voxel, "
                   "more with --spectral)")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(2, 2048));
    app.add_option("--size", params.size, "Edge length of the cube [pc]")
        ->capture_default_str()
        ->check(nebula::cli::positive());
    app.add_option("--seed", params.seed, "Noise seed")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(0, UINT64_MAX));
    app.add_option("--density", params.densityPeak,
                   "Density scale: n_H [cm^-3] where the shaped noise is 1")
        ->capture_default_str()
        ->check(nebula::cli::nonNegative());
    // The seeds' fBm cloud (--preset fbm).
    const std::string fbmGroup = "fBm cloud (--preset fbm)";
    std::vector<CLI::Option*> fbmOnly;
    fbmOnly.push_back(
        app.add_option("--frequency", params.frequency, "Noise features across the cube")
            ->capture_default_str()
            ->group(fbmGroup));
    fbmOnly.push_back(app.add_option("--octaves", params.fbm.octaves, "fBm octaves")
                          ->capture_default_str()
                          ->check(nebula::cli::integerIn(1, 16))
                          ->group(fbmGroup));
    fbmOnly.push_back(app.add_option("--lacunarity", params.fbm.lacunarity, "fBm frequency ratio")
                          ->capture_default_str()
                          ->group(fbmGroup));
    fbmOnly.push_back(app.add_option("--gain", params.fbm.gain, "fBm amplitude ratio")
                          ->capture_default_str()
                          ->group(fbmGroup));
    fbmOnly.push_back(
        app.add_option("--threshold", params.threshold, "fBm level below which there is no dust")
            ->capture_default_str()
            ->group(fbmGroup));
    fbmOnly.push_back(
        app.add_option("--contrast", params.contrast, "Gain on fBm above the threshold")
            ->capture_default_str()
            ->check(nebula::cli::positive())
            ->group(fbmGroup));
    fbmOnly.push_back(app.add_option("--exponent", params.exponent,
                                     "Density = (contrast (fBm - threshold))^exponent")
                          ->capture_default_str()
                          ->check(nebula::cli::positive())
                          ->group(fbmGroup));
    app.add_option("--warp", params.warp,
                   "Domain-warp strength [cube edges] (the turbulent presets: at most 0.5)")
        ->capture_default_str();
    fbmOnly.push_back(app.add_option("--envelope", params.envelope, "Cloud radius [cube edges]")
                          ->capture_default_str()
                          ->group(fbmGroup));

    // The turbulent presets' statistics.
    const std::string turbulenceGroup = "Turbulence (every preset but fbm)";
    std::vector<CLI::Option*> turbulenceOnly;
    turbulenceOnly.push_back(
        app.add_option("--mach", params.turbulence.mach,
                       "RMS sonic Mach number M > 0: sigma_s^2 = ln(1 + b^2 M^2)")
            ->capture_default_str()
            ->check(nebula::cli::positive())
            ->group(turbulenceGroup));
    turbulenceOnly.push_back(
        app.add_option("--forcing-b", params.turbulence.forcingB,
                       "Forcing parameter b in (0, 1]: 1/3 solenoidal, 1 compressive")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 1.0, true))
            ->group(turbulenceGroup));
    turbulenceOnly.push_back(
        app.add_option("--power-index", params.turbulence.index,
                       "3-D power spectrum of ln n: P(k) ~ (k^2 + k0^2)^(-index/2), in [0, 10]")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 10.0))
            ->group(turbulenceGroup));
    turbulenceOnly.push_back(
        app.add_option("--outer-scale", params.turbulence.outerScale,
                       "Driving scale [cube edges], k0 = 1 / outer-scale, in (0, 100]")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 100.0, true))
            ->group(turbulenceGroup));
    turbulenceOnly.push_back(
        app.add_option("--edge-cut", params.edgeCut,
                       "The cloud ends where n falls below this times --density (a sharp, "
                       "fractal edge; 0: none), in [0, 100]")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 100.0))
            ->group(turbulenceGroup));
    turbulenceOnly.push_back(
        app.add_option("--anisotropy", params.turbulence.anisotropy,
                       "A >= 0: structures (1 + A) times longer along --anisotropy-axis (a "
                       "magnetic field's striations); 0 isotropic")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 100.0))
            ->group(turbulenceGroup));
    turbulenceOnly.push_back(nebula::cli::addVec3(app, "--anisotropy-axis", params.turbulence.axis,
                                                  "The anisotropy's axis (any length)")
                                 ->group(turbulenceGroup));
    app.add_option("--emission", params.emissionPeak, "Peak gas emission (0: none)")
        ->capture_default_str()
        ->check(nebula::cli::nonNegative());
    fbmOnly.push_back(app.add_option("--emission-radius", params.emissionRadius,
                                     "Radius of the emitting region [cube edges]")
                          ->capture_default_str());
    app.add_option("--cavity", params.cavity, "Dust-free cavity around each star [pc] (0: none)")
        ->capture_default_str()
        ->check(nebula::cli::nonNegative());
    nebula::cli::addStars(app, starOpts);
    app.add_flag("--no-stars", noStars, "No stars (default: the example's two stars)");
    nebula::cli::addDust(app, dustOpts);

    // Emission lines and shape (with or without --spectral).
    const std::string emissionGroup = "Emission lines and shape";
    app.add_option("--lines", lines,
                   "Lines of the emission grid, NAME[:STRENGTH],... (metadata nebula:lines; "
                   "Case B H-alpha/H-beta = 2.86 by default)")
        ->capture_default_str()
        ->group(emissionGroup);
    fbmOnly.push_back(app.add_option("--emission-shape", shape,
                                     "sphere (about the cube centre) or shell (radius "
                                     "--emission-radius about the motion centre)")
                          ->capture_default_str()
                          ->check(CLI::IsMember({"sphere", "shell"}))
                          ->group(emissionGroup));
    auto* shellWidth = app.add_option("--shell-width", params.shellWidth,
                                      "Shell thickness (FWHM) relative to its radius")
                           ->capture_default_str()
                           ->check(nebula::cli::numberIn(0.0, 1.0, true))
                           ->group(emissionGroup);
    auto* motionCentre = app.add_option("--motion-centre", centre,
                                        "X,Y,Z [pc]: centre of the motion, the shell and the "
                                        "[O III] zone (default: the first star, or 0,0,0)")
                             ->group(emissionGroup);

    // Spectral grids.
    const std::string spectralGroup = "Spectral grids (temperature, velocity, [O III])";
    app.add_flag("--spectral", params.spectral.enabled,
                 "Also write the temperature and velocity grids")
        ->group(spectralGroup);
    std::vector<CLI::Option*> spectralOnly;
    spectralOnly.push_back(
        app.add_option("--gas-temperature", params.spectral.gasTemperature,
                       "Ionised-gas temperature [K] where emission > 0 (e.g. 8000; 0: dust "
                       "temperature everywhere)")
            ->capture_default_str()
            ->check(nebula::cli::nonNegative())
            ->group(spectralGroup));
    spectralOnly.push_back(
        app.add_option("--expansion", params.spectral.motion.expansion,
                       "Homologous expansion speed [km/s] at --motion-radius (negative: "
                       "contraction)")
            ->capture_default_str()
            ->group(spectralGroup));
    spectralOnly.push_back(
        app.add_option("--rotation", params.spectral.motion.rotation,
                       "Solid-body rotation speed [km/s] at --motion-radius from the axis "
                       "(positive: counter-clockwise seen from +axis)")
            ->capture_default_str()
            ->group(spectralGroup));
    spectralOnly.push_back(nebula::cli::addVec3(app, "--rotation-axis", params.spectral.motion.axis,
                                                "Rotation axis (any length)")
                               ->group(spectralGroup));
    spectralOnly.push_back(
        app.add_option("--turbulence", params.spectral.motion.turbulence,
                       "RMS speed [km/s] of divergence-free curl-noise turbulence "
                       "(Kolmogorov-like octaves)")
            ->capture_default_str()
            ->check(nebula::cli::nonNegative())
            ->group(spectralGroup));
    spectralOnly.push_back(app.add_option("--turbulence-frequency",
                                          params.spectral.motion.turbulenceFrequency,
                                          "Turbulence features across the cube")
                               ->capture_default_str()
                               ->check(nebula::cli::positive())
                               ->group(spectralGroup));
    spectralOnly.push_back(
        app.add_option("--motion-radius", params.motionRadius,
                       "Distance [pc] at which --expansion and --rotation are reached "
                       "(default: --emission-radius times --size)")
            ->check(nebula::cli::positive())
            ->group(spectralGroup));
    spectralOnly.push_back(
        app.add_option("--oiii", params.spectral.oiii,
                       "Also write emission.oiii ([O III] 5007/4959 = 2.98) at this strength "
                       "relative to emission, in the inner ionised region (0: none)")
            ->capture_default_str()
            ->check(nebula::cli::nonNegative())
            ->group(spectralGroup));

    return nebula::cli::run(app, "nebgen", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        if (nebula::parsePreset(presetName) != params.preset) {
            throw nebula::UsageError("--preset " + presetName +
                                     ": give it on the command line, not in a config file");
        }
        const bool fbm = params.preset == nebula::NebulaPreset::Fbm;
        nebula::cli::requireMode(fbmOnly, fbm, "--preset fbm (the default)");
        nebula::cli::requireMode(turbulenceOnly, !fbm, "a turbulent --preset (not fbm)");
        params.emissionShape =
            shape == "shell" ? nebula::EmissionShape::Shell : nebula::EmissionShape::Sphere;
        nebula::cli::requireMode(spectralOnly, params.spectral.enabled, "--spectral");
        if (!params.spectral.enabled) {
            if (motionCentre->count() > 0 && params.emissionShape != nebula::EmissionShape::Shell) {
                throw nebula::UsageError(
                    "--motion-centre needs --spectral or --emission-shape shell");
            }
        }
        if (shellWidth->count() > 0 && params.emissionShape != nebula::EmissionShape::Shell) {
            throw nebula::UsageError("--shell-width needs --emission-shape shell");
        }
        try {
            params.lines = nebula::parseLineList(lines, "--lines");
        } catch (const nebula::UsageError&) {
            throw;
        } catch (const nebula::Error& e) {
            throw nebula::UsageError(e.what());
        }
        if (motionCentre->count() > 0) {
            params.motionCentre = nebula::cli::parseVec3(centre, "--motion-centre");
        }
        params.stars = nebula::cli::loadStars(starOpts);
        if (params.stars.empty() && !noStars) {
            params.stars = nebula::presetStars(params.preset, params.size);
        }
        params.dust = dustOpts.apply(params.dust);
        nebula::Progress bar(run, "nebgen", std::uint64_t(params.res));
        run.info("generating a " + std::to_string(params.res) + "^3 " + presetName +
                 " nebula, seed " + std::to_string(params.seed) + ", " +
                 std::to_string(params.stars.size()) + " stars" +
                 (params.spectral.enabled ? ", spectral grids" : ""));
        auto grids = nebula::generateNebula(params, [&](std::size_t n) { bar.add(n); });
        nebula::writeGrids(common.output, std::move(grids), run);
    });
}
