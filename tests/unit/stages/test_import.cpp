// SPDX-License-Identifier: Apache-2.0
/// @file test_import.cpp
/// stages/import.h: a cube becomes the sparse density grid (values converted to n_H, zeros
/// and values at the threshold inactive, the transform centred or from the file), temperature
/// and velocity on the density's voxels, units resolved or refused, lengths parsed.

#include "nebula/stages/import.h"

#include "nebula/core/error.h"
#include "nebula/io/cube_io.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <fstream>

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

class Import : public nebula::test::TempFolder
{
protected:
    void SetUp() override
    {
        TempFolder::SetUp();
        openvdb::initialize();
    }
    /// A 4 x 3 x 2 little-endian float32 .npy (C order) of f(x, y, z).
    template <typename F> std::string npy(const std::string& name, F f) const
    {
        std::string data;
        for (int x = 0; x < 4; ++x)
            for (int y = 0; y < 3; ++y)
                for (int z = 0; z < 2; ++z) {
                    const float v = float(f(x, y, z));
                    data.append(reinterpret_cast<const char*>(&v), 4);
                }
        std::ofstream(path(name), std::ios::binary) << nebula::npyHeader({4, 3, 2}, false) << data;
        return path(name);
    }
};

} // namespace

TEST_F(Import, DensityIsSparseConvertedAndCentred)
{
    nebula::ImportOptions o;
    o.input = npy("n.npy", [](int x, int y, int z) { return x == 0 ? 0.0 : x + 10 * y + 100 * z; });
    o.unit = "g/cm3";
    o.voxelSize = 0.5;
    o.threshold = 1.0 / (nebula::DEFAULT_MU * nebula::M_H_G) * 1.5; // x = 1 at y = z = 0 stays off
    const auto grids = nebula::importCube(o, nebula::Run());
    const auto d = grids.floatGrid("density", "--grid");
    const double f = 1.0 / (nebula::DEFAULT_MU * nebula::M_H_G);
    EXPECT_FLOAT_EQ(d->tree().getValue(openvdb::Coord(3, 2, 1)), float((3 + 20 + 100) * f));
    EXPECT_FALSE(d->tree().isValueOn(openvdb::Coord(0, 1, 1)));
    EXPECT_FALSE(d->tree().isValueOn(openvdb::Coord(1, 0, 0)));
    EXPECT_TRUE(d->tree().isValueOn(openvdb::Coord(2, 0, 0)));
    EXPECT_EQ(d->activeVoxelCount(), 4u * 3 * 2 - 3 * 2 - 1);
    // Centred: voxel (0, 0, 0) at -(n - 1)/2 voxels.
    const auto w = d->indexToWorld(openvdb::Vec3d(0, 0, 0));
    EXPECT_DOUBLE_EQ(w.x(), -0.75);
    EXPECT_DOUBLE_EQ(w.y(), -0.5);
    EXPECT_DOUBLE_EQ(w.z(), -0.25);
    EXPECT_TRUE(grids.stars().empty());
    EXPECT_TRUE(grids.hasDust());
}

TEST_F(Import, TemperatureAndVelocityOnTheDensitysVoxels)
{
    nebula::ImportOptions o;
    o.input = npy("n.npy", [](int x, int, int) { return x >= 2 ? 1.0 : 0.0; });
    o.unit = "cm-3";
    o.voxelSize = 1.0;
    o.origin = std::array<double, 3>{10, 20, 30};
    o.temperature = npy("t.npy", [](int x, int y, int z) { return 100 + x + y + z; });
    npy("vx.npy", [](int x, int, int) { return x; });
    npy("vy.npy", [](int, int y, int) { return -y; });
    npy("vz.npy", [](int, int, int z) { return z * 0.5; });
    o.velocity = path("vx.npy") + "," + path("vy.npy") + "," + path("vz.npy");
    const auto grids = nebula::importCube(o, nebula::Run());
    const auto t = grids.floatGrid("temperature", "--temperature");
    EXPECT_EQ(t->activeVoxelCount(), 12u);
    EXPECT_FLOAT_EQ(t->tree().getValue(openvdb::Coord(3, 2, 1)), 106.0f);
    EXPECT_FALSE(t->tree().isValueOn(openvdb::Coord(1, 2, 1)));
    const auto v = openvdb::gridPtrCast<openvdb::Vec3fGrid>(grids.find("velocity"));
    ASSERT_TRUE(v);
    EXPECT_EQ(v->tree().getValue(openvdb::Coord(3, 2, 1)), openvdb::Vec3f(3, -2, 0.5f));
    EXPECT_DOUBLE_EQ(t->indexToWorld(openvdb::Vec3d(0, 0, 0)).z(), 30.0);
    o.temperature = npy("small.npy", [](int, int, int) { return 1; });
    std::ofstream(path("small.npy"), std::ios::binary)
        << nebula::npyHeader({2, 2, 2}, false) << std::string(32, '\0');
    EXPECT_TRUE(contains(errorMessage([&] { nebula::importCube(o, nebula::Run()); }),
                         "2 x 2 x 2 voxels, but the density has 4 x 3 x 2"));
}

TEST_F(Import, UnitsAndLengthsAreChecked)
{
    nebula::ImportOptions o;
    o.input = npy("n.npy", [](int, int, int) { return 1.0; });
    o.voxelSize = 1.0;
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::importCube(o, nebula::Run()); }), "give --unit"));
    o.unit = "cm-3";
    o.voxelSize.reset();
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::importCube(o, nebula::Run()); }), "give --voxel-size"));
    o.voxelSize = 1.0;
    o.mu = 0;
    EXPECT_TRUE(contains(errorMessage([&] { nebula::importCube(o, nebula::Run()); }), "--mu"));
    EXPECT_DOUBLE_EQ(nebula::parseLength("0.01pc", "--voxel-size"), 0.01);
    EXPECT_DOUBLE_EQ(nebula::parseLength("2kpc", "--voxel-size"), 2000.0);
    EXPECT_NEAR(nebula::parseLength("206264.806247au", "--voxel-size"), 1.0, 1e-11);
    EXPECT_NEAR(nebula::parseLength("3.0856775814913673e18cm", "--voxel-size"), 1.0, 1e-15);
    for (const char* bad : {"1", "1parsecs", "0pc", "-1pc", "pc", "1e999pc"}) {
        EXPECT_TRUE(contains(errorMessage([&] { nebula::parseLength(bad, "--voxel-size"); }),
                             "--voxel-size"))
            << bad;
    }
}
