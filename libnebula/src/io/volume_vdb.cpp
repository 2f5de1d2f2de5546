// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/volume_vdb.h"

#include "nebula/core/error.h"
#include "nebula/core/memory.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include <openvdb/tree/LeafManager.h>

#include <tbb/parallel_for.h>

#include <fmt/format.h>

namespace nebula {

Affine affineFromTransform(const openvdb::math::Transform& transform)
{
    // Read the map off by applying it: robust to OpenVDB's row-vector conventions.
    const auto o = transform.indexToWorld(openvdb::Vec3d(0, 0, 0));
    Affine a;
    for (int i = 0; i < 3; ++i) {
        openvdb::Vec3d e(0, 0, 0);
        e[i] = 1.0;
        const auto col = transform.indexToWorld(e) - o;
        for (int r = 0; r < 3; ++r)
            a.m[std::size_t(r * 3 + i)] = col[r];
    }
    a.t = Vec3(o[0], o[1], o[2]);
    return a;
}

openvdb::CoordBBox activeBounds(const std::vector<openvdb::FloatGrid::ConstPtr>& grids, int pad)
{
    openvdb::CoordBBox box;
    for (const auto& g : grids) {
        if (g) box.expand(g->evalActiveVoxelBoundingBox());
    }
    if (box.empty()) box = openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(0));
    box.expand(pad);
    return box;
}

SparseVolume emptyVolume(const openvdb::CoordBBox& bounds, int channels, const std::string& what)
{
    // The lattice spans the grids' active bounding box; its bricks hold memory only where
    // written, but the table of bricks is dense: two voxels very far apart would need more
    // memory than the machine has (a clear error, before anything is allocated).
    double bricks = 1.0;
    for (int a = 0; a < 3; ++a) {
        bricks *= double((std::int64_t(bounds.max()[a]) >> SparseVolume::BRICK_LOG2) -
                         (std::int64_t(bounds.min()[a]) >> SparseVolume::BRICK_LOG2) + 1);
    }
    const auto extent = [&](int a) {
        return std::to_string(std::int64_t(bounds.max()[a]) - std::int64_t(bounds.min()[a]) + 1);
    };
    const std::string span = what + ": the active voxels span " + extent(0) + " x " + extent(1) +
                             " x " + extent(2) + " voxels; the table of the volume's " +
                             fmt::format("{:.3g}", bricks) + " bricks of " +
                             std::to_string(SparseVolume::BRICK) + "^3 voxels";
    try {
        requireMemory(bricks * double(sizeof(std::uint32_t)), span);
        for (int a = 0; a < 3; ++a) {
            if (std::int64_t(bounds.max()[a]) - std::int64_t(bounds.min()[a]) + 1 >
                std::numeric_limits<int>::max()) {
                throw UsageError(span + ": an axis longer than " +
                                 std::to_string(std::numeric_limits<int>::max()) +
                                 " voxels is not supported");
            }
        }
        if (bricks > double(std::numeric_limits<std::uint32_t>::max() - 2)) {
            throw UsageError(span + ": more than " +
                             std::to_string(std::numeric_limits<std::uint32_t>::max() - 2) +
                             " bricks is not supported");
        }
    } catch (const UsageError& e) {
        throw Error(e.what());
    }
    const auto dim = bounds.dim();
    return SparseVolume({bounds.min().x(), bounds.min().y(), bounds.min().z()},
                        {dim.x(), dim.y(), dim.z()}, channels);
}

namespace {

/// Calls @p f(box, value) for each active tile of @p grid, its box clipped to @p bounds (tiles
/// outside them skipped: OpenVDB's box iterator does not notice an empty box in x and y).
template <typename F>
void forEachActiveTile(const openvdb::FloatGrid& grid, const openvdb::CoordBBox& bounds, const F& f)
{
    auto it = grid.tree().cbeginValueOn();
    it.setMaxDepth(openvdb::FloatTree::ValueOnCIter::LEAF_DEPTH - 1); // tiles only
    for (; it; ++it) {
        openvdb::CoordBBox tile;
        it.getBoundingBox(tile);
        tile.intersect(bounds);
        if (!tile.empty()) f(tile, *it);
    }
}

} // namespace

double volumeBytes(const std::vector<openvdb::FloatGrid::ConstPtr>& grids,
                   const openvdb::CoordBBox& bounds, int channels)
{
    // The bricks the grids' active leaves and tiles touch (leaves and bricks share their
    // alignment, so a leaf is one brick); tiles may count a brick twice: an upper bound.
    constexpr int L = SparseVolume::BRICK_LOG2;
    std::vector<std::array<int, 3>> leaves;
    double tileBricks = 0.0;
    for (const auto& g : grids) {
        if (!g) continue;
        for (auto it = g->tree().cbeginLeaf(); it; ++it) {
            if (it->isEmpty()) continue;
            const auto o = it->origin();
            if (!bounds.hasOverlap(openvdb::CoordBBox::createCube(o, SparseVolume::BRICK))) {
                continue;
            }
            leaves.push_back({o.x(), o.y(), o.z()});
        }
        forEachActiveTile(*g, bounds, [&](const openvdb::CoordBBox& tile, float) {
            double n = 1.0;
            for (int a = 0; a < 3; ++a)
                n *= double((tile.max()[a] >> L) - (tile.min()[a] >> L) + 1);
            tileBricks += n;
        });
    }
    std::sort(leaves.begin(), leaves.end());
    const double bricks =
        double(std::unique(leaves.begin(), leaves.end()) - leaves.begin()) + tileBricks;
    return bricks * double(SparseVolume::BRICK_VOXELS) * double(std::max(channels, 1)) *
           double(sizeof(float));
}

