// SPDX-License-Identifier: Apache-2.0
/// @file test_spectral_grids.cpp
/// The spectral grids (io/spectral_grids.h): an emission grid's nebula:lines metadata, the
/// temperature grid's check and the velocity grid's, each error naming the file and grid.

#include "nebula/io/spectral_grids.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

// ---- grid metadata ---------------------------------------------------------------------

TEST(GridLines, MetadataOrFallback)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("emission");
    const std::vector<nebula::SpectralLine> fallback = {{"H-alpha", 656.28, 1.0}};
    EXPECT_EQ(nebula::gridLines(*grid, "a.vdb", fallback), fallback);

    grid->insertMeta(nebula::META_LINES, openvdb::StringMetadata("[N II]6583:0.3,H-alpha"));
    const auto lines = nebula::gridLines(*grid, "a.vdb", fallback);
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0].name, "[N II]6583");
    EXPECT_DOUBLE_EQ(lines[0].strength, 0.3);

    grid->removeMeta(nebula::META_LINES);
    grid->insertMeta(nebula::META_LINES, openvdb::StringMetadata("H-alpha:-2"));
    std::string msg = errorMessage([&] { nebula::gridLines(*grid, "a.vdb", fallback); });
    EXPECT_EQ(msg.rfind("a.vdb: grid \"emission\" metadata nebula:lines \"H-alpha:-2\": ", 0), 0u)
        << msg;
    EXPECT_TRUE(contains(msg, "strength must be a finite number > 0")) << msg;

    grid->removeMeta(nebula::META_LINES);
    grid->insertMeta(nebula::META_LINES, openvdb::FloatMetadata(1.0f));
    msg = errorMessage([&] { nebula::gridLines(*grid, "a.vdb", fallback); });
    EXPECT_TRUE(contains(msg, "a.vdb: grid \"emission\" metadata nebula:lines is a float, "
                              "expected a string"))
        << msg;
}

TEST(GridAbsorptionLines, RequiredParsedAndNamed)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("absorption.nai");
    // No metadata: refused (an absorption grid has no default lines), naming file and grid.
    std::string msg = errorMessage([&] { nebula::gridAbsorptionLines(*grid, "a.vdb"); });
    EXPECT_EQ(msg.rfind("a.vdb: absorption grid \"absorption.nai\" has no "
                        "nebula:absorption-lines metadata",
                        0),
              0u)
        << msg;

    grid->insertMeta(nebula::META_ABSORPTION_LINES, openvdb::StringMetadata("Na I D2:2,Na I D1"));
    const auto lines = nebula::gridAbsorptionLines(*grid, "a.vdb");
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0].name, "Na I D2");
    EXPECT_DOUBLE_EQ(lines[0].wavelength, 588.995);
    EXPECT_DOUBLE_EQ(lines[0].strength, 2.0);
    EXPECT_DOUBLE_EQ(lines[1].wavelength, 589.592);

    grid->removeMeta(nebula::META_ABSORPTION_LINES);
    grid->insertMeta(nebula::META_ABSORPTION_LINES, openvdb::StringMetadata("Na I D3:1"));
    msg = errorMessage([&] { nebula::gridAbsorptionLines(*grid, "a.vdb"); });
    EXPECT_EQ(msg.rfind("a.vdb: absorption grid \"absorption.nai\" metadata "
                        "nebula:absorption-lines \"Na I D3:1\": ",
                        0),
              0u)
        << msg;

    grid->removeMeta(nebula::META_ABSORPTION_LINES);
    grid->insertMeta(nebula::META_ABSORPTION_LINES, openvdb::FloatMetadata(1.0f));
    msg = errorMessage([&] { nebula::gridAbsorptionLines(*grid, "a.vdb"); });
    EXPECT_TRUE(contains(msg, "nebula:absorption-lines is a float, expected a string")) << msg;
}

// ---- temperature -----------------------------------------------------------------------

