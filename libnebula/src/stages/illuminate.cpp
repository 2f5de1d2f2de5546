// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/illuminate.h"

#include "nebula/core/format.h"

#include "nebula/io/grid_names.h"

#include "nebula/core/error.h"
#include "nebula/io/volume_vdb.h"

#include <openvdb/tools/Morphology.h>
#include <openvdb/tree/LeafManager.h>

#include <atomic>

#include <sstream>

namespace nebula {

openvdb::FloatGrid::Ptr tauSupport(const openvdb::FloatGrid& density)
{
    auto grid = density.deepCopy();
    openvdb::tools::dilateActiveValues(grid->tree(), 1, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::EXPAND_TILES);
    return grid;
}

std::vector<std::uint32_t> tauSupportPoints(const openvdb::FloatGrid& support,
                                            const SparseVolume& n)
{
    std::vector<std::uint32_t> points;
    points.reserve(support.activeVoxelCount());
    for (auto it = support.cbeginValueOn(); it; ++it) {
        const auto& c = it.getCoord();
        if (n.contains(c.x(), c.y(), c.z())) {
            points.push_back(std::uint32_t(n.index(c.x(), c.y(), c.z())));
        }
    }
    return points;
}

void addOpticalDepths(GridSet& products, const openvdb::FloatGrid& density,
                      const std::vector<Star>& stars, const DustParams& dust,
                      const std::string& suffix, const Run& run)
{
    // The density as a sparse volume with a zero border, so the trilinear field falls to zero
    // at the edge.
    const openvdb::FloatGrid::ConstPtr source = density.copy(); // shares the tree
    const SparseVolume n = volumeFromGrids({source}, activeBounds({source}, 1), products.source);
    const Affine worldToIndex = n.indexToWorld.inverse();
    run.info("density " + std::to_string(n.dims()[0]) + "x" + std::to_string(n.dims()[1]) + "x" +
             std::to_string(n.dims()[2]) + " voxels, " + std::to_string(stars.size()) + " stars");

    const openvdb::FloatGrid::Ptr support = tauSupport(density);
    const ColumnIntegrator column(n); // its empty-cell bits once for all stars
    for (const auto& star : stars) {
        const Vec3 s =
            worldToIndex.apply(Vec3(star.position[0], star.position[1], star.position[2]));
        // tau straight into the output grid, leaf by leaf in parallel: no per-voxel array.
        auto grid = openvdb::FloatGrid::create(0.0f);
        grid->setTransform(density.transform().copy());
        grid->tree().topologyUnion(support->tree());
        grid->tree().voxelizeActiveTiles();
        std::atomic<bool> finite{true};
        {
            Progress bar(run, run.tool() + " " + star.name + suffix, grid->activeVoxelCount());
            openvdb::tree::LeafManager<openvdb::FloatTree> leaves(grid->tree());
            leaves.foreach ([&](openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
                std::size_t count = 0;
                for (auto it = leaf.beginValueOn(); it; ++it, ++count) {
                    const auto& p = it.getCoord();
                    // The column of a non-negative density is >= 0; Simpson's weights can leave
                    // a rounding residue of -1e-33 next to empty cells, which readers rightly
                    // reject. The support lies on the lattice (the density's box grown by 1).
                    const float t =
                        n.contains(p.x(), p.y(), p.z())
                            ? float(std::max(0.0,
                                             dust.kappa_V * column(s, Vec3(p.x(), p.y(), p.z()))))
                            : 0.0f;
                    if (!std::isfinite(t)) finite = false;
                    it.setValue(t);
                }
                bar.add(count);
            });
        }
        if (!finite) {
            throw Error(products.source + ": the optical depth towards star \"" + star.name +
                        "\" overflows: kappa_V = " + detail::numberText(dust.kappa_V) +
                        " [pc^-1 cm^3] (nebula:dust or --kappa-v) times the density grid \"" +
                        density.getName() +
                        "\" is too large; check kappa_V and the grid's units (n_H [cm^-3])");
        }
        grid->setName(tauGridName(star.name) + suffix);
        grid->setGridClass(openvdb::GRID_UNKNOWN);
        grid->insertMeta("star", openvdb::StringMetadata(star.name));
        grid->insertMeta("kappa_V", openvdb::DoubleMetadata(dust.kappa_V));
        grid->insertMeta("density_grid", openvdb::StringMetadata(density.getName()));
        grid->insertMeta("units", openvdb::StringMetadata("optical depth at V (550 nm)"));
        products.replace(grid);
    }
}

void illuminate(GridSet& grids, const IllumOptions& opts, const Run& run)
{
    const auto density = grids.floatGrid(opts.densityGrid, "--density-grid");
    requireFiniteNonNegative(*density, grids.source);
    const auto stars = opts.stars.empty() ? grids.stars() : opts.stars;
    if (stars.empty()) {
        throw Error(grids.source + ": no stars: the file has no " + std::string(META_STARS) +
                    " metadata; give --star or --stars");
    }
    opts.dust.validate();

    GridSet products;
    products.source = grids.source;
    addOpticalDepths(products, *density, stars, opts.dust, "", run);

    if (opts.onlyNew) grids.grids.clear();
    for (auto& g : products.grids)
        grids.replace(g);
    grids.setStars(stars);
    grids.setDust(opts.dust);
}

} // namespace nebula
