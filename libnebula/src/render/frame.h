// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file frame.h
/// Internal to render/: what every integrator's pixel loop shares. The image with the
/// standard layers, and the parallel loop over bands of rows that owns the threads, the
/// progress bar and the statistics, so an integrator only says what one band of rows does.

#include "nebula/core/error.h"
#include "nebula/core/memory.h"
#include "nebula/core/run.h"
#include "nebula/io/image.h"
#include "nebula/render/frame_layers.h"
#include "nebula/render/integrator.h"
#include "nebula/render/options.h"
#include "nebula/render/scene.h"
#include "nebula/render/sprites.h"
#include "nebula/render/star_depth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace nebula::detail {

/// Throws UsageError (requireMemory(), naming --res) if a frame of @p width x @p height with
/// the beauty R,G,B,A, @p layers RGB layers and @p channels single channels would not fit in
/// memory, counting the tone curve's and the PNG's per-pixel buffers (two doubles and four
/// bytes); and (naming --sprite-radius) if the star sprites' footprint would not.
inline void requireFrameMemory(const RenderOptions& opts, int width, int height, std::size_t layers,
                               std::size_t channels)
{
    const double floats = 4.0 + 3.0 * double(layers) + double(channels);
    const double perPixel = floats * sizeof(float) + 2.0 * sizeof(double) + 4.0;
    requireMemory(double(width) * double(height) * perPixel,
                  "--res " + std::to_string(width) + "x" + std::to_string(height) + ": the image");
    if (opts.drawStars) requireSpriteMemory(opts);
}

/// The standard layers of frameImage(), looked up once per frame: what an integrator
/// writes through per pixel.
struct FrameLayers
{
    std::vector<LayerId> stars; ///< starLayerName() of each of the scene's stars, in order
    LayerId transmittance;      ///< TRANSMITTANCE_LAYER
};

/// The standard layers, in this order: starLayerName() per star (0), TRANSMITTANCE_LAYER (1),
/// then each of @p extra (0), whose ids the caller finds by name; after the beauty R,G,B,A
/// (0). @p ids: the standard layers. @p channels: how many single channels the caller adds,
/// for the memory check (requireFrameMemory()) done first.
inline Image frameImage(const RenderScene& scene, const RenderOptions& opts, FrameLayers& ids,
                        const std::vector<std::string>& extra = {}, std::size_t channels = 0)
{
    const int width = opts.camera.width, height = opts.camera.height;
    requireFrameMemory(opts, width, height, scene.stars.size() + 1 + extra.size(), channels);
    Image img(width, height);
    ids.stars.clear();
    for (const auto& s : scene.stars)
        ids.stars.push_back(img.addLayer(starLayerName(s.name)));
    ids.transmittance = img.addLayer(TRANSMITTANCE_LAYER, 1.0f);
    for (const auto& name : extra)
        img.addLayer(name);
    const Projection projection(opts.camera);
    if (!projection.coversImage()) { // a fisheye's corners outside the circle
        img.inView.resize(std::size_t(width) * height);
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x)
                img.inView[std::size_t(y) * width + x] = projection.inView(x + 0.5, y + 0.5);
    }
    return img;
}

/// Refuses --levels without a phase table (the fast integrator and its spectral mode): each
/// level adds the change of the per-voxel scattering Phi.
inline void requireTableForLevels(const RenderOptions& opts)
{
    if (opts.levels > 0 && !opts.phaseTable) {
        throw UsageError("--levels needs a phase table (--phase): each level adds the change "
                         "of the per-voxel scattering Phi as the voxel doubles");
    }
}

/// Warns that @p input's pyramid levels go unused: without a phase table, --levels or the
/// RGB scattered-light @p field (the fast integrator and the path tracer). In integrator.cpp.
void warnUnusedLevels(const IntegratorInput& input, const RenderOptions& opts, bool field,
                      const Run& run);

