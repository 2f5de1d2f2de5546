// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file generate.h
/// Procedural nebula (nebgen): fBm dust density n_H, gas emission, stars, and with
/// --spectral the dust/gas temperature, the gas velocity and [O III] emission (DESIGN §2, §7).

#include "nebula/io/grid_io.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/lines.h"
#include "nebula/physics/motion.h"
#include "nebula/physics/noise.h"
#include "nebula/physics/stars.h"
#include "nebula/physics/turbulence.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace nebula {

/// Radial envelope of the emission (its noise texture is the same for both).
enum class EmissionShape {
    /// A ball about the cube centre: full to 0.4 emissionRadius, zero beyond emissionRadius.
    Sphere,
    /// A shell about the motion centre: envelope 1 - smoothstep(0, w R, |d - R|) at distance
    /// d, R = emissionRadius, w = shellWidth, so the shell's full width at half maximum is
    /// w R and it vanishes beyond R (1 +- w). Parts outside the cube are cut off.
    Shell,
};

/// The nebula's model (presets.h): the seeds' fBm cloud, or a turbulent lognormal cloud in
/// a preset's geometry.
enum class NebulaPreset {
    Fbm,        ///< domain-warped fBm in a soft envelope (the seeds' model; the default)
    Box,        ///< a periodic box of lognormal turbulence filling the cube, no geometry
    Reflection, ///< a B star in a cavity at the edge of a turbulent cloud (NGC 1999, NGC 7023)
    External,   ///< a striated cloud lit by a star outside it (Merope nebula, IC 2118)
    Pillars,    ///< dense columns pointing at an O star, ionised rims (M16)
    Bubble,     ///< a wind-blown shell broken on one side around an O star (NGC 7635)
    Globule,    ///< a Bok globule with a dark core, a bright rim and a tail (IC 1396A, B68)
    Bipolar,    ///< a young star's outflow cavities in a flattened envelope (NGC 2261)
    Hii,        ///< an O cluster's blister on the near face of a molecular cloud (M42, M8)
};

/// The spectral grids of nebgen --spectral.
struct SpectralParams
{
    bool enabled = false; ///< write `temperature` and `velocity` (and `emission.oiii`)
    /// Ionised-gas temperature [K] set where emission > 0 (e.g. 8000); 0 = off, the dust
    /// temperature everywhere.
    double gasTemperature = 0.0;
    /// [O III] emission relative to `emission` (0 = no `emission.oiii` grid):
    /// emission.oiii = oiii * emission * s(d), with the ionisation stratification
    /// s = 1 - smoothstep(r0 + 0.5 (r1 - r0), r0 + 0.8 (r1 - r0), d), d the distance from the
    /// motion centre and [r0, r1] the emission's radial extent: [0, R] for a sphere (so s
    /// falls from 1 at 0.5 R to 0 at 0.8 R), [R (1 - w), R (1 + w)] for a shell (the inner
    /// half of the shell). O++ needs harder photons than H+, so it sits nearer the star.
    double oiii = 0.0;
    /// Velocity models; its centre, radius and seed are replaced by motionParams().
    MotionParams motion;
};

/// Every parameter of a procedural nebula. World space is centred on the origin.
struct NebulaParams
{
    int res = 128;               ///< voxels along each axis
    double size = 10.0;          ///< edge length of the cube [pc]
    std::uint64_t seed = 1;      ///< noise seed
    double densityPeak = 4000.0; ///< n_H where the shaped noise is 1 [cm^-3]
    double frequency = 1.8;      ///< noise features across the cube (base octave)
    FbmParams fbm{6, 2.0, 0.55}; ///< octaves, lacunarity, gain
    double threshold = 0.05;     ///< fBm level below which there is no dust (voids)
    double contrast = 3.0;       ///< gain applied to fBm above the threshold
    double exponent = 2.0;       ///< shaped density = (contrast (fbm - threshold))^exponent
    double warp = 0.35;          ///< domain-warp strength (fraction of the cube) for wisps
    double envelope = 0.5;       ///< radius where the soft envelope reaches 0 [cube edges]
    double emissionPeak = 0.4;   ///< emission where its shaped noise is 1 [linear units]
    double emissionRadius = 0.3; ///< radius of the emitting region [cube edges]
    double cavity = 0.6;         ///< radius of the dust-free cavity around each star [pc]
    std::vector<Star> stars;     ///< point sources (travel as nebula:stars)
    DustParams dust;             ///< travels as nebula:dust
    EmissionShape emissionShape = EmissionShape::Sphere;
    double shellWidth = 0.15; ///< shell thickness (FWHM) relative to its radius, (0, 1]
    /// Centre of the motion, the shell and the [O III] zone [pc]; default: the first star,
    /// or the origin without stars.
    std::optional<std::array<double, 3>> motionCentre;
    /// Reference distance of the expansion and rotation speeds [pc]; default:
    /// emissionRadius * size.
    std::optional<double> motionRadius;
    /// Lines of the `emission` grid (its nebula:lines metadata).
    std::vector<SpectralLine> lines = parseLineList(DEFAULT_EMISSION_LINES, "default lines");
    SpectralParams spectral;
    /// The model. Every preset but fbm is a lognormal turbulent cloud (`turbulence`) times
    /// its geometry; fbm uses frequency, fbm, threshold, contrast, exponent, warp, envelope,
    /// emissionShape and shellWidth instead.
    NebulaPreset preset = NebulaPreset::Fbm;
    TurbulenceParams turbulence; ///< the turbulent presets' statistics
    /// The turbulent presets' cloud edge: n_H = densityPeak x smoothstep(c, 2c, x), x =
    /// exp(s) G, c = edgeCut; 0: no edge (the box).
    double edgeCut = 0.3;
};

