#include "nebula/stages/illuminate.h"

#include "nebula/core/format.h"

#include "nebula/io/grid_names.h"

#include "nebula/core/error.h"
#include "nebula/io/volume_vdb.h"

#include <openvdb/tools/Morphology.h>

#include <sstream>

namespace nebula {

TauSupport tauSupport(const openvdb::FloatGrid& density, const SparseVolume& n)
{
    TauSupport support;
    support.grid = density.deepCopy();
    openvdb::tools::dilateActiveValues(support.grid->tree(), 1, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::EXPAND_TILES);
    support.points.reserve(support.grid->activeVoxelCount());
    for (auto it = support.grid->cbeginValueOn(); it; ++it) {
        const auto& c = it.getCoord();
        if (n.contains(c.x(), c.y(), c.z())) {
            support.points.push_back(std::uint32_t(n.index(c.x(), c.y(), c.z())));
        }
    }
    return support;
}

void addOpticalDepths(GridSet& products, const openvdb::FloatGrid& density,
                      const std::vector<Star>& stars, const DustParams& dust,
                      const std::string& suffix, const Run& run)
{
    // Dense density with a zero border, so the trilinear field falls to zero at the edge.
    const openvdb::FloatGrid::ConstPtr source = density.copy(); // shares the tree
    const SparseVolume n = volumeFromGrids({source}, activeBounds({source}, 1), products.source);
    const Affine worldToIndex = n.indexToWorld.inverse();
    run.info("density " + std::to_string(n.dims()[0]) + "x" + std::to_string(n.dims()[1]) + "x" +
             std::to_string(n.dims()[2]) + " voxels, " + std::to_string(stars.size()) + " stars");

    const TauSupport support = tauSupport(density, n);

    for (const auto& star : stars) {
        const Vec3 s =
            worldToIndex.apply(Vec3(star.position[0], star.position[1], star.position[2]));
        std::vector<float> tau;
        {
            Progress bar(run, run.tool() + " " + star.name + suffix, support.points.size());
            tau = opticalDepthAt(n, s, dust.kappa_V, support.points,
                                 [&](std::size_t k) { bar.add(k); });
        }
        for (const float t : tau) {
            if (!std::isfinite(t)) {
                throw Error(products.source + ": the optical depth towards star \"" + star.name +
                            "\" overflows: kappa_V = " + detail::numberText(dust.kappa_V) +
                            " [pc^-1 cm^3] (nebula:dust or --kappa-v) times the density grid \"" +
                            density.getName() +
                            "\" is too large; check kappa_V and the grid's units (n_H [cm^-3])");
            }
        }
        auto grid = gridFromField(n, tau, *support.grid);
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
