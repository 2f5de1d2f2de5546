// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file motion.h
/// Gas motion (DESIGN §2, §7): the `velocity` field [km/s] in world axes (parsec world) as a
/// sum of simple models. Reading and checking a velocity grid is io/spectral_grids.h.

#include <array>
#include <cstdint>
#include <string>

namespace nebula {

/// The velocity models nebgen --spectral sums. Every speed is in km/s, every length in pc.
struct MotionParams
{
    /// Homologous (Hubble-flow-like) expansion about `centre` [km/s]:
    /// v = expansion * (x - centre) / radius, i.e. speed `expansion` at distance `radius`.
    /// Negative values contract.
    double expansion = 0.0;
    /// Solid-body rotation about the axis through `centre` along `axis` [km/s]:
    /// v = rotation * (axis x (x - centre)) / radius, speed `rotation` at distance `radius`
    /// from the axis. Right-handed: positive turns counter-clockwise seen from +axis.
    double rotation = 0.0;
    std::array<double, 3> axis{0, 1, 0}; ///< rotation axis (any length > 0; normalised)
    /// RMS speed [km/s] of a divergence-free turbulent field: curl noise (Bridson et al.
    /// 2007) of a potential made of three decorrelated Perlin fBm fields, 4 octaves,
    /// lacunarity 2, gain 2^(-4/3) (so the velocity's octaves fall as 2^(-1/3), the
    /// Kolmogorov scaling of velocity with scale, v_l ~ l^(1/3)), scaled so that its RMS
    /// over the cube is `turbulence`. Must be >= 0.
    double turbulence = 0.0;
    double turbulenceFrequency = 2.0;      ///< base features of the turbulence across the cube, > 0
    std::array<double, 3> centre{0, 0, 0}; ///< [pc] (nebgen: the first star by default)
    double radius = 1.0;                   ///< reference distance of the speeds above [pc], > 0
    std::uint64_t seed = 1;                ///< turbulence seed

    /// Throws UsageError naming nebgen's option if a value is not finite, the axis is zero,
    /// the radius or frequency not > 0, or the turbulence negative.
    void validate() const;
};

/// The velocity field of MotionParams. The cube of edge @p cubeSize [pc] is centred on
/// the world origin (as nebgen's): the turbulence noise is scaled to it and its RMS
/// normalisation is measured once, at construction, on a fixed 32^3 lattice of cell
/// centres over the cube (serially: the same field whatever the thread count).
class MotionField
{
public:
    /// Throws UsageError as MotionParams::validate(), or if @p cubeSize is not > 0.
    MotionField(const MotionParams& params, double cubeSize);

    /// Velocity [km/s] in world axes at world point @p x [pc]. Thread-safe.
    std::array<double, 3> operator()(const std::array<double, 3>& x) const;

    /// The factor from raw curl noise to km/s (0 without turbulence).
    double turbulenceScale() const { return mTurbulenceScale; }

private:
    std::array<double, 3> turbulent(const std::array<double, 3>& x) const;

    MotionParams mParams;
    std::array<double, 3> mAxis; ///< unit vector
    double mCubeSize;
    double mTurbulenceScale = 0.0;
};

} // namespace nebula
