// SPDX-License-Identifier: Apache-2.0
/// @file test_grid_names.cpp
/// io/grid_names.h: the grid names and metadata keys that are a contract between the tools
/// (DESIGN §1-2).

#include "nebula/io/grid_names.h"

#include <gtest/gtest.h>

#include <string>

namespace {

TEST(GridNames, TauGridName)
{
    EXPECT_EQ(nebula::tauGridName("alpha"), "tau.alpha");
    EXPECT_EQ(nebula::tauGridName("B-2_x"), "tau.B-2_x");
}

TEST(GridNames, LevelGridName)
{
    EXPECT_EQ(nebula::levelGridName("density", 1), "density.L1");
    EXPECT_EQ(nebula::levelGridName("density", 12), "density.L12");
    EXPECT_EQ(nebula::levelGridName("n", 0), "n.L0");
    // nebpyramid's optical depths: the level of a star's tau grid.
    EXPECT_EQ(nebula::levelGridName(nebula::tauGridName("beta"), 3), "tau.beta.L3");
}

TEST(GridNames, AbsorptionGridName)
{
    EXPECT_EQ(nebula::absorptionGridName("nai"), "absorption.nai");
    EXPECT_TRUE(nebula::isAbsorptionGridName("absorption.caii"));
    EXPECT_FALSE(nebula::isAbsorptionGridName("emission.oiii"));
    EXPECT_FALSE(nebula::isAbsorptionGridName("absorption"));
}

TEST(GridNames, MetadataKeysAreTheDocumentedOnes)
{
    // DESIGN §2's table of file metadata.
    EXPECT_STREQ(nebula::META_TOOL, "nebula:tool");
    EXPECT_STREQ(nebula::META_VERSION, "nebula:version");
    EXPECT_STREQ(nebula::META_COMMAND, "nebula:command");
    EXPECT_STREQ(nebula::META_HISTORY, "nebula:history");
    EXPECT_STREQ(nebula::META_STARS, "nebula:stars");
    EXPECT_STREQ(nebula::META_DUST, "nebula:dust");
    EXPECT_STREQ(nebula::META_LINES, "nebula:lines");
    EXPECT_STREQ(nebula::META_ABSORPTION_LINES, "nebula:absorption-lines");
}

} // namespace
