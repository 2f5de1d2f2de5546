// SPDX-License-Identifier: Apache-2.0
// A program of one's own on an installed libnebula (find_package(nebula) or pkg-config): it
// renders a lit nebula with nebrender's defaults and compares the image with nebrender's EXR.
#include <nebula/io/grid_io.h>
#include <nebula/io/image.h>
#include <nebula/render/fast.h>
#include <nebula/stages/scene_assembly.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>

int main(int argc, char** argv)
{
    if (argc != 3) return std::fprintf(stderr, "usage: downstream LIT.vdb NEBRENDER.exr\n"), 2;
    try {
        const nebula::GridSet grids = nebula::readGrids(argv[1]);
        const nebula::RenderOptions opts; // nebrender's defaults
        const nebula::Image mine =
            nebula::renderFrame(nebula::buildScene(grids, opts, grids.dust()), opts);
        const nebula::Image theirs = nebula::readExr(argv[2], nullptr);
        if (mine.rgba.size() != theirs.rgba.size()) return std::puts("sizes differ"), 1;
        double worst = 0.0, peak = 0.0;
        for (std::size_t i = 0; i < mine.rgba.size(); ++i) {
            worst = std::max(worst, double(std::fabs(mine.rgba[i] - theirs.rgba[i])));
            peak = std::max(peak, double(std::fabs(theirs.rgba[i])));
        }
        std::printf("%dx%d: largest difference %g, peak %g\n", mine.width, mine.height, worst,
                    peak);
        return peak > 0.0 && worst <= 1e-6 * peak ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "downstream: %s\n", e.what());
        return 1;
    }
}
