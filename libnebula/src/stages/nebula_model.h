#pragma once
/// @file nebula_model.h
/// (private to stages/) What generateNebula() asks of a nebula's model: the fields at a voxel,
/// and whether a box of voxels may hold any of them (the sparse generation's test).

#include "nebula/stages/generate.h"

#include <openvdb/openvdb.h>

#include <memory>

namespace nebula::detail {

class NebulaModel
{
public:
    virtual ~NebulaModel() = default;
    /// The fields at voxel (i, j, k) of a res^3 cube.
    virtual NebulaVoxel at(int i, int j, int k, bool withOiii) const = 0;
    /// False only if every voxel centre of [lo, hi] (inclusive) has no dust and no emission.
    virtual bool mayHoldNebula(const openvdb::Coord& lo, const openvdb::Coord& hi) const = 0;
};

/// A turbulent preset's model (presets.cpp). Without @p withLattice it answers only
/// mayHoldNebula() (generateBytes() needs no lattice).
std::unique_ptr<NebulaModel> makePresetModel(const NebulaParams& params, bool withLattice);

/// Memory a turbulent preset's model holds while generating [bytes] (its lattice).
double presetModelBytes(const NebulaParams& params);

/// Throws UsageError naming nebgen's option for a preset parameter out of range.
void validatePresetParams(const NebulaParams& params);

} // namespace nebula::detail
