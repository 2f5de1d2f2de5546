// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scene.h
/// What the integrators render: compact dense fields, the stars and the per-channel dust.
/// The scene is assembled from the files in stages/ (stages/scene_assembly.h: buildScene(),
/// buildSpectralScene()); render/ knows no files and no OpenVDB.

#include "nebula/physics/dust.h"
#include "nebula/physics/optical_depth.h"
#include "nebula/physics/stars.h"
#include "nebula/render/options.h"
#include "nebula/volume/block_walk.h"
#include "nebula/volume/volume.h"

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace nebula {

/// One pyramid level's fields for the fast integrator: channels as RenderScene::fields
/// (0 density, 1 emission = 0, 2 + s tau_V of star s), voxel 2^level times level 0's. Levels
/// are looked up at level-0 samples, never marched, so they need no occupancy.
struct RenderLevel
{
    int level = 0;
    SparseVolume fields;
};

/// The dust as the integrators use it: the dust itself plus the extinction ratio of each
/// RGB channel.
struct ChannelDust : DustParams
{
    std::array<double, 3> r{1, 1, 1}; ///< A(lambda_c)/A_V of channel c (DustParams::curve)
};

/// nebscatter's field as the fast integrator adds it (DESIGN §5b): the moments of every
/// source summed (each star's scaled to the scene's luminosity, the emission's by
/// --emission-scale and colour), channel shIndex(l, m) * 3 + c holding c_lm of channel c
/// [L_sun pc^-2], on the field level's lattice. order -1: no field. A spectral field
/// (nebscatter --spectral, for the spectral renderer): channel shIndex(l, m) * N + i holds
/// c_lm at wavelengths[i] [L_sun pc^-2 nm^-1].
struct SceneScatterField
{
    int order = -1;
    int level = 0;
    std::vector<double> wavelengths; ///< a spectral field's [nm]; empty: R, G, B
    SparseVolume moments;
    std::string description;     ///< what it is, for -v and the EXR
    bool emissionSource = false; ///< it holds the glow of the emission grid (DESIGN §5b)
};

/// Coarser copies of a scene's fields for the level of detail (RenderOptions::lod): level L
/// is SparseVolume::halfResolution() applied L times. Built on first use and kept, so the
/// frames of a camera path share them; safe to ask from several threads. A copied or moved
/// scene starts with none (they are a cache of its fields).
class DetailLevels
{
public:
    DetailLevels() = default;
    DetailLevels(const DetailLevels&) {}
    DetailLevels& operator=(const DetailLevels&)
    {
        clear();
        return *this;
    }
    /// Level @p level (>= 1) of @p fields, building it (and the levels below) if needed.
    const SparseVolume& level(const SparseVolume& fields, int level) const;
    /// Forgets the levels built.
    void clear();
    /// The number of levels built so far.
    int built() const;

private:
    mutable std::mutex mMutex;
    mutable std::vector<std::unique_ptr<SparseVolume>> mLevels;
};

/// The density's exact column integrator (physics/optical_depth.h, on channel 0 of a scene's
/// fields, in place), built on first use and kept: StarDepth and the star sprites share its
/// empty-cell bits, and the frames of a camera path build them once. Safe to ask from
/// several threads. A copied or moved scene starts without it (it refers to the fields).
class DensityColumn
{
public:
    DensityColumn() = default;
    DensityColumn(const DensityColumn&) {}
    DensityColumn& operator=(const DensityColumn&)
    {
        clear();
        return *this;
    }
    /// The integrator on channel 0 of @p fields, building it if needed.
    const ColumnIntegrator& get(const SparseVolume& fields) const;
    /// Forgets the integrator built.
    void clear();

private:
    mutable std::mutex mMutex;
    mutable std::unique_ptr<ColumnIntegrator> mColumn;
};

/// The gas's glow as the RGB integrators draw it (DESIGN §3.4), times --emission-scale:
/// with gridChannel < 0, channel 1 of the fields times `colour` (unset: RenderOptions::
/// emissionColor), per channel: a grid without lines, the old layout; with gridChannel >= 0,
/// channel gridChannel + k holds grids[k], drawn by its line groups (`lines`), and channel 1
/// their plain sum (> 0 wherever any grid glows: occupancy, majorants, the test for an empty
/// sample); gridChannel 1: one grid with lines, channel 1 itself.
struct SceneEmission
{
    /// A group of a grid's lines of one extinction (a doublet), or a grid without lines.
    struct Line
    {
        int grid = 0;                   ///< index into grids
        std::array<double, 3> colour{}; ///< its share of the grid's colour (they sum to it)
        /// A(lambda)/A_V at its wavelengths (the fast integrator dims it by exp(-ratio
        /// tau_V)); painted (a grid without lines): dimmed per channel instead.
        double ratio = 1.0;
        bool painted = false;
    };
    std::optional<std::array<double, 3>> colour;
    int gridChannel = -1;
    /// The grids drawn, each with its colour (linear sRGB per grid unit, may be negative).
    std::vector<std::pair<std::string, std::array<double, 3>>> grids;
    std::vector<Line> lines; ///< with gridChannel >= 0: every grid's line groups
};

/// What the kernel renders: compact fields plus the stars and dust.
struct RenderScene
{
    /// The coarsest level of detail the fast integrator samples (8 voxels on a side).
    static constexpr int MAX_DETAIL_LEVEL = 3;

    /// Channels: 0 density n_H, 1 emission, 2 + s: tau_V of star s; then, with
    /// emission.gridChannel >= 0, each emission grid.
    SparseVolume fields;
    SceneEmission emission;
    std::vector<Star> stars;
    /// L_s * linear sRGB (Y = 1) [L_sun]; with RenderOptions::monochromatic, the star's
    /// spectral luminosity at each channel's wavelength [L_sun nm^-1]
    std::vector<std::array<double, 3>> starColor;
    ChannelDust dust;
    /// Coarse occupancy: block (bi,bj,bk) of OCCUPANCY_BLOCK^3 lattice cells holds dust or
    /// emission.
    std::array<int, 3> blocks{0, 0, 0};
    std::vector<std::uint8_t> occupied;
    /// Per block, the lowest level of detail L that may be non-zero in it (level L reaches 1.5 x
    /// 2^L voxels past the dust): 0 for an occupied block, 1 next to one (levels 1 and 2 reach at
    /// most 6 voxels), 3 two blocks from one, 255 farther. A level-L step skips blocks whose value
    /// exceeds L.
    std::vector<std::uint8_t> detailReach;
    /// Per block, the largest density n_H a level-of-detail sample there can average: over
    /// the block and the 26 around it ([0]: what a level-1 or level-2 voxel sampled in the
    /// block covers, with its trilinear neighbours) and over two blocks every way ([1]: a
    /// level-3 voxel's). The fast integrator coarsens a block only to levels whose voxel is
    /// optically thin at that density (RenderOptions::lodMaxDepth, DESIGN §9).
    std::vector<std::array<float, 2>> detailDensity;
    /// The fields' levels of detail, built when a frame first needs them.
    DetailLevels detail;
    /// The density's column integrator, built when a frame first needs it.
    DensityColumn column;

    /// (Re)computes `blocks`, `occupied`, `detailReach` and `detailDensity` from channels 0
    /// (density) and 1 (emission), and forgets the levels of detail and the column
    /// integrator.
    void buildOccupancy();

    /// Pyramid levels 1..K (empty without RenderOptions::levels).
    std::vector<RenderLevel> levels;

    /// The scattered-light field, if the input has one and RenderOptions::scatterField
    /// (buildScene()), or sceneScatterField() of a field in memory.
    SceneScatterField scatter;
};

/// Each star's light as the integrators use it (RenderScene::starColor): L_s times its
/// black body's linear sRGB (Y = 1) [L_sun], or with opts.monochromatic its spectral
/// luminosity at each of opts.wavelengths [L_sun nm^-1].
std::vector<std::array<double, 3>> starColors(const std::vector<Star>& stars,
                                              const RenderOptions& opts);

/// @p dust with each RGB channel's extinction ratio at @p wavelengths [nm]; UsageError naming
/// --wavelengths if one is outside the extinction curve.
ChannelDust channelDust(const DustParams& dust, const std::array<double, 3>& wavelengths);

/// The largest radiance any option or value may produce before a frame is rendered
/// [L_sun pc^-2 sr^-1]: far beyond any nebula, and 3e8 times short of a float's limit, so
/// that sums over pixels and channels stay finite. buildScene() (stages/scene_assembly.h)
/// refuses an --emission-scale
/// that would exceed it across the grid, naming the option and the grid's largest value.
inline constexpr double MAX_RADIANCE = 1e30;

/// The most ray-march steps a ray may take across a scene's lattice (corner to corner).
inline constexpr double MAX_STEPS_PER_RAY = 1e6;

/// The length of @p scene's lattice corner to corner [voxels].
double latticeDiagonal(const RenderScene& scene);

/// Throws UsageError naming --step unless @p step [voxels] is a finite number > 0 with which
/// a ray across @p scene's lattice takes at most MAX_STEPS_PER_RAY steps; the message says
/// the smallest step allowed for this grid, in voxels and pc.
void requireRayStep(const RenderScene& scene, double step);

} // namespace nebula
