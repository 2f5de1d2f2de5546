// SPDX-License-Identifier: Apache-2.0
/// @file test_grid_io.cpp
/// io/grid_io.h: reading and writing grid files (round trip, provenance stamps and the
/// nebula:history chain, errors naming the file), GridSet's grid lookup and replacement,
/// typed access with errors naming the source, grid and option, and the metadata accessors.

#include "nebula/io/grid_io.h"
#include "nebula/io/grid_values.h"

#include "nebula/core/error.h"
#include "nebula/core/version.h"

#include "test_util.h"

#include <openvdb/io/io.h>
#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;

using nebula::GridSet;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

class GridIoTest : public nebula::test::TempFolder
{
protected:
    void SetUp() override
    {
        openvdb::initialize();
        TempFolder::SetUp();
    }
};

openvdb::FloatGrid::Ptr floatGrid(const std::string& name, float scale)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
    for (int i = 0; i < 20; ++i) {
        g->tree().setValue(openvdb::Coord(i, 2 * i - 7, 3), scale * float(i + 1));
    }
    return g;
}

/// A file's grids as nebgen would leave them: density, emission and a velocity grid, with
/// stars and dust metadata.
GridSet sampleSet()
{
    GridSet s;
    s.source = "sample";
    s.grids.push_back(floatGrid("density", 10.0f));
    s.grids.push_back(floatGrid("emission", 0.5f));
    auto v = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
    v->setName("velocity");
    v->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3f(1.5f, -2.0f, 3.0f));
    s.grids.push_back(v);
    nebula::Star a;
    a.name = "alpha";
    a.position = {0.5, -1.25, 2.0};
    a.luminosity = 8000.0;
    a.temperature = 25000.0;
    nebula::Star b;
    b.name = "beta";
    b.luminosity = 60.0;
    s.setStars({a, b});
    nebula::DustParams d;
    d.albedo = 0.45;
    d.g = -0.2;
    d.phase = nebula::PhaseModel::Rayleigh;
    d.curve = "grey";
    s.setDust(d);
    return s;
}

using nebula::test::CerrCapture;

// ---- round trip -----------------------------------------------------------------------------

TEST_F(GridIoTest, WriteThenReadRoundTrip)
{
    const std::string file = path("cloud.vdb");
    nebula::writeGrids(file, sampleSet(), "nebgen", "nebgen -o cloud.vdb --seed 7");
    const GridSet back = nebula::readGrids(file);
    EXPECT_EQ(back.source, file);
    ASSERT_EQ(back.grids.size(), 3u);
    EXPECT_EQ(back.grids[0]->getName(), "density");
    EXPECT_EQ(back.grids[1]->getName(), "emission");
    EXPECT_EQ(back.grids[2]->getName(), "velocity");

    const auto density = back.floatGrid("density", "--density-grid");
    const auto original = floatGrid("density", 10.0f);
    EXPECT_EQ(density->activeVoxelCount(), original->activeVoxelCount());
    for (auto it = original->cbeginValueOn(); it; ++it) {
        EXPECT_EQ(density->tree().getValue(it.getCoord()), *it);
    }
    EXPECT_DOUBLE_EQ(density->voxelSize()[0], 0.25);
    const auto v = openvdb::gridPtrCast<openvdb::Vec3fGrid>(back.find("velocity"));
    ASSERT_TRUE(v);
    EXPECT_EQ(v->tree().getValue(openvdb::Coord(1, 2, 3)), openvdb::Vec3f(1.5f, -2.0f, 3.0f));

    // Stars and dust travel with the file.
    const auto stars = back.stars();
    ASSERT_EQ(stars.size(), 2u);
    EXPECT_EQ(stars[0].name, "alpha");
    EXPECT_EQ(stars[0].position, (std::array<double, 3>{0.5, -1.25, 2.0}));
    EXPECT_EQ(stars[0].luminosity, 8000.0);
    EXPECT_EQ(stars[0].temperature, 25000.0);
    EXPECT_EQ(stars[1].name, "beta");
    ASSERT_TRUE(back.hasDust());
    const auto dust = back.dust();
    EXPECT_EQ(dust.albedo, 0.45);
    EXPECT_EQ(dust.g, -0.2);
    EXPECT_EQ(dust.phase, nebula::PhaseModel::Rayleigh);
    EXPECT_EQ(dust.curve, "grey");
    EXPECT_EQ(dust.kappa_V, nebula::DustParams{}.kappa_V);

    // Provenance: the writing tool, its version and command.
    EXPECT_EQ(back.metaString(nebula::META_TOOL), "nebgen");
    EXPECT_EQ(back.metaString(nebula::META_VERSION), NEBULA_VERSION_STRING);
    EXPECT_EQ(back.metaString(nebula::META_COMMAND), "nebgen -o cloud.vdb --seed 7");
    // Grids without a creator get the tool's.
    EXPECT_EQ(back.grids[0]->getCreator(), std::string("nebgen ") + NEBULA_VERSION_STRING);
    // Nothing else is left in the folder (the write is atomic: no temporary).
    int files = 0;
    for (const auto& e : fs::directory_iterator(dir)) {
        ++files;
        EXPECT_EQ(e.path().filename(), "cloud.vdb");
    }
    EXPECT_EQ(files, 1);
}

