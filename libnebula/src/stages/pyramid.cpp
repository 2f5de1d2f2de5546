// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/pyramid.h"

#include "nebula/core/error.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/stages/illuminate.h"

#include <openvdb/tools/Morphology.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>

namespace nebula {

namespace {

/// Levels beyond this would overflow coarse index arithmetic long before any grid is that big.
constexpr int MAX_LEVEL = 24;

using FloatLeaf = openvdb::FloatTree::LeafNodeType;
constexpr int LEAF_DIM = int(FloatLeaf::DIM); // 8

openvdb::Coord coarseCoord(const openvdb::Coord& c, int level)
{
    return {coarseIndex(c.x(), level), coarseIndex(c.y(), level), coarseIndex(c.z(), level)};
}

/// Sum and count of the active values of @p fine in the block of 2^level voxels a side from
/// @p lo, in a fixed order (so the same whatever the thread count). Blocks of a leaf or
/// more are walked leaf by leaf, with a tile standing for its 8^3 voxels.
void blockSum(const openvdb::FloatGrid::ConstAccessor& fine, const openvdb::Coord& lo, int level,
              double& sum, double& count)
{
    const int s = 1 << level;
    sum = 0.0;
    count = 0.0;
    if (s < LEAF_DIM) {
        float v = 0.0f;
        for (int z = 0; z < s; ++z)
            for (int y = 0; y < s; ++y)
                for (int x = 0; x < s; ++x) {
                    if (fine.probeValue(lo.offsetBy(x, y, z), v)) {
                        sum += double(v);
                        count += 1.0;
                    }
                }
        return;
    }
    for (int z = 0; z < s; z += LEAF_DIM)
        for (int y = 0; y < s; y += LEAF_DIM)
            for (int x = 0; x < s; x += LEAF_DIM) {
                const openvdb::Coord origin = lo.offsetBy(x, y, z);
                if (const FloatLeaf* leaf = fine.probeConstLeaf(origin)) {
                    for (auto it = leaf->cbeginValueOn(); it; ++it) {
                        sum += double(*it);
                        count += 1.0;
                    }
                } else {
                    float v = 0.0f;
                    if (fine.probeValue(origin, v)) { // an active tile covers this leaf
                        sum += double(v) * double(FloatLeaf::SIZE);
                        count += double(FloatLeaf::SIZE);
                    }
                }
            }
}

/// The coarse grid of level @p level, its values the block sums divided by 8^level (volume
/// average, inactive = 0) or by the number of active voxels (mean of the active ones).
openvdb::FloatGrid::Ptr reduce(const openvdb::FloatGrid& grid, int level, bool activeOnly)
{
    if (level < 0 || level > MAX_LEVEL) {
        throw Error("grid \"" + grid.getName() + "\": pyramid level " + std::to_string(level) +
                    " is outside 0 .. " + std::to_string(MAX_LEVEL));
    }
    auto coarse = openvdb::FloatGrid::create(0.0f);

    // Topology: every coarse voxel whose block holds an active voxel or tile. Tiles first
    // (fill), then the leaves through an accessor.
    {
        auto it = grid.tree().cbeginValueOn();
        it.setMaxDepth(openvdb::FloatTree::ValueOnCIter::LEAF_DEPTH - 1); // tiles only
        for (; it; ++it) {
            openvdb::CoordBBox tile;
            it.getBoundingBox(tile);
            coarse->tree().fill(
                openvdb::CoordBBox(coarseCoord(tile.min(), level), coarseCoord(tile.max(), level)),
                0.0f, true);
        }
    }
    {
        auto acc = coarse->getAccessor();
        for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
            if (leaf->isEmpty()) continue;
            if ((1 << level) >= LEAF_DIM) { // the whole leaf falls into one coarse voxel
                acc.setValueOn(coarseCoord(leaf->origin(), level), 0.0f);
                continue;
            }
            for (auto it = leaf->cbeginValueOn(); it; ++it) {
                acc.setValueOn(coarseCoord(it.getCoord(), level), 0.0f);
            }
        }
    }
    coarse->tree().voxelizeActiveTiles();

