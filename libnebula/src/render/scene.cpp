#include "nebula/render/scene.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/colour.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace nebula {

using detail::numberText;

namespace {

/// The tau grid of star @p star (with @p suffix, ".L<k>" for a level); Error naming the file,
/// the grid and the command that makes it if it is missing.
openvdb::FloatGrid::Ptr tauGrid(const GridSet& grids, const Star& star, const std::string& suffix,
                                const std::string& missingHint)
{
    const std::string name = tauGridName(star.name) + suffix;
    if (!grids.find(name)) {
        throw Error(grids.source + ": no grid \"" + name + "\" for star \"" + star.name + "\"" +
                    missingHint);
    }
    return grids.floatGrid(name, "");
}

/// Throws Error unless @p tau was computed with the dust's kappa_V (its metadata, if any).
void requireSameKappa(const GridSet& grids, const openvdb::FloatGrid& tau, const DustParams& dust)
{
    if (const auto k = tau.getMetadata<openvdb::DoubleMetadata>("kappa_V")) {
        if (std::abs(k->value() - dust.kappa_V) > 1e-9 * dust.kappa_V) {
            throw Error(grids.source + ": grid \"" + tau.getName() +
                        "\" was computed with kappa_V = " + std::to_string(k->value()) +
                        " but the dust has kappa_V = " + std::to_string(dust.kappa_V) +
                        "; rerun nebillum");
        }
    }
}

/// Throws Error unless the phase table was made for the dust's albedo, g and phase model
/// (or opts.phaseIgnoreDust).
void requireTableForDust(const GridSet& grids, const RenderOptions& opts, const DustParams& dust)
{
    const auto& table = opts.phaseTable;
    if (!table) return;
    const auto& m = table->medium;
    const bool same = std::abs(m.albedo - dust.albedo) <= 1e-9 && std::abs(m.g - dust.g) <= 1e-9 &&
                      m.phase == dust.phase;
    if (!same && !opts.phaseIgnoreDust) {
        throw Error(opts.phaseSource + ": the phase table was made for albedo " +
                    numberText(m.albedo) + ", g " + numberText(m.g) + ", phase " +
                    toString(m.phase) + " but " + grids.source + "'s dust has albedo " +
                    numberText(dust.albedo) + ", g " + numberText(dust.g) + ", phase " +
                    toString(dust.phase) + "; rebuild it (nebphase -i " + grids.source +
                    " -o phase.vdb) or pass --phase-ignore-dust");
    }
}

/// How many pyramid levels to read: opts.levels, or (auto, -1) every level the input has
/// when there is a phase table.
int levelCount(const GridSet& grids, const RenderOptions& opts)
{
    int count = opts.levels;
    if (count < 0) {
        count = 0;
        while (opts.phaseTable && grids.find(levelGridName(opts.densityGrid, count + 1)))
            ++count;
    }
    if (count > 0 && !opts.phaseTable) {
        throw UsageError("--levels needs a phase table (--phase): each level adds the change "
                         "of the per-voxel scattering Phi as the voxel doubles");
    }
    return count;
}

/// Pyramid level @p k: density.L<k> and tau.<star>.L<k> as dense fields (channel 1, the
/// emission, empty); Error if a grid is missing or its voxels are not 2^k times level 0's
/// (@p a0: level 0's index-to-world map).
RenderLevel readLevel(const GridSet& grids, const RenderOptions& opts,
                      const std::vector<Star>& stars, int k, const Affine& a0)
{
    const std::string suffix = ".L" + std::to_string(k);
    const std::string dName = levelGridName(opts.densityGrid, k);
    if (!grids.find(dName)) {
        throw Error(grids.source + ": no grid \"" + dName + "\" for level " + std::to_string(k) +
                    " of --levels " + std::to_string(opts.levels) + "; run nebpyramid --levels " +
                    std::to_string(opts.levels) + " first");
    }
    auto dk = grids.floatGrid(dName, "");
    requireFiniteNonNegative(*dk, grids.source);
    auto empty = openvdb::FloatGrid::create(0.0f);
    empty->setTransform(dk->transform().copy());
    std::vector<openvdb::FloatGrid::ConstPtr> lf{dk, empty};
    for (const auto& st : stars) {
        lf.push_back(tauGrid(grids, st, suffix,
                             " at level " + std::to_string(k) + "; run nebpyramid on this file"));
    }
    RenderLevel level;
    level.level = k;
    level.fields = denseFromGrids(lf, activeBounds({dk}, 1), grids.source);
    // Voxels 2^k times level 0's (same orientation): compare the linear maps.
    const auto& ak = level.fields.indexToWorld;
    const double scale = double(1 << k);
    double worst = 0.0, norm = 0.0;
    for (int i = 0; i < 9; ++i) {
        worst = std::max(worst, std::abs(ak.m[std::size_t(i)] - scale * a0.m[std::size_t(i)]));
        norm = std::max(norm, std::abs(scale * a0.m[std::size_t(i)]));
    }
    if (worst > 1e-6 * norm) {
        throw Error(grids.source + ": grid \"" + dName + "\" has voxels that are not " +
                    std::to_string(1 << k) + " times those of \"" + opts.densityGrid +
                    "\" (level " + std::to_string(k) + "); rebuild the levels with nebpyramid");
    }
    return level;
}

} // namespace

