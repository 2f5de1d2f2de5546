// SPDX-License-Identifier: Apache-2.0
// nebillum - per-star optical depth from each star to every voxel.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/stages/illuminate.h"

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::IllumOptions opts; // every default lives here
    nebula::StarOptions starOpts;
    nebula::DustOptions dustOpts;

    CLI::App app{
        "nebillum - optical depth tau.<star> from every star to every voxel\n\n"
        "Examples:\n"
        "  nebillum -i nebula.vdb -o lit.vdb\n"
        "  nebgen -o - | nebillum -i - -o - | nebrender -i - -o frame.exr\n"
        "  nebillum -i smoke.vdb --density-grid smoke --star s:0,1,0:100:B5V -o lit.vdb\n\n"
        "Adds a FloatGrid tau.<star> per star: the V-band (550 nm) optical depth of the\n"
        "trilinearly interpolated density from the star to each active voxel centre,\n"
        "tau_V = kappa_V * integral n_H dl. Stars come from the input's nebula:stars,\n"
        "or from --star/--stars (which replace them). Next step: nebrender.",
        "nebillum"};
    nebula::cli::addCommon(app, common,
                           nebula::cli::INPUT | nebula::cli::OUTPUT | nebula::cli::PASS_THROUGH |
                               nebula::cli::DENSITY_GRID);
    nebula::cli::addStars(app, starOpts);
    auto* grp = app.add_option_group("Dust");
    grp->add_option("--kappa-v", dustOpts.kappa_V,
                    "V-band extinction per n_H per pc [pc^-1 cm^3] (default: the input's)")
        ->check(nebula::cli::numberIn(0.0, nebula::MAX_KAPPA_V, true));

    return nebula::cli::run(app, "nebillum", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        auto grids = nebula::readGrids(common.input, run);
        opts.stars = nebula::cli::loadStars(starOpts);
        opts.dust = dustOpts.apply(grids.dust(run));
        opts.densityGrid = common.densityGrid;
        opts.onlyNew = common.onlyNew;
        nebula::illuminate(grids, opts, run);
        nebula::writeGrids(common.output, std::move(grids), run);
    });
}
