// SPDX-License-Identifier: Apache-2.0
/// @file exr_compare.cpp
/// Compares two nebrender EXRs of the same view: a reference and a test image.
///
///     build/bench/exr_compare REF.exr TEST.exr [--ratio-png FILE] [--threshold 0.01] [--block N]
///                              [--percentile P] [--max] [--chromaticity]
///                              [--second-reference REF2.exr]
///
/// Prints, per channel R, G, B and for luminance Y (Rec. 709 weights of linear sRGB):
///  - flux: the sum over pixels of TEST / the sum of REF, minus 1 (relative error of the
///    total flux, the pixels having equal solid angle to first order);
///  - rms: the relative RMS error sqrt(mean((TEST - REF)^2 / REF^2)) over the pixels where
///    REF is above --threshold (default 1 %) of its maximum in that channel;
///  - if REF has a "variance" layer (nebrender --integrator path: squared standard error of
///    each pixel), ref_noise = sqrt(mean(variance / REF^2)) over the same pixels, REF's own
///    relative noise (luminance: its "variance.Y" channel where it has one, else the channels'
///    variances taken as independent), and rms_corrected = sqrt(max(0, rms^2 - ref_noise^2)), the
///    RMS error with REF's noise taken out (the noise is independent of TEST's error).
/// --second-reference REF2.exr, another reference of the same view with independent noise
/// (another seed), adds rms_two_refs = sqrt(max(0, mean((TEST - REF)(TEST - REF2) / TEST^2)))
/// over the pixels where M = (REF + REF2) / 2 is above the threshold: the two references'
/// noises are independent of each other and of TEST, so the product's mean is the squared
/// error of TEST alone, with no estimate of the noise in it (the variance layer's estimate is
/// itself noisy where a pixel's walks are few or long). It is relative to TEST, not to the
/// references (dividing by M would correlate with M's noise).
/// --block N first sums both images (and the variance) over blocks of N x N pixels (the
/// right and bottom edges' partial blocks are dropped), so the figures are per block: the
/// error of the image smoothed on that scale, with N times less noise.
/// --percentile P takes the threshold as a fraction of REF's P-th percentile (of its non-zero
/// pixels or blocks) instead of its maximum (a star's sprite is the maximum of most frames);
/// --max adds the largest relative error among the pixels or blocks counted.
/// --chromaticity prints, instead of the table, the colour noise between two frames of the same
/// view (two seeds of nebscatter's field): the RMS difference of the chromaticities
/// r = R/(R+G+B) and b = B/(R+G+B) over the faint cloud (REF's S = R+G+B between 0.3 % and
/// 3 % of its 99.9th percentile) and over the bright cloud (above 3 %), in per cent: absolute
/// (100 x the difference of r or b) and relative (the difference over r or b).
/// Also prints the optical depth -ln T of REF's centre pixel (its transmittance layer).
/// --ratio-png writes a map of TEST_Y / REF_Y: white where equal, red where TEST is brighter,
/// blue where it is darker, full colour at a factor of 2 (log scale); black where REF_Y is
/// below the threshold. Exit 1 with a message on unreadable or mismatched images.

#include "nebula/core/error.h"
#include "nebula/io/image.h"
#include "nebula/physics/colour.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

double luminance(const float* p)
{
    return nebula::linearSRGBLuminance(p[0], p[1], p[2]);
}

/// Channel value of pixel @p i: c = 0..2 for R, G, B, 3 for luminance.
double channel(const nebula::Image& img, std::size_t i, int c)
{
    const float* p = &img.rgba[i * 4];
    return c < 3 ? p[c] : luminance(p);
}

