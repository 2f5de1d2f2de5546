// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file blackbody.h
/// Planck's law, the one black body of nebula (DESIGN §3, §7): star colours, the spectral
/// renderer's starlight and the gas's Kirchhoff emission all use these.

#include "nebula/core/units.h"

#include <cmath>

namespace nebula {

/// Planck's law B_lambda(T) [W m^-2 sr^-1 m^-1] at wavelength @p lambda_m [m] and
/// temperature @p T [K]: 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1) (CODATA 2018 h,
/// c, k). Throws Error unless both are finite and > 0.
double planck(double lambda_m, double T);

/// Planck's spectral radiance B_lambda(T) per nm [W m^-2 sr^-1 nm^-1] at @p lambda_nm [nm]
/// and temperature @p T [K]: planck() divided by 1e9. Throws Error unless both are finite
/// and > 0.
double planckPerNm(double lambda_nm, double T);

/// planckPerNm() without argument checks, for hot loops whose arguments are validated once
/// (lambda_nm > 0, T > 0). The same law, with the constants folded: C1 = 2 h c^2, C2 = h c/k.
inline double planckPerNmUnchecked(double lambda_nm, double T)
{
    constexpr double C1 = 2.0 * PLANCK_H * SPEED_OF_LIGHT * SPEED_OF_LIGHT; // 2 h c^2
    constexpr double C2 = PLANCK_H * SPEED_OF_LIGHT / BOLTZMANN_K;          // h c / k [m K]
    const double l = lambda_nm * 1e-9;
    const double l2 = l * l;
    return C1 / (l2 * l2 * l) / std::expm1(C2 / (l * T)) * 1e-9;
}

/// The spectral luminosity [L_sun nm^-1] at @p lambda_nm [nm] of a black body of
/// temperature @p T [K] whose bolometric luminosity is @p L [L_sun]:
/// L pi B_lambda(T) / (sigma T^4) (DESIGN §13: the stars of calibrated images). Throws Error
/// unless lambda_nm and T are finite and > 0.
inline double blackbodySpectralLuminosity(double L, double T, double lambda_nm)
{
    return L * PI * planckPerNm(lambda_nm, T) / (STEFAN_BOLTZMANN * T * T * T * T);
}

} // namespace nebula
