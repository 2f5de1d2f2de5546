// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file spherical_harmonics.h
/// Real spherical harmonics and the Legendre moments of the phase functions: what the
/// multiply scattered light field is stored in (DESIGN §5b, nebscatter) and how a phase
/// function acts on it. With c_lm = integral of L(w) Y_lm(w) over the sphere, the light a
/// phase function p scatters into direction w_o is
///   integral of p(w_i . w_o) L(w_i) dw_i = sum_l p_l sum_m c_lm Y_lm(w_o)
/// (the addition theorem), p_l = 2 pi integral_-1^1 p(mu) P_l(mu) dmu (p_0 = 1).

#include "nebula/physics/dust.h"
#include "nebula/volume/volume.h"

#include <vector>

namespace nebula {

/// The largest degree l the field supports.
inline constexpr int SH_MAX_DEGREE = 4;

/// Number of real harmonics of degree 0..L: (L + 1)^2.
constexpr int shCount(int L)
{
    return (L + 1) * (L + 1);
}

/// Index of Y_lm (m = -l..l) in a coefficient array: l^2 + l + m.
constexpr int shIndex(int l, int m)
{
    return l * l + l + m;
}

/// The real spherical harmonics Y_lm(d) of degree 0..@p L (L <= SH_MAX_DEGREE) at the unit
/// direction @p d into @p out[shIndex(l, m)]: orthonormal on the sphere (integral of
/// Y_lm Y_l'm' = delta), Y_00 = 1 / (2 sqrt(pi)), Y_1,-1..1 proportional to y, z, x (the
/// usual real basis, Condon-Shortley phase left out). Throws Error for L outside [0, 4].
void realSphericalHarmonics(const Vec3& d, int L, double* out);

/// The Legendre polynomial P_l(x), l >= 0.
double legendre(int l, double x);

/// The Legendre moments p_0..p_L of @p model's phase function (g used by Henyey-Greenstein):
/// g^l for Henyey-Greenstein, (1, 0, 1/10, 0, ...) for Rayleigh, by exact Gauss-Legendre
/// quadrature for the hazy and murky Mie functions (polynomials in mu).
std::vector<double> phaseLegendreMoments(PhaseModel model, double g, int L);

} // namespace nebula
