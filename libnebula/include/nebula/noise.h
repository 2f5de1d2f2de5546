#pragma once
/// @file noise.h
/// Ken Perlin's improved noise (SIGGRAPH 2002, with his permutation table) and fractal
/// Brownian motion built on it. Used by nebgen for dust density and gas emission.

#include <cstdint>

namespace nebula {

/// Perlin's improved noise at (x, y, z), exactly as his 2002 reference Java code computes
/// it (same permutation table, fade 6t^5-15t^4+10t^3, 12 gradient directions). Range
/// about [-1, 1]; zero at every integer lattice point. NaN if a coordinate is not finite.
double perlinNoise(double x, double y, double z);

/// Parameters of fractal Brownian motion (sum of noise octaves).
struct FbmParams
{
    int octaves = 6;          ///< number of octaves [1, 16]
    double lacunarity = 2.0;  ///< frequency ratio between successive octaves
    double gain = 0.5;        ///< amplitude ratio between successive octaves
};

/// fBm: sum over octaves i of gain^i * perlinNoise(lacunarity^i * p + offset_i(seed)),
/// divided by the sum of the amplitudes so the result stays within about [-1, 1].
/// Each seed shifts every octave by its own pseudo-random offset, so different seeds give
/// independent-looking fields; the result depends on nothing but (x, y, z, params, seed).
/// Throws UsageError naming the parameter if octaves is outside [1, 16] or lacunarity or
/// gain is not a finite number > 0.
double fbm(double x, double y, double z, const FbmParams& params, std::uint64_t seed);

} // namespace nebula
