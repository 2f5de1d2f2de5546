#pragma once
/// @file render.h
/// nebrender's single-scattering ray caster (DESIGN §3, §8).

#include "nebula/cli.h"
#include "nebula/dust.h"
#include "nebula/grid_io.h"
#include "nebula/image.h"
#include "nebula/phase_table.h"
#include "nebula/stars.h"
#include "nebula/volume.h"

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace nebula {

/// Perspective pinhole camera (world space, pc).
struct Camera
{
    Vec3 eye{4, 3, -19};
    Vec3 lookAt{0, 0, 0};
    Vec3 up{0, 1, 0};
    double fovDeg = 36.0;   ///< horizontal field of view [degrees]
    int width = 512;
    int height = 512;

    /// Unit direction through the centre of pixel (px, py) (py = 0 is the top row), and its
    /// solid angle [sr].
    Vec3 direction(double px, double py) const;
    double pixelSolidAngle(double px, double py) const;
    /// Projects world point @p p to pixel coordinates; false if behind the eye.
    bool project(const Vec3& p, double& px, double& py) const;
};

inline Vec3 toVec3(const std::array<double, 3>& a) { return Vec3(a[0], a[1], a[2]); }

/// Throws UsageError unless the eye differs from the look-at point and up is not parallel
/// to the view direction.
void validateCamera(const Camera& camera);

/// nebrender's integrators: the fast ray caster (DESIGN §3-5) or the reference path tracer
/// (DESIGN §6).
enum class Integrator { Fast, Path };

/// How the fast integrator uses a phase table (DESIGN §4-5):
///  - Replace: the scattered source is k Phi(t, mu) E (Phi replaces a p(mu)); Phi includes the
///    voxel's own extinction of the light, which the ray caster applies as well.
///  - Gain: k a p(mu) G(t, mu) E with G = Phi / Phi_1, the voxel's multiple-scattering gain
///    over its single scattering (both from the same Monte Carlo), so the ray caster's
///    extinction is not applied twice.
enum class PhaseUse { Replace, Gain };

/// nebrender --spectral (DESIGN §7): spectra along each ray instead of three channels.
struct SpectralOptions
{
    bool enabled = false;
    /// 0: piecewise-linear spectra (lines as exact Doppler trapezoids, continuum on nodes
    /// continuumStep apart); N > 0: N fixed bands over 360-830 nm, point-sampled at their
    /// centres (for comparison).
    int bands = 0;
    double continuumStep = 10.0;     ///< piecewise-linear mode: continuum node spacing [nm]
    /// Multiplies every velocity before the Doppler shift: the velocity grid's and the line
    /// width alike (visualisation).
    double exaggerateVelocity = 1.0;
    double lineWidth = 10.0;         ///< half-width of a line's rest-frame box profile [km/s]
    /// Relativistic Doppler factor gamma (1 + v_r/c) instead of 1 + v_r/c.
    bool relativistic = false;
    double blackbodyScale = 1.0;     ///< multiplies the black-body (Kirchhoff) emission
    double temperatureScale = 1.0;   ///< multiplies the temperature grid (visualisation)
    std::string temperatureGrid = "temperature";
    std::string velocityGrid = "velocity";
    std::string lines;               ///< line list of the emission grid (overrides metadata)
    int layers = 0;                  ///< spectral EXR channels: N bands over 360-830 nm
    bool countPieces = false;        ///< build each ray's spectrum to count its pieces (stats)
    double mergeTolerance = 0.0;     ///< with countPieces: also count after merge(tolerance)
};

/// Every render parameter; defaults give the README's example picture.
struct RenderOptions
{
    Integrator integrator = Integrator::Fast;
    int spp = 64;            ///< path tracer: samples per pixel (per channel)
    std::uint64_t seed = 1;  ///< path tracer: same seed, same image whatever the threads
    Camera camera;
    double step = 0.5;                              ///< ray step [voxels]
    std::array<double, 3> wavelengths{700.0, 546.1, 435.8};  ///< R, G, B channels [nm]
    double emissionScale = 1.0;                     ///< multiplies the emission grid
    std::array<double, 3> emissionColor{1.0, 0.15, 0.2};  ///< linear sRGB (H-alpha + H-beta pink)
    std::string emissionGrid = "emission";
    bool drawStars = true;                          ///< star sprites
    double spriteRadius = 2.5;                      ///< sprite radius [pixels]
    double minStarDistance = 0.5;                   ///< 1/r^2 clamp radius [voxels]
    double minTransmittance = 1e-5;                 ///< rays stop below this in all channels
    /// Effective phase function (DESIGN §4): with a table, the scattered radiance uses
    /// Phi(t_c, mu) at the voxel's optical thickness t_c = k_c * voxel size instead of the
    /// thin limit a p(mu). Null: single scattering, a p(mu).
    std::shared_ptr<const PhaseTable> phaseTable;
    std::string phaseSource;       ///< the table's file, for messages and the EXR
    bool phaseIgnoreDust = false;  ///< accept a table whose albedo/g/phase differ from the dust
    PhaseUse phaseUse = PhaseUse::Gain;
    /// Multi-resolution global scattering (DESIGN §5): pyramid levels 1..levels (nebpyramid's
    /// density.L<k>, tau.<star>.L<k>) each add the change of the per-voxel scattering when
    /// the voxel doubles, see renderFrame(). 0: level 0 only; > 0 needs a phase table.
    /// -1 (auto): with a phase table, every level the input has (L1, L2, ... while they
    /// last); without one, none.
    int levels = -1;
    SpectralOptions spectral;
};

/// One pyramid level's fields for the fast integrator: channels as RenderScene::fields
/// (0 density, 1 emission = 0, 2 + s tau_V of star s), voxel 2^level times level 0's. Levels
/// are looked up at level-0 samples, never marched, so they need no occupancy.
struct RenderLevel
{
    int level = 0;
    DenseVolume fields;
};

/// The per-channel dust numbers the kernel uses.
struct ChannelDust
{
    std::array<double, 3> r{1, 1, 1};  ///< A(lambda_c)/A_V (CCM)
    double kappa_V = 1.5e-3;
    double albedo = 0.6;
    double g = 0.6;
    PhaseModel phase = PhaseModel::HenyeyGreenstein;
};

/// What the kernel renders: compact fields plus the stars and dust.
struct RenderScene
{
    /// Channels: 0 density n_H, 1 emission, 2 + s: tau_V of star s.
    DenseVolume fields;
    std::vector<Star> stars;
    std::vector<std::array<double, 3>> starColor;  ///< L_s * linear sRGB (Y = 1) [L_sun]
    ChannelDust dust;
    /// Coarse occupancy: block (bi,bj,bk) of BLOCK^3 lattice cells holds dust or emission.
    static constexpr int BLOCK = 8;
    std::array<int, 3> blocks{0, 0, 0};
    std::vector<std::uint8_t> occupied;

    /// (Re)computes `blocks` and `occupied` from channels 0 (density) and 1 (emission).
    void buildOccupancy();

    /// Pyramid levels 1..K (empty without RenderOptions::levels).
    std::vector<RenderLevel> levels;
};

/// Per block of RenderScene::BLOCK^3 lattice cells: the largest channel 0 (density) and
/// channel 1 (emission) at the corners of its cells, i.e. the largest values the trilinear
/// fields take in the block (occupancy, and the path tracer's majorant).
void blockMaxima(const DenseVolume& v, std::array<int, 3>& blocks,
                 std::vector<std::array<float, 2>>& maxima);

/// The edge of a cube of a voxel's volume: cbrt |det M| of the index-to-world map [pc].
double voxelSize(const Affine& indexToWorld);

/// Builds the scene from nebillum's output: density, emission (optional) and tau.<star> for
/// every star in nebula:stars. Throws Error naming the file and grid on anything missing or
/// inconsistent (no stars, a tau grid missing, kappa_V of a tau grid != the dust's), or if
/// opts.phaseTable was made for another albedo, g or phase model than @p dust (unless
/// opts.phaseIgnoreDust). With opts.levels = K, also reads density.L<k> and tau.<star>.L<k>
/// for k = 1..K and throws Error if one is missing or its voxels are not 2^k times level 0's.
RenderScene buildScene(const GridSet& grids, const CommonOptions& common,
                       const RenderOptions& opts, const DustParams& dust);

/// What a render did, for benchmarks and -v.
struct RenderStats
{
    std::uint64_t rays = 0;     ///< rays that met the volume's box
    std::uint64_t samples = 0;  ///< field lookups (ray steps in occupied space)
    /// Channel samples whose voxel optical thickness exceeded the phase table's t_max (the
    /// table's last row was used).
    std::uint64_t phaseClamped = 0;
    std::uint64_t paths = 0;       ///< path tracer: random walks (pixels x spp x channels)
    std::uint64_t collisions = 0;  ///< path tracer: tentative collisions (real and null)
    std::uint64_t pieces = 0;      ///< spectral: linear pieces projected (lines + continuum)
    std::uint64_t spectrumPieces = 0;  ///< spectral, countPieces: pieces of the rays' spectra
    std::uint64_t mergedPieces = 0;    ///< the same after merge(mergeTolerance)
    std::uint64_t maxSpectrumPieces = 0;  ///< the largest ray spectrum
};

/// Renders the single-scattering image: beauty R,G,B,A (A = 1 - T at the green channel),
/// layer "star.<name>" per star (its scattered light and sprite), layer "transmittance".
Image renderFrame(const RenderScene& scene, const RenderOptions& opts, const Run* run = nullptr,
                  RenderStats* stats = nullptr);

/// The reference integrator (DESIGN §6): unbiased volumetric path tracing of the same scene,
/// each RGB channel its own random walk (one walk for all three in grey dust, where their
/// extinctions are equal). Free flights by delta tracking against a majorant
/// that is constant on each occupancy block (kappa_V r_c times the block's largest density);
/// emission by the collision estimator at every tentative collision (the majorant has a floor
/// of two collisions per voxel where there is gas); at every real collision the weight is
/// multiplied by the albedo, every star is sampled (next-event estimation, transmittance by
/// ratio tracking, 1/r^2 clamped as in renderFrame), and the walk continues in a
/// phase-sampled direction; Russian roulette after a few bounces. opts.spp walks per pixel
/// and channel, each pixel and sample with its own PCG32 stream (deterministic for a seed,
/// whatever the thread count). Output: the beauty R,G,B (the mean), A = 1 - T_G, layers
/// star.<name> (sprites only), "transmittance" (ratio-tracked, per channel) and "variance"
/// (variance of each channel's pixel mean, i.e. the squared standard error).
Image renderPathTraced(const RenderScene& scene, const RenderOptions& opts,
                       const Run* run = nullptr, RenderStats* stats = nullptr);

/// Adds each star's attenuated sprite to the beauty and its star.<name> layer (renderFrame
/// does this unless !opts.drawStars).
/// @p colour, if set, gives star s's attenuated colour (linear sRGB, L_sun) from its V-band
/// optical depth from the eye; otherwise starColor[s] * exp(-r_c tau_V) per channel.
/// @p footprint, if set, is called for every pixel a sprite touches with the star, the pixel
/// index and the factor that turns the star's attenuated luminosity into the pixel's radiance
/// (for outputs other than R,G,B, e.g. spectral channels).
void drawStarSprites(Image& img, const RenderScene& scene, const RenderOptions& opts,
                     const std::function<std::array<double, 3>(std::size_t, double)>& colour = {},
                     const std::function<void(std::size_t, std::size_t, double)>& footprint = {});


} // namespace nebula

namespace nebula {

/// Output settings of nebrender.
struct RenderOutput
{
    std::string exr;          ///< EXR path (required)
    std::string png;          ///< PNG path ("" = the EXR's name with .png; "none" = no PNG)
    ToneParams tone;
};

/// nebrender's entry point: builds the scene from @p grids (dust from nebula:dust with
/// @p dustOverride applied), renders, and writes the EXR and PNG atomically.
void renderToFiles(const GridSet& grids, const CommonOptions& common, const RenderOptions& opts,
                   const DustParams& dust, const RenderOutput& out, const Run& run);

} // namespace nebula
