// SPDX-License-Identifier: Apache-2.0
// End-to-end tests of nebpyramid (DESIGN §5): the level grids in files and pipes, mass
// conservation, metadata, pass-through and --only-new, determinism, and bad input.
#include "cli_fixture.h"

#include "nebula/core/version.h"
#include "nebula/io/grid_io.h"
#include "nebula/stages/pyramid.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

class NebPyramid : public Cli
{
};

/// A cube of n_H 100, 16 voxels a side (so at most 3 levels), named @p name.
openvdb::FloatGrid::Ptr cube(const std::string& name = "density", float value = 100.0f)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    g->fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(15)), value, true);
    g->tree().voxelizeActiveTiles();
    return g;
}

openvdb::MetaMap starMeta()
{
    openvdb::MetaMap m;
    m.insertMeta(
        nebula::META_STARS,
        openvdb::StringMetadata(
            R"([{"name":"s","position":[0.8,0.8,3.0],"luminosity":10,"temperature":20000}])"));
    return m;
}

/// The grid names of @p grids, sorted (a file lists its grids by name).
std::vector<std::string> names(const nebula::GridSet& grids)
{
    std::vector<std::string> n;
    for (const auto& g : grids.grids)
        n.push_back(g->getName());
    std::sort(n.begin(), n.end());
    return n;
}

/// The level grids nebpyramid adds to lit.vdb (stars alpha and beta).
std::vector<std::string> levelNames(int levels)
{
    std::vector<std::string> n;
    for (int k = 1; k <= levels; ++k) {
        for (const std::string base : {"density", "tau.alpha", "tau.beta"}) {
            n.push_back(nebula::levelGridName(base, k));
        }
    }
    std::sort(n.begin(), n.end());
    return n;
}

/// Every active value of grid @p name equal in @p a and @p b (same topology).
void expectSameGrid(const nebula::GridSet& a, const nebula::GridSet& b, const std::string& name)
{
    const auto ga = a.floatGrid(name, ""), gb = b.floatGrid(name, "");
    ASSERT_EQ(ga->activeVoxelCount(), gb->activeVoxelCount()) << name;
    EXPECT_EQ(ga->transform(), gb->transform()) << name;
    const auto acc = gb->getConstAccessor();
    for (auto it = ga->cbeginValueOn(); it; ++it) {
        ASSERT_TRUE(acc.isValueOn(it.getCoord())) << name << " " << it.getCoord();
        ASSERT_EQ(*it, acc.getValue(it.getCoord())) << name << " " << it.getCoord();
    }
}

} // namespace