    // Values: each coarse voxel from its own block, coarse leaves in parallel.
    const double volume = std::ldexp(1.0, 3 * level); // 8^level
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(coarse->tree());
    leaves.foreach ([&](FloatLeaf& leaf, std::size_t) {
        const auto fine = grid.getConstAccessor();
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const openvdb::Coord I = it.getCoord();
            const openvdb::Coord lo(I.x() * (1 << level), I.y() * (1 << level),
                                    I.z() * (1 << level));
            double sum = 0.0, count = 0.0;
            blockSum(fine, lo, level, sum, count);
            const double value = activeOnly ? (count > 0.0 ? sum / count : 0.0) : sum / volume;
            it.setValue(float(value));
        }
    });

    coarse->setTransform(levelTransform(grid.transform(), level));
    coarse->setName(levelGridName(grid.getName(), level));
    coarse->setGridClass(grid.getGridClass());
    coarse->insertMeta("level", openvdb::Int32Metadata(level));
    coarse->insertMeta("scale", openvdb::Int32Metadata(1 << level));
    coarse->insertMeta("source_grid", openvdb::StringMetadata(grid.getName()));
    return coarse;
}

std::string dimsText(const openvdb::CoordBBox& box)
{
    if (box.empty()) return "0x0x0";
    const auto d = box.dim();
    return std::to_string(d.x()) + "x" + std::to_string(d.y()) + "x" + std::to_string(d.z());
}

double secondsSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string approx(double v)
{
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", v);
    return text;
}

} // namespace

TauMethod tauMethodFromString(const std::string& name)
{
    if (name == "recompute") return TauMethod::Recompute;
    if (name == "average") return TauMethod::Average;
    throw UsageError("--tau \"" + name + "\": expected recompute or average");
}

std::string toString(TauMethod method)
{
    return method == TauMethod::Average ? "average" : "recompute";
}

openvdb::math::Transform::Ptr levelTransform(const openvdb::math::Transform& fine, int level)
{
    // world(I) = fine(2^k I + (2^k - 1)/2): preTranslate gives x -> fine(x + c), and the
    // preScale after it x -> fine(2^k x + c).
    const double s = std::ldexp(1.0, level);
    auto xform = fine.copy();
    xform->preTranslate(openvdb::Vec3d(0.5 * (s - 1.0)));
    xform->preScale(s);
    return xform;
}

openvdb::FloatGrid::Ptr boxAverage(const openvdb::FloatGrid& grid, int level)
{
    return reduce(grid, level, /*activeOnly=*/false);
}

openvdb::FloatGrid::Ptr activeMean(const openvdb::FloatGrid& grid, int level)
{
    return reduce(grid, level, /*activeOnly=*/true);
}

openvdb::FloatGrid::Ptr averageOpticalDepth(const openvdb::FloatGrid& tau0,
                                            const openvdb::FloatGrid& coarse, int level,
                                            const ColumnIntegrator& column0, const Vec3& star0,
                                            double kappa_V)
{
    auto tau = activeMean(tau0, level);
    auto support = coarse.deepCopy();
    openvdb::tools::dilateActiveValues(support->tree(), 1, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::EXPAND_TILES);
    std::vector<openvdb::Coord> holes;
    for (auto it = support->cbeginValueOn(); it; ++it) {
        if (!tau->tree().isValueOn(it.getCoord())) holes.push_back(it.getCoord());
    }
    // The exact level-0 tau at each hole's centre, the level-0 index point 2^k I + (2^k-1)/2.
    std::vector<float> values(holes.size());
    const double s = std::ldexp(1.0, level), half = 0.5 * (s - 1.0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, holes.size(), 64),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t q = r.begin(); q != r.end(); ++q) {
                              const openvdb::Coord& I = holes[q];
                              const Vec3 centre(s * I.x() + half, s * I.y() + half,
                                                s * I.z() + half);
                              values[q] = float(kappa_V * column0(star0, centre));
                          }
                      });
    auto acc = tau->getAccessor();
    for (std::size_t q = 0; q < holes.size(); ++q)
        acc.setValueOn(holes[q], values[q]);
    return tau;
}

