// SPDX-License-Identifier: Apache-2.0
// nebexport - a grid as a dense float32 cube (FITS, .npy, HDF5) for other programs.
#include "nebula/cli/cli.h"
#include "nebula/stages/export.h"

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::ExportOptions opts; // every default lives here
    std::string format;

    CLI::App app{
        "nebexport - a grid as a dense float32 cube: FITS, NumPy .npy or HDF5\n\n"
        "Examples:\n"
        "  nebexport -i nebula.vdb -o density.fits                # the density grid\n"
        "  nebexport -i lit.vdb --grid tau.star -o tau.npy\n"
        "  nebexport -i lit.vdb --grid density --bbox active -o density.h5\n"
        "  nebexport -i nebula.vdb --bbox 0,0,0,63,63,63 -o corner.fits\n"
        "  nebgen -o - | nebexport -i - -o - --format npy > density.npy\n\n"
        "Axes: voxel (x, y, z) of the box is FITS pixel (x+1, y+1, z+1) (NAXIS1 = x), numpy's\n"
        "a[x, y, z] and the HDF5 dataset's [x, y, z] as h5py reads it. FITS gets a linear WCS\n"
        "whose pixel -> world map is the grid's (the imported WCS where it still matches),\n"
        "BUNIT (density: cm-3, tau: none, temperature: K) and HISTORY; HDF5 the attributes\n"
        "voxel_size_pc, origin_pc (voxel (0, 0, 0)'s centre) and units. The box: --bbox auto\n"
        "(the cube the grid was imported from, else the active voxels' bounding box),\n"
        "active, or I0,J0,K0,I1,J1,K1 (index coordinates, inclusive; min <= max).\n"
        "Refused before the first byte: a cube larger than the output's free disk space or\n"
        "than the memory its writer holds (FITS and HDF5 are built in memory), and a NaN or\n"
        "infinite value in it.",
        "nebexport"};
    nebula::cli::addCommon(app, common, nebula::cli::INPUT | nebula::cli::OUTPUT);
    // -o's format is --format's or its name's: the cube writer checks the name.
    nebula::cli::outputFile(app.get_option("--output"), std::nullopt);
    app.add_option("--grid", opts.grid, "The FloatGrid written")->capture_default_str();
    app.add_option("--format", format,
                   nebula::cubeFormatList(true) + " (default: from -o's extension)")
        ->check(CLI::IsMember(nebula::cubeFormatNames(true)));
    app.add_option("--bbox", opts.bbox, "auto, active or I0,J0,K0,I1,J1,K1")->capture_default_str();
    app.add_option("--dataset", opts.dataset, "HDF5 dataset path (default: /<grid>)");

    return nebula::cli::run(app, "nebexport", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        if (!format.empty()) opts.format = &nebula::cubeFormat(format, "--format");
        opts.output = common.output;
        opts.validate();
        // A --format the name does not say: refused before the grids are read.
        if (opts.format && opts.format->fileFormat)
            nebula::checkOutputName(common.output, "-o", *opts.format->fileFormat);
        const auto grids = nebula::readGrids(common.input, run);
        nebula::exportCube(grids, opts, run);
    });
}