/// The motion centre [pc] of @p params: motionCentre, else the first star, else the origin.
std::array<double, 3> motionCentre(const NebulaParams& params);

/// The MotionParams of the `velocity` grid: spectral.motion with the centre from
/// motionCentre(), the radius from motionRadius (default emissionRadius * size) and the
/// nebula's seed.
MotionParams motionParams(const NebulaParams& params);

/// Interstellar radiation field of Mathis, Mezger & Panagia 1983 as Draine 2011 uses it
/// (energy density 0.0912-8 um) [erg cm^-3].
inline constexpr double U_ISRF = 8.64e-13;

/// Starlight in units of the interstellar field at @p x [pc] (optically thin, the stars
/// unattenuated): U = sum_s L_s / (4 pi r_s^2 c u_ISRF), r_s = |x - x_s| clamped to at
/// least @p rMin [pc], L_s [L_sun] taken as bolometric (L_sun = 3.828e33 erg/s, IAU 2015).
double radiationFieldU(const std::array<double, 3>& x, const std::vector<Star>& stars, double rMin);

/// Equilibrium temperature [K] of 0.1 um dust grains in a radiation field @p U times the
/// interstellar one: T = 16.4 K (1 + U)^(1/6) (Draine 2011, "Physics of the Interstellar and
/// Intergalactic Medium", eqs. 24.19-24.20; the 1 + U keeps the ambient interstellar field,
/// so T -> 16.4 K far from the stars).
inline double dustTemperature(double U)
{
    return 16.4 * std::pow(1.0 + U, 1.0 / 6.0);
}

/// The stars of the README's example nebula: a hot B star inside the cloud and a cooler
/// A star near its edge.
std::vector<Star> exampleStars();

/// The most memory [bytes] generateNebula() may need for @p params: its grids, at worst
/// (every voxel active). It holds no dense arrays: it builds the grids leaf by leaf.
double generateBytes(const NebulaParams& params);

/// The procedural fields at one voxel: dust density n_H [cm^-3], gas emission and the [O III]
/// zone's emission.
struct NebulaVoxel
{
    double density = 0.0, emission = 0.0, oiii = 0.0;
};

/// The fields at voxel (i, j, k) of a params.res^3 cube, evaluated there whatever the support:
/// what generateNebula()'s grids hold at that voxel (as float; inactive where zero). The
/// reference its tests compare every voxel against. Throws as generateNebula() does.
NebulaVoxel nebulaVoxel(const NebulaParams& params, int i, int j, int k);

/// Builds the `density` (fog volume, n_H [cm^-3]) and `emission` grids (with `nebula:lines`
/// metadata) and sets the stars and dust metadata. Zero voxels are inactive, trees pruned.
/// With spectral.enabled also:
/// - `temperature` (FloatGrid [K], grid class unknown, metadata units = "K"): on every
///   active voxel of density or emission, dustTemperature(radiationFieldU(x, stars,
///   half a voxel)), or spectral.gasTemperature where emission > 0 if that is > 0;
/// - `velocity` (Vec3fGrid [km/s], world axes, VEC_CONTRAVARIANT_RELATIVE, in world space,
///   metadata units = "km/s"): MotionField(motionParams(params), size) on the same voxels;
/// - `emission.oiii` if spectral.oiii > 0 (see SpectralParams::oiii), with nebula:lines
///   OIII_EMISSION_LINES.
/// The grids are built leaf by leaf (8^3 voxels) in parallel: a leaf wholly outside the
/// fields' support (beyond the dust envelope's largest radius and the emission's ball or
/// shell) is never evaluated, and a leaf of zeros is never stored, so time and memory follow
/// the nebula, not the cube. The result depends only on the parameters, not on the thread
/// count. @p progress gets z-slices done. Throws UsageError naming nebgen's option for a bad
/// parameter, and (naming --res, requireMemory()) before allocating if generateBytes() exceeds
/// the machine's memory.
GridSet generateNebula(const NebulaParams& params,
                       const std::function<void(std::size_t)>& progress = {});

} // namespace nebula