int maxPyramidLevel(const openvdb::CoordBBox& bounds)
{
    if (bounds.empty()) return -1;
    const auto d = bounds.dim();
    const std::int64_t longest = std::max({d.x(), d.y(), d.z()});
    int level = -1;
    while (level < MAX_LEVEL && (std::int64_t(2) << (level + 1)) <= longest)
        ++level;
    return level;
}

namespace {

/// Throws unless @p density can have opts.levels levels: active voxels, spanning enough.
void checkLevels(const GridSet& grids, const openvdb::FloatGrid& density,
                 const PyramidOptions& opts)
{
    if (opts.levels < 1) {
        throw UsageError("--levels must be >= 1, got " + std::to_string(opts.levels));
    }
    const std::string quoted = "grid \"" + density.getName() + "\"";
    const auto bounds = density.evalActiveVoxelBoundingBox();
    if (bounds.empty()) {
        throw Error(grids.source + ": " + quoted + " has no active voxels; nothing to average");
    }
    const int maxLevel = maxPyramidLevel(bounds);
    const auto dim = bounds.dim();
    const int longest = std::max({dim.x(), dim.y(), dim.z()});
    if (maxLevel < 1) {
        throw Error(grids.source + ": " + quoted + ": its active voxels span only " +
                    std::to_string(longest) +
                    " voxels along the longest axis; level 1 needs at least 4");
    }
    if (opts.levels > maxLevel) {
        throw UsageError(
            "--levels " + std::to_string(opts.levels) + " is too many for " + quoted + " of " +
            grids.source + ": its active bounding box is " + std::to_string(longest) +
            " voxels along the longest axis, so level " + std::to_string(opts.levels) +
            " would be fewer than 2 voxels across; at most --levels " + std::to_string(maxLevel));
    }
}

/// --tau average: the level-0 optical depths, checked before any work.
std::vector<openvdb::FloatGrid::Ptr> levelZeroTaus(const GridSet& grids,
                                                   const openvdb::FloatGrid& density,
                                                   const std::vector<Star>& stars)
{
    std::vector<openvdb::FloatGrid::Ptr> tau0;
    for (const auto& star : stars) {
        const std::string name = tauGridName(star.name);
        if (!grids.find(name)) {
            throw Error(grids.source + ": no grid \"" + name + "\" for star \"" + star.name +
                        "\"; --tau average averages the level-0 optical depths: run "
                        "nebillum first, or use --tau recompute");
        }
        auto tau = grids.floatGrid(name, "--tau average");
        requireFiniteNonNegative(*tau, grids.source);
        if (tau->transform() != density.transform()) {
            throw Error(grids.source + ": grid \"" + name + "\" does not share the transform of " +
                        "grid \"" + density.getName() +
                        "\"; rerun nebillum, or use --tau recompute");
        }
        tau0.push_back(tau);
    }
    return tau0;
}

/// --tau average at level @p k: each star's level-0 tau averaged over the coarse voxels,
/// exact where it has none (@p column0 through the level-0 density @p n0).
void averagedTaus(GridSet& taus, const openvdb::FloatGrid& coarse, int k,
                  const std::vector<openvdb::FloatGrid::Ptr>& tau0, const std::vector<Star>& stars,
                  const DustParams& dust, const SparseVolume& n0, const ColumnIntegrator& column0)
{
    const Affine worldToIndex0 = n0.indexToWorld.inverse();
    for (std::size_t s = 0; s < stars.size(); ++s) {
        const auto& p = stars[s].position;
        double kappa_V = dust.kappa_V; // the one the level-0 tau was made with
        if (auto m = tau0[s]->getMetadata<openvdb::DoubleMetadata>("kappa_V")) {
            kappa_V = m->value();
        }
        auto tau = averageOpticalDepth(*tau0[s], coarse, k, column0,
                                       worldToIndex0.apply(Vec3(p[0], p[1], p[2])), kappa_V);
        tau->setGridClass(openvdb::GRID_UNKNOWN);
        tau->insertMeta("star", openvdb::StringMetadata(stars[s].name));
        tau->insertMeta("kappa_V", openvdb::DoubleMetadata(kappa_V));
        tau->insertMeta("units", openvdb::StringMetadata("optical depth at V (550 nm)"));
        taus.replace(tau);
    }
}

} // namespace

