// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file noise.h
/// Ken Perlin's improved noise (SIGGRAPH 2002, with his permutation table) and fractal
/// Brownian motion built on it. Used by nebgen for dust density and gas emission.

#include <array>
#include <cstdint>

namespace nebula {

/// Perlin's improved noise at (x, y, z), exactly as his 2002 reference Java code computes
/// it (same permutation table, fade 6t^5-15t^4+10t^3, 12 gradient directions). Range
/// about [-1, 1]; zero at every integer lattice point. NaN if a coordinate is not finite.
double perlinNoise(double x, double y, double z);

/// Parameters of fractal Brownian motion (sum of noise octaves).
struct FbmParams
{
    int octaves = 6;         ///< number of octaves [1, 16]
    double lacunarity = 2.0; ///< frequency ratio between successive octaves
    double gain = 0.5;       ///< amplitude ratio between successive octaves
};

/// fBm: sum over octaves i of gain^i * perlinNoise(lacunarity^i * p + offset_i(seed)),
/// divided by the sum of the amplitudes so the result stays within about [-1, 1].
/// Each seed shifts every octave by its own pseudo-random offset, so different seeds give
/// independent-looking fields; the result depends on nothing but (x, y, z, params, seed).
/// Throws UsageError naming the parameter if octaves is outside [1, 16] or lacunarity or
/// gain is not a finite number > 0.
double fbm(double x, double y, double z, const FbmParams& params, std::uint64_t seed);

/// A noise value and its gradient d/d(x, y, z).
struct NoiseGradient
{
    double value = 0.0;
    std::array<double, 3> gradient{0, 0, 0};
};

/// perlinNoise() and its analytic gradient: the chain rule through the fade curves
/// (fade'(t) = 30 t^2 (t - 1)^2) and the corners' gradient dot products, no finite
/// differences. The value is computed exactly as perlinNoise() computes it. Improved noise
/// is C2 (the quintic fade has zero second derivatives at the lattice planes), so the
/// gradient is continuous. NaN if a coordinate is not finite.
NoiseGradient perlinNoiseGradient(double x, double y, double z);

/// fbm() and its analytic gradient (same octaves, offsets and normalisation; the value
/// equals fbm()'s). Throws UsageError as fbm() does.
NoiseGradient fbmGradient(double x, double y, double z, const FbmParams& params,
                          std::uint64_t seed);

/// Curl noise (Bridson, Hourihan & Nordenstam 2007, "Curl-noise for procedural fluid
/// flow", SIGGRAPH): the curl of a vector potential psi whose three components are fBm
/// fields with decorrelated seeds derived from @p seed, v = curl psi. Computed from the
/// analytic gradients, so div v = 0 up to rounding (psi is C2, its mixed second
/// derivatives agree); the field is in noise units (per unit of x, y, z), unnormalised.
/// Throws UsageError as fbm() does.
std::array<double, 3> curlNoise(double x, double y, double z, const FbmParams& params,
                                std::uint64_t seed);

} // namespace nebula
