// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file optical_depth.h
/// Optical depth from a star to every voxel (nebillum, DESIGN §2-3):
///     tau_V(x) = kappa_V * integral over the segment star -> x of n_H dl   [dl in pc]
/// of the trilinearly interpolated density, exactly: along a line the trilinear interpolant
/// is a cubic inside each lattice cell, so Simpson's rule per cell segment is exact.
/// Production: ColumnIntegrator walks the cells (Amanatides-Woo), loads each cell's corners
/// once and skips empty cells; opticalDepthAt() runs it for every output voxel in parallel.
/// Reference: columnDensityReference(), a short independent implementation for the tests.

#include "nebula/volume/volume.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace nebula {

/// Exact column density  integral n dl [cm^-3 pc] along the segment a -> b (index space)
/// of channel 0 of @p n (any number of channels: the renderers integrate their fields' density
/// in place), trilinear between lattice points, zero outside the lattice.
/// Along a line the trilinear interpolant is a cubic inside each cell, so Simpson's rule
/// per cell segment is exact (up to rounding).
double columnDensity(const SparseVolume& n, const Vec3& a, const Vec3& b);

/// A bit per lattice cell of @p n (at its lower corner's voxel index): whether any of its 8
/// corners is non-zero in channel 0, i.e. whether a column or a flight through the cell must
/// sample it. Parallel over the bricks; only bricks next to stored ones are read.
VoxelBits dustyCells(const SparseVolume& n);

/// columnDensity() for many segments through one volume (channel 0 of it; it keeps a
/// reference): the per-cell occupancy it skips empty cells with is built once, in parallel.
class ColumnIntegrator
{
public:
    explicit ColumnIntegrator(const SparseVolume& n);
    /// integral n dl [cm^-3 pc] from index-space point a to b (see columnDensity()).
    double operator()(const Vec3& a, const Vec3& b) const;
    /// Its bits: dustyCells() of the volume.
    const VoxelBits& dusty() const { return mDusty; }

private:
    const SparseVolume& mN;
    VoxelBits mDusty; ///< a bit per cell: any corner non-zero
};

/// Reference for tests: the same integral as columnDensity(), written as simply as possible
/// (sort every lattice-plane crossing, Simpson per piece on the interpolant of the cell that
/// holds it, so that a field which jumps at the lattice's faces is integrated right too).
double columnDensityReference(const SparseVolume& n, const Vec3& a, const Vec3& b);

/// Reference for tests: tau_V at every lattice point of @p n via columnDensityReference().
std::vector<float> opticalDepthReference(const SparseVolume& n, const Vec3& starIndex,
                                         double kappa_V);

/// Production: exact tau_V (one long characteristic each, ColumnIntegrator) at the lattice
/// points @p points (voxel indices, SparseVolume::index()), oneTBB-parallel and deterministic;
/// every other lattice point of the returned field is 0. Cost is proportional to the number
/// of points times their distance from the star (about 0.8 us a point at 256^3).
std::vector<float> opticalDepthAt(const SparseVolume& n, const Vec3& starIndex, double kappa_V,
                                  const std::vector<std::uint32_t>& points,
                                  const std::function<void(std::size_t)>& progress = {});

} // namespace nebula
