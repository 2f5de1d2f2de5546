// SPDX-License-Identifier: Apache-2.0
// nebgen --preset and nebstats end to end: the presets' options, their errors (exit 2 with
// the range), and nebstats' report, JSON and errors.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"

#include <openvdb/openvdb.h>

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace nebula::clitest;

namespace {

std::string readText(const std::string& path)
{
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

bool contains(const std::string& text, const std::string& part)
{
    return text.find(part) != std::string::npos;
}

} // namespace

TEST_F(Cli, PresetUnknownListsTheKnownOnes)
{
    const auto r = run("nebgen --preset m42 -o x.vdb");
    EXPECT_EQ(r.code, 2);
    EXPECT_TRUE(contains(r.err, "unknown preset 'm42'")) << r.err;
    for (const char* name :
         {"fbm", "box", "reflection", "external", "pillars", "bubble", "globule", "bipolar", "hii"})
        EXPECT_TRUE(contains(r.err, name)) << name << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(path("x.vdb")));
}

TEST_F(Cli, PresetTurbulenceOutOfRangeIsRefusedWithTheRange)
{
    struct Case
    {
        const char* args;
        const char* expected;
    };
    for (const Case& c :
         {Case{"--mach 0", "--mach"}, Case{"--mach -2", "--mach"},
          Case{"--forcing-b 0", "--forcing-b"}, Case{"--forcing-b 1.5", "--forcing-b"},
          Case{"--anisotropy -1", "--anisotropy"}}) {
        const auto r =
            run(std::string("nebgen --preset reflection --res 16 ") + c.args + " -o x.vdb");
        EXPECT_EQ(r.code, 2) << c.args;
        EXPECT_TRUE(contains(r.err, c.expected)) << c.args << ": " << r.err;
    }
    // The ranges are named.
    EXPECT_TRUE(contains(run("nebgen --preset box --forcing-b 2 -o x.vdb").err, "1"));
    const auto b = run("nebgen --preset box --forcing-b 2 -o x.vdb");
    EXPECT_TRUE(contains(b.err, "[0") || contains(b.err, "(0")) << b.err;
}

TEST_F(Cli, PresetOptionsBelongToTheirModel)
{
    auto r = run("nebgen --preset reflection --frequency 2 -o x.vdb");
    EXPECT_EQ(r.code, 2);
    EXPECT_TRUE(contains(r.err, "--frequency needs --preset fbm")) << r.err;
    r = run("nebgen --mach 3 -o x.vdb");
    EXPECT_EQ(r.code, 2);
    EXPECT_TRUE(contains(r.err, "--mach needs a turbulent --preset")) << r.err;
}

TEST_F(Cli, PresetIsOverriddenByOptionsAndMeasuredByNebstats)
{
    // --preset=NAME and --preset NAME alike; --star replaces the preset's star; the preset's
    // turbulence is what nebstats measures (the box: sigma of ln n = sqrt(ln(1 + b^2 M^2))).
    ASSERT_EQ(run("nebgen --preset=box --res 32 --mach 3 --forcing-b 1 "
                  "--star a:0,0,-4:100:B5V -o box.vdb")
                  .code,
              0);
    const auto grids = nebula::readGrids(path("box.vdb"));
    ASSERT_EQ(grids.stars().size(), 1u);
    EXPECT_EQ(grids.stars()[0].name, "a");
    ASSERT_EQ(run("nebstats -i box.vdb --json > stats.json").code, 0);
    const auto j = nlohmann::json::parse(readText(path("stats.json")));
    EXPECT_NEAR(j["volume"]["sigma_ln"].get<double>(), std::sqrt(std::log(10.0)), 1e-3);
    EXPECT_EQ(j["volume"]["voxels"].get<int>(), 32 * 32 * 32);
    EXPECT_EQ(j["column"]["width"].get<int>(), 32);
    EXPECT_TRUE(j["spectrum"]["fitted"].get<bool>());
    EXPECT_EQ(j["spectrum"]["k"].size(), 16u);
    // The text report, from a pipe.
    ASSERT_EQ(
        run("nebgen --preset external --res 32 -o - | nebstats -i - --axis x > report.txt").code,
        0);
    const std::string report = readText(path("report.txt"));
    for (const char* line :
         {"volume", "column     along x", "pdf ", "spectrum", "anisotropy", "contours"})
        EXPECT_TRUE(contains(report, line)) << line << "\n" << report;
}

