// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file options.h
/// Every render parameter, with its default and unit (the values nebrender's options fill).

#include "nebula/physics/phase_table.h"
#include "nebula/render/camera.h"

#include <array>
#include <cstdint>
#include <memory>
#include <string>

namespace nebula {

/// The names of the fast ray caster (DESIGN §3-5) and the reference path tracer (DESIGN §6),
/// for RenderOptions::integrator. Transitional: code above render/ is to choose an
/// integrator by its name (render/integrator.h's registry) and name none of them itself.
struct Integrator
{
    static inline const std::string Fast = "fast";
    static inline const std::string Path = "path";
};

/// How the fast integrator uses a phase table (DESIGN §4-5):
///  - Replace: the scattered source is k Phi(t, mu) E (Phi replaces a p(mu)); Phi includes the
///    voxel's own extinction of the light, which the ray caster applies as well.
///  - Gain: k a p(mu) G(t, mu) E with G = Phi / Phi_1, the voxel's multiple-scattering gain
///    over its single scattering (both from the same Monte Carlo), so the ray caster's
///    extinction is not applied twice.
enum class PhaseUse { Replace, Gain };

/// nebrender --spectral (DESIGN §7): spectra along each ray instead of three channels.
/// Work bounds (README, Failure behaviour): a spectrum resolved finer than 0.1 nm, or a path
/// traced frame of more random walks than MAX_PATH_WALKS, is refused before any work starts.
/// The most fixed bands (--bands): 0.1 nm wide over 360-830 nm.
inline constexpr int MAX_SPECTRAL_BANDS = 4700;
/// The finest continuum node spacing (--continuum-step) [nm]: 4701 nodes over 360-830 nm.
inline constexpr double MIN_CONTINUUM_STEP = 0.1;
/// The most random walks in one path-traced frame (--spp x pixels): 150 times the README's
/// reference (256 spp at 512x512, 6.7e7 walks).
inline constexpr double MAX_PATH_WALKS = 1e10;

struct SpectralOptions
{
    bool enabled = false;
    /// 0: piecewise-linear spectra (lines as exact Doppler trapezoids, continuum on nodes
    /// continuumStep apart); N > 0: N fixed bands over 360-830 nm, point-sampled at their
    /// centres (for comparison).
    int bands = 0;
    double continuumStep = 10.0; ///< piecewise-linear mode: continuum node spacing [nm]
    /// Multiplies every velocity before the Doppler shift: the velocity grid's and the line
    /// width alike (visualisation).
    double exaggerateVelocity = 1.0;
    double lineWidth = 10.0; ///< half-width of a line's rest-frame box profile [km/s]
    /// Relativistic Doppler factor gamma (1 + v_r/c) instead of 1 + v_r/c.
    bool relativistic = false;
    double blackbodyScale = 1.0;   ///< multiplies the black-body (Kirchhoff) emission
    double temperatureScale = 1.0; ///< multiplies the temperature grid (visualisation)
    std::string temperatureGrid = "temperature";
    std::string velocityGrid = "velocity";
    std::string lines;           ///< line list of the emission grid (overrides metadata)
    int layers = 0;              ///< spectral EXR channels: N bands over 360-830 nm
    bool countPieces = false;    ///< build each ray's spectrum to count its pieces (stats)
    double mergeTolerance = 0.0; ///< with countPieces: also count after merge(tolerance)
};

/// Every render parameter; defaults give the README's example picture.
struct RenderOptions
{
    /// The integrator's name (render/integrator.h: integratorType()); with spectral.enabled,
    /// the spectral renderer (chosenIntegrator()).
    std::string integrator = "fast";
    std::string densityGrid = "density"; ///< the dust density grid (n_H [cm^-3])
    int spp = 64;                        ///< path tracer: samples per pixel (per channel)
    std::uint64_t seed = 1; ///< path tracer: same seed, same image whatever the threads
    Camera camera;
    double step = 0.5; ///< ray step [voxels]
    /// Level of detail (fast integrator, DESIGN §9): where a voxel of a level-L copy of the
    /// fields (2^L times the voxel, the mean of the voxels it covers) spans at most this many
    /// pixels, the ray samples that copy, in steps of `step` of its voxels, up to
    /// RenderScene::MAX_DETAIL_LEVEL. 0: always full resolution.
    double lod = 2.0;
    /// Level of detail in optically thick dust: a block of the occupancy grid is sampled at
    /// level L only where a level-L voxel of the densest dust it can average (within 1.5 x
    /// 2^L voxels, RenderScene::detailDensity) has at most this optical depth across, in the
    /// most opaque channel; a coarser voxel would change what the dust transmits (DESIGN §9).
    /// Infinity: coarsen everywhere, as before this limit.
    double lodMaxDepth = 0.5;
    std::array<double, 3> wavelengths{700.0, 546.1, 435.8}; ///< R, G, B channels [nm]
    /// Calibrated light (DESIGN §13; nebrender --fits): every star shines its black body's
    /// spectral luminosity (blackbodySpectralLuminosity(), its luminosity bolometric), not its
    /// sRGB colour (RGB mode) or a spectrum of luminance Y = L (spectral mode), so the
    /// renderer's values are spectral radiance [L_sun pc^-2 sr^-1 nm^-1]. RGB mode: each
    /// channel is the monochromatic image at its wavelength; the gas's emission, which has
    /// no spectral calibration there, is left out. Spectral mode: the spectral layers are the
    /// calibrated bands, and each emission grid times --emission-scale is its lines' summed
    /// emissivity [L_sun pc^-3 sr^-1], shared among them by their strengths.
    bool monochromatic = false;
    /// The components of calibrated images, which nebrender writes into the FITS, not the
    /// EXR. Fast integrator: the image layers "field" (the light scattered more than once,
    /// from nebscatter's field), "emission" (the gas's glow) and "direct" (the star sprites:
    /// their light that reached the eye unscattered); the rest of the beauty is single
    /// scattering. Spectral renderer: after the N spectral layers, N more channels per
    /// component of SPECTRAL_COMPONENTS (render/spectral.h), "<component>.S0.<centre>nm".
    bool componentLayers = false;
    double emissionScale = 1.0; ///< multiplies the emission grid
    /// Linear sRGB (H-alpha + H-beta pink): the colour of an emission grid that does not say
    /// what it emits (no nebula:lines), and, through its luminance Y, the brightness of a
    /// unit of a line grid in both modes (DESIGN §3.4).
    std::array<double, 3> emissionColor{1.0, 0.15, 0.2};
    std::string emissionGrid = "emission";
    /// RGB mode (DESIGN §3.4): draw emissionGrid and every grid with nebula:lines, each line
    /// grid in the true colour of its lines. false (nebrender --emission-color given, and
    /// nebscatter): only emissionGrid, in emissionColor.
    bool lineColours = true;
    bool drawStars = true;          ///< star sprites
    double spriteRadius = 2.5;      ///< sprite radius [pixels]
    double minStarDistance = 0.5;   ///< 1/r^2 clamp radius [voxels]
    double minTransmittance = 1e-5; ///< rays stop below this in all channels
    /// Effective phase function (DESIGN §4): with a table, the scattered radiance uses
    /// Phi(t_c, mu) at the voxel's optical thickness t_c = k_c * voxel size instead of the
    /// thin limit a p(mu). Null: single scattering, a p(mu).
    std::shared_ptr<const PhaseTable> phaseTable;
    std::string phaseSource;      ///< the table's file, for messages and the EXR
    bool phaseIgnoreDust = false; ///< accept a table whose albedo/g/phase differ from the dust
    PhaseUse phaseUse = PhaseUse::Gain;
    /// Multi-resolution global scattering (DESIGN §5): pyramid levels 1..levels (nebpyramid's
    /// density.L<k>, tau.<star>.L<k>) each add the change of the per-voxel scattering when
    /// the voxel doubles, see renderFrame(). 0: level 0 only; > 0 needs a phase table.
    /// -1 (auto): with a phase table, every level the input has (L1, L2, ... while they
    /// last); without one, none.
    int levels = -1;
    /// Use nebscatter's scattered-light field (DESIGN §5b) when the input has one
    /// (--no-scatter-field: false).
    bool scatterField = true;
    /// Each star's optical depth exact through the cells where it bends (render/star_depth.h,
    /// DESIGN §3.3) instead of the trilinear tau grid everywhere (--interpolated-tau: false).
    bool exactStarDepth = true;
    SpectralOptions spectral;
};

/// What a render did, for benchmarks and -v.
struct RenderStats
{
    std::uint64_t rays = 0;    ///< rays that met the volume's box
    std::uint64_t samples = 0; ///< field lookups (ray steps in occupied space)
    /// Channel samples whose voxel optical thickness exceeded the phase table's t_max (the
    /// table's last row was used).
    std::uint64_t phaseClamped = 0;
    std::uint64_t paths = 0;             ///< path tracer: random walks (pixels x spp)
    std::uint64_t collisions = 0;        ///< path tracer: tentative collisions (real and null)
    std::uint64_t pieces = 0;            ///< spectral: linear pieces projected (lines + continuum)
    std::uint64_t spectrumPieces = 0;    ///< spectral, countPieces: pieces of the rays' spectra
    std::uint64_t mergedPieces = 0;      ///< the same after merge(mergeTolerance)
    std::uint64_t maxSpectrumPieces = 0; ///< the largest ray spectrum

    /// Adds @p o's counts (the largest spectrum: the larger of the two).
    RenderStats& operator+=(const RenderStats& o)
    {
        rays += o.rays;
        samples += o.samples;
        phaseClamped += o.phaseClamped;
        paths += o.paths;
        collisions += o.collisions;
        pieces += o.pieces;
        spectrumPieces += o.spectrumPieces;
        mergedPieces += o.mergedPieces;
        maxSpectrumPieces =
            maxSpectrumPieces > o.maxSpectrumPieces ? maxSpectrumPieces : o.maxSpectrumPieces;
        return *this;
    }
};

} // namespace nebula
