// SPDX-License-Identifier: Apache-2.0
// nebscatter's noise filter (render/scatter_filter.h, DESIGN §5b "Noise filter"): a local
// Wiener filter towards a plane fitted to each cell's neighbourhood, driven by the cells' own
// noise estimate. Checked on smooth
// analytic fields plus noise of a known size: the error falls, the colour noise falls, the
// bias on the noise-free field stays within the box mean's closed-form bound, an edge the
// noise cannot explain is kept, and inactive cells are neither read nor written.
#include "scatter_filter.h"

#include "nebula/core/rng.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <vector>

using namespace nebula;
using namespace nebula::detail;

namespace {

constexpr int N = 32; // cells per side
constexpr double TWO_PI = 6.283185307179586;

/// A standard normal deviate (Box-Muller) from @p rng.
double gaussian(Pcg32& rng)
{
    const double u = 1.0 - rng.uniformDouble(), v = rng.uniformDouble();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(TWO_PI * v);
}

/// A field of N^3 cells from @p lo with 3 channels: channel c of cell (i, j, k) is
/// @p f(i, j, k, c); the noise channel is 1.
SparseVolume makeField(const std::array<int, 3>& lo,
                       const std::function<double(int, int, int, int)>& f)
{
    SparseVolume v(lo, {N, N, N}, 3);
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                float* p = v.writable(v.index(i + lo[0], j + lo[1], k + lo[2]));
                for (int c = 0; c < 3; ++c)
                    p[c] = float(f(i, j, k, c));
            }
    return v;
}

double value(const SparseVolume& v, const std::array<int, 3>& lo, int i, int j, int k, int c)
{
    return v.voxel(v.index(i + lo[0], j + lo[1], k + lo[2]))[c];
}

/// A smooth, coloured field: a sinusoid of wavelength N cells on a constant, channels in
/// the ratios 1 : 0.8 : 0.6.
double smooth(int i, int j, int k, int c)
{
    const double colour[3] = {1.0, 0.8, 0.6};
    return colour[c] * (2.0 + std::sin(TWO_PI * i / N) * std::cos(TWO_PI * j / N) +
                        0.5 * std::sin(TWO_PI * k / N));
}

} // namespace

TEST(ScatterFilter, NoiseFallsAndColourNoiseFallsWithIt)
{
    const std::array<int, 3> lo = {-4, 0, 7};
    const double rel = 0.1; // each channel's own relative noise: independent, so colour noise
    Pcg32 rng(3, 11);
    // A gradient across the box too: the plane takes it out of the spread.
    SparseVolume noisy = makeField(lo, [&](int i, int j, int k, int c) {
        return smooth(i, j, k, c) * (1.0 + 0.05 * (i + 2 * j)) * (1.0 + rel * gaussian(rng));
    });
    const SparseVolume before = noisy;
    const std::vector<float> relError(std::size_t(N) * N * N, float(rel));
    const DenoiseReport r = denoiseField(noisy, lo, {N, N, N}, relError, 1, 1);
    EXPECT_EQ(r.cells, std::size_t(N) * N * N);
    EXPECT_GT(r.meanWeight, 0.5); // mostly noise at this scale: mostly averaged
    // The error of J and of the chromaticity R / (R + G + B), before and after, over the
    // inner cells (the faces' neighbourhoods are one-sided).
    double e0 = 0.0, e1 = 0.0, c0 = 0.0, c1 = 0.0;
    int n = 0;
    for (int k = 1; k < N - 1; ++k)
        for (int j = 1; j < N - 1; ++j)
            for (int i = 1; i < N - 1; ++i) {
                const double t = smooth(i, j, k, 1) * (1.0 + 0.05 * (i + 2 * j));
                const double a = value(before, lo, i, j, k, 1), b = value(noisy, lo, i, j, k, 1);
                e0 += (a - t) * (a - t) / (t * t);
                e1 += (b - t) * (b - t) / (t * t);
                const auto chroma = [&](const SparseVolume& v) {
                    const double s = value(v, lo, i, j, k, 0) + value(v, lo, i, j, k, 1) +
                                     value(v, lo, i, j, k, 2);
                    return value(v, lo, i, j, k, 0) / s;
                };
                const double truth = 1.0 / 2.4;
                c0 += std::pow(chroma(before) - truth, 2);
                c1 += std::pow(chroma(noisy) - truth, 2);
                ++n;
            }
    const double err0 = std::sqrt(e0 / n), err1 = std::sqrt(e1 / n);
    const double chr0 = std::sqrt(c0 / n), chr1 = std::sqrt(c1 / n);
    EXPECT_NEAR(err0, rel, 0.01); // the noise is what it claims
    // Averaging 27 cells would divide the noise by 5.2; k < 1 keeps a little of each cell.
    EXPECT_LT(err1, err0 / 3.0) << err0 << " -> " << err1; // measured: 3.4x
    EXPECT_LT(chr1, chr0 / 3.0) << chr0 << " -> " << chr1;
    // The report's estimate of the noise after agrees with the measured error within a
    // factor of 1.5 (it ignores the bias and the neighbours' correlation).
    EXPECT_NEAR(r.noiseBefore, rel, 0.01);
    EXPECT_GT(r.noiseAfter, err1 / 1.5);
    EXPECT_LT(r.noiseAfter, err1 * 1.5);
}

