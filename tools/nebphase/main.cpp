// SPDX-License-Identifier: Apache-2.0
// nebphase - the effective phase function Phi(t, mu) of a dust voxel by Monte Carlo
// (DESIGN §4), and plane-parallel slab runs of the same Monte Carlo core.
#include "nebula/cli/cli.h"
#include "nebula/cli/option_table.h"
#include "nebula/cli/options.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/stages/phase.h"

#include <cstdint>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::PhaseOptions opts; // every default lives here (and in PhaseTableSpec)
    nebula::DustOptions dustOpts;
    const nebula::PhaseTableSpec& spec = opts.table;
    namespace cli = nebula::cli;

    CLI::App app{
        "nebphase - effective phase function Phi(t, mu) of a dust voxel, by Monte Carlo\n\n"
        "Examples:\n"
        "  nebphase -o phase.vdb                                 # default dust, t 1e-4 .. 1e3\n"
        "  nebphase -i nebula.vdb -o phase.vdb --json phase.json # the nebula's dust\n"
        "  nebphase --albedo 0.6 --g 0.6 --t-count 16 --mu-bins 64 --error 0.03 -o quick.vdb\n"
        "  nebphase -i lit.vdb -o phase.vdb && nebrender -i lit.vdb --phase phase.vdb -o f.exr\n"
        "  nebphase --slab --tau 1 --albedo 0.9 --g 0.75 --mu0 0.5 > slab.json\n\n"
        "Table mode (default): photons enter one face of a cube of optical edge t along its\n"
        "normal. Phi(t, mu) [1/sr per unit optical depth] is the light scattered out of the\n"
        "cube per sr at cosine mu to the entry direction, per entering photon, divided by t\n"
        "(unscattered light excluded; Phi -> albedo p(mu) as t -> 0). Each of the --t-count\n"
        "log-spaced t gets photons (at least --photons) until every mu > 0 bin of the rows\n"
        "with t <= 10 has a relative standard error below --error, or --max-photons is\n"
        "reached (then a warning). The output holds only the grids phase and phase.error\n"
        "(index space: x = mu bin, y = t row; the axes, photons and seed as metadata) and\n"
        "nebula:dust. The dust is the input's nebula:dust (-i) or the defaults, with the dust\n"
        "options applied; the input's grids are NOT passed through. nebrender --phase uses it.\n\n"
        "Slab mode (--slab): a plane-parallel slab of optical depth --tau lit by a beam at\n"
        "cosine --mu0 to the normal. Prints JSON to stdout: diffuse reflection and\n"
        "transmission, direct transmission, absorption, roulette, balance (direct +\n"
        "reflected + transmitted + absorbed - roulette; 1 in expectation), and per bin the\n"
        "power per sr leaving each face [fraction of the incident power / sr], in --bins\n"
        "equal-cos bins per face of the cosine to that face's outward normal. The\n"
        "next-event estimator (default) forces the first interaction, so the direct\n"
        "transmission exp(-tau/mu0) is then exact (error 0); analog (MCML) balances each\n"
        "photon exactly.",
        "nebphase"};
    cli::addCommon(app, common, 0);
    cli::inputFile(
        app.add_option("-i,--input", common.input,
                       "VDB whose nebula:dust is the dust (file, or - for stdin); optional"));
    std::vector<CLI::Option*> tableOnly{
        cli::outputFile(app.add_option("-o,--output", common.output,
                                       "Output phase table VDB, or - for stdout (table mode)"),
                        nebula::FileFormat::Vdb)};
    cli::addOptions(
        app,
        {{"--seed", &opts.table.seed, "Random seed (same seed, same result whatever --threads)",
          cli::integerIn(0, UINT64_MAX)},
         {"--photons", &opts.photons,
          "Photons: per t at least (table, default " + std::to_string(spec.minPhotons) +
              "); in all (--slab, default " + std::to_string(opts.slabPhotons) + ")",
          cli::integerIn(1, UINT64_MAX)}});
    cli::addDust(app, dustOpts, /*withKappa=*/false);

    auto* table = app.add_option_group("Table", "Table mode (the default)");
    cli::addOptions(
        *table,
        {{"--t-min", &opts.table.tMin, "Smallest voxel optical thickness t", cli::positive(), "",
          &tableOnly},
         {"--t-max", &opts.table.tMax, "Largest t", cli::positive(), "", &tableOnly},
         {"--t-count", &opts.table.tCount,
          "Log-spaced t values, both ends included (--t-count x --mu-bins as far as the table "
          "fits in memory)",
          cli::integerIn(2, 1000000), "", &tableOnly},
         {"--mu-bins", &opts.table.muBins, "Equal-cos bins over [-1, 1] (even)",
          cli::integerIn(2, 1000000), "", &tableOnly},
         {"--max-photons", &opts.maxPhotons,
          "Photons per t at most (default " + std::to_string(spec.maxPhotons) +
              ", or --photons if larger; at most 1e9 per t and 1e11 in the table)",
          cli::integerIn(1, UINT64_MAX), "", &tableOnly},
         {"--error", &opts.table.targetError,
          "Target relative standard error of Phi (mu > 0 bins, t <= " +
              nebula::detail::numberText(spec.errorTMax) + ")",
          cli::positive(), "", &tableOnly},
         {"--json",
          &opts.json,
          "Also write the table as JSON (file, or -)",
          {},
          "",
          &tableOnly,
          false}});
    cli::outputFile(table->get_option("--json"), nebula::FileFormat::Json);

    auto* slab = app.add_option_group("Slab", "Slab mode (--slab)");
    std::vector<CLI::Option*> slabOnly;
    cli::addOptions(
        *slab, {{"--slab", &opts.slab, "Run a plane-parallel slab instead; JSON to stdout"},
                {"--tau", &opts.tau, "Optical depth of the slab", cli::positive(), "", &slabOnly},
                {"--mu0", &opts.mu0, "Cosine of the incident beam to the normal",
                 cli::numberIn(0.0, 1.0, true), "", &slabOnly},
                {"--bins", &opts.bins, "Equal-cos angular bins per face", cli::integerIn(1, 100000),
                 "", &slabOnly},
                {"--estimator", &opts.estimator, "analog or next-event",
                 CLI::IsMember({"analog", "next-event"}), "", &slabOnly}});

    return cli::run(app, "nebphase", common, argc, argv, [&](nebula::Run& run) {
        // Options of the other mode are refused rather than silently ignored.
        for (const auto* o : opts.slab ? tableOnly : slabOnly) {
            if (o->count() == 0) continue;
            throw nebula::UsageError(o->get_name() +
                                     (opts.slab ? " is for table mode; --slab prints JSON to stdout"
                                                : " is for slab mode; add --slab"));
        }
        if (opts.slab && !opts.tau) {
            throw nebula::UsageError("--slab needs --tau T, the slab's optical depth");
        }
        opts.input = common.input;
        opts.output = common.output;
        opts.applyDust = [&](const nebula::DustParams& d) { return dustOpts.apply(d); };
        if (opts.slab) {
            nebula::writeSlabJson(opts, run, std::cout);
        } else {
            nebula::writePhaseTable(opts, run, std::cout);
        }
    });
}
