// SPDX-License-Identifier: Apache-2.0
/// @file test_export.cpp
/// stages/export.h: the box written (the imported cube, the active voxels, explicit bounds),
/// the unit a grid's cube carries, and a grid written as .npy and read back with its values
/// where the box says.

#include "nebula/stages/export.h"

#include "nebula/core/error.h"
#include "nebula/io/cube_io.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

class Export : public nebula::test::TempFolder
{
protected:
    void SetUp() override
    {
        TempFolder::SetUp();
        openvdb::initialize();
    }
};

openvdb::FloatGrid::Ptr grid(const std::string& name)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->tree().setValueOn(openvdb::Coord(2, 3, 4), 1.5f);
    g->tree().setValueOn(openvdb::Coord(5, 3, 6), 2.5f);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
    return g;
}

} // namespace

TEST_F(Export, BoxesAndUnits)
{
    auto g = grid("density");
    auto box = nebula::exportBox(*g, "auto");
    EXPECT_EQ(box[0], (std::array<int, 3>{2, 3, 4}));
    EXPECT_EQ(box[1], (std::array<int, 3>{5, 3, 6}));
    g->insertMeta("nebula:cube", openvdb::StringMetadata("{\"dims\": [8, 9, 10]}"));
    box = nebula::exportBox(*g, "auto");
    EXPECT_EQ(box[0], (std::array<int, 3>{0, 0, 0}));
    EXPECT_EQ(box[1], (std::array<int, 3>{7, 8, 9}));
    EXPECT_EQ(nebula::exportBox(*g, "active")[1], (std::array<int, 3>{5, 3, 6}));
    EXPECT_EQ(nebula::exportBox(*g, "-1,0,0,1,1,1")[0], (std::array<int, 3>{-1, 0, 0}));
    EXPECT_TRUE(
        contains(errorMessage([] { nebula::exportBox(*openvdb::FloatGrid::create(), "active"); }),
                 "no active voxels"));
    nebula::ExportOptions o;
    o.bbox = "1,2,3";
    EXPECT_TRUE(contains(errorMessage([&] { o.validate(); }), "--bbox"));
    o.bbox = "1,1,1,0,1,1";
    EXPECT_TRUE(contains(errorMessage([&] { o.validate(); }),
                         "--bbox 1,1,1,0,1,1: the minimum must be <= the maximum on each axis, "
                         "and on x it is 1 > 0"));
    // exportBox() refuses it too (nebstats' path).
    EXPECT_TRUE(contains(
        errorMessage([] { nebula::exportBox(*openvdb::FloatGrid::create(), "0,0,5,1,1,4"); }),
        "on z it is 5 > 4"));

    // What a cube costs: the file (4 bytes a voxel and the header); the memory its writer
    // holds (FITS the file and a z plane, HDF5 the file twice and an x plane, .npy a z plane).
    const std::array<std::int64_t, 3> dims{100, 200, 300};
    const double data = 4.0 * 100 * 200 * 300, header = 1000.0;
    const auto fits = nebula::cubeCost(nebula::cubeFormat("fits", "--format"), dims, header);
    EXPECT_EQ(fits.voxels, 100.0 * 200 * 300);
    EXPECT_EQ(fits.fileBytes, data + header);
    EXPECT_EQ(fits.memoryBytes, data + header + 4.0 * 100 * 200);
    const auto h5 = nebula::cubeCost(nebula::cubeFormat("hdf5", "--format"), dims, header);
    EXPECT_EQ(h5.memoryBytes, 2.0 * (data + header) + 4.0 * 200 * 300);
    const auto npy = nebula::cubeCost(nebula::cubeFormat("npy", "--format"), dims, header);
    EXPECT_EQ(npy.fileBytes, data + header);
    EXPECT_EQ(npy.memoryBytes, 4.0 * 100 * 200);
    // No wrap-around: 2^31 on a side is a finite double, far above any limit.
    const auto huge =
        nebula::cubeCost(nebula::cubeFormat("npy", "--format"), {1LL << 31, 1LL << 31, 1LL << 31});
    EXPECT_EQ(huge.voxels, std::ldexp(1.0, 93));

    EXPECT_EQ(nebula::cubeUnit(*grid("density")), "cm-3");
    EXPECT_EQ(nebula::cubeUnit(*grid("density.L2")), "cm-3");
    EXPECT_EQ(nebula::cubeUnit(*grid("tau.alpha")), "");
    EXPECT_EQ(nebula::cubeUnit(*grid("temperature")), "K");
    auto other = grid("smoke");
    other->insertMeta("units", openvdb::StringMetadata("heat [W m^-3]"));
    EXPECT_EQ(nebula::cubeUnit(*other), "W m^-3");
}

TEST_F(Export, NpyHoldsTheBox)
{
    nebula::GridSet set;
    set.source = "test";
    set.grids.push_back(grid("density"));
    nebula::ExportOptions o;
    o.output = path("d.npy");
    o.bbox = "active";
    nebula::exportCube(set, o, nebula::Run());
    auto cube = nebula::openCube(o.output, nebula::CubeSelect{});
    ASSERT_EQ(cube->info().dims, (std::array<std::int64_t, 3>{4, 1, 3}));
    std::vector<double> plane(4);
    std::vector<double> all;
    for (int k = 0; k < 3; ++k) {
        cube->readPlane(k, plane.data());
        all.insert(all.end(), plane.begin(), plane.end());
    }
    EXPECT_EQ(all, (std::vector<double>{1.5, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2.5}));
    o.grid = "missing";
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::exportCube(set, o, nebula::Run()); }), "\"missing\""));
    auto rotated = grid("density");
    rotated->transform().preRotate(0.3, openvdb::math::Z_AXIS);
    set.grids = {rotated};
    o.grid = "density";
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::exportCube(set, o, nebula::Run()); }), "rotated"));
}
