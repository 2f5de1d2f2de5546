// SPDX-License-Identifier: Apache-2.0
/// @file test_phase.cpp
/// stages/phase.h: nebphase's table and slab runs: the slab's JSON (energy balance, the
/// bins' cosines, the given dust), the table's outputs written both or neither, and the
/// refusals before any work.

#include "nebula/stages/phase.h"

#include "nebula/core/error.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/phase_table_vdb.h"
#include "test_util.h"

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

/// A slab run small enough for a unit test.
nebula::PhaseOptions slabOptions()
{
    nebula::PhaseOptions o;
    o.slab = true;
    o.tau = 1.0;
    o.mu0 = 0.5;
    o.bins = 4;
    o.photons = 20000;
    return o;
}

/// A table small enough for a unit test, written to @p dir.
nebula::PhaseOptions tableOptions(const fs::path& dir)
{
    nebula::PhaseOptions o;
    o.table.tCount = 4;
    o.table.muBins = 8;
    o.photons = 500;
    o.maxPhotons = 1000;
    o.output = (dir / "phase.vdb").string();
    return o;
}

/// An empty folder of its own for a test's files.
fs::path freshFolder(const std::string& name)
{
    const fs::path dir = fs::temp_directory_path() / ("nebula_test_phase_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

} // namespace

TEST(PhaseStage, SlabJsonBalancesAndMirrorsTheReflectedBins)
{
    auto o = slabOptions();
    o.applyDust = [](const nebula::DustParams& d) {
        auto dust = d;
        dust.albedo = 0.8;
        return dust;
    };
    std::ostringstream out;
    nebula::writeSlabJson(o, nebula::Run(), out);
    const auto j = nlohmann::json::parse(out.str());
    EXPECT_EQ(j["slab"]["albedo"], 0.8); // the dust options reach the run
    EXPECT_EQ(j["photons"], 20000);
    // 1 in expectation: within 5 standard errors.
    EXPECT_NEAR(j["balance"]["value"].get<double>(), 1.0,
                5.0 * j["balance"]["error"].get<double>());
    // Direct transmission exp(-tau / mu0) is exact with the next-event estimator.
    EXPECT_NEAR(j["transmitted"]["direct"]["value"].get<double>(), std::exp(-2.0), 1e-12);
    const auto& reflected = j["angular"]["reflected"];
    ASSERT_EQ(reflected.size(), 4u);
    EXPECT_EQ(reflected[0]["mu_lo"], 0.0); // both lists run from mu = 0 to 1
    EXPECT_EQ(reflected[3]["mu_hi"], 1.0);
    EXPECT_EQ(j["angular"]["transmitted"].size(), 4u);
}

TEST(PhaseStage, SlabRefusesOptionsOutOfRange)
{
    auto o = slabOptions();
    o.mu0 = 0.0;
    std::ostringstream out;
    EXPECT_TRUE(contains(errorMessage([&] { nebula::writeSlabJson(o, nebula::Run(), out); }),
                         "--mu0 must be in (0, 1]"));
    o = slabOptions();
    o.photons = nebula::MAX_SLAB_PHOTONS + 1;
    EXPECT_TRUE(contains(errorMessage([&] { nebula::writeSlabJson(o, nebula::Run(), out); }),
                         "--photons must be in [1, 1e10]"));
    EXPECT_TRUE(out.str().empty());
}

TEST(PhaseStage, TableWritesTheVdbAndTheJsonTogether)
{
    openvdb::initialize();
    const fs::path dir = freshFolder("both");
    auto o = tableOptions(dir);
    o.json = (dir / "phase.json").string();
    std::ostringstream out;
    nebula::writePhaseTable(o, nebula::Run(), out);
    EXPECT_TRUE(out.str().empty());
    const auto grids = nebula::readGrids(o.output, nebula::Run());
    const auto table = nebula::readPhaseTable(grids);
    EXPECT_EQ(table.tCount, 4);
    EXPECT_EQ(table.muBins, 8);
    ASSERT_TRUE(fs::exists(o.json));
    EXPECT_EQ(nlohmann::json::parse(std::ifstream(o.json))["t_count"], 4);
    fs::remove_all(dir);
}

TEST(PhaseStage, TableJsonToTheStreamGiven)
{
    openvdb::initialize();
    const fs::path dir = freshFolder("stream");
    auto o = tableOptions(dir);
    o.json = "-";
    std::ostringstream out;
    nebula::writePhaseTable(o, nebula::Run(), out);
    EXPECT_EQ(nlohmann::json::parse(out.str())["mu_bins"], 8);
    fs::remove_all(dir);
}

TEST(PhaseStage, TableRefusesMissingOrCollidingOutputsBeforeAnyWork)
{
    const fs::path dir = freshFolder("refusals");
    std::ostringstream out;
    auto o = tableOptions(dir);
    o.output.clear();
    EXPECT_TRUE(contains(errorMessage([&] { nebula::writePhaseTable(o, nebula::Run(), out); }),
                         "-o/--output is required"));
    o = tableOptions(dir);
    o.json = o.output;
    EXPECT_TRUE(contains(errorMessage([&] { nebula::writePhaseTable(o, nebula::Run(), out); }),
                         "are the same file"));
    EXPECT_TRUE(fs::is_empty(dir));
    fs::remove_all(dir);
}