TEST(TemperatureGrid, RejectsNegativeNanAndInfinite)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("temperature");
    grid->tree().setValue(openvdb::Coord(1, 2, 3), 20.0f);
    grid->tree().setValue(openvdb::Coord(0, 0, 0), 0.0f); // active 0 K is allowed
    EXPECT_NO_THROW(nebula::requireValidTemperature(*grid, "t.vdb"));

    const std::pair<float, const char*> bad[] = {
        {-1.0f, "a negative temperature -1"},
        {std::numeric_limits<float>::quiet_NaN(), "a NaN temperature"},
        {std::numeric_limits<float>::infinity(), "an infinite temperature"},
    };
    for (const auto& [value, mention] : bad) {
        auto g = grid->deepCopy();
        g->tree().setValue(openvdb::Coord(4, 5, 6), value);
        const std::string msg = errorMessage([&] { nebula::requireValidTemperature(*g, "t.vdb"); });
        EXPECT_EQ(msg.rfind("t.vdb: grid \"temperature\" has ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, mention)) << msg;
        EXPECT_TRUE(contains(msg, "at voxel (4, 5, 6)")) << msg;
        EXPECT_TRUE(contains(msg, "expected finite temperatures >= 0 [K]")) << msg;
    }
}

// ---- velocity grids --------------------------------------------------------------------

nebula::GridSet velocitySet(openvdb::Vec3f value)
{
    auto g = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
    g->setName("velocity");
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
    g->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3f(1, 2, 3));
    g->tree().setValue(openvdb::Coord(2, 2, 3), value);
    nebula::GridSet set;
    set.source = "v.vdb";
    set.grids.push_back(g);
    return set;
}

TEST(VelocityGrid, ReturnsAValidGridAndRejectsTheRest)
{
    openvdb::initialize();
    auto set = velocitySet(openvdb::Vec3f(-4, 0, 2));
    const auto v = nebula::velocityGrid(set, "velocity", "--velocity-grid");
    ASSERT_TRUE(v);
    EXPECT_EQ(v->activeVoxelCount(), 2);

    std::string msg = errorMessage([&] { nebula::velocityGrid(set, "vel", "--velocity-grid"); });
    EXPECT_TRUE(contains(msg, "v.vdb: no grid \"vel\" (--velocity-grid)")) << msg;
    EXPECT_TRUE(contains(msg, "grids: velocity")) << msg;

    auto f = openvdb::FloatGrid::create(0.0f);
    f->setName("temperature");
    set.grids.push_back(f);
    msg = errorMessage([&] { nebula::velocityGrid(set, "temperature", "--velocity-grid"); });
    EXPECT_TRUE(contains(msg, "v.vdb: grid \"temperature\" (--velocity-grid) is a FloatGrid "
                              "(Tree_float_5_4_3), expected a Vec3fGrid of velocities [km/s]"))
        << msg;

    auto d = openvdb::Vec3dGrid::create();
    d->setName("vd");
    set.grids.push_back(d);
    msg = errorMessage([&] { nebula::velocityGrid(set, "vd", ""); });
    EXPECT_TRUE(contains(msg, "is a Vec3dGrid")) << msg;

    const float nan = std::numeric_limits<float>::quiet_NaN();
    auto bad = velocitySet(openvdb::Vec3f(0, nan, 0));
    msg = errorMessage([&] { nebula::velocityGrid(bad, "velocity", ""); });
    EXPECT_TRUE(contains(msg, "v.vdb: grid \"velocity\" has a non-finite velocity")) << msg;
    EXPECT_TRUE(contains(msg, "at voxel (2, 2, 3)")) << msg;

    auto inf = velocitySet(openvdb::Vec3f(std::numeric_limits<float>::infinity(), 0, 0));
    EXPECT_THROW(nebula::velocityGrid(inf, "velocity", ""), nebula::Error);

    auto frustum = velocitySet(openvdb::Vec3f(0, 0, 0));
    const openvdb::BBoxd box(openvdb::Vec3d(0), openvdb::Vec3d(10));
    frustum.grids[0]->setTransform(
        openvdb::math::Transform::createFrustumTransform(box, 0.5, 10.0, 1.0));
    msg = errorMessage([&] { nebula::velocityGrid(frustum, "velocity", ""); });
    EXPECT_TRUE(contains(msg, "non-affine")) << msg;
}

} // namespace