TEST_F(GridIoTest, WriteReplacesAnExistingFile)
{
    const std::string file = path("x.vdb");
    nebula::writeGrids(file, sampleSet(), "nebgen", "first");
    GridSet one;
    one.grids.push_back(floatGrid("only", 1.0f));
    nebula::writeGrids(file, one, "nebgen", "second");
    const GridSet back = nebula::readGrids(file);
    ASSERT_EQ(back.grids.size(), 1u);
    EXPECT_EQ(back.grids[0]->getName(), "only");
    EXPECT_EQ(back.metaString(nebula::META_COMMAND), "second");
}

TEST_F(GridIoTest, WriteIntoAMissingFolderThrowsAndLeavesNothing)
{
    const std::string file = path("missing/out.vdb");
    const std::string msg =
        errorMessage([&] { nebula::writeGrids(file, sampleSet(), "nebgen", "c"); });
    EXPECT_TRUE(contains(msg, file)) << msg;
    EXPECT_FALSE(fs::exists(dir / "missing"));
}

TEST_F(GridIoTest, AnUnwritableTransformIsNamedInOwnWords)
{
    // Voxels of 1e-4 at 1e13: OpenVDB's writer throws "ArithmeticError: Non-zero scale values
    // required"; the message names the grid and the transform instead, and no file is left.
    GridSet s = sampleSet();
    auto xform = openvdb::math::Transform::createLinearTransform(1e-4);
    xform->postTranslate(openvdb::Vec3d(1e13, 0, 0));
    s.grids[0]->setTransform(xform);
    const std::string file = path("far.vdb");
    const std::string msg = errorMessage([&] { nebula::writeGrids(file, s, "nebimport", "c"); });
    EXPECT_TRUE(contains(msg, file + ": cannot write grid \"density\": its transform")) << msg;
    EXPECT_FALSE(contains(msg, "ArithmeticError")) << msg;
    EXPECT_FALSE(fs::exists(file));
}

// ---- history ----------------------------------------------------------------------------------

TEST_F(GridIoTest, WriteGridsAppendsToTheHistory)
{
    const std::string a = path("a.vdb"), b = path("b.vdb");
    nebula::writeGrids(a, sampleSet(), "nebgen", "nebgen -o a.vdb");
    GridSet first = nebula::readGrids(a);
    const auto h1 = first.history();
    ASSERT_TRUE(h1.is_array());
    ASSERT_EQ(h1.size(), 1u);
    EXPECT_EQ(h1[0]["tool"], "nebgen");
    EXPECT_EQ(h1[0]["version"], NEBULA_VERSION_STRING);
    EXPECT_EQ(h1[0]["command"], "nebgen -o a.vdb");
    EXPECT_EQ(h1[0].size(), 3u); // exactly {"tool", "version", "command"}

    // The next stage keeps the chain and adds itself, oldest first.
    nebula::writeGrids(b, first, "nebillum", "nebillum -i a.vdb -o b.vdb");
    const GridSet second = nebula::readGrids(b);
    const auto h2 = second.history();
    ASSERT_EQ(h2.size(), 2u);
    EXPECT_EQ(h2[0], h1[0]);
    EXPECT_EQ(h2[1]["tool"], "nebillum");
    EXPECT_EQ(h2[1]["command"], "nebillum -i a.vdb -o b.vdb");
    EXPECT_EQ(second.metaString(nebula::META_TOOL), "nebillum");
    // The metadata is the JSON array itself.
    EXPECT_EQ(nlohmann::json::parse(second.metaString(nebula::META_HISTORY)), h2);

    // historyWith() appends without changing the set.
    const auto h3 = second.historyWith("nebrender", "nebrender -i b.vdb");
    ASSERT_EQ(h3.size(), 3u);
    EXPECT_EQ(h3[2]["tool"], "nebrender");
    EXPECT_EQ(h3[2]["version"], NEBULA_VERSION_STRING);
    EXPECT_EQ(second.history().size(), 2u);
}

