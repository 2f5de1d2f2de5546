// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file ionize.h
/// nebionize's entry point: the ionisation state of the gas and its line emission, from the
/// stars and the density (DESIGN §16).

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/physics/ionization.h"

namespace nebula {

struct IonizeOptions
{
    std::vector<Star> stars;             ///< replaces the input's nebula:stars when not empty
    DustParams dust;                     ///< kappa_V: the dust's absorption of ionising photons
    bool dustAbsorbs = true;             ///< whether dust absorbs ionising photons
    std::string densityGrid = "density"; ///< the gas density grid (n_H [cm^-3])
    /// T_e of the ionised gas [K]; 0: each voxel's from the thermal balance (IonizationParams::
    /// thermalBalance)
    double electronTemperature = 0.0;
    /// A grid of the gas's electron temperature [K] ("": none); where it is 0 or inactive,
    /// electronTemperature or the thermal balance. Not nebgen's `temperature`, the dust's.
    std::string temperatureGrid;
    Abundances abundances;   ///< He, N, O, S relative to H
    double raySpacing = 0.5; ///< rays split when wider than this [voxels]
    bool onlyNew = false;    ///< write only the new grids
};

/// Dust absorption cross-section per H atom for ionising photons [cm^2]: twice the V-band
/// extinction per H (kappa_V / pc): about 1e-21 cm^2 for kappa_V = 1.5e-3 pc^-1 cm^3, the value
/// AGN2 §7.3 quotes for the ionising continuum.
double ionizingDustCrossSection(const DustParams& dust);

/// The grids nebionize writes (DESIGN §2): ionisation fractions and line emissivities.
inline constexpr const char* HII_GRID = "ionization.hii";            ///< H+ / H
inline constexpr const char* OIII_FRACTION_GRID = "ionization.oiii"; ///< O++ / O
inline constexpr const char* EMISSION_H_GRID = "emission";           ///< H-alpha and H-beta
inline constexpr const char* EMISSION_OIII_GRID = "emission.oiii";
inline constexpr const char* EMISSION_NII_GRID = "emission.nii";
inline constexpr const char* EMISSION_SII_GRID = "emission.sii";
inline constexpr const char* EMISSION_OI_GRID = "emission.oi";

/// What ionize() found, per star and overall (for -v and the tests).
struct IonizeReport
{
    std::vector<StarPhotons> photons; ///< per star
    std::vector<IonizingRates> rates; ///< per star
    int iterations = 0;
    double recombinations = 0.0;  ///< sum over voxels of alpha_B n_e n_p x V [s^-1]
    double meanTemperature = 0.0; ///< T_e weighted by n_e n_p x V [K]
};

/// Ionises the density of @p grids by its stars and adds (or replaces) the grids above plus
/// `emission` (H-alpha and H-beta), each emission grid in L_sun pc^-3 sr^-1 with its
/// nebula:lines. Throws Error on a missing or bad density grid, voxels that are not cubes, or
/// no stars.
IonizeReport ionize(GridSet& grids, const IonizeOptions& opts, const Run& run);

} // namespace nebula