TEST(ScatterFilter, BiasOnANoiseFreeFieldIsWithinTheBoxMeansBound)
{
    // The field claims 10 % noise but has none: the filter averages it (k near 1), and its
    // bias is at most the 3x3x3 box mean's. For f = 2 + sin(a i) cos(a j) + 0.5 sin(a k),
    // a = 2 pi / N, the box mean of sin(a i) is sin(a i) (1 + 2 cos a) / 3, so the mean's
    // deviation is at most (1 - ((1 + 2 cos a) / 3)^2) + 0.5 (1 - (1 + 2 cos a) / 3) of
    // the smallest f, 0.5 (inner cells).
    const std::array<int, 3> lo = {0, 0, 0};
    SparseVolume field = makeField(lo, smooth);
    const std::vector<float> relError(std::size_t(N) * N * N, 0.1f);
    denoiseField(field, lo, {N, N, N}, relError, 1, 1);
    const double g = (1.0 + 2.0 * std::cos(TWO_PI / N)) / 3.0;
    const double bound = ((1.0 - g * g) + 0.5 * (1.0 - g)) / 0.5; // relative to f >= 0.5
    double worst = 0.0;
    for (int k = 1; k < N - 1; ++k)
        for (int j = 1; j < N - 1; ++j)
            for (int i = 1; i < N - 1; ++i)
                for (int c = 0; c < 3; ++c) {
                    const double t = smooth(i, j, k, c);
                    worst = std::max(worst, std::abs(value(field, lo, i, j, k, c) - t) / t);
                }
    EXPECT_GT(worst, 0.0); // it did average
    EXPECT_LE(worst, bound * 1.0001) << "bound " << bound;
    EXPECT_LT(bound, 0.07); // and the bound is small at this wavelength
}

TEST(ScatterFilter, KeepsAnEdgeTheNoiseCannotExplain)
{
    // A step from 1 to 10 at i = N / 2 with 1 % noise: next to the step the neighbourhood's
    // spread is far above the noise, so the cells stay within their noise.
    const std::array<int, 3> lo = {0, 0, 0};
    Pcg32 rng(5, 2);
    SparseVolume field = makeField(lo, [&](int i, int, int, int) {
        return (i < N / 2 ? 1.0 : 10.0) * (1.0 + 0.01 * gaussian(rng));
    });
    const SparseVolume before = field;
    const std::vector<float> relError(std::size_t(N) * N * N, 0.01f);
    denoiseField(field, lo, {N, N, N}, relError, 1, 1);
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i : {N / 2 - 1, N / 2}) {
                const double a = value(before, lo, i, j, k, 1), b = value(field, lo, i, j, k, 1);
                EXPECT_LT(std::abs(b - a) / a, 0.01) << i << " " << j << " " << k;
            }
}

TEST(ScatterFilter, InactiveCellsAreNeitherReadNorWritten)
{
    // The half i >= N / 2 is inactive and holds garbage: the active half's result is the
    // same as with zeros there, and the garbage stays as it was.
    const std::array<int, 3> lo = {2, 2, 2};
    std::vector<float> relError(std::size_t(N) * N * N, 0.2f);
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = N / 2; i < N; ++i)
                relError[(std::size_t(k) * N + j) * N + i] = NOISE_INACTIVE;
    relError[0] = NOISE_UNKNOWN; // no packets: it takes its neighbours' mean
    const auto make = [&](double outside) {
        Pcg32 rng(7, 1);
        return makeField(lo, [&](int i, int j, int k, int c) {
            const double x = smooth(i, j, k, c) * (1.0 + 0.2 * gaussian(rng));
            return i < N / 2 ? x : outside;
        });
    };
    SparseVolume a = make(0.0), b = make(1e30);
    denoiseField(a, lo, {N, N, N}, relError, 1, 1);
    denoiseField(b, lo, {N, N, N}, relError, 1, 1);
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i)
                for (int c = 0; c < 3; ++c) {
                    if (i < N / 2) {
                        ASSERT_EQ(value(a, lo, i, j, k, c), value(b, lo, i, j, k, c));
                    } else {
                        ASSERT_EQ(value(b, lo, i, j, k, c), 1e30f);
                    }
                }
    // Cell 0 takes the plane fitted to its 8 active neighbours (the corner's 2x2x2) in every
    // channel: on a 2x2x2 cube the least-squares plane's value at the corner (0, 0, 0) is the
    // mean minus half of each axis's slope (the upper face's mean minus the lower's).
    const SparseVolume orig = make(0.0);
    for (int c = 0; c < 3; ++c) {
        double m = 0.0, slope[3] = {0, 0, 0};
        for (int k = 0; k < 2; ++k)
            for (int j = 0; j < 2; ++j)
                for (int i = 0; i < 2; ++i) {
                    const double v = value(orig, lo, i, j, k, c);
                    m += v / 8.0;
                    const int at[3] = {i, j, k};
                    for (int ax = 0; ax < 3; ++ax)
                        slope[ax] += (at[ax] ? v : -v) / 4.0;
                }
        const double plane = m - 0.5 * (slope[0] + slope[1] + slope[2]);
        EXPECT_NEAR(value(a, lo, 0, 0, 0, c), plane, 1e-5 * m);
    }
}
