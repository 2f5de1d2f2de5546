// SPDX-License-Identifier: Apache-2.0
// nebimport - a dense density cube from another program (FITS, HDF5, .npy, RADMC-3D) as
// nebula's sparse density grid.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/stages/import.h"

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::ImportOptions opts; // every default lives here
    nebula::StarOptions starOpts;
    std::string format, voxelSize;
    std::array<double, 3> origin{0, 0, 0};

    CLI::App app{
        "nebimport - a simulation's density cube as nebula's density grid\n\n"
        "Examples:\n"
        "  nebimport -i cube.fits -o nebula.vdb                  # BUNIT and WCS from the file\n"
        "  nebimport -i sim.h5 --dataset /gas/rho --unit g/cm3 --voxel-size 0.02pc -o n.vdb\n"
        "  nebimport -i rho.npy --unit Msun/pc3 --voxel-size 500au --threshold 1 -o n.vdb\n"
        "  nebimport -i radmc_model/ --star s:0,0,0:1e4:B0V -o - | nebillum -i - -o lit.vdb\n"
        "  nebimport -i n.fits --temperature t.fits --velocity vx.fits,vy.fits,vz.fits \\\n"
        "            --emission halpha.fits --lines H-alpha:1 -o spectral.vdb\n\n"
        "Axes: voxel (x, y, z) = FITS (NAXIS1, NAXIS2, NAXIS3) = numpy a[x, y, z] (C or\n"
        "Fortran order) = HDF5 dataset [x, y, z] as h5py reads it = RADMC-3D (ix, iy, iz).\n"
        "Units: the file's (FITS BUNIT, an HDF5 attribute units/unit; RADMC-3D is dust mass\n"
        "density) or --unit: cm-3 (n_H), g/cm3 (gas; n_H = rho / (mu m_H)), g/cm3-dust\n"
        "(n_H = rho / (dust-to-gas mu m_H)), Msun/pc3 (gas). The grid is n_H [cm^-3].\n"
        "Geometry: the FITS WCS (CDELTn, CUNITn, CRPIXn, CRVALn; equal steps, no rotation),\n"
        "RADMC-3D's cell walls, HDF5 attributes voxel_size_pc and origin_pc, or\n"
        "--voxel-size; without an origin the cube is centred on (0, 0, 0). Values at or\n"
        "below --threshold stay inactive (background 0). Next step: nebillum.",
        "nebimport"};
    nebula::cli::addCommon(app, common, nebula::cli::OUTPUT);
    nebula::cli::inputFile(
        app.add_option("-i,--input", opts.input, "The cube: " + nebula::cubeFileNamesDoc())
            ->required());
    auto* grp = app.add_option_group("Cube");
    grp->add_option("--format", format, nebula::cubeFormatList(false) + " (default: from the name)")
        ->check(CLI::IsMember(nebula::cubeFormatNames(false)));
    grp->add_option("--hdu", opts.select.hdu,
                    "FITS: the HDU, by number (0 = primary) or EXTNAME (default: the first 3-D "
                    "image)");
    grp->add_option("--dataset", opts.select.dataset,
                    "HDF5: the dataset's path (default: the file's only 3-D dataset)");
    grp->add_option("--species", opts.select.species, "RADMC-3D: the dust species (1 = first)")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(1, 100000));
    grp->add_option("--unit", opts.unit,
                    "Density unit: cm-3, g/cm3, g/cm3-dust or Msun/pc3 (default: the file's; "
                    "a file that says another is an error)");
    grp->add_option("--mu", opts.mu, "Gas mass per H atom [m_H] (mass densities to n_H)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1e3, true));
    grp->add_option("--dust-to-gas", opts.dustToGas, "Dust-to-gas mass ratio (g/cm3-dust)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1e3, true));
    grp->add_option("--voxel-size", voxelSize,
                    "Voxel size with its unit: 0.01pc, 200au, 3e16cm, ... (replaces the file's)");
    auto* originOpt = nebula::cli::addVec3(
        *grp, "--origin", origin,
        "Centre of voxel (0, 0, 0) [pc] (default: the file's, else the cube centred on 0)");
    grp->add_option("--threshold", opts.threshold,
                    "n_H [cm^-3] at or below which a voxel stays inactive")
        ->capture_default_str()
        ->check(nebula::cli::nonNegative());
    grp->add_option("--temperature", opts.temperature,
                    "Temperature cube [K]: FILE[:HDU or dataset] -> grid temperature");
    grp->add_option("--velocity", opts.velocity,
                    "Velocity [km/s]: FX,FY,FZ (three cubes) or FILE[:HDU or dataset] (4-D, a "
                    "first or last axis of 3) -> Vec3f grid velocity");
    grp->add_option("--emission", opts.emission,
                    "The gas's emissivity cube: FILE[:HDU or dataset] -> grid emission (active\n"
                    "where > 0), its lines' summed emissivity for nebrender --spectral --fits");
    grp->add_option("--emission-unit", opts.emissionUnit,
                    "Its unit: Lsun/pc3/sr or erg/s/cm3/sr (default: the file's)");
    grp->add_option("--lines", opts.lines,
                    "What it emits, NAME:STRENGTH or LAMBDA_NM:STRENGTH, comma-separated (e.g.\n"
                    "H-alpha:1,H-beta:0.35; default: the renderer's)");
    grp->add_option("--grid", opts.gridName, "Name of the density grid")->capture_default_str();
    nebula::cli::addStars(app, starOpts);

    return nebula::cli::run(app, "nebimport", common, argc, argv, [&](nebula::Run& run) {
        nebula::refuseBinaryToTerminal(common.output, "-o");
        std::vector<nebula::cli::ExtraFile> inputs;
        for (const auto& [option, file] : nebula::importInputFiles(opts))
            inputs.push_back({option, file, false, std::nullopt});
        nebula::cli::checkFileOptions(app, common, inputs);
        if (!format.empty()) opts.select.format = &nebula::cubeFormat(format, "--format");
        if (!voxelSize.empty()) opts.voxelSize = nebula::parseLength(voxelSize, "--voxel-size");
        if (originOpt->count() > 0) opts.origin = origin;
        opts.stars = nebula::cli::loadStars(starOpts);
        auto grids = nebula::importCube(opts, run);
        nebula::writeGrids(common.output, std::move(grids), run);
    });
}
