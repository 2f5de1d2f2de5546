// SPDX-License-Identifier: Apache-2.0
/// @file colour_compare.cpp
/// CIEDE2000 colour difference between a reference EXR and test EXRs of the same view.
///
///     build/bench/colour_compare REF.exr TEST.exr [TEST2.exr ...]
///
/// Both images are nebrender's linear sRGB (R,G,B; negative values allowed). Each pixel is
/// converted to CIE XYZ and then to CIE L*a*b* relative to a white of the D65 chromaticity
/// whose luminance Y is the reference's 99.5th-percentile pixel luminance (the PNG's white
/// point), so that Delta E 2000 measures what a viewer of the tone-mapped picture sees.
/// Pixels whose reference Y is below 1e-3 of that white are left out (black sky).
/// Prints one line per test image: mean, 99th percentile and maximum Delta E 2000 over the
/// pixels counted, and the fraction of them above 1. Exit 1 on unreadable or mismatched images.

#include "nebula/core/error.h"
#include "nebula/io/image.h"
#include "nebula/physics/colour.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

int main(int argc, char** argv)
{
    if (argc < 3) {
        std::fprintf(stderr, "usage: colour_compare REF.exr TEST.exr [TEST2.exr ...]\n");
        return 1;
    }
    try {
        const nebula::Image ref = nebula::readExr(argv[1], nullptr);
        const std::size_t n = std::size_t(ref.width) * ref.height;
        std::vector<nebula::XYZ> refXYZ(n);
        std::vector<double> Ys;
        for (std::size_t i = 0; i < n; ++i) {
            refXYZ[i] = nebula::linearSRGBToXYZ(
                {ref.rgba[i * 4], ref.rgba[i * 4 + 1], ref.rgba[i * 4 + 2]});
            if (refXYZ[i][1] > 0.0) Ys.push_back(refXYZ[i][1]);
        }
        if (Ys.empty()) throw nebula::Error(std::string(argv[1]) + ": black image");
        std::sort(Ys.begin(), Ys.end());
        const double Yw = Ys[std::min(Ys.size() - 1, std::size_t(0.995 * double(Ys.size())))];
        const nebula::XYZ white = nebula::linearSRGBToXYZ({Yw, Yw, Yw});
        std::printf("# white Y %.6g; columns: file mean_dE p99_dE max_dE frac_above_1 pixels\n",
                    Yw);
        for (int a = 2; a < argc; ++a) {
            const nebula::Image test = nebula::readExr(argv[a], nullptr);
            if (test.width != ref.width || test.height != ref.height) {
                throw nebula::Error(std::string(argv[a]) + ": size differs from the reference");
            }
            std::vector<double> dE;
            for (std::size_t i = 0; i < n; ++i) {
                if (!(refXYZ[i][1] > 1e-3 * Yw)) continue;
                const auto t = nebula::linearSRGBToXYZ(
                    {test.rgba[i * 4], test.rgba[i * 4 + 1], test.rgba[i * 4 + 2]});
                dE.push_back(nebula::deltaE2000(nebula::xyzToLab(refXYZ[i], white),
                                                nebula::xyzToLab(t, white)));
            }
            if (dE.empty()) throw nebula::Error("no pixel above the threshold");
            double mean = 0.0, above = 0.0;
            for (double d : dE) {
                mean += d;
                above += d > 1.0;
            }
            std::sort(dE.begin(), dE.end());
            std::printf("%s %.4f %.4f %.4f %.5f %zu\n", argv[a], mean / double(dE.size()),
                        dE[std::min(dE.size() - 1, std::size_t(0.99 * double(dE.size())))],
                        dE.back(), above / double(dE.size()), dE.size());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "colour_compare: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