TEST(GridSetHistory, LegacyToolAndCommandGiveOneEntry)
{
    GridSet s;
    s.source = "old.vdb";
    s.setMetaString(nebula::META_TOOL, "nebgen");
    s.setMetaString(nebula::META_VERSION, "0.0.9");
    s.setMetaString(nebula::META_COMMAND, "nebgen -o old.vdb --seed 3");
    const auto h = s.history();
    ASSERT_TRUE(h.is_array());
    ASSERT_EQ(h.size(), 1u);
    EXPECT_EQ(h[0]["tool"], "nebgen");
    EXPECT_EQ(h[0]["version"], "0.0.9");
    EXPECT_EQ(h[0]["command"], "nebgen -o old.vdb --seed 3");
    // Appending a stage keeps that entry first.
    const auto next = s.historyWith("nebillum", "nebillum -i old.vdb");
    ASSERT_EQ(next.size(), 2u);
    EXPECT_EQ(next[0], h[0]);
    EXPECT_EQ(next[1]["tool"], "nebillum");
}

TEST(GridSetHistory, ForeignFileHasAnEmptyHistory)
{
    GridSet s;
    s.source = "foreign.vdb";
    const auto h = s.history();
    EXPECT_TRUE(h.is_array());
    EXPECT_TRUE(h.empty());
    const auto next = s.historyWith("nebillum", "nebillum -i foreign.vdb");
    ASSERT_EQ(next.size(), 1u);
    EXPECT_EQ(next[0]["command"], "nebillum -i foreign.vdb");
}

