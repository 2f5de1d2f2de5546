// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_field.h
/// The scattered-light field (DESIGN §5b): the angular moments of the radiance of light
/// scattered at least once (the collided light), computed once per scene by Monte Carlo
/// packets (nebscatter) and added by the fast integrator to its exact single scattering.
///
/// Radiance splits into direct starlight, exact through tau.<star>, and collided light.
/// Packets start from the first-scattering source, known exactly from the tau grids (a point
/// drawn in proportion to k a E, a direction from the phase function around the star's
/// light), and from the gas emission (tallied only after its first collision). Every flight
/// is walked through the half-voxel lattice with the optical depth of each piece exact
/// (Simpson's rule on the trilinear density); it tallies its expected track length,
/// integral of w e^-tau dl, into the field cell of each piece, times the real spherical
/// harmonics of its direction; then it collides inside the walked part for certain (its
/// weight times the probability of colliding), scatters with the albedo, and goes on until
/// Russian roulette ends it. One walk serves the three channels (coloured dust): the
/// collision point is drawn from the mixture of the channels' distributions and each
/// channel's weight carries its own ratio. Tallies are fixed-point integers (rounded to
/// nearest), summed per thread or atomically in one buffer; integer sums do not depend on
/// their order, so the field is the same bit for bit whatever the thread count.

#include "nebula/core/ranks.h"
#include "nebula/core/run.h"
#include "nebula/io/scatter_field_meta.h"
#include "nebula/render/options.h"
#include "nebula/render/scene.h"

#include <array>
#include <climits>
#include <cstdint>
#include <string>
#include <vector>

