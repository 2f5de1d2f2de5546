// SPDX-License-Identifier: Apache-2.0
// End-to-end tests of nebrender's other modes: the reference path tracer (--integrator path)
// and global scattering from pyramid levels (--levels), with their bad inputs.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
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
                  "--phase is for --integrator fast (here: --integrator path)");
    expectFailure("nebrender -i pyr.vdb --integrator path --levels 1 -o x.exr", 2,
                  "--levels is for --integrator fast (here: --integrator path)");
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

// --frame-nebula end to end (issue 47): the column density's image (-ln of the
// transmittance layer) has its centroid in the central 10 % of a perspective view from a
// given eye far off to the side (far: the image's centroid of the column is the projected
// centroid of the mass only where the perspective is nearly parallel), and on the sweet spot of a
// 30-degree dome (5/9 of the radius below the centre); -v says the camera chosen; --look-at,
// --camera-path and a density grid without dust are refused.
TEST_F(RenderModes, FrameNebulaAimsEveryCameraAtTheDust)
{
    makeLit();
    const auto columnCentroid = [&](const std::string& exr, double& cx, double& cy) {
        const nebula::Image img = nebula::readExr(path(exr), nullptr);
        const std::vector<float>& t = img.rgb("transmittance");
        double sum = 0, sx = 0, sy = 0;
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x) {
                const float g = t[(std::size_t(y) * img.width + x) * 3 + 1];
                const double column = g > 0.0f ? -std::log(double(g)) : 0.0;
                sum += column;
                sx += column * (x + 0.5);
                sy += column * (y + 0.5);
            }
        ASSERT_GT(sum, 0.0) << exr;
        cx = sx / sum / img.width;
        cy = sy / sum / img.height;
    };
    Result r = run("nebrender -i lit.vdb --frame-nebula --eye 30,12,-6 --res 32x32 -v "
                   "-o side.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("--frame-nebula: the dust of \"density\": centroid"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("(given)"), std::string::npos) << r.err;
    double cx = 0, cy = 0;
    columnCentroid("side.exr", cx, cy);
    EXPECT_NEAR(cx, 0.5, 0.05);
    EXPECT_NEAR(cy, 0.5, 0.05);
    r = run("nebrender -i lit.vdb --camera fisheye --dome-tilt 30 --frame-nebula --res 36x36 "
            "-o dome.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    columnCentroid("dome.exr", cx, cy);
    EXPECT_NEAR(cx, 0.5, 0.05);
    EXPECT_NEAR(cy, 0.5 + 0.5 * 5.0 / 9.0, 0.05);
    expectFailure("nebrender -i lit.vdb --frame-nebula --look-at 0,0,0 -o bad.exr", 2,
                  "--frame-nebula chooses --look-at itself");
    {
        std::ofstream f(path("p.json"));
        f << R"({"fps": 4, "keyframes": [{"time": 0, "eye": [0,0,-9]}, {"time": 1, "eye": [1,0,-9]}]})";
    }
    expectFailure("nebrender -i lit.vdb --frame-nebula --camera-path p.json --frame 1 -o bad.exr",
                  2, "--frame-nebula frames one view");
    ASSERT_EQ(run("nebgen --res 8 --density 0 -o empty.vdb").code, 0);
    expectFailure("nebrender -i empty.vdb --frame-nebula -o bad.exr", 2,
                  "the density grid \"density\" of empty.vdb holds no dust");
}