namespace {

/// Applies @p op(value, active value) to channel @p c of every lattice point of @p vol where
/// @p grid has an active voxel or tile: leaves in parallel (each writes its own voxels), then
/// tiles serially.
template <typename Op>
void forEachActive(SparseVolume& vol, const openvdb::FloatGrid& grid, int c, const Op& op)
{
    using Leaf = openvdb::FloatTree::LeafNodeType;
    static_assert(Leaf::DIM == SparseVolume::BRICK, "a leaf is one brick");
    openvdb::tree::LeafManager<const openvdb::FloatTree> leaves(grid.tree());
    leaves.foreach ([&](const Leaf& leaf, std::size_t) {
        const auto& o = leaf.origin();
        constexpr int E = SparseVolume::BRICK - 1;
        if (vol.contains(o.x(), o.y(), o.z()) && vol.contains(o.x() + E, o.y() + E, o.z() + E)) {
            // The leaf is one whole brick of the lattice: find it once, then each active
            // value's place in it (OpenVDB's offset is x-major, the brick's z-major).
            float* brick = vol.writable(vol.index(o.x(), o.y(), o.z()));
            const float* values = leaf.buffer().data();
            const std::size_t C = std::size_t(vol.channels());
            for (auto on = leaf.getValueMask().beginOn(); on; ++on) {
                const openvdb::Index n = on.pos();
                const std::size_t x = n >> 6, y = (n >> 3) & 7u, z = n & 7u;
                float& v = brick[((z << 6) | (y << 3) | x) * C + std::size_t(c)];
                v = op(v, values[n]);
            }
            return;
        }
        for (auto it = leaf.cbeginValueOn(); it; ++it) {
            const auto& p = it.getCoord();
            if (vol.contains(p.x(), p.y(), p.z())) {
                float& v = vol.writable(vol.index(p.x(), p.y(), p.z()))[c];
                v = op(v, *it);
            }
        }
    });
    const auto& lo = vol.lo();
    const auto& dims = vol.dims();
    const openvdb::CoordBBox bounds(
        openvdb::Coord(lo[0], lo[1], lo[2]),
        openvdb::Coord(lo[0] + dims[0] - 1, lo[1] + dims[1] - 1, lo[2] + dims[2] - 1));
    forEachActiveTile(grid, bounds, [&](const openvdb::CoordBBox& tile, float value) {
        for (auto p = tile.beginXYZ(); p; ++p) {
            float& v = vol.writable(vol.index((*p).x(), (*p).y(), (*p).z()))[c];
            v = op(v, value);
        }
    });
}

} // namespace

SparseVolume volumeFromGrids(const std::vector<openvdb::FloatGrid::ConstPtr>& grids,
                             const openvdb::CoordBBox& bounds, const std::string& source)
{
    std::string names;
    for (const auto& g : grids)
        names += (names.empty() ? "\"" : ", \"") + g->getName() + "\"";
    const std::string what = source + ": grid" + (grids.size() > 1 ? "s " : " ") + names;
    try {
        requireMemory(volumeBytes(grids, bounds, int(grids.size())),
                      what + ": the bricks of " + std::to_string(SparseVolume::BRICK) +
                          "^3 voxels their active values fill");
    } catch (const UsageError& e) {
        throw Error(e.what());
    }
    SparseVolume vol = emptyVolume(bounds, int(grids.size()), what);
    if (!grids.empty()) vol.indexToWorld = affineFromTransform(grids[0]->transform());
    for (std::size_t c = 0; c < grids.size(); ++c) {
        const auto& grid = *grids[c];
        if (grid.transform() != grids[0]->transform()) {
            throw Error(source + ": grid \"" + grid.getName() +
                        "\" does not share the transform of grid \"" + grids[0]->getName() +
                        "\"; resample it onto the same voxels first");
        }
        forEachActive(vol, grid, int(c), [](float, float value) { return value; });
    }
    return vol;
}

void addGridToVolume(SparseVolume& vol, const openvdb::FloatGrid& grid, int channel, double factor,
                     double scale)
{
    forEachActive(vol, grid, channel,
                  [&](float sum, float value) { return sum + float(factor * value * scale); });
}

openvdb::FloatGrid::Ptr gridFromField(const SparseVolume& lattice, const std::vector<float>& field,
                                      const openvdb::FloatGrid& topology)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setTransform(topology.transform().copy());
    grid->tree().topologyUnion(topology.tree());
    grid->tree().voxelizeActiveTiles();
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(grid->tree());
    leaves.foreach ([&](openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const auto& p = it.getCoord();
            it.setValue(lattice.contains(p.x(), p.y(), p.z())
                            ? field[lattice.index(p.x(), p.y(), p.z())]
                            : 0.0f);
        }
    });
    return grid;
}

} // namespace nebula