namespace nebula {

/// The most packets per source (--packets), a work bound (README, Failure behaviour): the
/// default 1e6 takes 15-60 s per star on 2 cores, 1e9 some hours.
inline constexpr std::uint64_t MAX_PACKETS = 1000000000;

/// What nebscatter computes (ScatterSettings: order, field level, packets, seed, adaptive
/// cells, per star; recorded with the field) and how it runs.
struct ScatterOptions : ScatterSettings
{
    bool emission = true; ///< also the gas emission's collided light (if the scene emits)
    /// Per-thread tally buffers (one set per thread, the first becomes the sum) while all of
    /// them stay below this [bytes]; above it one shared buffer with atomic additions. The
    /// field is the same either way.
    double perThreadTallyBytes = 512.0 * 1024.0 * 1024.0;
    /// The processes sharing the packets (MPI ranks; null: this process alone). Each runs
    /// its share() of every source's packets, with the same streams one process would give
    /// them, and the integer tallies are summed onto rank 0 (Ranks::sumToRoot()): the same
    /// field, bit for bit, whatever the number of ranks. Only rank 0's result holds the
    /// field; the others' sources have empty moments.
    const Ranks* ranks = nullptr;
};

/// One source's field: its summary (ScatterSourceSummary: the source, packets, power, noise)
/// and its moments.
struct ScatterSourceField : ScatterSourceSummary
{
    /// Moments on the field lattice: channel k * C + c is c_lm of channel c (C = 3: R, G, B;
    /// a spectral field: C wavelengths), k = shIndex(l, m), c_lm = integral of L(w) Y_lm(w)
    /// dw [L_sun pc^-2] (a spectral field: per nm, [L_sun pc^-2 nm^-1]; the l = 0 moment is
    /// 4 pi Y_00 J = 2 sqrt(pi) J). The emission's is per unit --emission-scale and colour
    /// (1, 1, 1). Its indexToWorld is fieldLevelMap() of level 0's.
    SparseVolume moments;
};

/// The whole field: every source's moments on one lattice.
struct ScatterField
{
    int order = 2;
    int level = 0;
    /// Empty: the channels are R, G, B; else a spectral field's wavelengths [nm], one
    /// channel each (computeSpectralScatterField()).
    std::vector<double> wavelengths;
    std::vector<ScatterSourceField> sources;
    /// Per cell of the sources' lattice (x fastest, then y, then z): 1 where the renderer reads the
    /// field (the cells holding dust and their 26 neighbours; only these are tallied).
    std::vector<std::uint8_t> active;
};

/// Field level @p level's index-to-world map from level 0's @p level0: field voxel I covers
/// level-0 voxels 2^k I ... 2^k I + 2^k - 1, its centre at 2^k I + (2^k - 1) / 2
/// (nebpyramid's levelTransform()).
Affine fieldLevelMap(const Affine& level0, int level);

/// The largest ScatterOptions::refineTau (--refine-tau): blocks thicker than this are
/// beyond what trilinear cells follow anyway.
inline constexpr double MAX_REFINE_TAU = 100.0;

/// ScatterOptions::fieldLevel: chosen by autoFieldLevel().
inline constexpr int AUTO_FIELD_LEVEL = INT_MIN;

/// What autoFieldLevel() chose and why.
struct FieldLevelChoice
{
    int level = 0;
    int gridLevel = 0; ///< the level of about 64 cells (45 to 90) across the grid's longest side
    double voxelTau = 0.0;   ///< tau_V across one voxel of the densest 1 % of the dust
    double cellTau = 0.0;    ///< the same across a cell of the chosen level
    double tallyBytes = 0.0; ///< one set of the chosen level's tallies (every cell)
};

/// The largest cell optical depth (tau_V across a cell of the densest 1 % of the dust
/// voxels) autoFieldLevel() accepts.
inline constexpr double AUTO_FIELD_MAX_CELL_TAU = 1.0;
/// The most memory one set of tallies may take at the level autoFieldLevel() chooses.
inline constexpr double AUTO_FIELD_MAX_TALLY_BYTES = 1024.0 * 1024.0 * 1024.0;

/// The field level for @p scene's density at order @p order with @p channels channels per
/// moment: cells about 1/64 of the grid's longest side (45 to 90 across), finer while a
/// cell of the densest 1 % of the dust is optically thicker than AUTO_FIELD_MAX_CELL_TAU
/// (the collided light varies like e^-tau inside such cells), down to half-voxel cells
/// (MIN_FIELD_LEVEL, for optically thick voxels), while the finer tallies take at most
/// AUTO_FIELD_MAX_TALLY_BYTES (levels >= 0: every cell of the box, a bound; half-voxel
/// cells: estimated for adaptive cells of --refine-tau @p refineTau, 0: uniform), coarser
/// while they take more.
FieldLevelChoice autoFieldLevel(const RenderScene& scene, int order, int channels,
                                double refineTau = 0.0);

/// Throws UsageError naming the option unless @p opts are usable on @p scene: order in
/// 0..SH_MAX_DEGREE (--order), packets > 0 (--packets), a field level whose cells are not
/// larger than the grid (--field-level), and at least one packet per rank (opts.ranks).
void validateScatterOptions(const RenderScene& scene, const ScatterOptions& opts);

/// Computes the field of @p scene (its density, emission, tau.<star>, stars and channel
/// dust; @p ropts: emission grid scale is not used, min star distance is) with @p opts.
/// Progress and -v reports through @p run (may be null). Same seed, same field, whatever the
/// thread count.
ScatterField computeScatterField(const RenderScene& scene, const RenderOptions& ropts,
                                 const ScatterOptions& opts, const Run* run);

/// Adds @p src's moments (channel k * C + c, as in ScatterSourceField::moments, C =
/// @p factor's size) times @p factor[c] to @p total's, the l = 0 ones also times
/// @p c00Factor (2 sqrt(pi) turns nebscatter's J grids into c_00); both on the same lattice.
void addScatterMoments(SparseVolume& total, const SparseVolume& src,
                       const std::vector<double>& factor, double c00Factor = 1.0);

/// A spectral field's wavelength range [nm] (spectralFieldWavelengths()).
inline constexpr double SPECTRAL_FIELD_MIN_NM = 380.0;
inline constexpr double SPECTRAL_FIELD_MAX_NM = 780.0;
/// The most wavelengths a spectral field has (one walk carries them all).
inline constexpr std::size_t SPECTRAL_FIELD_MAX_WAVELENGTHS = 64;

/// The wavelengths of a spectral field of @p n (>= 2) wavelengths: evenly spaced over
/// 380-780 nm, the ends included (beyond them, where the colour-matching functions are below
/// 0.4 % of their peaks, nebrender --spectral extends the power law of the end two).
std::vector<double> spectralFieldWavelengths(int n);

/// Star @p star's spectral power at @p lambda_nm [L_sun nm^-1]: its black body normalised
/// so that its luminance Y (the CIE y-bar integral over 360-830 nm) is its luminosity, the
/// spectral renderer's convention (DESIGN §7).
double starSpectralPower(const Star& star, double lambda_nm);

/// The starlight's field for nebrender --spectral: the collided light at each of
/// @p wavelengths [nm] (2..SPECTRAL_FIELD_MAX_WAVELENGTHS of them; UsageError otherwise),
/// per nm, of stars whose spectra are starSpectralPower(). One walk carries every
/// wavelength as a channel (the dust's extinction and the stars' spectral power there;
/// collisions drawn from the mixture of all of them), so the field's noise is shared by
/// its wavelengths and colours stay smooth. The emission is left out (the spectral
/// renderer does not scatter the gas's glow). Same seed, same field, whatever the thread
/// count.
ScatterField computeSpectralScatterField(const RenderScene& scene, const RenderOptions& ropts,
                                         const ScatterOptions& opts,
                                         const std::vector<double>& wavelengths, const Run* run);

/// The spectral field @p field keeps only its wavelengths 0, @p stride, 2 @p stride, ...
/// (stride > 0): a coarser spectral field with the same noise (for measuring how many
/// wavelengths a field needs).
ScatterField spectralFieldSubset(const ScatterField& field, std::size_t stride);

/// The field as the fast integrator adds it (RenderScene::scatter): every source's moments
/// summed, the emission's times @p opts' emission scale and colour (in memory; nebrender
/// reads nebscatter's grids in buildScene()). A spectral field stays spectral (its
/// wavelengths kept), for buildSpectralScene()'s scene.
SceneScatterField sceneScatterField(const ScatterField& field, const RenderOptions& opts);

} // namespace nebula
