// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file spectral.h
/// nebrender --spectral (DESIGN §7): spectra along camera rays instead of three channels.
/// Line emission is shifted by the gas's radial velocity and broadened into exact
/// trapezoids (Alghamdi et al. 2023, DESIGN §7.1); black-body emission and the starlight the
/// dust scatters carry the extinction curve at every wavelength. Colour is the exact
/// integral of the piecewise-linear spectrum against the CIE 1931 colour-matching functions,
/// then linear sRGB. A fixed-band mode point-samples the same spectra for comparison. The
/// light scattered more than once comes from nebscatter --spectral's field (DESIGN §5b),
/// if the input has one, linear in wavelength between the field's wavelengths (the power
/// law of the end two beyond them).

#include "nebula/core/run.h"
#include "nebula/io/image.h"
#include "nebula/physics/lines.h"
#include "nebula/physics/spectrum.h"
#include "nebula/render/options.h"
#include "nebula/render/scene.h"

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

namespace nebula {

/// The visible range every spectral image covers (the CMF table's range) [nm].
inline constexpr double SPECTRAL_MIN_NM = 360.0;
inline constexpr double SPECTRAL_MAX_NM = 830.0;
/// The components of a calibrated spectral render (RenderOptions::componentLayers), in the
/// order their channels follow the spectral layers: the stars' light that reached the eye
/// unscattered (the sprites), the starlight scattered once, the light scattered more than
/// once (nebscatter --spectral's field), the gas's emission (lines and black body).
inline constexpr const char* SPECTRAL_COMPONENTS[] = {"direct", "single", "field", "emission"};
inline constexpr std::size_t SPECTRAL_COMPONENT_COUNT = 4;
/// The image channel of spectral layer @p band of @p bands (equal bands over 360-830 nm):
/// "S0.<centre>nm" with ',' for the decimal point ("S0.364,95nm"); with @p component (one of
/// SPECTRAL_COMPONENTS), that component's: "<component>.S0.<centre>nm".
std::string spectralChannelName(std::size_t band, std::size_t bands,
                                const std::string& component = "");

/// One emission grid as the spectral renderer sees it.
struct SpectralEmitter
{
    std::string grid;                ///< grid name
    int channel = -1;                ///< its channel in RenderScene::fields
    std::vector<SpectralLine> lines; ///< what it emits
    /// Energy of line l per unit of the grid per pc: unit * lines[l].strength. Chosen so that
    /// the line mix has the luminance Y of the RGB mode's --emission-color times
    /// --emission-scale: the two modes show the gas equally bright. Calibrated
    /// (RenderOptions::monochromatic): --emission-scale / the lines' summed strength, so that
    /// the grid times --emission-scale is the lines' emissivity [L_sun pc^-3 sr^-1].
    double unit = 1.0;
};

/// One absorption grid (`absorption.<species>`, DESIGN §7.6) as the spectral renderer sees it.
struct SpectralAbsorber
{
    std::string grid; ///< grid name
    int channel = -1; ///< its channel in RenderScene::fields
    /// What it absorbs: line l's opacity integrated over wavelength per unit length is the
    /// grid's value times lines[l].strength [nm pc^-1].
    std::vector<SpectralLine> lines;
};

/// The scene of a spectral render (assembled by buildSpectralScene(),
/// stages/scene_assembly.h): the RGB scene's fields (channels 0 density, 1 the sum of
/// every emission and absorption grid (occupancy only), 2 + s tau_V of star s) followed by
/// the emission grids, the absorption grids, the temperature and the velocity (3 channels),
/// each where present.
struct SpectralScene
{
    RenderScene base;
    DustParams dust;
    std::vector<SpectralEmitter> emitters;
    std::vector<SpectralAbsorber> absorbers;
    /// The fastest gas speed of the velocity grid [km/s] (before --exaggerate-velocity): the
    /// Doppler range the absorption lines' wavelength windows cover. 0 without one.
    double maxSpeed = 0.0;
    int temperatureChannel = -1; ///< -1: no temperature grid
    int velocityChannel = -1;    ///< vx; vy, vz follow. -1: no velocity grid
};

/// UsageError for options the spectral renderer cannot honour: a phase table, levels, the
/// path tracer, bands outside [0, MAX_SPECTRAL_BANDS], a continuum step outside
/// [MIN_CONTINUUM_STEP, 50] nm, a line width, --exaggerate-velocity or --temperature-scale
/// <= 0, a --blackbody-scale < 0 (or any of them not finite), --spectral-layers outside
/// [0, 470]. buildSpectralScene() (stages/scene_assembly.h) calls it first.
void validateSpectralOptions(const RenderOptions& opts);

/// Renders @p scene spectrally (see the file comment and DESIGN §7). Output as renderFrame:
/// beauty R,G,B (linear sRGB of the spectrum's XYZ; may be negative for colours outside the
/// sRGB gamut, such as a lone H-alpha line), A = 1 - T at the green channel's wavelength,
/// layers star.<name> and transmittance, plus opts.spectral.layers single channels
/// "S0.<centre>nm" (mean spectral radiance per nm over equal bands of 360-830 nm, named
/// after the OpenEXR spectral layout of Fichet et al. 2021, with ',' for the decimal point),
/// and with opts.componentLayers the same bands of each of SPECTRAL_COMPONENTS. With
/// opts.monochromatic the stars and lines are calibrated (RenderOptions::monochromatic).
Image renderSpectral(const SpectralScene& scene, const RenderOptions& opts,
                     const Run* run = nullptr, RenderStats* stats = nullptr);

} // namespace nebula
