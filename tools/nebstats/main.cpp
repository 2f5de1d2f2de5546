// SPDX-License-Identifier: Apache-2.0
// nebstats - the statistics of observed clouds, measured on a grid: the column density's PDF,
// power spectrum and contour dimension, and the 3-D PDF of ln n.
#include "nebula/cli/cli.h"
#include "nebula/core/error.h"
#include "nebula/stages/stats.h"

#include <cstdio>
#include <iostream>
#include <string>

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::StatsOptions opts; // every default lives here
    std::string axis = "z", kRange;
    bool json = false;

    CLI::App app{
        "nebstats - the statistics of observed clouds, measured on a grid's column density\n\n"
        "Examples:\n"
        "  nebstats -i nebula.vdb                          # density projected along z\n"
        "  nebstats -i nebula.vdb --axis x --k-range 4,40\n"
        "  nebstats -i nebula.vdb --json > stats.json\n"
        "  nebgen --preset external --res 64 -o - | nebstats -i -\n"
        "  nebimport -i cube.fits -o cube.vdb && nebstats -i cube.vdb\n\n"
        "It sums the grid (default density, n_H [cm^-3]) along an axis over a box into a map\n"
        "of column density N (N_H [cm^-2]) and prints:\n"
        "  volume:   mean and sigma of ln n over the voxels > 0 (sigma_s of turbulence:\n"
        "            sigma_s^2 = ln(1 + b^2 M^2), Federrath et al. 2008);\n"
        "  pdf:      the lognormal fit of the PDF of ln(N/<N>) over the pixels with\n"
        "            N >= --pdf-floor <N> (<N>: the mean of the pixels > 0): a\n"
        "            parabola fitted to ln(count) over the bins about the peak with >= 10 %\n"
        "            of its count (observed: sigma 0.3-0.5 in quiescent clouds, Kainulainen\n"
        "            et al. 2009), and a power-law tail where the bins above the peak + sigma\n"
        "            hold >= 2x the lognormal (p(ln N) ~ N^s; p(N) ~ N^(s-1));\n"
        "  spectrum: the slope of the ring-averaged power spectrum of N over a k range in\n"
        "            cycles per map edge (default edge/40 to edge/4, a decade; observed -2.6\n"
        "            to -3, Miville-Deschenes et al. 2010), and the anisotropy: the mean power\n"
        "            across the map's first axis over the power along it;\n"
        "  contours: the perimeter-area dimension D (P ~ A^(D/2)) of the closed contours of N\n"
        "            at --levels levels from the 20th to the 90th percentile (observed\n"
        "            1.3-1.4, Falgarone et al. 1991).\n"
        "Map axes: along z the map is (x, y), along y (x, z), along x (y, z). Maps of at\n"
        "most 8192 pixels a side; active tiles are summed whole, not voxel by voxel.",
        "nebstats"};
    nebula::cli::addCommon(app, common, nebula::cli::INPUT);
    app.add_option("--grid", opts.grid, "The FloatGrid projected")->capture_default_str();
    app.add_option("--axis", axis, "Line of sight: x, y or z")
        ->capture_default_str()
        ->check(CLI::IsMember({"x", "y", "z"}));
    app.add_option("--bbox", opts.bbox,
                   "The box projected: auto (an imported cube's, else the active voxels'), "
                   "active, or I0,J0,K0,I1,J1,K1 (inclusive)")
        ->capture_default_str();
    app.add_option("--k-range", kRange,
                   "KMIN,KMAX: the power spectrum's fitted range [cycles per map edge] "
                   "(default: edge/40,edge/4)");
    app.add_option("--bin-width", opts.binWidth, "The PDF's bins in ln N")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1.0, true));
    app.add_option("--pdf-floor", opts.pdfFloor,
                   "The PDF's pixels: N >= this times the mean column (a completeness limit)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1.0));
    app.add_option("--levels", opts.levels, "Contour levels of the perimeter-area fit")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(1, 100));
    app.add_option("--min-area", opts.minArea, "Smallest contour fitted [pixels]")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(1, 1000000));
    app.add_flag("--json", json, "Print JSON (with the ring power spectrum) instead of text");

    return nebula::cli::run(app, "nebstats", common, argc, argv, [&](nebula::Run& run) {
        opts.axis = axis == "x" ? 0 : axis == "y" ? 1 : 2;
        if (!kRange.empty()) {
            const auto comma = kRange.find(',');
            try {
                if (comma == std::string::npos) throw std::invalid_argument(kRange);
                std::size_t a = 0, b = 0;
                const std::string lo = kRange.substr(0, comma), hi = kRange.substr(comma + 1);
                opts.kMin = std::stod(lo, &a);
                opts.kMax = std::stod(hi, &b);
                if (a != lo.size() || b != hi.size()) throw std::invalid_argument(kRange);
            } catch (const std::logic_error&) {
                throw nebula::UsageError("--k-range must be KMIN,KMAX (two numbers), got '" +
                                         kRange + "'");
            }
            if (opts.kMin == 0.0 && opts.kMax == 0.0) opts.kMax = -1.0; // refused, not default
        }
        opts.validate();
        const auto grids = nebula::readGrids(common.input, run);
        const auto stats = nebula::cloudStatistics(grids, opts);
        const std::string text = json ? nebula::statsJson(stats) : nebula::statsReport(stats);
        std::fwrite(text.data(), 1, text.size(), stdout);
        if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
            throw nebula::Error("writing the report to standard output failed");
        }
    });
}