TEST(GridSetHistory, MalformedHistoryIsAnErrorNamingTheFile)
{
    GridSet s;
    s.source = "broken.vdb";
    s.setMetaString(nebula::META_TOOL, "nebgen"); // not used when nebula:history is there
    s.setMetaString(nebula::META_HISTORY, "[{\"tool\": \"nebgen\"");
    std::string msg = errorMessage([&] { s.history(); });
    EXPECT_EQ(msg.rfind("broken.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, nebula::META_HISTORY)) << msg;
    EXPECT_TRUE(contains(msg, "not valid JSON")) << msg;
    EXPECT_THROW(s.historyWith("t", "c"), nebula::Error);

    // Valid JSON, but not an array.
    s.setMetaString(nebula::META_HISTORY, "{\"tool\": \"nebgen\"}");
    msg = errorMessage([&] { s.history(); });
    EXPECT_EQ(msg.rfind("broken.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "not a JSON array")) << msg;
}

TEST_F(GridIoTest, MalformedHistoryInAFileStopsTheWrite)
{
    // A stage must not silently drop the chain it cannot read.
    GridSet s = sampleSet();
    s.source = "in.vdb";
    s.setMetaString(nebula::META_HISTORY, "not json");
    const std::string out = path("out.vdb");
    const std::string msg = errorMessage([&] { nebula::writeGrids(out, s, "nebillum", "c"); });
    EXPECT_EQ(msg.rfind("in.vdb: ", 0), 0u) << msg;
    EXPECT_FALSE(fs::exists(out));
}

// ---- reading errors ---------------------------------------------------------------------------

TEST_F(GridIoTest, ReadErrorsNameTheFile)
{
    // Missing.
    const std::string missing = path("nope.vdb");
    std::string msg = errorMessage([&] { nebula::readGrids(missing); });
    EXPECT_EQ(msg.rfind(missing + ": ", 0), 0u) << msg;

    // Not a VDB file.
    const std::string text = path("notes.vdb");
    std::ofstream(text) << "this is not a VDB file\n";
    msg = errorMessage([&] { nebula::readGrids(text); });
    EXPECT_EQ(msg.rfind(text + ": ", 0), 0u) << msg;

    // Truncated: a good file cut short, at several lengths.
    const std::string good = path("good.vdb");
    nebula::writeGrids(good, sampleSet(), "nebgen", "c");
    const auto size = fs::file_size(good);
    for (const double fraction : {0.9, 0.5, 0.1}) {
        const std::string cut = path("cut.vdb");
        fs::copy_file(good, cut, fs::copy_options::overwrite_existing);
        fs::resize_file(cut, std::uintmax_t(double(size) * fraction));
        msg = errorMessage([&] { nebula::readGrids(cut); });
        EXPECT_EQ(msg.rfind(cut + ": ", 0), 0u) << fraction << ": " << msg;
    }
    // An empty file.
    const std::string empty = path("empty.vdb");
    std::ofstream(empty).close();
    msg = errorMessage([&] { nebula::readGrids(empty); });
    EXPECT_EQ(msg.rfind(empty + ": ", 0), 0u) << msg;
}

TEST(GridIo, RefuseBinaryToTerminal)
{
    // A file path is always fine, whatever stdout is.
    EXPECT_NO_THROW(nebula::refuseBinaryToTerminal("out.vdb", "-o"));
    EXPECT_NO_THROW(nebula::refuseBinaryToTerminal("/tmp/-", "-o"));
    // "-" is refused exactly when stdout is a terminal, naming the option.
    if (::isatty(STDOUT_FILENO)) {
        const std::string msg =
            errorMessage([] { nebula::refuseBinaryToTerminal("-", "--output"); });
        EXPECT_EQ(msg.rfind("--output -: ", 0), 0u) << msg;
        EXPECT_THROW(nebula::refuseBinaryToTerminal("-", "-o"), nebula::UsageError);
    } else {
        EXPECT_NO_THROW(nebula::refuseBinaryToTerminal("-", "-o"));
    }
}

// ---- GridSet ---------------------------------------------------------------------------------

TEST(GridSet, FindAndReplaceNeverDuplicates)
{
    GridSet s;
    EXPECT_EQ(s.find("density"), nullptr);
    auto a = floatGrid("density", 1.0f);
    auto b = floatGrid("emission", 1.0f);
    s.replace(a);
    s.replace(b);
    ASSERT_EQ(s.grids.size(), 2u);
    EXPECT_EQ(s.find("density"), a);
    EXPECT_EQ(s.find("emission"), b);

    // Same name again: replaced in place, never added twice.
    auto a2 = floatGrid("density", 2.0f);
    s.replace(a2);
    s.replace(floatGrid("density", 3.0f));
    auto a4 = floatGrid("density", 4.0f);
    s.replace(a4);
    ASSERT_EQ(s.grids.size(), 2u);
    EXPECT_EQ(s.grids[0], a4); // same position
    EXPECT_EQ(s.find("density"), a4);
    EXPECT_EQ(s.grids[1], b);
    int named = 0;
    for (const auto& g : s.grids)
        named += g->getName() == "density";
    EXPECT_EQ(named, 1);

    // A grid of another type under the same name replaces too.
    auto v = openvdb::Vec3fGrid::create();
    v->setName("emission");
    s.replace(v);
    ASSERT_EQ(s.grids.size(), 2u);
    EXPECT_EQ(s.find("emission"), v);
}

TEST(GridSet, FloatGridErrorsNameSourceGridAndOption)
{
    GridSet s;
    s.source = "cloud.vdb";
    s.grids.push_back(floatGrid("density", 1.0f));
    auto v = openvdb::Vec3fGrid::create();
    v->setName("velocity");
    s.grids.push_back(v);

    EXPECT_EQ(s.floatGrid("density", "--density-grid"), s.grids[0]);

    // Missing: the source, the grid, the option and what the file has.
    std::string msg = errorMessage([&] { s.floatGrid("dust", "--density-grid"); });
    EXPECT_EQ(msg.rfind("cloud.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "\"dust\"")) << msg;
    EXPECT_TRUE(contains(msg, "--density-grid")) << msg;
    EXPECT_TRUE(contains(msg, "density, velocity")) << msg;
    // Without an option the message still names the source and grid.
    msg = errorMessage([&] { s.floatGrid("dust", ""); });
    EXPECT_EQ(msg.rfind("cloud.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "\"dust\"")) << msg;
    // An empty set says so.
    GridSet none;
    none.source = "empty.vdb";
    msg = errorMessage([&] { none.floatGrid("density", "--density-grid"); });
    EXPECT_TRUE(contains(msg, "empty.vdb")) << msg;
    EXPECT_TRUE(contains(msg, "no grids")) << msg;

    // Another type: the source, the grid, the type found and the one expected.
    msg = errorMessage([&] { s.floatGrid("velocity", "--density-grid"); });
    EXPECT_EQ(msg.rfind("cloud.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "\"velocity\"")) << msg;
    EXPECT_TRUE(contains(msg, v->type())) << msg; // OpenVDB's name of the type found
    EXPECT_TRUE(contains(msg, "expected a FloatGrid")) << msg;

    // A non-affine (frustum) transform.
    auto f = floatGrid("frustum", 1.0f);
    const openvdb::BBoxd box(openvdb::Vec3d(0), openvdb::Vec3d(10));
    f->setTransform(openvdb::math::Transform::createFrustumTransform(box, 0.5, 10.0, 1.0));
    s.grids.push_back(f);
    msg = errorMessage([&] { s.floatGrid("frustum", "--density-grid"); });
    EXPECT_EQ(msg.rfind("cloud.vdb: ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "\"frustum\"")) << msg;
    EXPECT_TRUE(contains(msg, "non-affine")) << msg;
}

TEST(GridSet, MetadataAccessors)
{
    GridSet s;
    s.source = "m.vdb";
    EXPECT_EQ(s.metaString("nebula:nothing"), "");
    EXPECT_EQ(s.metaString("nebula:nothing", "fallback"), "fallback");
    s.setMetaString("k", "one");
    s.setMetaString("k", "two"); // replaced
    EXPECT_EQ(s.metaString("k"), "two");
    // A key of another type is replaced by the string.
    s.meta.insertMeta("n", openvdb::Int32Metadata(5));
    s.setMetaString("n", "five");
    EXPECT_EQ(s.metaString("n"), "five");

    // No stars or dust metadata: no stars, the default dust.
    EXPECT_TRUE(s.stars().empty());
    EXPECT_FALSE(s.hasDust());
    EXPECT_EQ(s.dust().albedo, nebula::DustParams{}.albedo);
    EXPECT_EQ(s.dust().g, nebula::DustParams{}.g);

    // Bad metadata: errors naming the source.
    s.setMetaString(nebula::META_STARS, "[{\"name\": 3}]");
    std::string msg = errorMessage([&] { s.stars(); });
    EXPECT_EQ(msg.rfind("m.vdb", 0), 0u) << msg;
    s.setMetaString(nebula::META_DUST, "{\"albedo\": \"high\"}");
    EXPECT_TRUE(s.hasDust());
    msg = errorMessage([&] { s.dust(); });
    EXPECT_EQ(msg.rfind("m.vdb", 0), 0u) << msg;
}

// A nebula:dust that lacks fields: the defaults for them, and with a Run one warning that
// names them (none under -q, none for a complete one).
TEST(GridSet, PartialDustWarnsOnceNamingTheMissingFields)
{
    GridSet s;
    s.source = "m.vdb";
    s.setMetaString(nebula::META_DUST, R"({"albedo": 0.5, "g": 0.2, "phase": "hg"})");
    {
        nebula::test::CerrCapture cap;
        const auto d = s.dust(nebula::Run("nebtest", "", {}));
        EXPECT_EQ(d.albedo, 0.5);
        EXPECT_EQ(d.kappa_V, nebula::DustParams{}.kappa_V);
        EXPECT_EQ(cap.text(), "nebtest: warning: m.vdb: metadata nebula:dust lacks 3 fields; "
                              "using the defaults kappa_V = 0.0015, curve = CCM89, R_V = 3.1\n");
    }
    {
        nebula::test::CerrCapture cap;
        EXPECT_EQ(s.dust().albedo, 0.5); // silent without a Run
        s.dust(nebula::Run("nebtest", "", {true, 0}));
        s.setDust(nebula::DustParams{});
        s.dust(nebula::Run("nebtest", "", {}));
        EXPECT_EQ(cap.text(), "");
    }
}

TEST(GridSet, DescribeGrids)
{
    GridSet s;
    EXPECT_EQ(nebula::describeGrids(s), "0 grids");
    s.grids.push_back(floatGrid("density", 1.0f));
    EXPECT_EQ(nebula::describeGrids(s), "1 grid: density");
    s.grids.push_back(floatGrid("tau.alpha", 1.0f));
    EXPECT_EQ(nebula::describeGrids(s), "2 grids: density, tau.alpha");
    // A family of more than 3 (nebscatter's field) is one entry; 3 or fewer are listed.
    for (const char* name :
         {"scatter.stars.J.R", "scatter.stars.J.G", "scatter.stars.J.B", "scatter.stars.c1_0.R",
          "scatter.emission.J.R", "scatter.emission.J.G", "tau.beta"}) {
        auto g = openvdb::FloatGrid::create();
        g->setName(name);
        s.grids.push_back(g);
    }
    EXPECT_EQ(nebula::describeGrids(s),
              "9 grids: density, tau.alpha, scatter.stars.* (4), scatter.emission.J.R, "
              "scatter.emission.J.G, tau.beta");
}

TEST_F(GridIoTest, RunOverloadsReportUnderVerbose)
{
    const std::string file = path("v.vdb");
    {
        const nebula::Run verbose("nebgen", "nebgen -o v.vdb", nebula::Verbosity{false, 1});
        CerrCapture cap;
        nebula::writeGrids(file, sampleSet(), verbose);
        EXPECT_EQ(cap.text(), "nebgen: wrote " + file + ": 3 grids: density, emission, velocity\n");
    }
    // The run's tool and command are the provenance.
    const GridSet back = [&] {
        const nebula::Run verbose("nebillum", "c", nebula::Verbosity{false, 1});
        CerrCapture cap;
        GridSet g = nebula::readGrids(file, verbose);
        EXPECT_EQ(cap.text(),
                  "nebillum: read " + file + ": 3 grids: density, emission, velocity\n");
        return g;
    }();
    EXPECT_EQ(back.metaString(nebula::META_TOOL), "nebgen");
    EXPECT_EQ(back.metaString(nebula::META_COMMAND), "nebgen -o v.vdb");
    // Silent otherwise.
    const nebula::Run quiet;
    CerrCapture cap;
    nebula::readGrids(file, quiet);
    nebula::writeGrids(path("w.vdb"), sampleSet(), quiet);
    EXPECT_EQ(cap.text(), "");
}

// ---- checks ----------------------------------------------------------------------------------

TEST(GridChecks, RequireFiniteNonNegative)
{
    auto g = floatGrid("density", 1.0f);
    g->tree().setValue(openvdb::Coord(100, 0, 0), 0.0f); // active zero is fine
    EXPECT_EQ(nebula::requireFiniteNonNegative(*g, "d.vdb"), std::size_t(21));
    const std::pair<float, const char*> bad[] = {
        {-0.5f, "a negative value"},
        {std::numeric_limits<float>::quiet_NaN(), "a NaN value"},
        {std::numeric_limits<float>::infinity(), "an infinite value"},
    };
    for (const auto& [value, mention] : bad) {
        auto c = g->deepCopy();
        c->tree().setValue(openvdb::Coord(4, 5, 6), value);
        const std::string msg =
            errorMessage([&] { nebula::requireFiniteNonNegative(*c, "d.vdb"); });
        EXPECT_EQ(msg.rfind("d.vdb: grid \"density\" has ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, mention)) << msg;
        EXPECT_TRUE(contains(msg, "(4, 5, 6)")) << msg;
    }
}

// requireFinite(): NaN and infinities named as they are; negative values pass; with a box,
// the background and the inactive values inside it (what a dense cube holds) too.
TEST(GridChecks, RequireFinite)
{
    auto g = floatGrid("density", 1.0f);
    g->tree().setValue(openvdb::Coord(100, 0, 0), -3.0f); // negative: fine
    EXPECT_EQ(nebula::requireFinite(*g, "d.vdb"), std::size_t(21));
    const float inf = std::numeric_limits<float>::infinity();
    const std::pair<float, const char*> bad[] = {
        {std::numeric_limits<float>::quiet_NaN(), "the value nan at voxel (4, 5, 6)"},
        {-std::numeric_limits<float>::quiet_NaN(), "the value nan at voxel (4, 5, 6)"},
        {inf, "the value inf at voxel (4, 5, 6)"},
        {-inf, "the value -inf at voxel (4, 5, 6)"},
    };
    for (const auto& [value, mention] : bad) {
        auto c = g->deepCopy();
        c->tree().setValue(openvdb::Coord(4, 5, 6), value);
        const std::string msg = errorMessage([&] { nebula::requireFinite(*c, "d.vdb"); });
        EXPECT_EQ(msg.rfind("d.vdb: grid \"density\" has ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, mention)) << msg;
        EXPECT_FALSE(contains(msg, "-nan")) << msg;
    }
    // An active tile: named at its first voxel.
    auto t = g->deepCopy();
    t->tree().addTile(1, openvdb::Coord(64, 64, 64), inf, true);
    EXPECT_TRUE(contains(errorMessage([&] { nebula::requireFinite(*t, "d.vdb"); }),
                         "the value inf at voxel (64, 64, 64)"));
    // Inactive values count only inside a box given.
    auto off = g->deepCopy();
    off->tree().setValueOff(openvdb::Coord(1, -4, 3), -inf);
    EXPECT_EQ(nebula::requireFinite(*off, "d.vdb"), std::size_t(21));
    const openvdb::CoordBBox inside(openvdb::Coord(0, -10, 0), openvdb::Coord(8, 8, 8));
    const openvdb::CoordBBox outside(openvdb::Coord(2, -10, 0), openvdb::Coord(8, 8, 8));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::requireFinite(*off, "d.vdb", &inside); }),
                         "the inactive value -inf at voxel (1, -4, 3)"));
    EXPECT_EQ(nebula::requireFinite(*off, "d.vdb", &outside), std::size_t(21));
    auto tile = g->deepCopy();
    tile->tree().addTile(1, openvdb::Coord(0, -16, 0), inf, false); // 8^3, y -16 to -9
    EXPECT_TRUE(contains(errorMessage([&] { nebula::requireFinite(*tile, "d.vdb", &inside); }),
                         "the inactive value inf at voxel (0, -16, 0)"));
    auto bg = openvdb::FloatGrid::create(inf);
    bg->setName("density");
    bg->tree().setValueOn(openvdb::Coord(0), 1.0f);
    EXPECT_EQ(nebula::requireFinite(*bg, "d.vdb"), std::size_t(1));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::requireFinite(*bg, "d.vdb", &inside); }),
                         "the background value inf"));
    EXPECT_EQ(nebula::valueText(2.5), "2.5");
}

