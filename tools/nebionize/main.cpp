// SPDX-License-Identifier: Apache-2.0
// nebionize - the gas ionised by the stars, and its line emission.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/core/error.h"
#include "nebula/physics/photoionization.h"
#include "nebula/stages/ionize.h"

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::IonizeOptions opts; // every default lives here
    nebula::StarOptions starOpts;
    nebula::DustOptions dustOpts;
    bool noDust = false;
    std::string abundances;

    CLI::App app{
        "nebionize - photoionisation by the stars: ionisation fronts and line emission\n\n"
        "Examples:\n"
        "  nebionize -i nebula.vdb -o ionized.vdb\n"
        "  nebgen --preset pillars -o - | nebionize -i - -o - | nebillum -i - -o lit.vdb\n"
        "  nebionize -i cloud.vdb --star O7:0,0,0:2e5:37000 -v -o hii.vdb\n\n"
        "Each star's hydrogen-ionising photons (Q in the star JSON, or its black body's above\n"
        "13.6 eV) ionise the gas out to a front along every direction, where the Case B\n"
        "recombinations (alpha_B n_e n_p) have used them up; dense clumps cast neutral\n"
        "shadows, dust absorbs ionising photons (--no-dust-absorption to switch off), and\n"
        "overlapping H II regions share their recombinations. The photons above 35.1 eV\n"
        "make O++ until they run out. The electron temperature is each voxel's thermal\n"
        "balance of photoheating and cooling (lines, recombination, free-free) unless\n"
        "--electron-temperature or --temperature-grid sets it. Writes ionization.hii (H+/H,\n"
        "a front voxel partly ionised), ionization.oiii (O++/O), and the line emissivities\n"
        "[L_sun pc^-3 sr^-1] emission (H-alpha, H-beta), emission.oiii, emission.nii,\n"
        "emission.sii, emission.oi with their nebula:lines, replacing a painted emission.\n"
        "-v reports each star's photon budget, the fraction escaping the grid and the mean\n"
        "electron temperature.\n"
        "Next step: nebillum, then nebrender (--spectral shows the lines' own colours).",
        "nebionize"};
    nebula::cli::addCommon(app, common,
                           nebula::cli::INPUT | nebula::cli::OUTPUT | nebula::cli::PASS_THROUGH |
                               nebula::cli::DENSITY_GRID);
    nebula::cli::addStars(app, starOpts);
    auto* gas = app.add_option_group("Gas");
    gas->add_option("--electron-temperature", opts.electronTemperature,
                    "one electron temperature for all the ionised gas [K] (recombination and "
                    "the forbidden lines); default: each voxel's from the thermal balance of "
                    "photoheating and cooling (lines, recombination, free-free)")
        ->check(nebula::cli::numberIn(1000.0, 1e5));
    gas->add_option("--temperature-grid", opts.temperatureGrid,
                    "a grid of the gas's electron temperature [K] (a simulation's), used where "
                    "it is > 0 instead of --electron-temperature or the thermal balance (not "
                    "nebgen's temperature: that is the dust's)");
    gas->add_option(
        "--abundances", abundances,
        "number abundances relative to H, e.g. he=0.1,n=4e-5,o=3.3e-4,ne=5e-5,s=9e-6 (the "
        "default: the Lexington benchmark's H II region); he=0 for pure hydrogen");
    gas->add_option("--ray-spacing", opts.raySpacing,
                    "largest width of a ray before it splits [voxels]; smaller is finer and slower")
        ->check(nebula::cli::numberIn(0.1, 4.0))
        ->capture_default_str();
    gas->add_option("--kappa-v", dustOpts.kappa_V,
                    "V-band extinction per n_H per pc [pc^-1 cm^3] (default: the input's); the "
                    "dust absorbs ionising photons with twice this cross-section")
        ->check(nebula::cli::numberIn(0.0, nebula::MAX_KAPPA_V, true));
    gas->add_flag("--no-dust-absorption", noDust, "dust does not absorb ionising photons");

    return nebula::cli::run(app, "nebionize", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        if (!abundances.empty()) {
            try {
                opts.abundances = nebula::parseAbundances(abundances, "--abundances");
            } catch (const nebula::Error& e) {
                throw nebula::UsageError(e.what());
            }
        }
        auto grids = nebula::readGrids(common.input, run);
        opts.stars = nebula::cli::loadStars(starOpts);
        opts.dust = dustOpts.apply(grids.dust(run));
        opts.dustAbsorbs = !noDust;
        opts.densityGrid = common.densityGrid;
        opts.onlyNew = common.onlyNew;
        nebula::ionize(grids, opts, run);
        nebula::writeGrids(common.output, std::move(grids), run);
    });
}
