// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file nebula_model.h
/// (private to stages/) What generateNebula() asks of a nebula's model: the fields at a voxel,
/// and whether a box of voxels may hold any of them (the sparse generation's test).

#include "nebula/stages/generate.h"

#include <openvdb/openvdb.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <vector>

namespace nebula::detail {

class NebulaModel
{
public:
    virtual ~NebulaModel() = default;
    /// The fields at voxel (i, j, k) of a res^3 cube.
    virtual NebulaVoxel at(int i, int j, int k, bool withOiii) const = 0;
    /// False only if every voxel centre of [lo, hi] (inclusive) has no dust and no emission.
    virtual bool mayHoldNebula(const openvdb::Coord& lo, const openvdb::Coord& hi) const = 0;
    /// Memory the model holds while generating, besides the grids [bytes] (a preset's
    /// turbulence lattice, also when this model was made without it).
    virtual double heldBytes() const { return 0.0; }
};

/// A turbulent preset's model (presets.cpp). Without @p withLattice it answers only
/// mayHoldNebula() and heldBytes() (generateBytes() needs no lattice).
std::unique_ptr<NebulaModel> makePresetModel(const NebulaParams& params, bool withLattice);

// ---- What both models share. ----

/// 0 below e0, 1 above e1, Hermite's cubic between.
inline double smoothstep(double e0, double e1, double x)
{
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

/// The centre of voxel @p i of a @p res^3 cube, in cube units ([-0.5, 0.5]).
inline double cubeCoordinate(int i, int res)
{
    return (i + 0.5) / res - 0.5;
}

/// The voxel centres of [lo, hi] (inclusive, index space) as a box in cube units.
struct CubeBox
{
    std::array<double, 3> lo{}, hi{};
};
inline CubeBox cubeBox(const openvdb::Coord& lo, const openvdb::Coord& hi, int res)
{
    CubeBox box;
    for (int d = 0; d < 3; ++d) {
        box.lo[std::size_t(d)] = cubeCoordinate(lo[d], res);
        box.hi[std::size_t(d)] = cubeCoordinate(hi[d], res);
    }
    return box;
}

/// The least distance from @p c to @p box.
inline double minDistance(const std::array<double, 3>& c, const CubeBox& box)
{
    double s = 0.0;
    for (std::size_t d = 0; d < 3; ++d) {
        const double e = std::max({box.lo[d] - c[d], 0.0, c[d] - box.hi[d]});
        s += e * e;
    }
    return std::sqrt(s);
}

/// The greatest distance from @p c to @p box.
inline double maxDistance(const std::array<double, 3>& c, const CubeBox& box)
{
    double s = 0.0;
    for (std::size_t d = 0; d < 3; ++d) {
        const double e = std::max(std::abs(box.lo[d] - c[d]), std::abs(box.hi[d] - c[d]));
        s += e * e;
    }
    return std::sqrt(s);
}

/// --cavity: @p value times smoothstep(0.5 cavity, cavity, distance) for each star, the
/// distance from @p xPc [pc] to the star; unchanged if @p cavity is not > 0.
inline void clearStarCavities(double& value, const std::array<double, 3>& xPc,
                              const std::vector<Star>& stars, double cavity)
{
    if (!(cavity > 0.0)) return;
    for (const auto& s : stars) {
        const double sx = xPc[0] - s.position[0], sy = xPc[1] - s.position[1],
                     sz = xPc[2] - s.position[2];
        value *= smoothstep(0.5 * cavity, cavity, std::sqrt(sx * sx + sy * sy + sz * sz));
    }
}

/// Throws UsageError naming nebgen's option for a preset parameter out of range.
void validatePresetParams(const NebulaParams& params);

} // namespace nebula::detail
