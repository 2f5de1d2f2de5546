// SPDX-License-Identifier: Apache-2.0
// nebgen - procedural reflection nebula: fBm dust density, gas emission, stars, and with
// --spectral temperature, velocity and [O III] emission.
#include "nebula/cli/cli.h"
#include "nebula/cli/generate_options.h"
#include "nebula/cli/option_table.h"
#include "nebula/stages/generate.h"
#include "nebula/stages/presets.h"

#include <cstdint>
#include <string>

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    // The preset's parameters are the defaults --help shows; every option overrides them.
    nebula::GenerateOptions opts(nebula::cli::argumentOf(argc, argv, "--preset"));
    CLI::App app{nebula::cli::generateDescription(), "nebgen"};
    nebula::cli::addCommon(app, common, nebula::cli::OUTPUT);
    nebula::cli::addGenerate(app, opts);

    return nebula::cli::run(app, "nebgen", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        const nebula::NebulaParams params = opts.resolve();
        nebula::Progress bar(run, "nebgen", std::uint64_t(params.res));
        run.info("generating a " + std::to_string(params.res) + "^3 " + opts.presetName +
                 " nebula, seed " + std::to_string(params.seed) + ", " +
                 std::to_string(params.stars.size()) + " stars" +
                 (params.spectral.enabled ? ", spectral grids" : ""));
        if (nebula::presetIonised(params.preset)) {
            run.info("the " + opts.presetName +
                     " preset's glow is the gas its stars ionise: run nebionize on this "
                     "file for it (nebgen paints none)");
        }
        auto grids = nebula::generateNebula(params, [&](std::size_t n) { bar.add(n); });
        nebula::writeGrids(common.output, std::move(grids), run);
    });
}