TEST_F(Cli, NebstatsRefusesBadRequests)
{
    ASSERT_EQ(run("nebgen --preset box --res 16 -o box.vdb").code, 0);
    struct Case
    {
        const char* args;
        int code;
        const char* expected;
    };
    for (const Case& c :
         {Case{"--k-range 5", 2, "--k-range"}, Case{"--k-range 0,0", 2, "--k-range"},
          Case{"--k-range 4,2", 2, "--k-range"}, Case{"--k-range 20,30", 2, "fewer than 3 rings"},
          Case{"--axis w", 2, "--axis"}, Case{"--grid nope", 1, "nope"},
          Case{"--bbox 1,2", 2, "--bbox"}, Case{"--pdf-floor 1", 2, "--pdf-floor"},
          Case{"--levels 0", 2, "--levels"}}) {
        const auto r = run(std::string("nebstats -i box.vdb ") + c.args);
        EXPECT_EQ(r.code, c.code) << c.args << ": " << r.err;
        EXPECT_TRUE(contains(r.err, c.expected)) << c.args << ": " << r.err;
    }
    // A map too small for the default k range: the spectrum is not fitted, the rest stands.
    ASSERT_EQ(run("nebgen --preset box --res 6 -o tiny.vdb").code, 0);
    auto tiny = run("nebstats -i tiny.vdb > tiny.txt");
    EXPECT_EQ(tiny.code, 0) << tiny.err;
    EXPECT_TRUE(contains(readText(path("tiny.txt")), "spectrum   not fitted")) << tiny.err;
    // A grid with no active voxel is named.
    ASSERT_EQ(run("nebgen --preset reflection --res 2 -o empty.vdb").code, 0);
    tiny = run("nebstats -i empty.vdb");
    EXPECT_EQ(tiny.code, 2);
    EXPECT_TRUE(contains(tiny.err, "no active voxels")) << tiny.err;
    const auto r = run("nebstats -i missing.vdb");
    EXPECT_NE(r.code, 0);
    EXPECT_TRUE(contains(r.err, "missing.vdb")) << r.err;
}

TEST_F(Cli, IonisedPresetsGetTheirGlowFromNebionize)
{
    // nebgen paints no glow for pillars, bubble and hii, and refuses --emission, naming
    // nebionize.
    const auto r = run("nebgen --preset pillars --res 16 --emission 5 -o x.vdb");
    EXPECT_EQ(r.code, 2);
    EXPECT_TRUE(contains(r.err, "--emission") && contains(r.err, "nebionize")) << r.err;
    EXPECT_FALSE(std::filesystem::exists(path("x.vdb")));
    for (const std::string preset : {"pillars", "bubble", "hii"}) {
        ASSERT_EQ(run("nebgen --preset " + preset + " --res 48 -o g.vdb").code, 0) << preset;
        const auto g = nebula::readGrids(path("g.vdb"));
        EXPECT_TRUE(!g.find("emission") || g.floatGrid("emission", "")->activeVoxelCount() == 0)
            << preset;
        const auto ionise = run("nebionize -i g.vdb -v -o i.vdb");
        ASSERT_EQ(ionise.code, 0) << preset << ": " << ionise.err;
        const auto i = nebula::readGrids(path("i.vdb"));
        const auto density = i.floatGrid("density", "");
        const auto hii = i.floatGrid("ionization.hii", "");
        const auto ha = i.floatGrid("emission", ""), oiii = i.floatGrid("emission.oiii", "");
        const auto hAcc = hii->getConstAccessor();
        const auto haAcc = ha->getConstAccessor();
        const auto oAcc = oiii->getConstAccessor();
        // The brightest star (the first): [O III] sits nearer it than H-alpha.
        const auto star = i.stars().front().position;
        const auto starIndex =
            density->transform().worldToIndex(openvdb::Vec3d(star[0], star[1], star[2]));
        int ionised = 0, front = 0, neutral = 0;
        double haSum = 0.0, haR = 0.0, oSum = 0.0, oR = 0.0;
        for (auto it = density->cbeginValueOn(); it; ++it) {
            if (!(*it > 0.0f)) continue;
            const float x = hAcc.getValue(it.getCoord());
            ionised += x > 0.99f ? 1 : 0;
            front += (x > 0.01f && x <= 0.99f) ? 1 : 0;
            neutral += x <= 0.01f ? 1 : 0;
            const double d = (it.getCoord().asVec3d() - starIndex).length();
            haSum += haAcc.getValue(it.getCoord());
            haR += haAcc.getValue(it.getCoord()) * d;
            oSum += oAcc.getValue(it.getCoord());
            oR += oAcc.getValue(it.getCoord()) * d;
        }
        // Ionised gas, fronts partly ionised, and neutral gas behind them (clumps, shadows).
        EXPECT_GT(ionised, 100) << preset;
        EXPECT_GT(front, 100) << preset;
        EXPECT_GT(neutral, 100) << preset;
        ASSERT_GT(haSum, 0.0) << preset;
        ASSERT_GT(oSum, 0.0) << preset;
        // In the pillars' open cavity the O++ zone is well inside the H+ one; in the bubble's
        // shell and the blister's face the zones are squeezed into one layer, [O III] on its
        // inner side.
        const double inner = preset == "pillars" ? 0.9 : 0.99;
        EXPECT_LT(oR / oSum, inner * (haR / haSum)) << preset << ": [O III] nearer the star";
    }
}
