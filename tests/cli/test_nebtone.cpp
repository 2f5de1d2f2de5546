// SPDX-License-Identifier: Apache-2.0
// nebtone end to end: a static camera's sequence gets one curve (identical PNGs), a moving
// one a smooth curve; 16-bit PNGs; the EXRs record nebula:luminance (nebtone takes the
// statistics from the pixels; tests/cli/test_hardening.cpp: a damaged one is only a warning).
#include "cli_fixture.h"

#include "nebula/io/image.h"

#include <gtest/gtest.h>

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
