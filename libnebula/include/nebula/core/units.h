// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file units.h
/// The one place for mathematical and physical constants and unit conversions (DESIGN §3).
/// Units used across nebula: lengths of the grids in parsecs [pc], number densities n_H
/// [cm^-3], cross-sections kappa_V [cm^2 per H] (so kappa_V n_H ds needs ds in cm:
/// PC_CM), luminosities in solar units [L_sun], wavelengths [nm], velocities [km/s].

namespace nebula {

inline constexpr double PI = 3.14159265358979323846;
inline constexpr double INV_FOUR_PI = 1.0 / (4.0 * PI);

// Physical constants: CODATA 2018, exact in the 2019 SI.
inline constexpr double PLANCK_H = 6.62607015e-34;          ///< Planck constant h [J s]
inline constexpr double SPEED_OF_LIGHT = 299792458.0;       ///< speed of light c [m/s]
inline constexpr double BOLTZMANN_K = 1.380649e-23;         ///< Boltzmann constant k [J/K]
inline constexpr double SPEED_OF_LIGHT_KMS = 299792.458;    ///< c [km/s]
inline constexpr double SPEED_OF_LIGHT_CGS = 2.99792458e10; ///< c [cm/s]

// Astronomical units: IAU 2015 resolutions B2 (parsec) and B3 (nominal solar luminosity).
inline constexpr double PC_M = 3.0856775814913673e16;  ///< parsec [m]
inline constexpr double PC_CM = 3.0856775814913673e18; ///< parsec [cm]
inline constexpr double L_SUN_W = 3.828e26;            ///< nominal solar luminosity [W]
inline constexpr double L_SUN_CGS = 3.828e33;          ///< nominal solar luminosity [erg/s]

inline constexpr double AU_CM = 1.495978707e13; ///< astronomical unit [cm] (IAU 2012 B2, exact)
inline constexpr double KPC_CM = 1e3 * PC_CM;   ///< kiloparsec [cm]
/// Nominal solar mass [g]: the IAU 2015 B3 nominal G M_sun (1.3271244e20 m^3 s^-2) over
/// CODATA 2018's G (6.67430e-11 m^3 kg^-1 s^-2).
inline constexpr double M_SUN_G = 1.3271244e20 / 6.67430e-11 * 1e3;
/// Mass of a hydrogen atom [g] (CODATA 2018: 1.00782503223 u, u = 1.66053906660e-24 g).
inline constexpr double M_H_G = 1.00782503223 * 1.66053906660e-24;

// Imported density cubes (DESIGN §10): the gas mass per hydrogen atom and the dust-to-gas
// mass ratio that turn mass densities into n_H [cm^-3].
inline constexpr double DEFAULT_MU = 1.4;           ///< mean gas mass per H atom [m_H]
inline constexpr double DEFAULT_DUST_TO_GAS = 0.01; ///< dust mass / gas mass
/// 1 M_sun pc^-3 in g cm^-3 (about 6.77e-23).
inline constexpr double MSUN_PC3_G_CM3 = M_SUN_G / (PC_CM * PC_CM * PC_CM);

/// W m^-2 -> L_sun pc^-2 (pc^2 / L_sun): turns a flux in SI into the renderer's units.
inline constexpr double WM2_TO_LSUN_PC2 = PC_M * PC_M / L_SUN_W;

// Observers' units (DESIGN §13).
inline constexpr double STEFAN_BOLTZMANN = 5.670374419e-8;  ///< sigma [W m^-2 K^-4] (CODATA 2018)
inline constexpr double JANSKY = 1e-26;                     ///< 1 Jy [W m^-2 Hz^-1]
inline constexpr double ARCSEC_RAD = PI / (180.0 * 3600.0); ///< one arcsecond [rad]
inline constexpr double DEG_RAD = PI / 180.0;               ///< one degree [rad]

/// Spectral radiance per nm: L_sun pc^-2 sr^-1 nm^-1 -> W m^-2 sr^-1 nm^-1.
inline constexpr double LSUN_PC2_TO_WM2 = L_SUN_W / (PC_M * PC_M);
/// Spectral radiance per nm at @p lambda_nm [nm]: L_sun pc^-2 sr^-1 nm^-1 -> I_nu [MJy sr^-1],
/// I_nu = I_lambda lambda^2 / c (I_lambda per m).
inline constexpr double perNmToMegajanskyPerSr(double lambda_nm)
{
    const double lambda_m = lambda_nm * 1e-9;
    return LSUN_PC2_TO_WM2 * 1e9 * lambda_m * lambda_m / SPEED_OF_LIGHT / (1e6 * JANSKY);
}

} // namespace nebula
