// SPDX-License-Identifier: Apache-2.0
// nebtone end to end: a static camera's sequence gets one curve (identical PNGs), a moving
// one a smooth curve; 16-bit PNGs; the EXRs record nebula:luminance (nebtone takes the
// statistics from the pixels; tests/cli/test_hardening.cpp: a damaged one is only a warning).
#include "cli_fixture.h"

#include "nebula/io/image.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

std::string bytesOf(const std::string& p)
{
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

} // namespace

TEST_F(Cli, NebtoneTonesASequenceWithOneSmoothCurve)
{
    makeLit();
    {
        std::ofstream f(path("still.json"));
        f << R"({"fps": 8, "keyframes": [
            {"time": 0, "eye": [0, 0, -6], "look_at": [0, 0, 0]},
            {"time": 0.5, "eye": [0, 0, -6], "look_at": [0, 0, 0]}]})";
    }
    ASSERT_EQ(run("mkdir s d && nebrender -i lit.vdb --camera-path still.json --res 24x24 "
                  "--no-png -o 's/f.####.exr'")
                  .code,
              0);
    std::map<std::string, std::string> attrs;
    nebula::readExr(path("s/f.0001.exr"), &attrs);
    EXPECT_NE(attrs["nebula:luminance"].find("\"percentile\":99.5"), std::string::npos)
        << attrs["nebula:luminance"];
    Result r = run("nebtone -i 's/f.####.exr' -o 'd/f.####.png' -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("5 frames, window 1 s at 8 fps"), std::string::npos) << r.err;
    // A static camera: the same frames, the same curve, the same pixels.
    int w = 0, h = 0;
    const auto first = pngPixels(path("d/f.0001.png"), &w, &h);
    const auto last = pngPixels(path("d/f.0005.png"), &w, &h);
    ASSERT_EQ(first.size(), std::size_t(24 * 24 * 4));
    EXPECT_EQ(first, last);
    std::size_t lit = 0;
    for (std::size_t i = 0; i < first.size(); i += 4)
        lit += first[i + 1] > 0;
    EXPECT_GT(lit, 10u);
    ASSERT_EQ(run("nebtone -i 's/f.####.exr' --bits 16 --window all -o 'd/g.%04d.png'").code, 0);
    const auto g = bytesOf(path("d/g.0001.png"));
    ASSERT_GT(g.size(), 26u);
    EXPECT_EQ(int(static_cast<unsigned char>(g[24])), 16); // IHDR bit depth
    expectFailure("nebtone -i 's/f.####.exr' -o 'd/nopattern.png'", 2, "frame pattern");
    expectFailure("nebtone -i 'none/f.####.exr' -o 'd/x.####.png'", 1, "none");
    expectFailure("nebtone -i 's/f.####.exr' --window fast -o 'd/x.####.png'", 2, "--window");
}

// nebrender's tone options in nebtone, with their names and meanings: --gamma alone (the
// automatic white point, a fixed gamma; each frame its own curve with --window 0) and
// --exposure with --gamma (a fixed curve) give nebrender's PNG of the same frame, pixel for
// pixel; out-of-range values are refused as nebrender refuses them.
TEST_F(Cli, NebtoneTakesNebrendersToneOptions)
{
    makeLit();
    ASSERT_EQ(run("mkdir s d && nebrender -i lit.vdb --res 24x24 --gamma 0.6 -o s/f.0001.exr && "
                  "nebrender -i lit.vdb --res 24x24 --exposure 3 --gamma 0.7 -o s/e.0001.exr")
                  .code,
              0);
    Result r = run("nebtone -i 's/f.####.exr' --gamma 0.6 --window 0 -o 'd/f.####.png' -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("gamma 0.6"), std::string::npos) << r.err;
    EXPECT_EQ(pngPixels(path("d/f.0001.png")), pngPixels(path("s/f.0001.png")));
    r = run("nebtone -i 's/e.####.exr' --exposure 3 --gamma 0.7 -o 'd/e.####.png' -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("fixed: exposure 3, gamma 0.7"), std::string::npos) << r.err;
    EXPECT_EQ(pngPixels(path("d/e.0001.png")), pngPixels(path("s/e.0001.png")));
    // The automatic gamma differs from 0.6 on this frame, so the test can fail.
    ASSERT_EQ(run("nebtone -i 's/f.####.exr' --window 0 -o 'd/a.####.png'").code, 0);
    EXPECT_NE(pngPixels(path("d/a.0001.png")), pngPixels(path("s/f.0001.png")));
    for (const char* bad : {"--gamma 0", "--gamma -1", "--gamma inf", "--exposure nan"}) {
        r = run(std::string("nebtone -i 's/f.####.exr' ") + bad + " -o 'd/b.####.png'");
        EXPECT_EQ(r.code, 2) << bad;
        EXPECT_NE(r.err.find(std::string(bad).substr(0, 7)), std::string::npos) << r.err;
        EXPECT_FALSE(std::filesystem::exists(path("d/b.0001.png"))) << bad;
    }
}
