#include "nebula/stages/scatter.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/io/grid_names.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/scene.h"
#include "nebula/stages/pyramid.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>

namespace nebula {

ScatterField scatter(GridSet& grids, const ScatterStageOptions& opts, const Run& run)
{
    const DustParams dust = grids.dust(run);
    RenderOptions ropts;
    ropts.densityGrid = opts.densityGrid;
    ropts.emissionGrid = opts.emissionGrid;
    ropts.wavelengths = opts.wavelengths;
    ropts.minStarDistance = opts.minStarDistance;
    ropts.exactStarDepth = opts.exactStarDepth;
    ropts.levels = 0;
    const RenderScene scene = buildScene(grids, ropts, dust);
    const bool spectral = opts.spectral > 0;
    ScatterOptions fopts = opts.field;
    if (fopts.fieldLevel == AUTO_FIELD_LEVEL) {
        const FieldLevelChoice c = autoFieldLevel(scene, fopts.order, spectral ? opts.spectral : 3);
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
    run.info(fmt::format("density {}x{}x{} voxels, {} stars; field level {} (cells of {}^3 "
                         "voxels), order L = {} ({} moments per channel), {} packets per source{}",
                         d[0], d[1], d[2], scene.stars.size(), fopts.fieldLevel,
                         1 << fopts.fieldLevel, fopts.order, shCount(fopts.order), fopts.packets,
                         spectral ? fmt::format("; spectral: {} wavelengths, {:g}-{:g} nm",
                                                wavelengths.size(), wavelengths.front(),
                                                wavelengths.back())
                                  : std::string()));

    const auto t0 = std::chrono::steady_clock::now();
    ScatterField field = spectral
                             ? computeSpectralScatterField(scene, ropts, fopts, wavelengths, &run)
                             : computeScatterField(scene, ropts, fopts, &run);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    run.info(fmt::format("field computed in {:.3g} s", seconds));

    // Replace any earlier field of the same kind (R, G, B or spectral).
    const auto density = grids.find(opts.densityGrid);
    const auto xform = levelTransform(density->transform(), field.level);
    if (opts.onlyNew) grids.grids.clear();
    openvdb::GridPtrVec kept;
    for (auto& g : grids.grids) {
        const std::string& name = g->getName();
        const bool spectralGrid = name.rfind(SPECTRAL_SCATTER_PREFIX, 0) == 0;
        const bool fieldGrid =
            spectral ? spectralGrid : name.rfind("scatter.", 0) == 0 && !spectralGrid;
        if (!fieldGrid) kept.push_back(g);
    }
    grids.grids = kept;

    const int L = field.order;
    const int C = spectral ? int(wavelengths.size()) : 3; // channels per moment
    nlohmann::json sources = nlohmann::json::array();
    for (const auto& src : field.sources) {
        const DenseVolume& m = src.moments;
        const double j0 = 0.5 / std::sqrt(PI); // Y_00: J = c_00 / (4 pi Y_00)
        for (int l = 0; l <= L; ++l)
            for (int mm = -l; mm <= l; ++mm)
                for (int c = 0; c < C; ++c) {
                    const int ch = shIndex(l, mm) * C + c;
                    const double scale = l == 0 ? 1.0 / (4.0 * PI * j0) : 1.0;
                    auto grid = openvdb::FloatGrid::create(0.0f);
                    auto acc = grid->getAccessor();
                    for (int K = m.lo()[2]; K < m.lo()[2] + m.dims()[2]; ++K)
                        for (int J = m.lo()[1]; J < m.lo()[1] + m.dims()[1]; ++J)
                            for (int I = m.lo()[0]; I < m.lo()[0] + m.dims()[0]; ++I) {
                                const std::size_t v = m.index(I, J, K);
                                if (!field.active[v]) continue;
                                acc.setValue(openvdb::Coord(I, J, K),
                                             float(m.voxel(v)[ch] * scale));
                            }
                    grid->setTransform(xform->copy());
                    grid->setName(spectral ? spectralScatterGridName(src.name, l, mm,
                                                                     wavelengths[std::size_t(c)])
                                           : scatterGridName(src.name, l, mm, c));
                    grid->setGridClass(openvdb::GRID_UNKNOWN);
                    const char* units =
                        spectral ? (l == 0 ? "L_sun pc^-2 sr^-1 nm^-1 (mean intensity J per nm)"
                                           : "L_sun pc^-2 nm^-1 (c_lm per nm)")
                                 : (l == 0 ? "L_sun pc^-2 sr^-1 (mean intensity J)"
                                           : "L_sun pc^-2 (c_lm)");
                    grid->insertMeta("units", openvdb::StringMetadata(units));
                    if (spectral) {
                        grid->insertMeta("wavelength_nm",
                                         openvdb::DoubleMetadata(wavelengths[std::size_t(c)]));
                    }
                    grid->insertMeta("source", openvdb::StringMetadata(src.name));
                    grid->insertMeta("l", openvdb::Int32Metadata(l));
                    grid->insertMeta("m", openvdb::Int32Metadata(mm));
                    grid->insertMeta("level", openvdb::Int32Metadata(field.level));
                    grids.replace(grid);
                }
        sources.push_back({{"name", src.name},
                           {"packets", src.packets},
                           {"flights", src.flights},
                           {"power", src.power},
                           {"escaped", src.escaped},
                           {"absorbed", src.absorbed},
                           {"relative_error", src.relativeError}});
    }
    const Affine& a0 = scene.fields.indexToWorld;
    nlohmann::json meta = {{"order", L},
                           {"level", field.level},
                           {"per_star", fopts.perStar},
                           {"packets", fopts.packets},
                           {"seed", fopts.seed},
                           {"sources", sources},
                           {"dust", nlohmann::json::parse(dust.toJson())},
                           {"stars", nlohmann::json::parse(starsToJson(scene.stars))},
                           {"wavelengths", spectral ? wavelengths
                                                    : std::vector<double>(opts.wavelengths.begin(),
                                                                          opts.wavelengths.end())},
                           {"min_star_distance", opts.minStarDistance},
                           {"exact_star_depth", opts.exactStarDepth},
                           {"density_grid", opts.densityGrid},
                           {"emission_grid", opts.emissionGrid},
                           {"index_to_world",
                            {a0.m[0], a0.m[1], a0.m[2], a0.t.x, a0.m[3], a0.m[4], a0.m[5], a0.t.y,
                             a0.m[6], a0.m[7], a0.m[8], a0.t.z}},
                           {"seconds", seconds}};
    grids.setMetaString(spectral ? META_SCATTER_SPECTRAL : META_SCATTER, meta.dump());
    return field;
}

} // namespace nebula
