#pragma once
/// @file optical_depth.h
/// Optical depth from a star to every voxel (nebillum, DESIGN §2-3):
///     tau_V(x) = kappa_V * integral over the segment star -> x of n_H dl   [dl in pc]
/// of the trilinearly interpolated density. Two implementations: an exact, simple reference
/// (one long characteristic per voxel, integrated exactly cell by cell) and the fast
/// production field (shell-ordered short characteristics of length L, see the .cpp).

#include "nebula/volume.h"

#include <functional>
#include <vector>

namespace nebula {

/// Exact column density  integral n dl [cm^-3 pc] along the segment a -> b (index space)
/// of channel 0 of @p n, trilinear between lattice points, zero outside the lattice.
/// Along a line the trilinear interpolant is a cubic inside each cell, so Simpson's rule
/// per cell segment is exact (up to rounding).
double columnDensity(const DenseVolume& n, const Vec3& a, const Vec3& b);

/// Reference: tau_V at every lattice point of @p n, one exact long characteristic each.
/// O(N^4); for tests and accuracy measurements on small grids.
std::vector<float> opticalDepthReference(const DenseVolume& n, const Vec3& starIndex,
                                         double kappa_V);

/// Parameters of the fast optical-depth field.
struct OpticalDepthParams
{
    /// Length L [voxels] of the exact segment integrated back from each voxel before the
    /// field is interpolated; >= 4 (the shell ordering needs L > 2 sqrt 3). Larger is more
    /// accurate and slower.
    double segment = 8.0;
};

/// Fast tau_V at every lattice point of @p n: voxels are processed in shells of increasing
/// Chebyshev distance from the star; each voxel integrates the last @p params.segment voxels
/// of its ray exactly and adds the trilinearly interpolated tau at the start of that
/// segment, which lies in an earlier shell. Voxels within 3 segments of the star, where tau
/// is a cone that interpolation resolves poorly, integrate their whole ray exactly. Parallel within a shell (oneTBB), deterministic
/// for any thread count. @p progress (optional) is told how many voxels are done.
std::vector<float> opticalDepthField(const DenseVolume& n, const Vec3& starIndex,
                                     double kappa_V, const OpticalDepthParams& params,
                                     const std::function<void(std::size_t)>& progress = {});

} // namespace nebula