/// @p img summed over blocks of @p b x @p b pixels: the beauty, the "variance" layer and the
/// "variance.Y" channel (if any); the transmittance layer keeps the block's centre pixel.
nebula::Image blockSums(const nebula::Image& img, int b)
{
    const int w = img.width / b, h = img.height / b;
    nebula::Image out(w, h);
    // Adds plane @p src (@p k floats per pixel) into @p dst, block by block; with @p centre,
    // copies each block's centre pixel instead.
    const auto reduce = [&](const std::vector<float>& src, std::vector<float>& dst, int k,
                            bool centre) {
        dst.assign(std::size_t(w) * h * k, 0.0f);
        for (int y = 0; y < h * b; ++y)
            for (int x = 0; x < w * b; ++x) {
                if (centre && (y % b != b / 2 || x % b != b / 2)) continue;
                const std::size_t i = (std::size_t(y) * img.width + x) * k;
                const std::size_t o = (std::size_t(y / b) * w + x / b) * k;
                for (int c = 0; c < k; ++c)
                    dst[o + c] += src[i + c];
            }
    };
    reduce(img.rgba, out.rgba, 4, false);
    for (const auto& l : img.layers) {
        if (l.name != "variance" && l.name != "transmittance") continue;
        out.layers.push_back({l.name, {}});
        reduce(l.rgb, out.layers.back().rgb, 3, l.name == "transmittance");
    }
    for (const auto& ch : img.channels) {
        if (ch.name != "variance.Y") continue;
        out.channels.push_back({ch.name, {}});
        reduce(ch.values, out.channels.back().values, 1, false);
    }
    return out;
}

} // namespace