void buildPyramid(GridSet& grids, const PyramidOptions& opts, const Run& run)
{
    if (opts.levels < 1) {
        throw UsageError("--levels must be >= 1, got " + std::to_string(opts.levels));
    }
    const auto density = grids.floatGrid(opts.densityGrid, "--density-grid");
    requireFiniteNonNegative(*density, grids.source);
    checkLevels(grids, *density, opts);
    const auto stars = grids.stars();
    if (stars.empty()) {
        throw Error(grids.source + ": no stars: the file has no " + std::string(META_STARS) +
                    " metadata, which the tau.<star>.L<k> grids need; add stars with nebgen "
                    "or nebillum (--star, --stars)");
    }
    const DustParams dust = grids.dust(run);
    dust.validate();
    const bool average = opts.tau == TauMethod::Average;
    const auto tau0 =
        average ? levelZeroTaus(grids, *density, stars) : std::vector<openvdb::FloatGrid::Ptr>{};
    // The level-0 density as a dense lattice (zero border), for the exact tau of the coarse
    // voxels that --tau average has no level-0 tau for.
    std::optional<SparseVolume> n0;
    std::optional<ColumnIntegrator> column0;
    if (average) {
        n0.emplace(volumeFromGrids({density}, activeBounds({density}, 1), grids.source));
        column0.emplace(*n0);
    }

    const double mass0 = gridMass(*density);
    run.info("grid \"" + density->getName() +
             "\": " + dimsText(density->evalActiveVoxelBoundingBox()) + " active bounding box, " +
             std::to_string(density->activeVoxelCount()) + " active voxels, mass " + approx(mass0) +
             " [cm^-3 pc^3]; " + std::to_string(opts.levels) + " levels, tau " +
             toString(opts.tau) + ", " + std::to_string(stars.size()) + " stars");
    GridSet products;
    products.source = grids.source;
    for (int k = 1; k <= opts.levels; ++k) {
        const auto start = std::chrono::steady_clock::now();
        const auto coarse = boxAverage(*density, k);
        products.replace(coarse);
        const double mass = gridMass(*coarse);
        run.info("level " + std::to_string(k) + ": " + coarse->getName() + " " +
                 dimsText(coarse->evalActiveVoxelBoundingBox()) + " active bounding box, mass " +
                 approx(mass) + " (relative change " + approx(mass / mass0 - 1.0) + ")");
        GridSet taus;
        taus.source = grids.source;
        if (average) {
            averagedTaus(taus, *coarse, k, tau0, stars, dust, *n0, *column0);
        } else {
            addOpticalDepths(taus, *coarse, stars, dust, ".L" + std::to_string(k), run);
        }
        for (auto& g : taus.grids) {
            g->insertMeta("level", openvdb::Int32Metadata(k));
            g->insertMeta("scale", openvdb::Int32Metadata(1 << k));
            g->insertMeta("method", openvdb::StringMetadata(toString(opts.tau)));
            products.replace(g);
        }
        run.info("level " + std::to_string(k) + ": " + std::to_string(taus.grids.size()) +
                 " tau grids (" + toString(opts.tau) + "), " + approx(secondsSince(start)) + " s");
    }
    if (opts.onlyNew) grids.grids.clear();
    for (auto& g : products.grids)
        grids.replace(g);
    grids.setStars(stars);
    grids.setDust(dust);
}

double gridMass(const openvdb::FloatGrid& grid)
{
    double sum = 0.0;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        sum += double(*it) * double(it.isVoxelValue() ? 1 : it.getVoxelCount());
    }
    return sum * std::fabs(grid.transform().voxelVolume());
}

} // namespace nebula
