// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/scatter.h"

#include "nebula/core/error.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/scatter_field_vdb.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/scene.h"
#include "nebula/stages/pyramid.h"
#include "nebula/stages/scene_assembly.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <memory>

namespace nebula {

namespace {

/// The render options the field's scene is built and walked with: @p opts' grids,
/// wavelengths, star distance clamp and exact star depth, no pyramid levels.
RenderOptions sceneOptions(const ScatterStageOptions& opts)
{
    RenderOptions ropts;
    ropts.densityGrid = opts.scene.densityGrid;
    ropts.emissionGrid = opts.scene.emissionGrid;
    ropts.wavelengths = opts.wavelengths;
    ropts.minStarDistance = opts.scene.minStarDistance;
    ropts.exactStarDepth = opts.scene.exactStarDepth;
    ropts.levels = 0;
    ropts.lineColours = false; // the emission source is --emission-grid alone (DESIGN §3.4)
    return ropts;
}

/// Warns if the emission is scattered and @p grids hold line grids (nebula:lines) besides
/// --emission-grid: their glow is not in the field (DESIGN §3.4).
void warnUnscatteredLineGrids(const GridSet& grids, const ScatterStageOptions& opts, const Run& run)
{
    if (!opts.field.emission || opts.spectral > 0 || !grids.find(opts.scene.emissionGrid)) return;
    std::string names;
    for (const auto& g : grids.grids) {
        if (g->getName() != opts.scene.emissionGrid && (*g)[META_LINES]) {
            names += (names.empty() ? "\"" : ", \"") + g->getName() + "\"";
        }
    }
    if (!names.empty()) {
        run.warn("the field scatters the glow of the emission grid \"" + opts.scene.emissionGrid +
                 "\" only; that of " + names + " is left out");
    }
}

} // namespace

ScatterField scatter(GridSet& grids, const ScatterStageOptions& opts, const Run& run)
{
    const DustParams dust = grids.dust(run);
    const RenderOptions ropts = sceneOptions(opts);
    // The scene is freed once the field is computed, before the field's grids are made (at
    // 512^3 it is the largest thing in memory then: 577 MiB of 1.5 GiB).
    auto built = std::make_unique<const RenderScene>(buildScene(grids, ropts, dust));
    const RenderScene& scene = *built;
    const bool spectral = opts.spectral > 0;
    warnUnscatteredLineGrids(grids, opts, run);
    ScatterOptions fopts = opts.field;
    if (fopts.fieldLevel == AUTO_FIELD_LEVEL) {
        const FieldLevelChoice c =
            autoFieldLevel(scene, fopts.order, spectral ? opts.spectral : 3, fopts.refineTau);
        fopts.fieldLevel = c.level;
        run.info(fmt::format(
            "field level {} chosen: about 64 cells across the grid gives level {}; a voxel "
            "of the densest 1 % of the dust has tau_V {:.3g}, a cell of level {} {:.3g} "
            "(finer while above {:g}); tallies {:.0f} MiB",
            c.level, c.gridLevel, c.voxelTau, c.level, c.cellTau, AUTO_FIELD_MAX_CELL_TAU,
            c.tallyBytes / (1024.0 * 1024.0)));
    }
    validateScatterOptions(scene, fopts);
    const std::vector<double> wavelengths =
        spectral ? spectralFieldWavelengths(opts.spectral) : std::vector<double>{};
    const auto d = scene.fields.dims();
    run.info(fmt::format(
        "density {}x{}x{} voxels, {} stars; field level {} (cells of {}^3 "
        "voxels), order L = {} ({} moments per channel), {} packets per source{}",
        d[0], d[1], d[2], scene.stars.size(), fopts.fieldLevel, fieldCellVoxels(fopts.fieldLevel),
        fopts.order, shCount(fopts.order), fopts.packets,
        spectral ? fmt::format("; spectral: {} wavelengths, {:g}-{:g} nm", wavelengths.size(),
                               wavelengths.front(), wavelengths.back())
                 : std::string()));

    const auto t0 = std::chrono::steady_clock::now();
    ScatterField field = spectral
                             ? computeSpectralScatterField(scene, ropts, fopts, wavelengths, &run)
                             : computeScatterField(scene, ropts, fopts, &run);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    run.info(fmt::format("field computed in {:.3g} s{}", seconds,
                         fopts.ranks && fopts.ranks->size() > 1
                             ? fmt::format(" by {} MPI ranks", fopts.ranks->size())
                             : std::string()));
    if (fopts.ranks && !fopts.ranks->root()) return field; // rank 0 writes the grids

    ScatterFieldMeta meta;
    meta.settings = fopts; // the level resolved: the field's
    meta.scene = opts.scene;
    std::vector<const SparseVolume*> moments;
    for (const auto& src : field.sources) {
        meta.sources.push_back(src); // its summary
        moments.push_back(&src.moments);
    }
    meta.dust = dust;
    meta.stars = scene.stars;
    meta.indexToWorld = scene.fields.indexToWorld;
    built.reset(); // the scene is not needed any more
    meta.wavelengths = spectral
                           ? wavelengths
                           : std::vector<double>(opts.wavelengths.begin(), opts.wavelengths.end());
    meta.seconds = seconds;
    meta.storedBits = opts.storedBits;
    const auto xform = levelTransform(grids.find(opts.scene.densityGrid)->transform(), field.level);
    if (opts.onlyNew) grids.grids.clear();
    writeScatterField(grids, meta, moments, field.active, *xform, spectral);
    return field;
}

} // namespace nebula