namespace {

/// @p grid's transform read back from its serialisation with every double @p from replaced by
/// @p to: a scale OpenVDB's constructors refuse but a file can hold.
void doctorTransform(openvdb::GridBase& grid, double from, double to)
{
    openvdb::initialize(); // Transform::read() looks the map type up in the registry
    std::ostringstream out(std::ios::binary);
    grid.transform().write(out);
    std::string bytes = out.str();
    std::string a(sizeof from, '\0'), b(sizeof to, '\0');
    std::memcpy(a.data(), &from, sizeof from);
    std::memcpy(b.data(), &to, sizeof to);
    int n = 0;
    for (auto at = bytes.find(a); at != std::string::npos; at = bytes.find(a, at + 1), ++n)
        bytes.replace(at, b.size(), b);
    ASSERT_GE(n, 3);
    std::istringstream in(bytes, std::ios::binary);
    openvdb::io::setCurrentVersion(in); // as a file of this library version would be read
    auto xform = openvdb::math::Transform::createLinearTransform();
    xform->read(in);
    grid.setTransform(xform);
}

} // namespace

// requireVoxelSize: a zero, NaN or degenerate voxel is an error naming the file and grid
// (GridSet::floatGrid() checks it), not "singular grid transform" later.
TEST(GridChecks, RequireVoxelSize)
{
    auto g = floatGrid("density", 1.0f);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.125));
    EXPECT_NO_THROW(nebula::requireVoxelSize(*g, "a.vdb"));
    doctorTransform(*g, 0.125, 0.0);
    EXPECT_EQ(errorMessage([&] { nebula::requireVoxelSize(*g, "a.vdb"); }),
              "a.vdb: grid \"density\" has voxel size 0 along its x axis (a singular "
              "transform); expected a finite voxel size > 0");
    GridSet s;
    s.source = "a.vdb";
    s.grids.push_back(g);
    EXPECT_EQ(errorMessage([&] {
                  s.floatGrid("density", "");
              }).rfind("a.vdb: grid \"density\" has voxel size 0", 0),
              0u);

    auto n = floatGrid("density", 1.0f);
    n->setTransform(openvdb::math::Transform::createLinearTransform(0.125));
    doctorTransform(*n, 0.125, std::nan(""));
    EXPECT_EQ(errorMessage([&] {
                  nebula::requireVoxelSize(*n, "b.vdb");
              }).rfind("b.vdb: grid \"density\" has a transform with non-finite values", 0),
              0u);

    // Rotated, sheared, anisotropic and mirrored voxels are fine.
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.setToRotation(openvdb::math::Vec3d(1, 2, 3).unit(), 0.7);
    m.preScale(openvdb::math::Vec3d(0.1, -0.2, 0.3));
    m(1, 0) += 0.05;
    auto p = floatGrid("density", 1.0f);
    p->setTransform(openvdb::math::Transform::createLinearTransform(m));
    EXPECT_NO_THROW(nebula::requireVoxelSize(*p, "c.vdb"));
}

