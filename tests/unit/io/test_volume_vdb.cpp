// SPDX-License-Identifier: Apache-2.0
/// @file test_volume_vdb.cpp
/// io/volume_vdb.h: OpenVDB grids <-> SparseVolume: the affine map of a transform, the
/// active bounds, sparse channels holding the active values (voxels and tiles) and zero
/// elsewhere, and a grid made from a lattice field on another grid's topology.

#include "nebula/io/volume_vdb.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

openvdb::math::Transform::Ptr skewed()
{
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.setToRotation(openvdb::math::Vec3d(1, -2, 0.5).unit(), 0.8);
    m.preScale(openvdb::math::Vec3d(0.1, 0.25, -0.2)); // anisotropic, mirrored
    m.postTranslate(openvdb::math::Vec3d(3, -1, 7));
    return openvdb::math::Transform::createLinearTransform(m);
}

TEST(VolumeVdb, AffineFromTransformMapsLikeTheTransform)
{
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> u(-40, 40);
    auto scaled = openvdb::math::Transform::createLinearTransform(0.3);
    scaled->postTranslate(openvdb::Vec3d(-2, 5, 1));
    for (const auto& t : {scaled, skewed()}) {
        const nebula::Affine a = nebula::affineFromTransform(*t);
        for (int i = 0; i < 50; ++i) {
            const openvdb::Vec3d p(u(rng), u(rng), u(rng));
            const openvdb::Vec3d w = t->indexToWorld(p);
            const nebula::Vec3 q = a.apply(nebula::Vec3(p[0], p[1], p[2]));
            EXPECT_NEAR(q.x, w[0], 1e-9 * (1 + std::abs(w[0])));
            EXPECT_NEAR(q.y, w[1], 1e-9 * (1 + std::abs(w[1])));
            EXPECT_NEAR(q.z, w[2], 1e-9 * (1 + std::abs(w[2])));
        }
    }
    const nebula::Affine s = nebula::affineFromTransform(*scaled);
    EXPECT_NEAR(s.m[0], 0.3, 1e-15);
    EXPECT_NEAR(s.m[1], 0.0, 1e-15);
    EXPECT_NEAR(s.t.y, 5.0, 1e-15);
}

TEST(VolumeVdb, ActiveBoundsIsTheUnionGrownByPad)
{
    auto a = openvdb::FloatGrid::create(0.0f);
    a->tree().setValue(openvdb::Coord(2, 3, 4), 1.0f);
    a->tree().setValue(openvdb::Coord(5, -1, 4), 1.0f);
    auto b = openvdb::FloatGrid::create(0.0f);
    b->tree().setValue(openvdb::Coord(-3, 0, 10), 1.0f);
    const auto box = nebula::activeBounds({a, b}, 0);
    EXPECT_EQ(box.min(), openvdb::Coord(-3, -1, 4));
    EXPECT_EQ(box.max(), openvdb::Coord(5, 3, 10));
    const auto padded = nebula::activeBounds({a, b}, 2);
    EXPECT_EQ(padded.min(), openvdb::Coord(-5, -3, 2));
    EXPECT_EQ(padded.max(), openvdb::Coord(7, 5, 12));
    // A null entry is skipped; one grid alone gives its own bounds.
    EXPECT_EQ(nebula::activeBounds({a, nullptr}, 1).min(), openvdb::Coord(1, -2, 3));
}

