// nebgen - procedural reflection nebula: fBm dust density, gas emission, stars.
#include "nebula/cli.h"
#include "nebula/generate.h"
#include "nebula/options.h"

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::NebulaParams params;      // every default lives here
    nebula::StarOptions starOpts;
    nebula::DustOptions dustOpts;
    bool noStars = false;

    CLI::App app{"nebgen - generate a procedural nebula (dust density, gas emission, stars)\n\n"
                 "Examples:\n"
                 "  nebgen -o nebula.vdb                         # the README's example nebula\n"
                 "  nebgen --res 256 --seed 7 --cavity 0.5 -o big.vdb\n"
                 "  nebgen --star a:0,0,0:5000:O9V --star b:2,1,0:30:A0V -o two.vdb\n"
                 "  nebgen -o - | nebillum -i - -o - | nebrender -i - -o frame.exr\n\n"
                 "Grids: density (n_H [cm^-3], fog volume), emission (linear units).\n"
                 "Metadata: nebula:stars (JSON), nebula:dust (JSON). Next step: nebillum.",
                 "nebgen"};
    nebula::cli::addCommon(app, common, nebula::cli::OUTPUT);
    app.add_option("--res", params.res, "Voxels along each axis")->capture_default_str();
    app.add_option("--size", params.size, "Edge length of the cube [pc]")->capture_default_str();
    app.add_option("--seed", params.seed, "Noise seed")->capture_default_str();
    app.add_option("--density", params.densityPeak, "Density scale: n_H [cm^-3] where the shaped noise is 1")
        ->capture_default_str();
    app.add_option("--frequency", params.frequency, "Noise features across the cube")
        ->capture_default_str();
    app.add_option("--octaves", params.fbm.octaves, "fBm octaves")->capture_default_str();
    app.add_option("--lacunarity", params.fbm.lacunarity, "fBm frequency ratio")
        ->capture_default_str();
    app.add_option("--gain", params.fbm.gain, "fBm amplitude ratio")->capture_default_str();
    app.add_option("--threshold", params.threshold, "fBm level below which there is no dust")
        ->capture_default_str();
    app.add_option("--contrast", params.contrast, "Gain on fBm above the threshold")
        ->capture_default_str();
    app.add_option("--exponent", params.exponent, "Density = (contrast (fBm - threshold))^exponent")
        ->capture_default_str();
    app.add_option("--warp", params.warp, "Domain-warp strength [cube edges]")
        ->capture_default_str();
    app.add_option("--envelope", params.envelope, "Cloud radius [cube edges]")
        ->capture_default_str();
    app.add_option("--emission", params.emissionPeak, "Peak gas emission (0: none)")
        ->capture_default_str();
    app.add_option("--emission-radius", params.emissionRadius,
                   "Radius of the emitting region [cube edges]")
        ->capture_default_str();
    app.add_option("--cavity", params.cavity, "Dust-free cavity around each star [pc] (0: none)")
        ->capture_default_str();
    nebula::cli::addStars(app, starOpts);
    app.add_flag("--no-stars", noStars, "No stars (default: the example's two stars)");
    nebula::cli::addDust(app, dustOpts);

    return nebula::cli::run(app, "nebgen", common, argc, argv, [&](nebula::Run& run) {
        nebula::cli::refuseBinaryToTerminal(common.output, "-o");
        params.stars = nebula::cli::loadStars(starOpts);
        if (params.stars.empty() && !noStars) params.stars = nebula::exampleStars();
        params.dust = dustOpts.apply(params.dust);
        nebula::Progress bar(run, "nebgen", std::uint64_t(params.res));
        auto grids = nebula::generateNebula(params, [&](std::size_t n) { bar.add(n); });
        nebula::writeGrids(common.output, std::move(grids), "nebgen", run.command());
    });
}