TEST_F(NebPyramid, FileLevelsMassAndMetadata)
{
    makeLit();
    const Result r = run("nebpyramid -i lit.vdb -o pyr.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "stderr must stay quiet without -v: " << r.err;
    const auto lit = read(path("lit.vdb"));
    const auto pyr = read(path("pyr.vdb"));

    // Input grids passed through, and the levels.
    auto expected = names(lit);
    for (const auto& n : levelNames(3))
        expected.push_back(n);
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(names(pyr), expected);
    for (const auto& n : names(lit))
        expectSameGrid(lit, pyr, n);

    const auto density = pyr.floatGrid("density", "");
    const double mass0 = nebula::gridMass(*density);
    ASSERT_GT(mass0, 0.0);
    for (int k = 1; k <= 3; ++k) {
        const auto d = pyr.floatGrid(nebula::levelGridName("density", k), "");
        EXPECT_EQ(d->getGridClass(), openvdb::GRID_FOG_VOLUME);
        EXPECT_EQ(d->metaValue<openvdb::Int32>("level"), k);
        EXPECT_EQ(d->metaValue<openvdb::Int32>("scale"), 1 << k);
        EXPECT_EQ(d->metaValue<std::string>("source_grid"), "density");
        EXPECT_NEAR(d->voxelSize()[0], density->voxelSize()[0] * (1 << k), 1e-12);
        EXPECT_NEAR(nebula::gridMass(*d), mass0, 1e-6 * mass0) << "level " << k;
        for (const std::string star : {"alpha", "beta"}) {
            const auto tau = pyr.floatGrid(nebula::levelGridName("tau." + star, k), "");
            EXPECT_EQ(tau->metaValue<std::string>("star"), star);
            EXPECT_EQ(tau->metaValue<std::string>("method"), "recompute");
            EXPECT_EQ(tau->metaValue<openvdb::Int32>("level"), k);
            EXPECT_EQ(tau->metaValue<double>("kappa_V"), lit.dust().kappa_V);
            EXPECT_EQ(tau->transform(), d->transform());
            EXPECT_GE(tau->activeVoxelCount(), d->activeVoxelCount()); // + neighbours
            EXPECT_GT(maxValue(*tau), 0.0);
        }
    }
    EXPECT_EQ(pyr.metaString(nebula::META_TOOL), "nebpyramid");
    EXPECT_NE(pyr.metaString(nebula::META_COMMAND).find("nebpyramid -i lit.vdb -o pyr.vdb"),
              std::string::npos);
    EXPECT_EQ(pyr.stars().size(), 2u);
    EXPECT_TRUE(pyr.hasDust());
    EXPECT_EQ(entries(), (std::vector<std::string>{"lit.vdb", "pyr.vdb", "small.vdb"}));

    // The pyramid renders (nebrender ignores the extra grids).
    const Result render = run("nebrender -i pyr.vdb --res 16x16 --no-png -o frame.exr");
    EXPECT_EQ(render.code, 0) << render.err;
}

TEST_F(NebPyramid, UnixPipeMatchesFiles)
{
    makeLit();
    ASSERT_EQ(run("nebpyramid -i lit.vdb --levels 2 -o pyr.vdb").code, 0);
    const Result r = run("nebgen --res 24 --seed 3 -o - | nebillum -i - -o - | "
                         "nebpyramid -i - --levels 2 -o - > piped.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto a = read(path("pyr.vdb")), b = read(path("piped.vdb"));
    EXPECT_EQ(names(a), names(b));
    for (const auto& n : levelNames(2))
        expectSameGrid(a, b, n);
}

TEST_F(NebPyramid, OnlyNewReplacingAndAverage)
{
    makeLit();
    ASSERT_EQ(run("nebpyramid -i lit.vdb --only-new -o only.vdb").code, 0);
    const auto only = read(path("only.vdb"));
    EXPECT_EQ(names(only), levelNames(3));
    EXPECT_EQ(only.stars().size(), 2u); // metadata still travels
    EXPECT_TRUE(only.hasDust());

    // Again on its own output: the levels are replaced, not appended.
    ASSERT_EQ(run("nebpyramid -i lit.vdb -o pyr.vdb").code, 0);
    ASSERT_EQ(run("nebpyramid -i pyr.vdb --tau average -o pyr.vdb").code, 0);
    const auto again = read(path("pyr.vdb"));
    EXPECT_EQ(again.grids.size(), 4u + 9u);
    const auto avg = again.floatGrid("tau.alpha.L2", "");
    EXPECT_EQ(avg->metaValue<std::string>("method"), "average");
    EXPECT_EQ(avg->metaValue<std::string>("source_grid"), "tau.alpha");
    // Averaged and recomputed tau are made on the same voxels.
    const auto rec = read(path("only.vdb")).floatGrid("tau.alpha.L2", "");
    EXPECT_EQ(avg->activeVoxelCount(), rec->activeVoxelCount());
}

TEST_F(NebPyramid, SameOutputWhateverTheThreadCount)
{
    makeLit();
    for (const std::string method : {"recompute", "average"}) {
        ASSERT_EQ(run("nebpyramid -i lit.vdb --tau " + method + " --threads 1 -o one.vdb").code, 0);
        ASSERT_EQ(run("nebpyramid -i lit.vdb --tau " + method + " --threads 2 -o two.vdb").code, 0);
        const auto one = read(path("one.vdb")), two = read(path("two.vdb"));
        for (const auto& n : levelNames(3))
            expectSameGrid(one, two, n);
    }
}

TEST_F(NebPyramid, DensityGridOptionAndLevels)
{
    writeVdb(path("smoke.vdb"), {cube("smoke")}, starMeta());
    const Result r = run("nebpyramid -i smoke.vdb --density-grid smoke --levels 2 -o out.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto out = read(path("out.vdb"));
    EXPECT_EQ(names(out),
              (std::vector<std::string>{"smoke", "smoke.L1", "smoke.L2", "tau.s.L1", "tau.s.L2"}));
    const auto l2 = out.floatGrid("smoke.L2", "");
    EXPECT_EQ(l2->metaValue<std::string>("source_grid"), "smoke");
    EXPECT_EQ(l2->activeVoxelCount(), 64u); // the 16^3 cube in 4^3 blocks
    for (auto it = l2->cbeginValueOn(); it; ++it)
        EXPECT_FLOAT_EQ(*it, 100.0f);
    EXPECT_EQ(out.floatGrid("tau.s.L2", "")->metaValue<std::string>("density_grid"), "smoke.L2");
}

TEST_F(NebPyramid, HelpStartsWithExamples)
{
    ASSERT_EQ(run("nebpyramid --help > help.txt").code, 0);
    std::ifstream in(path("help.txt"));
    std::stringstream s;
    s << in.rdbuf();
    const std::string help = s.str();
    EXPECT_EQ(help.rfind("nebpyramid - ", 0), 0u) << help.substr(0, 80);
    const auto ex = help.find("Examples:"), opts = help.find("Options:");
    ASSERT_NE(ex, std::string::npos);
    ASSERT_NE(opts, std::string::npos);
    EXPECT_LT(ex, opts);
    for (const std::string word : {"--levels", "--tau"})
        EXPECT_NE(help.find(word), std::string::npos) << word;
    // The method and the grids written: in the man page.
    ASSERT_EQ(run("nebpyramid --man > man.txt").code, 0);
    std::ifstream min(path("man.txt"));
    std::stringstream m;
    m << min.rdbuf();
    for (const std::string word :
         {"Mass", "recompute", "average", "density.L<k>", "tau.<star>.L<k>"})
        EXPECT_NE(m.str().find(word), std::string::npos) << word;
    const Result v = run("nebpyramid --version > version.txt");
    EXPECT_EQ(v.code, 0);
    std::ifstream vin(path("version.txt"));
    std::string line;
    std::getline(vin, line);
    EXPECT_EQ(line.rfind("nebpyramid " NEBULA_VERSION_STRING, 0), 0u) << line;
}

// ---- bad input: exit code, message naming the thing, no output left ---------------------

TEST_F(NebPyramid, BadOptions)
{
    writeVdb(path("cube.vdb"), {cube()}, starMeta());
    expectFailure("nebpyramid -i cube.vdb --levels 0 -o out.vdb", 2,
                  "--levels: expected an integer in [1, 24], got 0");
    expectFailure("nebpyramid -i cube.vdb --levels -2 -o out.vdb", 2, "--levels");
    expectFailure("nebpyramid -i cube.vdb --levels 4 -o out.vdb", 2,
                  "--levels 4 is too many for grid \"density\" of cube.vdb: its active bounding "
                  "box is 16 voxels along the longest axis");
    expectFailure("nebpyramid -i cube.vdb --levels 20 -o out.vdb", 2, "at most --levels 3");
    expectFailure("nebpyramid -i cube.vdb --levels 40 -o out.vdb", 2,
                  "--levels: expected an integer in [1, 24], got 40");
    expectFailure("nebpyramid -i cube.vdb --levels two -o out.vdb", 2, "--levels");
    expectFailure("nebpyramid -i cube.vdb --tau mean -o out.vdb", 2,
                  "--tau \"mean\": expected recompute or average");
    expectFailure("nebpyramid -i cube.vdb --bogus -o out.vdb", 2, "--bogus");
    expectFailure("nebpyramid -i cube.vdb", 2, "--output");
    expectFailure("nebpyramid -i cube.vdb -o no/such/folder/out.vdb", 1, "no/such/folder/out.vdb");
}

TEST_F(NebPyramid, BadGridsAndFiles)
{
    expectFailure("nebpyramid -i nowhere.vdb -o out.vdb", 1, "nowhere.vdb: cannot open file");
    writeVdb(path("smoke.vdb"), {cube("smoke")}, starMeta());
    expectFailure("nebpyramid -i smoke.vdb -o out.vdb", 1,
                  "smoke.vdb: no grid \"density\" (--density-grid); the file has grids: smoke");
    auto vec = openvdb::Vec3fGrid::create();
    vec->setName("density");
    vec->tree().setValue(openvdb::Coord(1, 1, 1), openvdb::Vec3f(1.0f));
    writeVdb(path("vec.vdb"), {vec}, starMeta());
    expectFailure("nebpyramid -i vec.vdb -o out.vdb", 1,
                  "vec.vdb: grid \"density\" (--density-grid) is a Vec3fGrid (Tree_vec3s_5_4_3), "
                  "expected a FloatGrid");
    auto none = openvdb::FloatGrid::create(0.0f);
    none->setName("density");
    writeVdb(path("empty.vdb"), {none}, starMeta());
    expectFailure("nebpyramid -i empty.vdb -o out.vdb", 1,
                  "empty.vdb: grid \"density\" has no active voxels");

    for (const float bad : {std::nanf(""), -5.0f}) {
        auto g = cube();
        g->tree().setValue(openvdb::Coord(2, 3, 4), bad);
        writeVdb(path("bad.vdb"), {g}, starMeta());
        expectFailure("nebpyramid -i bad.vdb -o out.vdb", 1,
                      std::string("bad.vdb: grid \"density\" has ") +
                          (std::isnan(bad) ? "a NaN" : "a negative") + " value");
        fs::remove(path("bad.vdb"));
    }

    auto frustum = cube();
    frustum->setTransform(openvdb::math::Transform::createFrustumTransform(
        openvdb::BBoxd(openvdb::Vec3d(0), openvdb::Vec3d(7)), 0.5, 2.0, 0.1));
    writeVdb(path("frustum.vdb"), {frustum}, starMeta());
    expectFailure("nebpyramid -i frustum.vdb -o out.vdb", 1,
                  "frustum.vdb: grid \"density\" has a non-affine transform");

    writeVdb(path("nostars.vdb"), {cube()}, openvdb::MetaMap());
    expectFailure("nebpyramid -i nostars.vdb -o out.vdb", 1, "nostars.vdb: no stars");

    // --tau average needs nebillum's tau.<star>.
    writeVdb(path("cube.vdb"), {cube()}, starMeta());
    expectFailure("nebpyramid -i cube.vdb --tau average -o out.vdb", 1,
                  "cube.vdb: no grid \"tau.s\" for star \"s\"; --tau average averages the "
                  "level-0 optical depths: run nebillum first, or use --tau recompute");
    expectFailure("nebpyramid -i - --tau average -o - < cube.vdb > /dev/null", 1,
                  "<stdin>: no grid \"tau.s\"");

    // A truncated stream.
    makeLit();
    fs::copy_file(path("lit.vdb"), path("cut.vdb"));
    fs::resize_file(path("cut.vdb"), fs::file_size(path("lit.vdb")) / 2);
    expectFailure("nebpyramid -i - -o out.vdb < cut.vdb", 1, "<stdin>: truncated");
}