int main(int argc, char** argv)
{
    std::string refPath, testPath, ratioPng, ref2Path;
    double threshold = 0.01, percentile = 100.0;
    bool showMax = false, chroma = false;
    int block = 1;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--ratio-png" && i + 1 < argc) {
            ratioPng = argv[++i];
        } else if (a == "--second-reference" && i + 1 < argc) {
            ref2Path = argv[++i];
        } else if (a == "--block" && i + 1 < argc) {
            block = std::atoi(argv[++i]);
        } else if (a == "--percentile" && i + 1 < argc) {
            percentile = std::atof(argv[++i]);
        } else if (a == "--max") {
            showMax = true;
        } else if (a == "--chromaticity") {
            chroma = true;
        } else if (a == "--threshold" && i + 1 < argc) {
            threshold = std::atof(argv[++i]);
        } else if (refPath.empty()) {
            refPath = a;
        } else if (testPath.empty()) {
            testPath = a;
        } else {
            std::fprintf(stderr,
                         "usage: exr_compare REF.exr TEST.exr [--ratio-png FILE] [--threshold F] "
                         "[--block N] [--second-reference REF2.exr]\n");
            return 2;
        }
    }
    if (testPath.empty() || !(threshold > 0.0 && threshold < 1.0) || block < 1) {
        std::fprintf(stderr, "usage: exr_compare REF.exr TEST.exr [--ratio-png FILE] "
                             "[--threshold F in (0,1)] [--block N >= 1] "
                             "[--second-reference REF2.exr]\n");
        return 2;
    }
    try {
        nebula::Image ref = nebula::readExr(refPath, nullptr);
        nebula::Image test = nebula::readExr(testPath, nullptr);
        if (ref.width != test.width || ref.height != test.height) {
            throw nebula::Error(testPath + ": " + std::to_string(test.width) + "x" +
                                std::to_string(test.height) + " pixels, but " + refPath + " has " +
                                std::to_string(ref.width) + "x" + std::to_string(ref.height));
        }
        if (block > std::min(ref.width, ref.height)) {
            throw nebula::Error("--block " + std::to_string(block) + " is larger than the " +
                                std::to_string(ref.width) + "x" + std::to_string(ref.height) +
                                " image");
        }
        nebula::Image ref2;
        if (!ref2Path.empty()) {
            ref2 = nebula::readExr(ref2Path, nullptr);
            if (ref2.width != ref.width || ref2.height != ref.height) {
                throw nebula::Error(ref2Path + ": " + std::to_string(ref2.width) + "x" +
                                    std::to_string(ref2.height) + " pixels, but " + refPath +
                                    " has " + std::to_string(ref.width) + "x" +
                                    std::to_string(ref.height));
            }
        }
        if (block > 1) {
            ref = blockSums(ref, block);
            test = blockSums(test, block);
            if (!ref2Path.empty()) ref2 = blockSums(ref2, block);
        }
        const std::size_t n = std::size_t(ref.width) * ref.height;
        if (chroma) {
            std::vector<double> sums;
            for (std::size_t i = 0; i < n; ++i) {
                const float* p = &ref.rgba[i * 4];
                if (p[0] + p[1] + p[2] > 0.0f) sums.push_back(double(p[0]) + p[1] + p[2]);
            }
            if (sums.empty()) throw nebula::Error(refPath + ": a black frame");
            const auto k = std::size_t(0.999 * double(sums.size() - 1));
            std::nth_element(sums.begin(), sums.begin() + std::ptrdiff_t(k), sums.end());
            const double top = sums[k];
            // [0]: faint (0.3 % to 3 % of top), [1]: bright (above 3 %).
            double abs2[2] = {0, 0}, rel2[2] = {0, 0};
            std::size_t count[2] = {0, 0};
            for (std::size_t i = 0; i < n; ++i) {
                const float* a = &ref.rgba[i * 4];
                const float* b = &test.rgba[i * 4];
                const double sa = double(a[0]) + a[1] + a[2], sb = double(b[0]) + b[1] + b[2];
                if (!(sa > 0.003 * top) || !(sb > 0.0)) continue;
                const int which = sa > 0.03 * top ? 1 : 0;
                for (int c : {0, 2}) {
                    const double ca = a[c] / sa, cb = b[c] / sb;
                    abs2[which] += (cb - ca) * (cb - ca);
                    if (ca > 0.0) rel2[which] += (cb - ca) * (cb - ca) / (ca * ca);
                }
                ++count[which];
            }
            const char* what[2] = {"faint (0.3-3 % of p99.9)", "bright (> 3 % of p99.9)"};
            std::printf(
                "region                     pixels  chroma_rms_abs_%%  chroma_rms_rel_%%\n");
            for (int w = 0; w < 2; ++w) {
                const double m = 2.0 * double(std::max<std::size_t>(count[w], 1));
                std::printf("%-26s %-7zu %15.4f  %15.4f\n", what[w], count[w],
                            100.0 * std::sqrt(abs2[w] / m), 100.0 * std::sqrt(rel2[w] / m));
            }
            return 0;
        }
        const char* names[4] = {"R", "G", "B", "Y"};
        const nebula::ImageLayer* variance = nullptr;
        for (const auto& l : ref.layers) {
            if (l.name == "variance") variance = &l;
        }
        const std::vector<float>* varianceY = nullptr;
        for (const auto& ch : ref.channels) {
            if (ch.name == "variance.Y") varianceY = &ch.values;
        }
        std::printf("channel  flux_ref      flux_test     flux_error  rms_error  pixels  ref_noise "
                    " rms_corrected%s\n",
                    ref2Path.empty() ? "" : "  rms_two_refs");
        for (int c = 0; c < 4; ++c) {
            double sumRef = 0.0, sumTest = 0.0, maxRef = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                sumRef += channel(ref, i, c);
                sumTest += channel(test, i, c);
                maxRef = std::max(maxRef, channel(ref, i, c));
            }
            if (percentile < 100.0) { // the threshold's scale: a percentile, not the maximum
                std::vector<double> v;
                for (std::size_t i = 0; i < n; ++i)
                    if (channel(ref, i, c) > 0.0) v.push_back(channel(ref, i, c));
                if (!v.empty()) {
                    const auto k = std::size_t(percentile / 100.0 * double(v.size() - 1));
                    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
                    maxRef = v[k];
                }
            }
            double sq = 0.0, noise = 0.0, worst = 0.0;
            std::size_t count = 0;
            for (std::size_t i = 0; i < n; ++i) {
                const double r = channel(ref, i, c);
                if (r <= threshold * maxRef) continue;
                const double d = (channel(test, i, c) - r) / r;
                sq += d * d;
                worst = std::max(worst, std::abs(d));
                if (variance) {
                    const float* v = &variance->rgb[i * 3];
                    // Luminance: its own variance where REF has it (the channels' noise is
                    // correlated, one walk carrying all three); else taken as independent.
                    const double var = c < 3       ? v[c]
                                       : varianceY ? (*varianceY)[i]
                                                   : nebula::independentLuminanceVariance(v);
                    noise += var / (r * r);
                }
                ++count;
            }
            const double rms = count ? std::sqrt(sq / double(count)) : 0.0;
            std::printf("%-8s %-13.6g %-13.6g %+10.4f  %9.4f  %-6zu", names[c], sumRef, sumTest,
                        sumTest / sumRef - 1.0, rms, count);
            if (showMax) std::printf("  max %.5f", worst);
            if (variance && count) {
                const double rn = std::sqrt(noise / double(count));
                std::printf("  %9.4f  %13.4f", rn, std::sqrt(std::max(0.0, rms * rms - rn * rn)));
            } else if (!ref2Path.empty()) {
                std::printf("  %9s  %13s", "-", "-");
            }
            if (!ref2Path.empty()) {
                double maxM = 0.0;
                for (std::size_t i = 0; i < n; ++i)
                    maxM = std::max(maxM, 0.5 * (channel(ref, i, c) + channel(ref2, i, c)));
                double cross = 0.0;
                std::size_t m = 0;
                for (std::size_t i = 0; i < n; ++i) {
                    const double a = channel(ref, i, c), b = channel(ref2, i, c);
                    const double mean = 0.5 * (a + b), t = channel(test, i, c);
                    if (mean <= threshold * maxM) continue;
                    // Relative to TEST, which is independent of both references' noise
                    // (over their mean M the product would correlate with M's noise).
                    if (!(t > 0.0)) continue;
                    cross += (t - a) * (t - b) / (t * t);
                    ++m;
                }
                std::printf("  %12.4f", m ? std::sqrt(std::max(0.0, cross / double(m))) : 0.0);
            }
            std::printf("\n");
        }
        for (const auto& l : ref.layers) {
            if (l.name != "transmittance") continue;
            const std::size_t c = std::size_t(ref.height / 2) * ref.width + ref.width / 2;
            std::printf("centre pixel optical depth of REF (-ln T, R G B): %.4g %.4g %.4g\n",
                        -std::log(l.rgb[c * 3]), -std::log(l.rgb[c * 3 + 1]),
                        -std::log(l.rgb[c * 3 + 2]));
        }
        if (!ratioPng.empty()) {
            double maxY = 0.0;
            for (std::size_t i = 0; i < n; ++i)
                maxY = std::max(maxY, channel(ref, i, 3));
            nebula::Image map(ref.width, ref.height);
            for (std::size_t i = 0; i < n; ++i) {
                const double r = channel(ref, i, 3);
                float* p = &map.rgba[i * 4];
                p[3] = 1.0f;
                if (r <= threshold * maxY) continue; // black
                const double x = std::clamp(std::log2(channel(test, i, 3) / r), -1.0, 1.0);
                // Diverging map: white at 0, red (1, 0.1, 0.05) at +1, blue (0.05, 0.2, 1) at -1.
                const double hi[3] = {1.0, 0.1, 0.05}, lo[3] = {0.05, 0.2, 1.0};
                const double* end = x > 0 ? hi : lo;
                const double t = std::abs(x);
                for (int c = 0; c < 3; ++c)
                    p[c] = float((1.0 - t) * 0.8 + t * end[c]);
            }
            nebula::writePng(ratioPng, map, nebula::ToneCurve{1.0, 1.0},
                             {{"Comment", "TEST_Y / REF_Y: " + testPath + " / " + refPath}});
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "exr_compare: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
