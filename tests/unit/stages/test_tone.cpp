// SPDX-License-Identifier: Apache-2.0
// stages/tone.h: the tone curve of a sequence (smoothed statistics), the frames on disk.
#include "nebula/stages/tone.h"

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>

using namespace nebula;

namespace {

LuminanceStats stats(double white, double logMean)
{
    LuminanceStats s;
    s.white = white;
    s.logMean = logMean;
    s.lit = 100;
    return s;
}

std::vector<double> times(std::size_t n, double fps)
{
    std::vector<double> t;
    for (std::size_t i = 0; i < n; ++i)
        t.push_back(double(i) / fps);
    return t;
}

} // namespace

// A static camera (equal statistics) gets one curve, equal to the frame's own automatic one.
TEST(ToneSequence, ConstantStatisticsGiveOneCurve)
{
    const std::vector<LuminanceStats> s(30, stats(2.0, 0.05));
    const auto curves = sequenceToneCurves(times(30, 24), s, 1.0, false);
    const ToneCurve own = toneCurveFromStats(s[0]);
    for (const auto& c : curves) {
        EXPECT_DOUBLE_EQ(c.white, own.white);
        EXPECT_DOUBLE_EQ(c.gamma, own.gamma);
    }
}

// Per-frame statistics that jump (a bright star enters the view) or jitter: the smoothed
// white point changes by a few per cent per frame instead of jumping 8x, and the frames far
// from the jump keep their own level; window 0 is the per-frame curve; "all" one curve, the
// geometric mean.
TEST(ToneSequence, SmoothingRemovesJumpsAndJitter)
{
    const std::size_t n = 96;
    std::vector<LuminanceStats> s;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> jitter(0.7, 1.4);
    for (std::size_t i = 0; i < n; ++i)
        s.push_back(stats((i < 48 ? 1.0 : 8.0) * jitter(rng), 0.01));
    const auto t = times(n, 24);
    const auto smooth = sequenceToneCurves(t, s, 1.0, false);
    const auto raw = sequenceToneCurves(t, s, 0.0, false);
    double worstSmooth = 0.0, worstRaw = 0.0;
    for (std::size_t i = 1; i < n; ++i) {
        worstSmooth =
            std::max(worstSmooth, std::fabs(std::log(smooth[i].white / smooth[i - 1].white)));
        worstRaw = std::max(worstRaw, std::fabs(std::log(raw[i].white / raw[i - 1].white)));
        EXPECT_DOUBLE_EQ(raw[i].white, s[i].white);
    }
    std::cout << "[ flicker ] largest frame-to-frame white-point ratio: per frame "
              << std::exp(worstRaw) << ", smoothed (1 s window) " << std::exp(worstSmooth) << "\n";
    EXPECT_GT(worstRaw, std::log(4.0));
    EXPECT_LT(worstSmooth, std::log(1.12)); // at most 12 % from one frame to the next
    EXPECT_NEAR(std::log(smooth[5].white), std::log(1.0), 0.25);
    EXPECT_NEAR(std::log(smooth[90].white), std::log(8.0), 0.25);
    const auto whole = sequenceToneCurves(t, s, 1.0, true);
    double meanLog = 0.0;
    for (const auto& x : s)
        meanLog += std::log(x.white) / double(n);
    for (const auto& c : whole)
        EXPECT_NEAR(c.white, std::exp(meanLog), 1e-9 * c.white);
    // Black frames neither count nor break the curve.
    std::vector<LuminanceStats> withBlack(10, stats(3.0, 0.1));
    withBlack[4] = LuminanceStats();
    for (const auto& c : sequenceToneCurves(times(10, 24), withBlack, 1.0, false))
        EXPECT_DOUBLE_EQ(c.white, 3.0);
}

// A fly-through into a dark interior: the frames inside are 200 times darker. Per frame, the
// automatic curve would lift them to the same brightness as the rest (a flat haze); with a
// window, their white point stays within --adapt stops of the sequence's and every frame has
// the sequence's gamma, so the interior shows dark: its log-mean maps below the key.
TEST(ToneSequence, DarkInteriorStaysDark)
{
    const std::size_t n = 120;
    std::vector<LuminanceStats> s;
    for (std::size_t i = 0; i < n; ++i)
        s.push_back(i >= 50 && i < 80 ? stats(0.005, 0.0002) : stats(1.0, 0.02));
    const auto t = times(n, 12);
    for (const double adapt : {0.0, 1.0, 2.0, 4.0}) {
        const auto curves = sequenceToneCurves(t, s, 1.0, false, adapt);
        // The sequence's statistics: the geometric means over every lit frame.
        const double w = std::exp((90.0 * std::log(1.0) + 30.0 * std::log(0.005)) / 120.0);
        const double m = std::exp((90.0 * std::log(0.02) + 30.0 * std::log(0.0002)) / 120.0);
        LuminanceStats seq;
        seq.white = w;
        seq.logMean = m;
        const ToneCurve sequence = toneCurveFromStats(seq);
        for (std::size_t i = 0; i < n; ++i) {
            EXPECT_NEAR(curves[i].gamma, sequence.gamma, 1e-12) << i;
            EXPECT_GE(curves[i].white, sequence.white * std::exp2(-adapt) * (1 - 1e-12)) << i;
            EXPECT_LE(curves[i].white, sequence.white * std::exp2(adapt) * (1 + 1e-12)) << i;
        }
        // The middle of the interior: its own log-mean is displayed well below the key (up to
        // the default 2 stops; 4 stops let it rise to 0.13).
        const double shown = std::pow(s[65].logMean / curves[65].white, curves[65].gamma);
        if (adapt <= 2.0) {
            EXPECT_LT(shown, 0.5 * TONE_KEY) << "adapt " << adapt;
        }
    }
    // Window 0 keeps each frame's own curve (nebrender's), interior lifted to the key.
    const auto own = sequenceToneCurves(t, s, 0.0, false, 2.0);
    EXPECT_DOUBLE_EQ(own[65].white, 0.005);
    EXPECT_NEAR(std::pow(s[65].logMean / own[65].white, own[65].gamma), TONE_KEY, 0.2);
    EXPECT_THROW(sequenceToneCurves(t, s, 1.0, false, -1.0), Error);
}

TEST(ToneSequence, FramesOnDiskMatchThePattern)
{
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(::testing::TempDir()) / "nebula_tone_frames";
    fs::remove_all(dir);
    fs::create_directories(dir);
    for (const char* name : {"f.0003.exr", "f.0001.exr", "f.12.exr", "f.0010.exr", "g.0002.exr",
                             "f.0004.exr.tmp.1.abc", "f.00x5.exr"})
        std::ofstream(dir / name) << "x";
    EXPECT_EQ(framesOnDisk((dir / "f.####.exr").string()), (std::vector<long>{1, 3, 10}));
    EXPECT_EQ(framesOnDisk((dir / "f.%d.exr").string()), (std::vector<long>{12}));
    EXPECT_THROW(framesOnDisk((dir / "f.exr").string()), UsageError);
    fs::remove_all(dir);
}