TEST(GridChecks, RequireAffine)
{
    auto g = floatGrid("density", 1.0f);
    EXPECT_NO_THROW(nebula::requireAffine(*g, "a.vdb"));
    // Rotated, anisotropic, mirrored: all affine.
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.setToRotation(openvdb::math::Vec3d(1, 2, 3).unit(), 0.7);
    m.preScale(openvdb::math::Vec3d(0.1, -0.2, 0.3));
    g->setTransform(openvdb::math::Transform::createLinearTransform(m));
    EXPECT_NO_THROW(nebula::requireAffine(*g, "a.vdb"));
    const openvdb::BBoxd box(openvdb::Vec3d(0), openvdb::Vec3d(10));
    g->setTransform(openvdb::math::Transform::createFrustumTransform(box, 0.5, 10.0, 1.0));
    const std::string msg = errorMessage([&] { nebula::requireAffine(*g, "a.vdb"); });
    EXPECT_EQ(msg.rfind("a.vdb: grid \"density\" has a non-affine transform", 0), 0u) << msg;
}

} // namespace

// No file is written with two grids of one name or a non-finite voxel, and none is read with
// two grids of one name: both named.
TEST_F(GridIoTest, DuplicateNamesAndNonFiniteVoxelsAreRefused)
{
    GridSet twice = sampleSet();
    twice.grids.push_back(floatGrid("density", 2.0f));
    std::string msg = errorMessage([&] { nebula::writeGrids(path("twice.vdb"), twice, "t", "c"); });
    EXPECT_TRUE(contains(msg, "grids 1 and 4 are both named \"density\"")) << msg;
    EXPECT_FALSE(fs::exists(path("twice.vdb")));
    // As another program would write it: refused on reading.
    {
        openvdb::io::File f(path("foreign.vdb"));
        f.write(twice.grids);
        f.close();
    }
    msg = errorMessage([&] { nebula::readGrids(path("foreign.vdb")); });
    EXPECT_EQ(msg, path("foreign.vdb") + ": grids 1 and 4 are both named \"density\"; a nebula "
                                         "file holds each grid name once");
    for (const float bad :
         {std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()}) {
        GridSet set = sampleSet();
        auto tau = floatGrid("tau.alpha", 1.0f);
        tau->tree().setValue(openvdb::Coord(4, 5, 6), bad);
        set.grids.push_back(tau);
        msg = errorMessage([&] { nebula::writeGrids(path("inf.vdb"), set, "t", "c"); });
        EXPECT_TRUE(contains(msg, "grid \"tau.alpha\" has a non-finite value at voxel (4, 5, 6)"))
            << msg;
        EXPECT_FALSE(fs::exists(path("inf.vdb")));
    }
    GridSet vec = sampleSet();
    auto v = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
    v->setName("velocity2");
    v->tree().setValue(openvdb::Coord(1, 1, 1),
                       openvdb::Vec3f(0.0f, std::numeric_limits<float>::infinity(), 0.0f));
    vec.grids.push_back(v);
    msg = errorMessage([&] { nebula::writeGrids(path("vec.vdb"), vec, "t", "c"); });
    EXPECT_TRUE(contains(msg, "grid \"velocity2\" has a non-finite value at voxel (1, 1, 1)"))
        << msg;
}