TEST(VolumeVdb, VolumeHoldsActiveValuesAndZeroElsewhere)
{
    auto a = openvdb::FloatGrid::create(0.0f);
    a->setName("density");
    a->setTransform(skewed());
    auto b = openvdb::FloatGrid::create(-7.0f); // background never shows: zero off the active
    b->setName("emission");
    b->setTransform(skewed());
    std::mt19937_64 rng(9);
    std::uniform_int_distribution<int> c(-6, 13);
    std::uniform_real_distribution<float> v(0.1f, 5.0f);
    for (int i = 0; i < 200; ++i)
        a->tree().setValue(openvdb::Coord(c(rng), c(rng), c(rng)), v(rng));
    for (int i = 0; i < 50; ++i)
        b->tree().setValue(openvdb::Coord(c(rng), c(rng), c(rng)), v(rng));
    // An inactive voxel with a value: not copied.
    b->tree().setValueOff(openvdb::Coord(0, 0, 0), 99.0f);
    // An active tile (a leaf-sized block, 8^3 voxels at 16..23) inside the bounds.
    a->tree().addTile(1, openvdb::Coord(16, 16, 16), 2.5f, true);

    const auto bounds = nebula::activeBounds({a, b}, 1);
    const nebula::SparseVolume d = nebula::volumeFromGrids({a, b}, bounds, "cloud.vdb");
    EXPECT_EQ(d.channels(), 2);
    EXPECT_EQ(d.lo(), (std::array<int, 3>{bounds.min().x(), bounds.min().y(), bounds.min().z()}));
    EXPECT_EQ(d.dims(), (std::array<int, 3>{bounds.dim().x(), bounds.dim().y(), bounds.dim().z()}));
    // The first grid's map.
    const auto w = a->transform().indexToWorld(openvdb::Vec3d(1, 2, 3));
    const nebula::Vec3 q = d.indexToWorld.apply(nebula::Vec3(1, 2, 3));
    EXPECT_NEAR(q.x, w[0], 1e-12);
    EXPECT_NEAR(q.z, w[2], 1e-12);
    for (int k = bounds.min().z(); k <= bounds.max().z(); ++k)
        for (int j = bounds.min().y(); j <= bounds.max().y(); ++j)
            for (int i = bounds.min().x(); i <= bounds.max().x(); ++i) {
                const openvdb::Coord p(i, j, k);
                const float* got = d.voxel(d.index(i, j, k));
                const float wantA = a->tree().isValueOn(p) ? a->tree().getValue(p) : 0.0f;
                const float wantB = b->tree().isValueOn(p) ? b->tree().getValue(p) : 0.0f;
                ASSERT_EQ(got[0], wantA) << i << "," << j << "," << k;
                ASSERT_EQ(got[1], wantB) << i << "," << j << "," << k;
            }
    EXPECT_EQ(d.voxel(d.index(20, 18, 23))[0], 2.5f); // from the tile

    // Bounds that cut through a tile: the part inside is filled, nothing else changes.
    const openvdb::CoordBBox cut(openvdb::Coord(12, 12, 12), openvdb::Coord(19, 19, 19));
    const nebula::SparseVolume e = nebula::volumeFromGrids({a}, cut, "cloud.vdb");
    for (int k = 12; k <= 19; ++k)
        for (int j = 12; j <= 19; ++j)
            for (int i = 12; i <= 19; ++i) {
                const openvdb::Coord p(i, j, k);
                const float want = a->tree().isValueOn(p) ? a->tree().getValue(p) : 0.0f;
                ASSERT_EQ(e.voxel(e.index(i, j, k))[0], want) << i << "," << j << "," << k;
            }
}

// A tile wholly outside the bounds (beside them in x, or in y) adds nothing: no voxel of the
// lattice changes, and nothing is written past it (ASan checks the latter).
TEST(VolumeVdb, VolumeIgnoresTilesOutsideTheBounds)
{
    for (const openvdb::Coord origin : {openvdb::Coord(8, 0, 0), openvdb::Coord(0, 8, 0),
                                        openvdb::Coord(-8, 0, 0), openvdb::Coord(0, 0, 8)}) {
        auto g = openvdb::FloatGrid::create(0.0f);
        g->tree().setValue(openvdb::Coord(3, 3, 3), 1.0f);
        g->tree().addTile(1, origin, 7.0f, true);
        const openvdb::CoordBBox bounds(openvdb::Coord(0), openvdb::Coord(7));
        const nebula::SparseVolume d = nebula::volumeFromGrids({g}, bounds, "cloud.vdb");
        for (int k = 0; k < 8; ++k)
            for (int j = 0; j < 8; ++j)
                for (int i = 0; i < 8; ++i) {
                    const float want = (i == 3 && j == 3 && k == 3) ? 1.0f : 0.0f;
                    ASSERT_EQ(d.voxel(d.index(i, j, k))[0], want)
                        << "tile at " << origin << ", voxel " << i << "," << j << "," << k;
                }
    }
}

TEST(VolumeVdb, VolumeRefusesGridsOnOtherVoxels)
{
    auto a = openvdb::FloatGrid::create(0.0f);
    a->setName("density");
    a->tree().setValue(openvdb::Coord(1, 1, 1), 1.0f);
    auto b = a->deepCopy();
    b->setName("tau.alpha");
    b->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
    const std::string msg = errorMessage([&] {
        nebula::volumeFromGrids({a, b}, nebula::activeBounds({a}, 1), "cloud.vdb");
    });
    EXPECT_EQ(msg.rfind("cloud.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "\"tau.alpha\"")) << msg;
    EXPECT_TRUE(contains(msg, "\"density\"")) << msg;
}

