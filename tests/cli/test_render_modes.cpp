// End-to-end tests of nebrender's other modes: the reference path tracer (--integrator path)
// and global scattering from pyramid levels (--levels), with their bad inputs.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <map>
#include <string>

using namespace nebula::clitest;

namespace {

class RenderModes : public Cli
{
protected:
    /// small.vdb, lit.vdb (makeLit), pyr.vdb (2 levels) and a small phase table t.vdb.
    void makePyramid()
    {
        makeLit();
        ASSERT_EQ(run("nebpyramid -i lit.vdb --levels 2 -o pyr.vdb").code, 0);
        ASSERT_EQ(run("nebphase -i lit.vdb --t-count 8 --mu-bins 16 --photons 1024 "
                      "--max-photons 2048 -o t.vdb")
                      .code,
                  0);
    }
};

} // namespace

TEST_F(RenderModes, PathTracerWritesMeanVarianceAndProvenance)
{
    makeLit();
    const Result r = run("nebrender -i lit.vdb --integrator path --spp 4 --seed 3 --res 16x16 "
                         "-o p.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    std::map<std::string, std::string> attrs;
    const nebula::Image img = nebula::readExr(path("p.exr"), &attrs);
    bool variance = false;
    double sum = 0.0;
    for (const auto& l : img.layers) {
        if (l.name != "variance") continue;
        variance = true;
        for (float v : l.rgb) {
            EXPECT_GE(v, 0.0f);
            sum += v;
        }
    }
    EXPECT_TRUE(variance);
    EXPECT_GT(sum, 0.0); // 4 walks per pixel: noisy
    EXPECT_NE(attrs["nebula:integrator"].find("path tracing (reference), spp 4, seed 3"),
              std::string::npos)
        << attrs["nebula:integrator"];
    // Same seed, same image; another seed, another.
    ASSERT_EQ(run("nebrender -i lit.vdb --integrator path --spp 4 --seed 3 --res 16x16 "
                  "--threads 1 -o q.exr")
                  .code,
              0);
    EXPECT_EQ(nebula::readExr(path("q.exr"), nullptr).rgba, img.rgba);
    ASSERT_EQ(
        run("nebrender -i lit.vdb --integrator path --spp 4 --seed 4 --res 16x16 -o s.exr").code,
        0);
    EXPECT_NE(nebula::readExr(path("s.exr"), nullptr).rgba, img.rgba);
}

TEST_F(RenderModes, LevelsAddLight)
{
    makePyramid();
    ASSERT_EQ(
        run("nebrender -i pyr.vdb --phase t.vdb --levels 0 --res 24x24 --no-stars -o l0.exr").code,
        0);
    const Result r =
        run("nebrender -i pyr.vdb --phase t.vdb --levels 2 --res 24x24 --no-stars -o l2.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    std::map<std::string, std::string> attrs;
    const auto l2 = nebula::readExr(path("l2.exr"), &attrs);
    const auto l0 = nebula::readExr(path("l0.exr"), nullptr);
    double s0 = 0.0, s2 = 0.0;
    for (std::size_t i = 0; i < l0.rgba.size(); i += 4) {
        s0 += l0.rgba[i + 1];
        s2 += l2.rgba[i + 1];
    }
    EXPECT_GT(s2, s0); // coarser voxels scatter more light out (gain > 1)
    EXPECT_NE(attrs["nebula:integrator"].find("levels 2"), std::string::npos);
    ASSERT_EQ(
        run("nebrender -i pyr.vdb --phase t.vdb --phase-use replace --res 24x24 -o r.exr").code, 0);
    // By default, with a table, every level the input has (here 2).
    ASSERT_EQ(run("nebrender -i pyr.vdb --phase t.vdb --res 24x24 --no-stars -o auto.exr").code, 0);
    EXPECT_EQ(nebula::readExr(path("auto.exr"), nullptr).rgba, l2.rgba);
    ASSERT_EQ(run("nebrender -i lit.vdb --phase t.vdb --res 24x24 --no-stars -o none.exr").code, 0);
}

TEST_F(RenderModes, BadCombinationsAndMissingLevels)
{
    makePyramid();
    expectFailure("nebrender -i pyr.vdb --levels 2 -o x.exr", 2, "--levels needs a phase table");
    expectFailure("nebrender -i pyr.vdb --integrator path --phase t.vdb -o x.exr", 2,
                  "--phase is for the fast integrator");
    expectFailure("nebrender -i pyr.vdb --integrator path --levels 1 -o x.exr", 2,
                  "--levels is for the fast integrator");
    expectFailure("nebrender -i pyr.vdb --integrator mc -o x.exr", 2, "--integrator");
    expectFailure("nebrender -i pyr.vdb --spp 0 --integrator path -o x.exr", 2, "--spp");
    expectFailure("nebrender -i lit.vdb --phase t.vdb --levels 1 -o x.exr", 1,
                  "no grid \"density.L1\" for level 1");
    expectFailure("nebrender -i pyr.vdb --phase t.vdb --levels 3 -o x.exr", 1,
                  "no grid \"density.L3\"");
    // A level whose voxels are not twice level 0's.
    {
        nebula::GridSet g = nebula::readGrids(path("pyr.vdb"));
        for (auto& grid : g.grids) {
            const std::string n = grid->getName();
            if (n.size() > 3 && n.compare(n.size() - 3, 3, ".L1") == 0) {
                grid->setTransform(g.find("density")->transform().copy());
            }
        }
        nebula::writeGrids(path("bad.vdb"), g, "test", "test");
    }
    expectFailure("nebrender -i bad.vdb --phase t.vdb --levels 1 -o x.exr", 1,
                  "has voxels that are not 2 times those of \"density\"");
    // A table from before phase.single cannot give the gain.
    {
        nebula::GridSet t = nebula::readGrids(path("t.vdb"));
        t.grids.erase(std::remove_if(t.grids.begin(), t.grids.end(),
                                     [](const auto& p) { return p->getName() == "phase.single"; }),
                      t.grids.end());
        nebula::writeGrids(path("old.vdb"), t, "test", "test");
    }
    expectFailure("nebrender -i pyr.vdb --phase old.vdb -o x.exr", 1, "no single-scattering part");
    ASSERT_EQ(
        run("nebrender -i pyr.vdb --phase old.vdb --phase-use replace --res 8x8 -o ok.exr").code,
        0);
}
