// SPDX-License-Identifier: Apache-2.0
// What a new user meets first: the history of a pipeline in its outputs, config files,
// -v in every tool, spectral classes the tables do not cover, pyramid levels without a phase
// table, and JSON attributes built from awkward file names.
#include "cli_fixture.h"

#include "nebula/core/version.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

/// The tools named by the entries of a nebula:history array, in order.
std::vector<std::string> toolsOf(const nlohmann::json& history)
{
    std::vector<std::string> tools;
    for (const auto& stage : history)
        tools.push_back(stage.at("tool").get<std::string>());
    return tools;
}

/// The lines of @p text that start with "<tool>: " (the -v reports).
int reportLines(const std::string& text, const std::string& tool)
{
    int n = 0;
    std::size_t start = 0;
    while (start < text.size()) {
        const auto end = text.find('\n', start);
        if (text.compare(start, tool.size() + 2, tool + ": ") == 0) ++n;
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return n;
}

} // namespace

// Every stage appends itself to nebula:history, so the last file and the EXR say which seed
// made the nebula and every command after it.
TEST_F(Cli, HistoryCarriesTheWholePipeline)
{
    ASSERT_EQ(run("nebgen --res 24 --seed 7 -o - | nebillum -i - -o - | "
                  "nebpyramid -i - --levels 1 -o pyr.vdb")
                  .code,
              0);
    const auto pyr = read(path("pyr.vdb"));
    const auto history = pyr.history();
    ASSERT_EQ(toolsOf(history), (std::vector<std::string>{"nebgen", "nebillum", "nebpyramid"}));
    EXPECT_NE(history[0].at("command").get<std::string>().find("--seed 7"), std::string::npos);
    EXPECT_EQ(history[2].at("version").get<std::string>(), NEBULA_VERSION_STRING);
    EXPECT_EQ(pyr.metaString(nebula::META_TOOL), "nebpyramid"); // the last stage, as before

    const Result r = run("nebrender -i pyr.vdb --levels 0 --res 16x16 -o frame.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    std::map<std::string, std::string> attrs;
    nebula::readExr(path("frame.exr"), &attrs);
    const auto exrHistory = nlohmann::json::parse(attrs.at("nebula:history"));
    EXPECT_EQ(toolsOf(exrHistory),
              (std::vector<std::string>{"nebgen", "nebillum", "nebpyramid", "nebrender"}));
    EXPECT_NE(exrHistory[0].at("command").get<std::string>().find("--seed 7"), std::string::npos);
    EXPECT_NE(exrHistory[3].at("command").get<std::string>().find("-o frame.exr"),
              std::string::npos);
}

// A file written before nebula:history existed starts its history with the one stage it
// recorded; a history that is not a JSON array is an error naming the file.
TEST_F(Cli, HistoryOfOlderFilesAndBrokenHistory)
{
    ASSERT_EQ(run("nebgen --res 16 -o a.vdb").code, 0);
    auto old = read(path("a.vdb"));
    old.meta.removeMeta(nebula::META_HISTORY);
    writeVdb(path("old.vdb"), old.grids, old.meta);
    ASSERT_EQ(run("nebillum -i old.vdb -o lit.vdb").code, 0);
    EXPECT_EQ(toolsOf(read(path("lit.vdb")).history()),
              (std::vector<std::string>{"nebgen", "nebillum"}));

    auto broken = read(path("a.vdb"));
    broken.meta.removeMeta(nebula::META_HISTORY);
    broken.meta.insertMeta(nebula::META_HISTORY, openvdb::StringMetadata("{\"tool\": 1}"));
    writeVdb(path("broken.vdb"), broken.grids, broken.meta);
    expectFailure("nebillum -i broken.vdb -o lit2.vdb", 1, "broken.vdb: metadata nebula:history");
}

// A misspelt key in a --config file is an error, as a misspelt option is; a right one works.
TEST_F(Cli, UnknownConfigKeysAreErrors)
{
    std::ofstream(path("typo.toml")) << "rez = 16\n";
    expectFailure("nebgen --config typo.toml -o a.vdb", 2, "unknown option \"rez\"");
    std::ofstream(path("good.toml")) << "res = 16\nseed = 4\n";
    ASSERT_EQ(run("nebgen --config good.toml -o a.vdb").code, 0);
    const auto density = read(path("a.vdb")).floatGrid("density", "");
    EXPECT_LE(density->evalActiveVoxelBoundingBox().dim().x(), 18);
}

// -v reports each stage of every tool on stderr; without it they are quiet.
TEST_F(Cli, VerboseReportsEveryTool)
{
    const std::vector<std::pair<std::string, std::string>> commands = {
        {"nebgen", "nebgen --res 16 -o a.vdb"},
        {"nebillum", "nebillum -i a.vdb -o b.vdb"},
        {"nebpyramid", "nebpyramid -i b.vdb --levels 1 -o c.vdb"},
        {"nebphase", "nebphase -i a.vdb --t-count 4 --mu-bins 8 --error 0.3 -o p.vdb"},
        {"nebrender", "nebrender -i c.vdb --phase p.vdb --res 16x16 -o f.exr"},
    };
    for (const auto& [tool, cmd] : commands) {
        const Result quiet = run(cmd + " -q");
        ASSERT_EQ(quiet.code, 0) << cmd << ": " << quiet.err;
        EXPECT_EQ(quiet.err, "") << cmd;
        const Result loud = run(cmd + " -v");
        ASSERT_EQ(loud.code, 0) << cmd << ": " << loud.err;
        // At least what it read or made, and what it wrote.
        EXPECT_GE(reportLines(loud.err, tool), 2) << cmd << ":\n" << loud.err;
        EXPECT_NE(loud.err.find(tool + ": wrote "), std::string::npos) << loud.err;
    }
}

// A giant's or supergiant's class is refused (the table is the main sequence's); a dwarf's
// class and an explicit temperature are fine.
TEST_F(Cli, GiantSpectralClassesAreRefused)
{
    expectFailure("nebgen --res 16 --star a:0,0,0:10:K0III -o a.vdb", 2,
                  "luminosity class III (giant) is not supported");
    EXPECT_EQ(run("nebgen --res 16 --star a:0,0,0:10:K0V -o a.vdb").code, 0);
    EXPECT_EQ(run("nebgen --res 16 --star a:0,0,0:10:4800 -o b.vdb").code, 0);
    expectFailure("nebillum -i a.vdb --star a:0,0,0:10:B1Ia -o c.vdb", 2, "supergiant");
}

// Levels without a phase table: --levels N is an error; levels in the input with neither
// --levels nor --phase are a warning that says how to use them.
TEST_F(Cli, LevelsNeedAPhaseTable)
{
    ASSERT_EQ(run("nebgen --res 24 -o - | nebillum -i - -o - | nebpyramid -i - --levels 2 -o "
                  "pyr.vdb")
                  .code,
              0);
    expectFailure("nebrender -i pyr.vdb --levels 2 --res 16x16 -o f.exr", 2,
                  "--levels needs a phase table (--phase)");
    const Result r = run("nebrender -i pyr.vdb --res 16x16 -o f.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("warning: pyr.vdb has pyramid levels"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--phase"), std::string::npos) << r.err;
    const Result none = run("nebrender -i pyr.vdb --levels 0 --res 16x16 -o g.exr");
    ASSERT_EQ(none.code, 0) << none.err;
    EXPECT_EQ(none.err, "");
}