TEST(VolumeVdb, MemoryFollowsTheActiveLeavesNotTheBox)
{
    using nebula::SparseVolume;
    // Two voxels a million voxels apart: a box of 10^6 x 3 x 3 with a zero border (72 MB as
    // a dense lattice of 2 channels), two bricks stored; the rest is the brick table
    // (125002 x 2 x 2 slots of 4 bytes).
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->tree().setValue(openvdb::Coord(0, 0, 0), 2.0f);
    grid->tree().setValue(openvdb::Coord(1000000, 0, 0), 3.0f);
    const std::vector<openvdb::FloatGrid::ConstPtr> grids{grid, grid};
    const auto bounds = nebula::activeBounds({grid}, 1);
    EXPECT_EQ(nebula::volumeBytes(grids, bounds, 2), 2.0 * 512 * 2 * 4);
    const SparseVolume v = nebula::volumeFromGrids(grids, bounds, "two.vdb");
    EXPECT_EQ(v.dims()[0], 1000003);
    EXPECT_EQ(v.storedBricks(), 2u);
    EXPECT_EQ(v.storedBytes(), 2u * 512u * 2u * 4u + 125002u * 2u * 2u * 4u);
    EXPECT_EQ(v.voxel(v.index(1000000, 0, 0))[1], 3.0f);
    EXPECT_EQ(v.voxel(v.index(500000, 0, 0))[0], 0.0f);
    float out[2];
    v.sample(nebula::Vec3(999999.5, 0, 0), out);
    EXPECT_FLOAT_EQ(out[0], 1.5f);
    // Spread over all three axes the table itself would be too large: refused with both sizes.
    grid->tree().setValue(openvdb::Coord(0, 1000000, 1000000), 1.0f);
    const auto wide = nebula::activeBounds({grid}, 1);
    const std::string msg = errorMessage([&] { nebula::volumeFromGrids(grids, wide, "wide.vdb"); });
    EXPECT_TRUE(contains(msg, "wide.vdb")) << msg;
    EXPECT_TRUE(contains(msg, "1000003 x 1000003 x 1000003")) << msg;
    EXPECT_TRUE(contains(msg, "this machine has")) << msg;
}

TEST(VolumeVdb, GridFromFieldOnAnotherGridsTopology)
{
    auto topo = openvdb::FloatGrid::create(0.0f);
    topo->setTransform(skewed());
    topo->tree().setValue(openvdb::Coord(1, 2, 3), 1.0f);
    topo->tree().setValue(openvdb::Coord(4, 4, 4), 1.0f);
    topo->tree().setValue(openvdb::Coord(40, 0, 0), 1.0f);        // off the lattice below
    topo->tree().addTile(1, openvdb::Coord(8, 0, 0), 1.0f, true); // an active tile
    const nebula::SparseVolume lattice({0, 0, 0}, {16, 8, 8}, 1);
    std::vector<float> field(lattice.voxelCount());
    for (std::size_t i = 0; i < field.size(); ++i)
        field[i] = float(i) + 0.5f;

    const auto g = nebula::gridFromField(lattice, field, *topo);
    EXPECT_EQ(g->transform(), topo->transform());
    EXPECT_EQ(g->activeVoxelCount(), topo->activeVoxelCount());
    EXPECT_EQ(g->tree().getValue(openvdb::Coord(1, 2, 3)), field[lattice.index(1, 2, 3)]);
    EXPECT_EQ(g->tree().getValue(openvdb::Coord(4, 4, 4)), field[lattice.index(4, 4, 4)]);
    EXPECT_EQ(g->tree().getValue(openvdb::Coord(11, 5, 6)), field[lattice.index(11, 5, 6)]);
    EXPECT_TRUE(g->tree().isValueOn(openvdb::Coord(40, 0, 0)));
    EXPECT_EQ(g->tree().getValue(openvdb::Coord(40, 0, 0)), 0.0f);
    // Only the topology's voxels are active.
    EXPECT_FALSE(g->tree().isValueOn(openvdb::Coord(0, 0, 0)));
    for (auto it = g->cbeginValueOn(); it; ++it) {
        EXPECT_TRUE(topo->tree().isValueOn(it.getCoord()));
    }
}

} // namespace
