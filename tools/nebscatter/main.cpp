// SPDX-License-Identifier: Apache-2.0
// nebscatter - the field of multiply scattered light, computed once per scene (DESIGN §5b).
#include "nebula/cli/cli.h"
#include "nebula/cli/option_table.h"
#include "nebula/cli/options.h"
#include "nebula/cli/process_ranks.h"
#include "nebula/core/error.h"
#include "nebula/core/version.h"
#include "nebula/io/grid_io.h"
#include "nebula/stages/scatter.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

int main(int argc, char** argv)
{
    namespace cli = nebula::cli;
    nebula::CommonOptions common;
    nebula::ScatterStageOptions opts; // every default lives here
    bool noEmission = false, interpolatedTau = false;

    CLI::App app{
        "nebscatter - the field of light scattered at least once, for nebrender\n\n"
        "Examples:\n"
        "  nebscatter -i lit.vdb -o scattered.vdb && nebrender -i scattered.vdb -o f.exr\n"
        "  nebgen -o - | nebillum -i - -o - | nebscatter -i - -o - | nebrender -i - -o f.exr\n"
        "  nebscatter -i lit.vdb --field-level 1 --order 2 -o s.vdb   # quicker, rougher\n"
        "  nebscatter -i lit.vdb --per-star -o s.vdb   # a field per star\n"
        "  nebscatter -i lit.vdb --spectral 6 -o s.vdb && nebrender -i s.vdb --spectral -o s.exr\n"
        "  nebscatter -i lit.vdb -o - | nebscatter -i - --spectral 6 -o both.vdb  # both fields\n\n"
        "Monte Carlo packets start from the first-scattering source, known exactly from the\n"
        "tau.<star> grids (and from the gas emission), and are followed through every order\n"
        "of scattering on the full-resolution density (trilinear, exact optical depth per\n"
        "piece, albedo weights, Russian roulette), one walk serving R, G and B. Each flight\n"
        "tallies its expected track length times the real spherical harmonics Y_lm of its\n"
        "direction into the field cells it crosses. nebrender then adds, at every sample,\n"
        "k a sum_l p_l sum_m c_lm Y_lm(towards the eye) to its exact single scattering,\n"
        "so the image is right at every optical depth and the camera moves for free.\n"
        "Adds per source (stars: all stars together, or star_<name> with --per-star;\n"
        "emission: the gas emission's scattered glow, per unit --emission-scale and colour)\n"
        "and channel R, G, B the FloatGrids scatter.<source>.J.<c>, the mean intensity of\n"
        "the scattered light [L_sun pc^-2 sr^-1], and scatter.<source>.c<l>_<m>.<c>\n"
        "(l = 1..L) [L_sun pc^-2], on cells of 2^k voxels (nebpyramid's level-k layout),\n"
        "active where there is dust; the file metadata nebula:scatter records the dust,\n"
        "stars, wavelengths and transform the field was made for (nebrender refuses a field\n"
        "that does not match its scene). --spectral N computes instead the starlight's\n"
        "field for nebrender --spectral at N wavelengths over 380-780 nm (grids\n"
        "scatter.spectral.<source>.J.<lambda>nm and .c<l>_<m>.<lambda>nm, per nm; metadata\n"
        "nebula:scatter_spectral); it replaces only an earlier spectral field, so one file\n"
        "can hold both. Same seed, same field, whatever the thread count.\n"
        "-v reports the packets, the energy balance and the field's noise.\n"
        "Started by mpirun (or srun with an MPI plugin), the ranks share the packets and\n"
        "rank 0 writes the same field, bit for bit, as one process would (README,\n"
        "\"nebscatter over MPI\"):\n"
        "  mpirun -np 4 nebscatter -i lit.vdb -o scattered.vdb --threads 8",
        "nebscatter"};
    cli::addCommon(app, common, cli::INPUT | cli::OUTPUT | cli::PASS_THROUGH | cli::DENSITY_GRID);
    auto& f = opts.field;
    std::string fieldLevel = "auto";
    std::string precision = std::to_string(nebula::DEFAULT_FIELD_BITS);
    cli::addOptions(
        app,
        {{"--packets", &f.packets,
          "Packets per source (all stars, each star with --per-star, the emission);\n"
          "the field's noise falls as 1/sqrt(N); at most 1e9 (hours per star), a\n"
          "work bound refused with its estimate",
          cli::integerIn(1, std::int64_t(1) << 40)},
         {"--order", &f.order, "Degree L of the spherical harmonics, 0..4", cli::integerIn(0, 4)},
         {"--field-level", &fieldLevel,
          "Field cells of 2^k x 2^k x 2^k voxels (0: full resolution; -1: half a\n"
          "voxel, for optically thick voxels), not larger than the grid; auto: about\n"
          "64 cells across the grid, finer (down to -1) while cells of the densest\n"
          "dust are optically thick (tau_V > 1 across) and the tallies (at -1 the\n"
          "field too) fit in 1 GiB; -v says why",
          cli::autoOrIntegerIn(nebula::MIN_FIELD_LEVEL, nebula::MAX_FIELD_LEVEL)},
         {"--refine-tau", &f.refineTau,
          "Adaptive cells: a block of 2x2x2 field cells is tallied as one (its cells\n"
          "from the block's value and slopes: fewer, fuller tallies) unless its\n"
          "densest voxel makes it optically thicker than this across (tau_V), a star\n"
          "is in or next to it, or it borders such a block; 0: every cell on its own",
          CLI::Range(0.0, nebula::MAX_REFINE_TAU)},
         {"--denoise", &f.denoise,
          "Noise filter, in field space: each cell moves towards the plane fitted to\n"
          "the (2N+1)^3 cells around it only as far as its own noise estimate exceeds\n"
          "their spread about it (a local Wiener filter), so edges and gradients\n"
          "stay; 0: none. -v reports the noise before and after (DESIGN 5b)",
          cli::integerIn(0, nebula::MAX_DENOISE_RADIUS)},
         {"--precision", &precision,
          "Significant bits each stored moment keeps: every moment of a cell within\n"
          "2^-BITS of the cell's c_00 (J: of J), its float's low bits zero so the\n"
          "file compresses; half: 11 (a half float's), float: the floats as computed.\n"
          "The default's bound, 0.39 %, is about a tenth of the noise of J or less;\n"
          "-v reports both and the file's size",
          CLI::Validator(
              [](std::string& s) {
                  if (s == "half" || s == "float") return std::string();
                  std::string v = s;
                  return cli::integerIn(nebula::FIELD_MIN_BITS, nebula::FIELD_FLOAT_BITS)(v).empty()
                             ? std::string()
                             : "expected half, float or an integer in [" +
                                   std::to_string(nebula::FIELD_MIN_BITS) + ", " +
                                   std::to_string(nebula::FIELD_FLOAT_BITS) + "], got " + s;
              },
              "BITS|half|float")},
         {"--seed", &f.seed, "Random seed (same seed, same field)", cli::integerIn(0, UINT64_MAX)},
         {"--per-star", &f.perStar,
          "One field per star (scatter.star_<name>.*) instead of their sum: nebrender\n"
          "then scales each by the star's luminosity, for animating a star"},
         {"--no-emission", &noEmission, "Leave out the gas emission's scattered light"},
         {"--emission-grid", &opts.scene.emissionGrid, "Gas emission grid"},
         {"--wavelengths", &opts.wavelengths,
          "R,G,B channel wavelengths [nm] for the extinction curve (as nebrender's)"}});
    auto* wavelengthsOpt = app.get_option("--wavelengths");
    nebula::FilterOptions filterOpts;
    cli::addFilter(app, filterOpts,
                   "the field at its three quadrature wavelengths, for nebrender --filter");
    cli::addOptions(
        app,
        {{"--spectral", &opts.spectral,
          "The starlight's field for nebrender --spectral at N wavelengths evenly\n"
          "spaced over 380-780 nm, 2..64 (6 keep colours within Delta E 2000 < 0.4 of\n"
          "a dense field); one walk carries them all",
          cli::integerIn(2, 64), "", nullptr, false},
         {"--interpolated-tau", &interpolatedTau,
          "Start packets with each star's optical depth from the trilinear tau grid\n"
          "everywhere (as nebrender --interpolated-tau), not exact where it bends"},
         {"--min-star-distance", &opts.scene.minStarDistance,
          "Distance below which 1/r^2 is clamped [voxels] (as nebrender's)", cli::positive()}});

    std::unique_ptr<nebula::Ranks> ranks; // MPI's, when mpirun or srun started this process
    const int rc = cli::run(app, "nebscatter", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        if (const auto band = cli::loadFilter(filterOpts)) {
            opts.wavelengths = cli::filterWavelengths(*band, wavelengthsOpt->count() > 0);
        }
        ranks = cli::processRanks("nebscatter");
        if (ranks->size() > 1 && common.input == "-") {
            throw nebula::UsageError(
                "-i -: with " + std::to_string(ranks->size()) +
                " MPI ranks every rank reads the input, and stdin reaches rank 0 only: give a "
                "file every rank can read");
        }
        // Rank 0 speaks and writes; the others compute their packets quietly.
        const nebula::Run quiet(run.tool(), run.command(), nebula::Verbosity{true, 0});
        const nebula::Run& say = ranks->root() ? run : quiet;
        f.ranks = ranks.get();
        f.emission = !noEmission;
        f.fieldLevel = fieldLevel == "auto" ? nebula::AUTO_FIELD_LEVEL : std::stoi(fieldLevel);
        opts.scene.exactStarDepth = !interpolatedTau;
        auto grids = nebula::readGrids(common.input, say);
        if (ranks->size() > 1) { // every rank must compute the same field's share
            std::vector<cli::RunPart> parts{{"the version", NEBULA_VERSION_STRING}};
            for (auto& [name, value] : cli::optionValues(
                     app, {"--threads", "--quiet", "--verbose", "--config", "--help", "--version"}))
                parts.push_back({name, value});
            parts.push_back({"the wavelengths (--wavelengths, --filter, --filter-file)",
                             fmt::format("{}", fmt::join(opts.wavelengths, ","))});
            parts.push_back({"the input -i " + common.input + " (another file's grids)",
                             nebula::contentDigest(grids)});
            cli::requireSameRun(*ranks, parts);
        }
        opts.scene.densityGrid = common.densityGrid;
        opts.onlyNew = common.onlyNew;
        opts.storedBits = precision == "float"  ? nebula::FIELD_FLOAT_BITS
                          : precision == "half" ? nebula::FIELD_HALF_BITS
                                                : std::stoi(precision);
        const nebula::ScatterField field = nebula::scatter(grids, opts, say);
        if (!ranks->root()) return;
        nebula::writeGrids(common.output, std::move(grids), run);
        // -v: the file's size beside the field's noise and the stored precision's bound.
        double noise = 0.0;
        for (const auto& src : field.sources)
            noise = std::max(noise, src.relativeError);
        const std::string size =
            common.output == "-"
                ? std::string()
                : fmt::format("{:.1f} MB, ",
                              double(std::filesystem::file_size(common.output)) / 1e6);
        run.info(
            fmt::format("{}: {}moments stored to {} significant bits ({}), noise of J {:.2g} %",
                        common.output == "-" ? "<stdout>" : common.output, size, opts.storedBits,
                        opts.storedBits >= nebula::FIELD_FLOAT_BITS
                            ? std::string("the floats as computed")
                            : fmt::format("each within {:.2g} % of its cell's c_00",
                                          100.0 * std::ldexp(1.0, -opts.storedBits)),
                        100.0 * noise));
    });
    return cli::finishRanks(ranks, rc);
}
