// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file import.h
/// nebimport's entry point: a dense cube from another program (FITS, HDF5, .npy, RADMC-3D)
/// as the sparse `density` grid, with optional `temperature` and `velocity` (DESIGN §10).

#include "nebula/core/run.h"
#include "nebula/core/units.h"
#include "nebula/io/cube_io.h"
#include "nebula/io/grid_io.h"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace nebula {

struct ImportOptions
{
    std::string input;      ///< the cube: a file, or a RADMC-3D folder
    CubeSelect select;      ///< format, FITS HDU, HDF5 dataset, RADMC-3D species
    std::string unit;       ///< --unit: the cube's density unit; "" = the file's own
    double mu = DEFAULT_MU; ///< gas mass per H atom [m_H] (mass densities -> n_H)
    double dustToGas = DEFAULT_DUST_TO_GAS;      ///< dust mass / gas mass (dust densities -> n_H)
    std::optional<double> voxelSize;             ///< [pc], replaces the file's
    std::optional<std::array<double, 3>> origin; ///< centre of voxel (0, 0, 0) [pc]
    double threshold = 0.0;   ///< n_H [cm^-3] at or below which a voxel stays inactive
    std::string temperature;  ///< FILE[:HDU|DATASET] of temperatures [K], "" none
    std::string velocity;     ///< FX,FY,FZ (three cubes) or FILE[:HDU|DATASET] (4-D) [km/s]
    std::string emission;     ///< FILE[:HDU|DATASET] of the gas's emissivity, "" none
    std::string emissionUnit; ///< its unit (--emission-unit); "" = the file's own
    std::string lines;        ///< --lines: the emission grid's nebula:lines, "" none
    std::string gridName = "density";
    std::vector<Star> stars; ///< nebula:stars (may be empty)

    /// Throws UsageError naming the option: mu, dust-to-gas, voxel size <= 0 or not finite,
    /// a negative or non-finite threshold, an unknown --unit or --emission-unit, --lines that
    /// do not parse, --emission-unit or --lines without --emission.
    void validate() const;
};

/// "0.01pc", "200au", "3e16cm", "1.5e3m", "2km", "0.1kpc" in pc. Throws UsageError naming
/// @p option: no unit, an unknown one, a value <= 0 or not finite.
double parseLength(const std::string& text, const std::string& option);

/// Splits "FILE:SELECTOR" (a FITS HDU, an HDF5 dataset) where FILE exists and FILE:SELECTOR
/// does not; otherwise {text, ""}.
std::pair<std::string, std::string> splitCubeSelector(const std::string& text);

/// The files @p opts names, as (option, file) pairs: -i, and the FILEs of --temperature,
/// --emission and --velocity (each of FX,FY,FZ), selectors removed; for the output check
/// (cli::checkFileOptions()).
std::vector<std::pair<std::string, std::string>> importInputFiles(const ImportOptions& opts);

/// The factor that turns an emissivity in @p unit ("Lsun/pc3/sr", "erg/s/cm3/sr") into
/// L_sun pc^-3 sr^-1; nullopt for an unknown unit.
std::optional<double> emissivityUnitFactor(const std::string& unit);

/// The cube as grids: `density` (n_H [cm^-3], fog volume, active where > threshold), and
/// `temperature` [K], `velocity` [km/s] on the density's active voxels if asked for, and
/// `emission` (the gas's emissivity [L_sun pc^-3 sr^-1], active where > 0, with
/// nebula:lines from opts.lines) if asked for; the
/// transform from the file's geometry or the options; `nebula:stars`, `nebula:dust`
/// (defaults) and the grid metadata `nebula:cube` (source, format, unit, dims, WCS) that
/// nebexport uses to write the cube back. The cube is read plane by plane into the tree: no
/// dense copy. Throws Error naming the file: NaN or infinite values, negative densities or
/// temperatures, unit disagreements, cubes of different shapes.
GridSet importCube(const ImportOptions& opts, const Run& run);

} // namespace nebula