RenderScene buildScene(const GridSet& grids, const RenderOptions& opts, const DustParams& dust)
{
    RenderScene scene;
    const auto density = grids.floatGrid(opts.densityGrid, "--density-grid");
    requireFiniteNonNegative(*density, grids.source);
    openvdb::FloatGrid::Ptr emission;
    if (grids.find(opts.emissionGrid)) {
        emission = grids.floatGrid(opts.emissionGrid, "--emission-grid");
        requireFiniteNonNegative(*emission, grids.source);
    }
    scene.stars = grids.stars();
    if (scene.stars.empty()) {
        throw Error(grids.source + ": no stars: the file has no " + std::string(META_STARS) +
                    " metadata (run nebgen and nebillum, or nebillum --star)");
    }
    if (!emission) {
        emission = openvdb::FloatGrid::create(0.0f); // no emission: an empty grid
        emission->setTransform(density->transform().copy());
    }
    std::vector<openvdb::FloatGrid::ConstPtr> fields{density, emission};
    for (const auto& s : scene.stars) {
        auto tau = tauGrid(grids, s, "", "; run nebillum on this file first");
        requireSameKappa(grids, *tau, dust);
        fields.push_back(tau);
    }
    scene.fields = denseFromGrids(fields, activeBounds({density, fields[1]}, 1), grids.source);

    for (const auto& s : scene.stars) {
        const auto c = blackbodyLinearSRGB(s.temperature);
        scene.starColor.push_back({c[0] * s.luminosity, c[1] * s.luminosity, c[2] * s.luminosity});
    }
    static_cast<DustParams&>(scene.dust) = dust;
    for (int c = 0; c < 3; ++c) {
        try {
            scene.dust.r[c] = extinctionRatio(dust, opts.wavelengths[c]);
        } catch (const Error& e) { // a wavelength outside the curve: the option's fault
            throw UsageError("--wavelengths: " + std::string(e.what()));
        }
    }
    requireTableForDust(grids, opts, dust);
    scene.buildOccupancy();

    const int levels = levelCount(grids, opts);
    for (int k = 1; k <= levels; ++k) {
        scene.levels.push_back(readLevel(grids, opts, scene.stars, k, scene.fields.indexToWorld));
    }
    return scene;
}

void requireRayStep(const RenderScene& scene, double step)
{
    if (!(step > 0.0) || !std::isfinite(step)) {
        throw UsageError("--step must be a finite number > 0 [voxels], got " + numberText(step));
    }
    const auto& d = scene.fields.dims();
    const double diagonal =
        std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]); // [voxels]
    const double smallest = diagonal / MAX_STEPS_PER_RAY;
    if (step >= smallest) return;
    const double voxel = voxelSize(scene.fields.indexToWorld); // [pc]
    throw UsageError(fmt::format(
        "--step {}: a ray across this grid ({}x{}x{} voxels, {:.4g} voxels corner to corner) "
        "would take {:.3g} steps, more than the limit of {:.0e}; the smallest step for this "
        "grid is {:.3g} voxels ({:.3g} pc)",
        numberText(step), d[0], d[1], d[2], diagonal, diagonal / step, MAX_STEPS_PER_RAY, smallest,
        smallest * voxel));
}

void RenderScene::buildOccupancy()
{
    // A lattice cell is occupied if any of its 8 corners has dust or emission.
    std::vector<std::array<float, 2>> maxima;
    blockMaxima(fields, blocks, maxima);
    occupied.resize(maxima.size());
    for (std::size_t b = 0; b < maxima.size(); ++b) {
        occupied[b] = maxima[b][0] > 0.0f || maxima[b][1] > 0.0f;
    }
}

} // namespace nebula
