// SPDX-License-Identifier: Apache-2.0
#include "nebula/cli/generate_options.h"

#include "nebula/cli/cli.h"
#include "nebula/cli/option_table.h"
#include "nebula/core/error.h"
#include "nebula/stages/presets.h"

#include <cstdint>
#include <cstdio>
#include <cstring>

namespace nebula {

namespace {

/// The catalogue's names with their wavelengths, wrapped for --help.
std::string knownLinesHelp()
{
    std::string out, row = " ";
    for (const auto& name : knownLines()) {
        char wl[32];
        std::snprintf(wl, sizeof wl, " %.2f", lineWavelength(name));
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
    for (const auto& p : nebulaPresets()) {
        std::string name = p.name;
        name.resize(12, ' ');
        out += "  " + name + p.summary + "\n";
    }
    return out;
}

/// --preset: the kind of nebula, its names listed, an unknown one refused with parsePreset()'s
/// message.
cli::OptionRow presetRow(std::string& presetName)
{
    std::string names;
    for (const auto& p : nebulaPresets())
        names += std::string(names.empty() ? "" : ", ") + p.name;
    const CLI::Validator known(
        [](std::string& name) {
            try {
                parsePreset(name);
            } catch (const UsageError& e) {
                return std::string(e.what()).substr(std::strlen("--preset: "));
            }
            return std::string();
        },
        "");
    return {"--preset", &presetName,
            "The kind of nebula: " + names +
                " (each in man nebgen and docs/presets.md; fbm: the seeds' cloud)",
            known};
}

/// The options from --preset to --cavity: the model's (the fBm cloud's or the turbulent
/// presets'), the emission's strength and the stars' cavities.
std::vector<cli::OptionRow> modelRows(GenerateOptions& o)
{
    NebulaParams& p = o.params;
    const std::string fbm = "fBm cloud (--preset fbm)";
    const std::string turb = "Turbulence (every preset but fbm)";
    auto* fbmOnly = &o.fbmOnly;
    auto* turbOnly = &o.turbulenceOnly;
    return {
        presetRow(o.presetName),
        {"--res", &p.res,
         "Voxels along each axis (at most what fits in memory: about 16 bytes a voxel, more "
         "with --spectral)",
         cli::integerIn(2, 2048)},
        {"--size", &p.size, "Edge length of the cube [pc]", cli::positive()},
        {"--seed", &p.seed, "Noise seed", cli::integerIn(0, UINT64_MAX)},
        {"--density", &p.densityPeak, "Density scale: n_H [cm^-3] where the shaped noise is 1",
         cli::nonNegative()},
        // The seeds' fBm cloud (--preset fbm).
        {"--frequency", &p.frequency, "Noise features across the cube", {}, fbm, fbmOnly},
        {"--octaves", &p.fbm.octaves, "fBm octaves", cli::integerIn(1, 16), fbm, fbmOnly},
        {"--lacunarity", &p.fbm.lacunarity, "fBm frequency ratio", {}, fbm, fbmOnly},
        {"--gain", &p.fbm.gain, "fBm amplitude ratio", {}, fbm, fbmOnly},
        {"--threshold", &p.threshold, "fBm level below which there is no dust", {}, fbm, fbmOnly},
        {"--contrast", &p.contrast, "Gain on fBm above the threshold", cli::positive(), fbm,
         fbmOnly},
        {"--exponent", &p.exponent, "Density = (contrast (fBm - threshold))^exponent",
         cli::positive(), fbm, fbmOnly},
        {"--warp", &p.warp,
         "Domain-warp strength [cube edges] (the turbulent presets: at most 0.5)"},
        {"--envelope", &p.envelope, "Cloud radius [cube edges]", {}, fbm, fbmOnly},
        // The turbulent presets' statistics.
        {"--mach", &p.turbulence.mach, "RMS sonic Mach number M > 0: sigma_s^2 = ln(1 + b^2 M^2)",
         cli::positive(), turb, turbOnly},
        {"--forcing-b", &p.turbulence.forcingB,
         "Forcing parameter b in (0, 1]: 1/3 solenoidal, 1 compressive",
         cli::numberIn(0.0, 1.0, true), turb, turbOnly},
        {"--power-index", &p.turbulence.index,
         "3-D power spectrum of ln n: P(k) ~ (k^2 + k0^2)^(-index/2), in [0, 10]",
         cli::numberIn(0.0, 10.0), turb, turbOnly},
        {"--outer-scale", &p.turbulence.outerScale,
         "Driving scale [cube edges], k0 = 1 / outer-scale, in (0, 100]",
         cli::numberIn(0.0, 100.0, true), turb, turbOnly},
        {"--edge-cut", &p.edgeCut,
         "The cloud ends where n falls below this times --density (a sharp, fractal edge; 0: "
         "none), in [0, 100]",
         cli::numberIn(0.0, 100.0), turb, turbOnly},
        {"--anisotropy", &p.turbulence.anisotropy,
         "A >= 0: structures (1 + A) times longer along --anisotropy-axis (a magnetic field's "
         "striations); 0 isotropic",
         cli::numberIn(0.0, 100.0), turb, turbOnly},
        {"--anisotropy-axis",
         &p.turbulence.axis,
         "The anisotropy's axis (any length)",
         {},
         turb,
         turbOnly},
        {"--emission", &p.emissionPeak, "Peak gas emission (0: none)", cli::nonNegative()},
        {"--emission-radius",
         &p.emissionRadius,
         "Radius of the emitting region [cube edges]",
         {},
         "",
         fbmOnly},
        {"--cavity", &p.cavity, "Dust-free cavity around each star [pc] (0: none)",
         cli::nonNegative()},
    };
}

/// The emission's lines and shape (with or without --spectral).
std::vector<cli::OptionRow> emissionRows(GenerateOptions& o)
{
    const std::string group = "Emission lines and shape";
    return {
        {"--lines",
         &o.lines,
         "Lines of the emission grid, NAME[:STRENGTH],... (metadata nebula:lines; Case B "
         "H-alpha/H-beta = 2.86 by default)",
         {},
         group},
        {"--emission-shape", &o.shape,
         "sphere (about the cube centre) or shell (radius --emission-radius about the motion "
         "centre)",
         CLI::IsMember({"sphere", "shell"}), group, &o.fbmOnly},
        {"--shell-width", &o.params.shellWidth, "Shell thickness (FWHM) relative to its radius",
         cli::numberIn(0.0, 1.0, true), group},
        {"--motion-centre",
         &o.centre,
         "X,Y,Z [pc]: centre of the motion, the shell and the [O III] zone (default: the first "
         "star, or 0,0,0)",
         {},
         group,
         nullptr,
         false},
    };
}

/// The spectral grids: temperature, velocity, [O III].
std::vector<cli::OptionRow> spectralRows(GenerateOptions& o)
{
    SpectralParams& s = o.params.spectral;
    const std::string group = "Spectral grids (temperature, velocity, [O III])";
    auto* only = &o.spectralOnly;
    return {
        {"--spectral", &s.enabled, "Also write the temperature and velocity grids", {}, group},
        {"--gas-temperature", &s.gasTemperature,
         "Ionised-gas temperature [K] where emission > 0 (e.g. 8000; 0: dust temperature "
         "everywhere)",
         cli::nonNegative(), group, only},
        {"--expansion",
         &s.motion.expansion,
         "Homologous expansion speed [km/s] at --motion-radius (negative: contraction)",
         {},
         group,
         only},
        {"--rotation",
         &s.motion.rotation,
         "Solid-body rotation speed [km/s] at --motion-radius from the axis (positive: "
         "counter-clockwise seen from +axis)",
         {},
         group,
         only},
        {"--rotation-axis", &s.motion.axis, "Rotation axis (any length)", {}, group, only},
        {"--turbulence", &s.motion.turbulence,
         "RMS speed [km/s] of divergence-free curl-noise turbulence (Kolmogorov-like octaves)",
         cli::nonNegative(), group, only},
        {"--turbulence-frequency", &s.motion.turbulenceFrequency,
         "Turbulence features across the cube", cli::positive(), group, only},
        {"--motion-radius", &o.params.motionRadius,
         "Distance [pc] at which --expansion and --rotation are reached (default: "
         "--emission-radius times --size)",
         cli::positive(), group, only},
        {"--oiii", &s.oiii,
         "Also write emission.oiii ([O III] 5007/4959 = 2.98) at this strength relative to "
         "emission, in the inner ionised region (0: none)",
         cli::nonNegative(), group, only},
    };
}

} // namespace

GenerateOptions::GenerateOptions(const std::string& preset)
{
    for (const auto& p : nebulaPresets()) {
        if (preset == p.name) params = presetParams(p.id);
    }
    presetName = nebula::presetName(params.preset);
    lines = lineListToString(params.lines);
}

NebulaParams GenerateOptions::resolve() const
{
    NebulaParams p = params;
    if (parsePreset(presetName) != p.preset) {
        throw UsageError("--preset " + presetName +
                         ": give it on the command line, not in a config file");
    }
    const bool fbm = p.preset == NebulaPreset::Fbm;
    if (presetIonised(p.preset) && p.emissionPeak > 0.0) {
        throw UsageError("--emission: the " + presetName +
                         " preset's glow is the gas its stars ionise, which nebionize "
                         "computes (nebgen --preset " +
                         presetName + " -o - | nebionize -i - -o ionised.vdb); nebgen paints none");
    }
    cli::requireMode(fbmOnly, fbm, "--preset fbm (the default)");
    cli::requireMode(turbulenceOnly, !fbm, "a turbulent --preset (not fbm)");
    p.emissionShape = shape == "shell" ? EmissionShape::Shell : EmissionShape::Sphere;
    cli::requireMode(spectralOnly, p.spectral.enabled, "--spectral");
    if (!p.spectral.enabled) {
        if (motionCentre->count() > 0 && p.emissionShape != EmissionShape::Shell) {
            throw UsageError("--motion-centre needs --spectral or --emission-shape shell");
        }
    }
    if (shellWidth->count() > 0 && p.emissionShape != EmissionShape::Shell) {
        throw UsageError("--shell-width needs --emission-shape shell");
    }
    try {
        p.lines = parseLineList(lines, "--lines");
    } catch (const UsageError&) {
        throw;
    } catch (const Error& e) {
        throw UsageError(e.what());
    }
    if (motionCentre->count() > 0) p.motionCentre = cli::parseVec3(centre, "--motion-centre");
    p.stars = cli::loadStars(stars);
    if (p.stars.empty() && !noStars) p.stars = presetStars(p.preset, p.size);
    p.dust = dust.apply(p.dust);
    return p;
}

namespace cli {

std::string generateDescription()
{
    return std::string(
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
}

void addGenerate(CLI::App& app, GenerateOptions& opts)
{
    addOptions(app, modelRows(opts));
    addStars(app, opts.stars);
    addOptions(app, {{"--no-stars", &opts.noStars, "No stars (default: the example's two stars)"}});
    addDust(app, opts.dust);
    addOptions(app, emissionRows(opts));
    opts.shellWidth = app.get_option("--shell-width");
    opts.motionCentre = app.get_option("--motion-centre");
    addOptions(app, spectralRows(opts));
}

} // namespace cli
} // namespace nebula