// --camera fisheye and equirect end to end: the dome master's corners are black and
// transparent (EXR alpha 0, PNG alpha 0), the panorama is 2:1 by default, the EXR records
// the projection; shapes and options that do not fit the model are refused.
TEST_F(RenderModes, DomeAndPanoramaCameras)
{
    makeLit();
    Result r = run("nebrender -i lit.vdb --camera fisheye --dome-tilt 20 --eye 0,0,-1 "
                   "--res 32x32 -o dome.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    std::map<std::string, std::string> attrs;
    const nebula::Image dome = nebula::readExr(path("dome.exr"), &attrs);
    ASSERT_EQ(dome.width, 32);
    for (int c = 0; c < 4; ++c)
        EXPECT_EQ(dome.rgba[std::size_t(c)], 0.0f);
    EXPECT_GT(dome.rgba[(16 * 32 + 16) * 4 + 1], 0.0f);
    EXPECT_NE(attrs["nebula:camera"].find("\"projection\":\"fisheye\""), std::string::npos)
        << attrs["nebula:camera"];
    EXPECT_NE(attrs["nebula:camera"].find("\"dome_tilt_deg\":20"), std::string::npos)
        << attrs["nebula:camera"];
    EXPECT_NE(attrs["nebula:camera"].find("\"fov_deg\":180"), std::string::npos)
        << attrs["nebula:camera"];
    // The default size (1024x512) with long steps: the size is checked, not the picture.
    ASSERT_EQ(
        run("nebrender -i lit.vdb --camera equirect --eye 0,0,-1 --step 4 --no-png -o pano.exr")
            .code,
        0);
    const nebula::Image pano = nebula::readExr(path("pano.exr"), nullptr);
    EXPECT_EQ(pano.width, 1024);
    EXPECT_EQ(pano.height, 512);
    ASSERT_EQ(run("nebrender -i lit.vdb --camera equirect --integrator path --spp 2 --res 16x8 "
                  "--eye 0,0,-1 -o pano-path.exr")
                  .code,
              0);
    expectFailure("nebrender -i lit.vdb --camera fisheye --res 32x16 -o bad.exr", 2,
                  "must be square");
    expectFailure("nebrender -i lit.vdb --camera equirect --res 32x32 -o bad.exr", 2,
                  "twice as wide as high");
    expectFailure("nebrender -i lit.vdb --dome-tilt 10 -o bad.exr", 2,
                  "--dome-tilt is for --camera fisheye");
    expectFailure("nebrender -i lit.vdb --fov 200 -o bad.exr", 2, "(0, 179]");
    expectFailure("nebrender -i lit.vdb --camera cube -o bad.exr", 2, "--camera");
}

// The stereo fisheye end to end: --camera fisheye --stereo renders two dome masters, the left
// eye's on top (W x 2W by default from the width), each with its circle; --stereo with a
// camera that has no stereo form, and a stereo camera without --ipd, are refused.
TEST_F(RenderModes, StereoFisheyeDomeMaster)
{
    makeLit();
    const Result r = run("nebrender -i lit.vdb --camera fisheye --stereo --ipd 0.05 "
                         "--dome-tilt 20 --eye 0,0,-1 --res 32x64 --step 2 -o dome3d.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    const nebula::Image img = nebula::readExr(path("dome3d.exr"), nullptr);
    EXPECT_EQ(img.width, 32);
    EXPECT_EQ(img.height, 64);
    const auto alpha = [&](int x, int y) { return img.rgba[(std::size_t(y) * 32 + x) * 4 + 3]; };
    EXPECT_EQ(alpha(0, 0), 0.0f);   // the left eye's corner: outside its circle
    EXPECT_EQ(alpha(0, 32), 0.0f);  // the right eye's
    EXPECT_GT(alpha(16, 16), 0.0f); // the nebula in each eye's circle
    EXPECT_GT(alpha(16, 48), 0.0f);
    expectFailure("nebrender -i lit.vdb --camera perspective --stereo -o f.exr", 2,
                  "--stereo: --camera perspective has no stereo form");
    expectFailure("nebrender -i lit.vdb --camera fisheye --stereo --res 32x64 -o f.exr", 2,
                  "--camera fisheye-stereo needs --ipd");
    expectFailure("nebrender -i lit.vdb --camera fisheye --stereo --ipd 0.05 --res 32x32 -o f.exr",
                  2, "must be twice as high as wide, e.g. 32x64");
    EXPECT_FALSE(fs::exists(path("f.exr")));
}

// One mechanism refuses an option that the chosen camera, integrator or mode does not use,
// naming the option and what it is for: a camera model's parameter (the registry's rows), an
// integrator's option, a --spectral option.
TEST_F(RenderModes, OptionOfAnotherModeIsRefused)
{
    makeLit();
    expectFailure("nebrender -i lit.vdb --camera equirect --pixel-size 0.1 -o f.exr", 2,
                  "--pixel-size is for --camera orthographic (--camera is equirect)");
    expectFailure("nebrender -i lit.vdb --pole-merge 50,70 -o f.exr", 2,
                  "--pole-merge is for --camera ods or fisheye-stereo (--camera is perspective)");
    expectFailure("nebrender -i lit.vdb --spp 16 -o f.exr", 2,
                  "--spp is for --integrator path (here: --integrator fast)");
    expectFailure("nebrender -i lit.vdb --seed 3 -o f.exr", 2,
                  "--seed is for --integrator path (here: --integrator fast)");
    expectFailure("nebrender -i lit.vdb --line-width 20 -o f.exr", 2,
                  "--line-width is for --spectral (here: --integrator fast)");
    EXPECT_FALSE(fs::exists(path("f.exr")));
}

// --camera-path: many frames in one process with a frame pattern, one frame per process
// (the same pixels), the frame and time recorded, --skip-existing resuming a batch, and the
// mistakes a batch script makes refused before anything renders.
TEST_F(RenderModes, CameraPathFramesAndResume)
{
    makeLit();
    {
        std::ofstream f(path("flight.json"));
        f << R"({"fps": 4, "keyframes": [
            {"time": 0, "eye": [0, 0, -6], "look_at": [0, 0, 0], "fov": 40},
            {"time": 0.5, "eye": [2, 1, -3], "look_at": [0, 0, 0]},
            {"time": 1, "eye": [3, 0, 0], "look_at": [0, 0, 0], "fov": 60}]})";
    }
    const std::string common = "nebrender -i lit.vdb --camera-path flight.json --res 16x16 ";
    Result r = run(common + "--frames 1-5:2 -o 'f.####.exr' -v");
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* name : {"f.0001.exr", "f.0001.png", "f.0003.exr", "f.0005.png"})
        EXPECT_TRUE(fs::exists(path(name))) << name;
    EXPECT_FALSE(fs::exists(path("f.0002.exr")));
    std::map<std::string, std::string> attrs;
    const nebula::Image third = nebula::readExr(path("f.0003.exr"), &attrs);
    EXPECT_NE(attrs["nebula:frame"].find("\"frame\":3"), std::string::npos)
        << attrs["nebula:frame"];
    EXPECT_NE(attrs["nebula:frame"].find("\"time_s\":0.5"), std::string::npos)
        << attrs["nebula:frame"];
    EXPECT_NE(attrs["nebula:camera"].find("\"eye\":[2.0,1.0,-3.0]"), std::string::npos)
        << attrs["nebula:camera"];
    // One frame per process gives the same pixels as the batch.
    ASSERT_EQ(run(common + "--frame 3 -o single.exr").code, 0);
    EXPECT_EQ(nebula::readExr(path("single.exr"), nullptr).rgba, third.rgba);
    // --skip-existing: frames already there are skipped; a missing one is rendered.
    const auto before = fs::last_write_time(path("f.0001.exr"));
    fs::remove(path("f.0003.exr"));
    r = run(common + "--frames 1-5:2 --skip-existing -o 'f.%04d.exr' -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("frame 1: f.0001.exr exists, skipped"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("2 of 3 frames existed"), std::string::npos) << r.err;
    EXPECT_EQ(fs::last_write_time(path("f.0001.exr")), before);
    EXPECT_EQ(nebula::readExr(path("f.0003.exr"), nullptr).rgba, third.rgba);
    // All frames by default: 0..1 s at 4 fps is 5 frames.
    ASSERT_EQ(run("mkdir all && " + common + "--no-png -o 'all/a.##.exr'").code, 0);
    EXPECT_TRUE(fs::exists(path("all/a.05.exr")));
    EXPECT_FALSE(fs::exists(path("all/a.06.exr")));
    expectFailure(common + "--frames 1-3 -o nopattern.exr", 2, "need a frame pattern");
    expectFailure(common + "--frames 4-9 -o 'x.####.exr'", 2,
                  "frame 6 is beyond the end of flight.json, which has 5 frames at 4 fps");
    expectFailure("nebrender -i lit.vdb --frame 2 -o x.exr", 2, "need a --camera-path");
    expectFailure(common + "--frames 3-1 -o 'x.####.exr'", 2, "--frames \"3-1\"");
    {
        std::ofstream f(path("bad.json"));
        f << R"({"fps": 4, "keyframes": [{"time": 0, "eye": [0, 0, 0], "look_at": [0, 0, 0]}]})";
    }
    expectFailure("nebrender -i lit.vdb --camera-path bad.json -o 'x.####.exr'", 1,
                  "bad.json: keyframe 1: --eye and --look-at must differ");
    expectFailure("nebrender -i lit.vdb --camera-path flight.json -o flight.json", 2,
                  "flight.json");
}
