#pragma once
/// @file spectral.h
/// nebrender --spectral (DESIGN §7): spectra along camera rays instead of three channels.
/// Line emission is shifted by the gas's radial velocity and broadened into exact
/// trapezoids (Alghamdi et al. 2023, notes §6.2); black-body emission and the starlight the
/// dust scatters carry the extinction curve at every wavelength. Colour is the exact
/// integral of the piecewise-linear spectrum against the CIE 1931 colour-matching functions,
/// then linear sRGB. A fixed-band mode point-samples the same spectra for comparison.

#include "nebula/lines.h"
#include "nebula/render.h"
#include "nebula/spectrum.h"

#include <cmath>
#include <string>
#include <vector>

namespace nebula {

/// Speed of light [km/s].
inline constexpr double SPEED_OF_LIGHT_KMS = 299792.458;
/// The visible range every spectral image covers (the CMF table's range) [nm].
inline constexpr double SPECTRAL_MIN_NM = 360.0;
inline constexpr double SPECTRAL_MAX_NM = 830.0;
/// W m^-2 -> L_sun pc^-2: pc^2 / L_sun with the IAU 2015 nominal solar luminosity
/// 3.828e26 W and 1 pc = 3.0856775814913673e16 m.
inline constexpr double WM2_TO_LSUN_PC2 =
    3.0856775814913673e16 * 3.0856775814913673e16 / 3.828e26;

/// Observed over emitted wavelength for radial velocity @p vr [km/s], v_r > 0 receding
/// (DESIGN §7, first order in v/c): lambda' / lambda = 1 + v_r / c.
inline double dopplerFactor(double vr) { return 1.0 + vr / SPEED_OF_LIGHT_KMS; }

/// The relativistic Doppler factor (DESIGN §7's option) for radial velocity @p vr [km/s]
/// and squared speed @p v2 [km^2/s^2]: lambda' / lambda = gamma (1 + v_r / c), gamma =
/// 1 / sqrt(1 - v^2/c^2): gas moving across the line of sight is red-shifted by gamma.
inline double relativisticDopplerFactor(double vr, double v2)
{
    const double c = SPEED_OF_LIGHT_KMS;
    return (1.0 + vr / c) / std::sqrt(1.0 - v2 / (c * c));
}

/// The observed profile of one spectral line emitted along one ray segment: a trapezoid
/// through (x[0], 0), (x[1], height), (x[2], height), (x[3], 0) [nm].
struct LineTrapezoid
{
    double x[4];
    double height;  ///< [energy / nm]

    /// Value at @p lambda [nm] (0 outside [x[0], x[3]]).
    double at(double lambda) const;
};

/// The profile of a line of rest wavelength @p lambda0 [nm] and energy @p energy emitted
/// along a segment over which the emitter's density is constant and its radial velocity
/// varies linearly from @p vA to @p vB [km/s] (DESIGN §7). Every point of the segment emits
/// a box of half-width lambda0 * halfWidth / c (the rest-frame thermal and turbulent width,
/// @p halfWidth [km/s] > 0) centred on lambda0 (1 + v / c); the segment's points spread the
/// centres uniformly over [lambda0 (1 + vA/c), lambda0 (1 + vB/c)]. The sum is the
/// convolution of two boxes: a trapezoid whose ramps are as wide as the narrower box (a box
/// when vA == vB). Its integral is @p energy and its centroid lambda0 (1 + (vA + vB) / 2c),
/// both exactly (to rounding): Doppler broadening moves energy, never makes or loses it.
/// Works for either order of vA and vB.
LineTrapezoid lineTrapezoid(double lambda0, double vA, double vB, double halfWidth,
                            double energy);

/// The same with the Doppler factors lambda'/lambda at the segment's ends given, @p dA and
/// @p dB > 0 (e.g. relativisticDopplerFactor()).
LineTrapezoid lineTrapezoidFactors(double lambda0, double dA, double dB, double halfWidth,
                                   double energy);

/// One emission grid as the spectral renderer sees it.
struct SpectralEmitter
{
    std::string grid;                ///< grid name
    int channel = -1;                ///< its channel in RenderScene::fields
    std::vector<SpectralLine> lines; ///< what it emits
    /// Energy of line l per unit of the grid per pc: unit * lines[l].strength. Chosen so that
    /// the line mix has the luminance Y of the RGB mode's --emission-color times
    /// --emission-scale: the two modes show the gas equally bright.
    double unit = 1.0;
};

/// The scene of a spectral render: the RGB scene's fields (channels 0 density, 1 the sum of
/// every emission grid (occupancy only), 2 + s tau_V of star s) followed by the emission
/// grids, the temperature and the velocity (3 channels), each where present.
struct SpectralScene
{
    RenderScene base;
    DustParams dust;
    std::vector<SpectralEmitter> emitters;
    int temperatureChannel = -1;  ///< -1: no temperature grid
    int velocityChannel = -1;     ///< vx; vy, vz follow. -1: no velocity grid
};

/// Builds the spectral scene: everything buildScene() checks and reads, plus every emission
/// grid (opts.emissionGrid and each FloatGrid with nebula:lines metadata), the temperature
/// grid (opts.spectral.temperatureGrid, optional; Error if a value is negative, NaN or
/// infinite) and the velocity grid (opts.spectral.velocityGrid, optional; Error unless a
/// Vec3fGrid of finite values). The emission grid's lines: opts.spectral.lines if given,
/// else its nebula:lines metadata, else "H-alpha:1,H-beta:0.35" (Case B Balmer ratio).
/// UsageError for options the spectral renderer cannot honour (a phase table, levels,
/// the path tracer, bands < 0, a continuum step outside (0, 50] nm, a line width <= 0, an
/// --exaggerate-velocity <= 0 or one that makes gas move at the speed of light).
SpectralScene buildSpectralScene(const GridSet& grids, const CommonOptions& common,
                                 const RenderOptions& opts, const DustParams& dust);

/// Renders @p scene spectrally (see the file comment and DESIGN §7). Output as renderFrame:
/// beauty R,G,B (linear sRGB of the spectrum's XYZ; may be negative for colours outside the
/// sRGB gamut, such as a lone H-alpha line), A = 1 - T at the green channel's wavelength,
/// layers star.<name> and transmittance, plus opts.spectral.layers single channels
/// "S0.<centre>nm" (mean spectral radiance per nm over equal bands of 360-830 nm, named
/// after the OpenEXR spectral layout of Fichet et al. 2021, with ',' for the decimal point).
Image renderSpectral(const SpectralScene& scene, const RenderOptions& opts,
                     const Run* run = nullptr, RenderStats* stats = nullptr);

} // namespace nebula
