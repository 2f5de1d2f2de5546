// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file volume_vdb.h
/// Conversions between OpenVDB grids and the compact SparseVolume of volume.h.

#include "nebula/volume/volume.h"

#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace nebula {

/// The affine index-to-world map of @p transform (which must be linear).
Affine affineFromTransform(const openvdb::math::Transform& transform);

/// The bounding box of the active values of @p grids (union), grown by @p pad voxels.
openvdb::CoordBBox activeBounds(const std::vector<openvdb::FloatGrid::ConstPtr>& grids, int pad);

/// An all-zero SparseVolume of @p channels channels over @p bounds (no brick stored). Throws
/// Error, starting with @p what (the file and grids) and giving both sizes, if its table of
/// bricks would not fit in memory (requireMemory()), or an axis is longer than an int.
SparseVolume emptyVolume(const openvdb::CoordBBox& bounds, int channels, const std::string& what);

/// The memory [bytes] of a SparseVolume of @p channels channels over @p bounds holding the
/// active values of @p grids: the bricks their active leaves and tiles touch (an upper bound).
double volumeBytes(const std::vector<openvdb::FloatGrid::ConstPtr>& grids,
                   const openvdb::CoordBBox& bounds, int channels);

/// A SparseVolume over @p bounds with one channel per grid (in order), holding each grid's
/// active values (voxels and tiles) and zero elsewhere. Every grid must share the first
/// grid's transform; otherwise Error naming @p source and the grid. Memory follows the grids'
/// active leaves (volumeBytes(), checked with requireMemory() first: Error with both sizes).
SparseVolume volumeFromGrids(const std::vector<openvdb::FloatGrid::ConstPtr>& grids,
                             const openvdb::CoordBBox& bounds, const std::string& source);

/// Adds float(@p factor * value * @p scale) of each active value (voxel or tile) of @p grid
/// to channel @p channel of @p vol's lattice point at the same index (those on the lattice).
/// The caller checks that the grid's transform is the volume's.
void addGridToVolume(SparseVolume& vol, const openvdb::FloatGrid& grid, int channel, double factor,
                     double scale = 1.0);

/// A FloatGrid with the active topology and transform of @p topology whose active values
/// come from @p field, a scalar per lattice point of @p lattice (zero off the lattice).
openvdb::FloatGrid::Ptr gridFromField(const SparseVolume& lattice, const std::vector<float>& field,
                                      const openvdb::FloatGrid& topology);

} // namespace nebula
