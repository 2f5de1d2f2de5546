// SPDX-License-Identifier: Apache-2.0
// End-to-end tests: run the built tools on tiny generated grids and check grid values,
// metadata, images, exit codes, messages, and that failures leave no output.
#include "cli_fixture.h"

#include "nebula/cli/manual.h"
#include "nebula/core/version.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

using namespace nebula::clitest;

namespace {

/// A small valid density grid (a cube of n_H 100) with a star next to it.
openvdb::FloatGrid::Ptr cubeDensity(float value = 100.0f)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    g->fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(7)), value, true);
    g->tree().voxelizeActiveTiles();
    return g;
}

openvdb::MetaMap starMeta()
{
    openvdb::MetaMap m;
    m.insertMeta(
        nebula::META_STARS,
        openvdb::StringMetadata(
            R"([{"name":"s","position":[0.4,0.4,2.0],"luminosity":10,"temperature":20000}])"));
    return m;
}

} // namespace

// ---- the pipeline ----------------------------------------------------------------------

TEST_F(Cli, PipelineFilesGridsMetadataAndImages)
{
    makeLit();
    const auto lit = read(path("lit.vdb"));
    // Input grids passed through, one tau grid per star, nothing duplicated.
    std::vector<std::string> names;
    for (const auto& g : lit.grids)
        names.push_back(g->getName());
    EXPECT_EQ(names, (std::vector<std::string>{"density", "emission", "tau.alpha", "tau.beta"}));
    const auto density = lit.floatGrid("density", "");
    EXPECT_EQ(density->getGridClass(), openvdb::GRID_FOG_VOLUME);
    EXPECT_NEAR(density->voxelSize()[0], 10.0 / 24, 1e-12);
    EXPECT_GT(maxValue(*density), 10.0);
    const auto tau = lit.floatGrid("tau.alpha", "");
    EXPECT_EQ(tau->getGridClass(), openvdb::GRID_UNKNOWN);
    EXPECT_GE(tau->activeVoxelCount(), density->activeVoxelCount()); // + neighbours
    EXPECT_GT(maxValue(*tau), 0.0);
    // Provenance and the metadata later stages need.
    EXPECT_EQ(lit.metaString(nebula::META_TOOL), "nebillum");
    EXPECT_EQ(lit.metaString(nebula::META_VERSION), NEBULA_VERSION_STRING);
    EXPECT_NE(lit.metaString(nebula::META_COMMAND).find("nebillum -i small.vdb -o lit.vdb"),
              std::string::npos);
    EXPECT_EQ(lit.stars().size(), 2u);
    EXPECT_TRUE(lit.hasDust());

    const Result r = run("nebrender -i lit.vdb --res 48x32 -o frame.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "stderr must stay quiet without -v: " << r.err;
    std::map<std::string, std::string> attrs;
    const auto img = nebula::readExr(path("frame.exr"), &attrs);
    EXPECT_EQ(img.width, 48);
    EXPECT_EQ(img.height, 32);
    std::vector<std::string> layers;
    for (const auto& l : img.layers)
        layers.push_back(l.name);
    EXPECT_EQ(layers, (std::vector<std::string>{"star.alpha", "star.beta", "transmittance"}));
    double sum = 0.0, alphaMax = 0.0;
    for (int i = 0; i < 48 * 32; ++i) {
        for (int c = 0; c < 3; ++c) {
            ASSERT_TRUE(std::isfinite(img.rgba[4 * i + c]));
            ASSERT_GE(img.rgba[4 * i + c], 0.0f);
            sum += img.rgba[4 * i + c];
        }
        alphaMax = std::max(alphaMax, double(img.rgba[4 * i + 3]));
    }
    EXPECT_GT(sum, 0.0);
    EXPECT_GT(alphaMax, 0.0);
    EXPECT_LE(alphaMax, 1.0);
    EXPECT_NE(attrs["nebula:command"].find("nebrender"), std::string::npos);
    EXPECT_EQ(attrs["nebula:units"], "L_sun pc^-2 sr^-1");
    EXPECT_TRUE(fs::exists(path("frame.png")));
    EXPECT_EQ(entries(),
              (std::vector<std::string>{"frame.exr", "frame.png", "lit.vdb", "small.vdb"}));
}

TEST_F(Cli, UnixPipeMatchesFiles)
{
    makeLit();
    const Result r = run("nebgen --res 24 --seed 3 -o - | nebillum -i - -o - > piped.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto a = read(path("lit.vdb")), b = read(path("piped.vdb"));
    for (const std::string name : {"density", "emission", "tau.alpha", "tau.beta"}) {
        const auto ga = a.floatGrid(name, ""), gb = b.floatGrid(name, "");
        ASSERT_EQ(ga->activeVoxelCount(), gb->activeVoxelCount()) << name;
        auto acc = gb->getConstAccessor();
        for (auto it = ga->cbeginValueOn(); it; ++it) {
            ASSERT_EQ(*it, acc.getValue(it.getCoord())) << name;
        }
    }
}

TEST_F(Cli, SameSeedSameGridsWhateverTheThreadCount)
{
    ASSERT_EQ(run("nebgen --res 20 --seed 9 --threads 1 -o one.vdb").code, 0);
    ASSERT_EQ(run("nebgen --res 20 --seed 9 --threads 2 -o two.vdb").code, 0);
    ASSERT_EQ(run("nebgen --res 20 --seed 10 -o other.vdb").code, 0);
    ASSERT_EQ(run("nebillum -i one.vdb --threads 1 -o lone.vdb").code, 0);
    ASSERT_EQ(run("nebillum -i two.vdb --threads 2 -o ltwo.vdb").code, 0);
    const auto one = read(path("lone.vdb")), two = read(path("ltwo.vdb"));
    for (const std::string name : {"density", "emission", "tau.alpha"}) {
        const auto g1 = one.floatGrid(name, ""), g2 = two.floatGrid(name, "");
        ASSERT_EQ(g1->activeVoxelCount(), g2->activeVoxelCount());
        auto acc = g2->getConstAccessor();
        for (auto it = g1->cbeginValueOn(); it; ++it)
            ASSERT_EQ(*it, acc.getValue(it.getCoord()));
    }
    // A different seed gives a different cloud.
    const auto other = read(path("other.vdb")).floatGrid("density", "");
    const auto first = one.floatGrid("density", "");
    EXPECT_NE(other->activeVoxelCount(), first->activeVoxelCount());
}

TEST_F(Cli, OnlyNewAndReplacingGridsOfTheSameName)
{
    makeLit();
    ASSERT_EQ(run("nebillum -i lit.vdb -o again.vdb").code, 0);
    EXPECT_EQ(read(path("again.vdb")).grids.size(), 4u); // tau.* replaced, not appended
    ASSERT_EQ(run("nebillum -i small.vdb --only-new -o only.vdb").code, 0);
    const auto only = read(path("only.vdb"));
    ASSERT_EQ(only.grids.size(), 2u);
    EXPECT_TRUE(only.find("tau.alpha") && only.find("tau.beta"));
    EXPECT_EQ(only.stars().size(), 2u); // metadata still travels
    // In-place update through the atomic rename.
    ASSERT_EQ(run("nebillum -i small.vdb -o small.vdb").code, 0);
    EXPECT_EQ(read(path("small.vdb")).grids.size(), 4u);
}

TEST_F(Cli, HelpStartsWithExamplesAndVersion)
{
    for (const std::string tool : {"nebgen", "nebillum", "nebscatter", "nebrender"}) {
        const Result r = run(tool + " --help > help.txt");
        EXPECT_EQ(r.code, 0);
        std::ifstream in(path("help.txt"));
        std::stringstream s;
        s << in.rdbuf();
        const std::string help = s.str();
        EXPECT_EQ(help.rfind(tool + " - ", 0), 0u) << help.substr(0, 80);
        const auto ex = help.find("Examples:");
        EXPECT_NE(ex, std::string::npos);
        const auto opts = help.find("Options:");
        ASSERT_NE(opts, std::string::npos);
        EXPECT_LT(ex, opts) << tool;
        // --help: the purpose, at most five examples, the man page's name; then the options.
        int examples = 0;
        for (std::size_t at = help.find("\n  " + tool, ex); at < opts;
             at = help.find("\n  " + tool, at + 1))
            ++examples;
        EXPECT_GE(examples, 2) << tool;
        EXPECT_LE(examples, nebula::cli::MAX_HELP_EXAMPLES) << tool;
        EXPECT_LT(help.find("man " + tool), opts) << tool;
        // The man page: the whole description (every example) and every option.
        ASSERT_EQ(run(tool + " --man > man.txt").code, 0);
        std::ifstream min(path("man.txt"));
        std::stringstream m;
        m << min.rdbuf();
        const std::string man = m.str();
        for (const char* section :
             {".SH NAME", ".SH DESCRIPTION", ".SH OPTIONS", ".SH EXIT STATUS"})
            EXPECT_NE(man.find(section), std::string::npos) << tool << " " << section;
        EXPECT_NE(man.find("Examples:"), std::string::npos) << tool;
        const Result v = run(tool + " --version > version.txt");
        EXPECT_EQ(v.code, 0);
        std::ifstream vin(path("version.txt"));
        std::string line;
        std::getline(vin, line);
        EXPECT_EQ(line.rfind(tool + " " NEBULA_VERSION_STRING, 0), 0u) << line;
    }
}

TEST_F(Cli, ConfigFileSetsOptions)
{
    {
        std::ofstream cfg(path("gen.toml"));
        cfg << "res = 12\nseed = 4\n";
    }
    ASSERT_EQ(run("nebgen --config gen.toml -o c.vdb").code, 0);
    const auto d = read(path("c.vdb")).floatGrid("density", "");
    EXPECT_NEAR(d->voxelSize()[0], 10.0 / 12, 1e-12);
}

// ---- bad input: exit code, message naming the thing, no output left ---------------------

TEST_F(Cli, MissingNotVdbAndTruncatedFiles)
{
    expectFailure("nebillum -i nowhere.vdb -o out.vdb", 1, "nowhere.vdb: cannot open file");
    {
        std::ofstream(path("text.vdb")) << "this is not a grid file\n";
    }
    expectFailure("nebillum -i text.vdb -o out.vdb", 1, "text.vdb: not a VDB file");
    makeLit();
    const auto size = fs::file_size(path("lit.vdb"));
    for (const double frac : {0.05, 0.5, 0.95}) {
        fs::copy_file(path("lit.vdb"), path("cut.vdb"), fs::copy_options::overwrite_existing);
        fs::resize_file(path("cut.vdb"), std::uintmax_t(double(size) * frac));
        expectFailure("nebrender -i cut.vdb -o out.exr", 1, "cut.vdb: truncated");
        expectFailure("nebillum -i - -o out.vdb < cut.vdb", 1, "<stdin>: truncated");
    }
}

TEST_F(Cli, DensityGridMissingOrWrongType)
{
    auto vec = openvdb::Vec3fGrid::create();
    vec->setName("density");
    vec->tree().setValue(openvdb::Coord(1, 1, 1), openvdb::Vec3f(1.0f));
    writeVdb(path("vec.vdb"), {vec}, starMeta());
    expectFailure("nebillum -i vec.vdb -o out.vdb", 1,
                  "vec.vdb: grid \"density\" (--density-grid) is a Vec3fGrid (Tree_vec3s_5_4_3), "
                  "expected a FloatGrid");
    auto other = cubeDensity();
    other->setName("smoke");
    writeVdb(path("smoke.vdb"), {other}, starMeta());
    expectFailure("nebillum -i smoke.vdb -o out.vdb", 1, "smoke.vdb: no grid \"density\"");
    expectFailure("nebillum -i smoke.vdb --density-grid fog -o out.vdb", 1,
                  "no grid \"fog\" (--density-grid); the file has grids: smoke");
    // ...and naming the right one works.
    EXPECT_EQ(run("nebillum -i smoke.vdb --density-grid smoke -o ok.vdb").code, 0);
}

TEST_F(Cli, NanOrNegativeDensities)
{
    for (const float bad : {std::nanf(""), -5.0f}) {
        auto g = cubeDensity();
        g->tree().setValue(openvdb::Coord(2, 3, 4), bad);
        writeVdb(path("bad.vdb"), {g}, starMeta());
        expectFailure("nebillum -i bad.vdb -o out.vdb", 1,
                      std::string("bad.vdb: grid \"density\" has ") +
                          (std::isnan(bad) ? "a NaN" : "a negative") + " value");
        expectFailure("nebrender -i bad.vdb -o out.exr", 1, "at voxel (2, 3, 4)");
        fs::remove(path("bad.vdb"));
    }
}

TEST_F(Cli, StarFilesAndOptions)
{
    writeVdb(path("cube.vdb"), {cubeDensity()}, openvdb::MetaMap());
    std::ofstream(path("broken.json")) << "[{\"name\": \"a\", ";
    expectFailure("nebillum -i cube.vdb --stars broken.json -o out.vdb", 1,
                  "broken.json: not valid JSON");
    std::ofstream(path("nolum.json")) << R"([{"name":"a","position":[0,0,0],"class":"B2V"}])";
    expectFailure("nebillum -i cube.vdb --stars nolum.json -o out.vdb", 1, "\"luminosity\"");
    std::ofstream(path("zero.json"))
        << R"([{"name":"a","position":[0,0,0],"luminosity":0,"class":"B2V"}])";
    expectFailure("nebillum -i cube.vdb --stars zero.json -o out.vdb", 1,
                  "\"luminosity\" must be > 0");
    expectFailure("nebgen --star a:0,0,0:-3:B2V -o out.vdb", 2, "\"luminosity\" must be > 0");
    expectFailure("nebgen --star a:0,0:5:B2V -o out.vdb", 2,
                  "expected NAME:X,Y,Z:LUMINOSITY:CLASS");
    expectFailure("nebgen --star a:0,0,0:5:Q7V -o out.vdb", 2, "Q7V");
    // No stars anywhere.
    expectFailure("nebillum -i cube.vdb -o out.vdb", 1, "cube.vdb: no stars");
    // A good star file works and replaces the input's stars.
    std::ofstream(path("good.json"))
        << R"([{"name":"x1","position":[0.3,0.3,0.3],"luminosity":5,"class":"A0V"}])";
    ASSERT_EQ(run("nebillum -i cube.vdb --stars good.json -o good.vdb").code, 0);
    EXPECT_TRUE(read(path("good.vdb")).find("tau.x1"));
}

TEST_F(Cli, NonAffineTransform)
{
    auto g = cubeDensity();
    const openvdb::BBoxd frustumBox(openvdb::Vec3d(0), openvdb::Vec3d(7));
    g->setTransform(openvdb::math::Transform::createFrustumTransform(frustumBox, 0.5, 2.0, 0.1));
    writeVdb(path("frustum.vdb"), {g}, starMeta());
    expectFailure("nebillum -i frustum.vdb -o out.vdb", 1,
                  "frustum.vdb: grid \"density\" has a non-affine transform");
}

TEST_F(Cli, UnwritableOutputAndMissingTauGrid)
{
    makeLit();
    expectFailure("nebillum -i small.vdb -o no/such/folder/out.vdb", 1, "no/such/folder/out.vdb");
    expectFailure("nebrender -i lit.vdb -o missing/frame.exr", 1, "missing/frame.exr");
    expectFailure("nebrender -i small.vdb -o frame.exr", 1,
                  "no grid \"tau.alpha\" for star \"alpha\"; run nebillum");
    expectFailure("nebrender -i lit.vdb -o frame.jpg", 2,
                  "the name ends in \".jpg\", but this output is EXR; name it *.exr");
    expectFailure("nebrender -i lit.vdb --res 0x10 -o frame.exr", 2, "--res");
    expectFailure("nebrender -i lit.vdb --eye 1,2 -o frame.exr", 2, "--eye");
    expectFailure("nebrender -i lit.vdb --albedo 1.5 -o frame.exr", 2, "albedo");
    expectFailure("nebgen --res 1 -o x.vdb", 2, "--res");
    expectFailure("nebgen --bogus -o x.vdb", 2, "--bogus");
}

TEST_F(Cli, BinaryOutputToATerminalIsRefused)
{
    // script(1) gives the tool a pseudo-terminal as stdout.
    if (std::system("command -v script > /dev/null") != 0) GTEST_FAIL() << "script(1) missing";
    const Result r = run("script -qec 'nebgen --res 8 -o -' /dev/null > tty.txt");
    EXPECT_EQ(r.code, 2);
    std::ifstream in(path("tty.txt"));
    std::stringstream s;
    s << in.rdbuf();
    EXPECT_NE(s.str().find("refusing to write binary data to a terminal"), std::string::npos)
        << s.str();
}
