#pragma once
/// @file generate.h
/// Procedural nebula (nebgen): fBm dust density n_H, gas emission, stars.

#include "nebula/dust.h"
#include "nebula/grid_io.h"
#include "nebula/noise.h"
#include "nebula/stars.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace nebula {

/// Every parameter of a procedural nebula. World space is centred on the origin.
struct NebulaParams
{
    int res = 128;                 ///< voxels along each axis
    double size = 10.0;            ///< edge length of the cube [pc]
    std::uint64_t seed = 1;        ///< noise seed
    double densityPeak = 4000.0;   ///< n_H where the shaped noise is 1 [cm^-3]
    double frequency = 1.8;        ///< noise features across the cube (base octave)
    FbmParams fbm{6, 2.0, 0.55};   ///< octaves, lacunarity, gain
    double threshold = 0.05;       ///< fBm level below which there is no dust (voids)
    double contrast = 3.0;         ///< gain applied to fBm above the threshold
    double exponent = 2.0;         ///< shaped density = (contrast (fbm - threshold))^exponent
    double warp = 0.35;            ///< domain-warp strength (fraction of the cube) for wisps
    double envelope = 0.5;         ///< radius where the soft envelope reaches 0 [cube edges]
    double emissionPeak = 0.4;     ///< emission where its shaped noise is 1 [linear units]
    double emissionRadius = 0.3;   ///< radius of the emitting region [cube edges]
    double cavity = 0.6;           ///< radius of the dust-free cavity around each star [pc]
    std::vector<Star> stars;       ///< point sources (travel as nebula:stars)
    DustParams dust;               ///< travels as nebula:dust
};

/// The stars of the README's example nebula: a hot B star inside the cloud and a cooler
/// A star near its edge.
std::vector<Star> exampleStars();

/// Builds the `density` (fog volume, n_H [cm^-3]) and `emission` grids and sets the stars
/// and dust metadata. Zero voxels are inactive, trees pruned; the result depends only on
/// the parameters, not on the thread count. @p progress gets z-slices done.
GridSet generateNebula(const NebulaParams& params,
                       const std::function<void(std::size_t)>& progress = {});

} // namespace nebula