// EXR attributes are JSON built by a JSON library: a phase table whose path holds a quote
// still gives valid JSON that reads back to the path.
TEST_F(Cli, PhaseTableAttributeIsValidJson)
{
    ASSERT_EQ(run("nebgen --res 16 -o a.vdb && nebillum -i a.vdb -o lit.vdb").code, 0);
    ASSERT_EQ(run("nebphase -i a.vdb --t-count 4 --mu-bins 8 --error 0.3 -o 'ph\"ase.vdb'").code,
              0);
    const Result r = run("nebrender -i lit.vdb --phase 'ph\"ase.vdb' --res 16x16 -o f.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    std::map<std::string, std::string> attrs;
    nebula::readExr(path("f.exr"), &attrs);
    const auto table = nlohmann::json::parse(attrs.at("nebula:phase_table"));
    EXPECT_EQ(table.at("file").get<std::string>(), "ph\"ase.vdb");
    EXPECT_DOUBLE_EQ(table.at("albedo").get<double>(), 0.6);
    const auto camera = nlohmann::json::parse(attrs.at("nebula:camera"));
    EXPECT_EQ(camera.at("eye").size(), 3u);
    nlohmann::json exposure;
    EXPECT_NO_THROW(exposure = nlohmann::json::parse(attrs.at("nebula:exposure")));
    EXPECT_TRUE(exposure.contains("white")) << attrs.at("nebula:exposure");
}