/// The expected cost of each row of a frame of @p opts' camera over @p scene, for the
/// progress bar's time left (never the pixels): a sparse subset of each row's pixels
/// (ROW_COST_COLUMNS, evenly spaced) marched as the fast integrator marches them (steps of
/// --step voxels through the occupied blocks, at ROW_COST_STRIDE times the step, stopping
/// where the most transparent channel's transmittance falls below minTransmittance), each
/// pixel in view costing ROW_COST_PIXEL steps plus its steps, and each step where a star's
/// optical depth is marched exactly (@p depth, the integrator's own StarDepth: null where it
/// marches none, StarDepth::curved()) ROW_COST_STAR_DEPTH more per such star.
/// Deterministic (a function of the scene and the camera alone; the rows are independent);
/// every row weighs at least 1. In integrator.cpp.
std::vector<std::uint64_t> rowCosts(const RenderScene& scene, const RenderOptions& opts,
                                    const StarDepth* depth);
/// The pixels of a row that rowCosts() marches.
inline constexpr int ROW_COST_COLUMNS = 16;
/// rowCosts() steps this many ray steps at a time (each counted as that many).
inline constexpr int ROW_COST_STRIDE = 4;
/// A pixel's cost beyond its ray steps, in ray steps (camera ray, box, stars, writing).
inline constexpr double ROW_COST_PIXEL = 1.0;
/// The cost of a step where a star's optical depth is marched exactly (StarDepth: up to 32
/// voxels of exact column), in ray steps, per such star. These two were fitted to the rows'
/// times of a 512^2 dome master of the README example (bench/progress_truth.sh's view):
/// 3/4 of its steps are such steps, and they take most of the time.
inline constexpr double ROW_COST_STAR_DEPTH = 16.0;

/// Runs @p band(y0, y1, stats) for bands of rows [y0, y1) of a frame of @p opts' camera over
/// @p scene (its height rows), in parallel (bands of at least @p grain rows), with a progress
/// bar labelled @p label (drawn only if @p run shows progress) that counts work, not rows:
/// each row weighs rowCosts() with the integrator's @p depth (computed only when progress is
/// shown; the star depth's cells built for it serve the render too), so the time left holds
/// when rows cost unlike amounts (a dome master's sky and cloud); and adds every band's
/// statistics to @p stats (if not null). If @p run can be cancelled (Run::setCancel()), @p band
/// is called for one row at a time, each only while the run is not cancelled; once it is, the
/// loop ends by throwing Cancelled within a row, and the image is to be dropped. Every pixel is
/// computed by one band alone, so the image does not depend on how the rows are split or on the
/// thread count; the statistics are integer sums.
template <class Band>
void forEachRowBand(const RenderScene& scene, const RenderOptions& opts, const StarDepth* depth,
                    int grain, const Run* run, const std::string& label, RenderStats* stats,
                    Band&& band)
{
    const int height = opts.camera.height;
    // prefix[y]: the weight of rows [0, y).
    std::vector<std::uint64_t> prefix(std::size_t(height) + 1);
    for (int y = 0; y <= height; ++y)
        prefix[std::size_t(y)] = std::uint64_t(y);
    if (run && (run->showProgress() || run->progressLines())) {
        const std::vector<std::uint64_t> cost = rowCosts(scene, opts, depth);
        for (int y = 0; y < height; ++y)
            prefix[std::size_t(y) + 1] = prefix[std::size_t(y)] + cost[std::size_t(y)];
    }
    Progress bar(run, label, prefix.back());
    std::mutex mutex;
    RenderStats total;
    tbb::parallel_for(
        tbb::blocked_range<int>(0, height, grain), [&](const tbb::blocked_range<int>& rows) {
            RenderStats local;
            if (run && run->cancellable()) {
                // Row by row, the flag checked before each (the partitioner
                // may hand a thread many rows at once).
                for (int y = rows.begin(); y < rows.end(); ++y) {
                    run->checkCancel();
                    RenderStats row;
                    band(y, y + 1, row);
                    local += row;
                }
            } else {
                band(rows.begin(), rows.end(), local);
            }
            bar.add(prefix[std::size_t(rows.end())] - prefix[std::size_t(rows.begin())]);
            const std::lock_guard<std::mutex> lock(mutex);
            total += local;
        });
    if (stats) *stats += total;
}

} // namespace nebula::detail
