// SPDX-License-Identifier: Apache-2.0
/// @file test_rng.cpp
/// PCG32 (core/rng.h) against the reference implementation's published output, the
/// float conversions from raw bits, and independent streams.

#include "nebula/core/rng.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace {

using nebula::Pcg32;

constexpr uint64_t SEED = 20240611;

// ---------------------------------------------------------------------------------------------
// PCG32

TEST(Pcg32, ReproducesTheReferenceDemoOutput)
{
    // pcg32-demo (pcg-c / pcg-c-basic): pcg32_srandom_r(&rng, 42u, 54u), i.e. initstate 42 on
    // stream (initseq) 54; published first six outputs.
    Pcg32 rng(54, 42);
    const uint32_t reference[] = {0xa15c02b7u, 0x7b47f409u, 0xba1d3330u,
                                  0x83d2f293u, 0xbfa4784bu, 0xcbed606eu};
    for (uint32_t value : reference) {
        EXPECT_EQ(rng.uniformUInt32(), value);
    }
    // setSequence() restarts the same stream.
    rng.setSequence(54, 42);
    EXPECT_EQ(rng.uniformUInt32(), reference[0]);
}

TEST(Pcg32, FloatsComeFromRawBitsAndStayBelowOne)
{
    EXPECT_EQ(nebula::unitFloatFromBits(0u), 0.0f);
    EXPECT_EQ(nebula::unitFloatFromBits(0xffffffffu), 1.0f - 0x1p-24f);
    EXPECT_EQ(nebula::unitDoubleFromBits(0u), 0.0);
    EXPECT_EQ(nebula::unitDoubleFromBits(~uint64_t(0)), 1.0 - 0x1p-53);

    // uniformFloat / uniformDouble are those conversions of the raw stream.
    Pcg32 a(7, 3);
    Pcg32 b(7, 3);
    for (int i = 0; i < 100; ++i) {
        ASSERT_EQ(a.uniformFloat(), nebula::unitFloatFromBits(b.uniformUInt32()));
        const uint64_t hi = b.uniformUInt32();
        const uint64_t lo = b.uniformUInt32();
        ASSERT_EQ(a.uniformDouble(), nebula::unitDoubleFromBits((hi << 32) | lo));
    }

    // In [0, 1), with mean 1/2 within 4 standard errors (variance 1/12).
    constexpr int N = 200000;
    Pcg32 rng(1, SEED);
    double sumF = 0.0;
    double sumD = 0.0;
    for (int i = 0; i < N; ++i) {
        const float f = rng.uniformFloat();
        const double d = rng.uniformDouble();
        ASSERT_TRUE(f >= 0.0f && f < 1.0f) << f;
        ASSERT_TRUE(d >= 0.0 && d < 1.0) << d;
        sumF += f;
        sumD += d;
    }
    const double standardError = std::sqrt(1.0 / 12.0 / N);
    EXPECT_NEAR(sumF / N, 0.5, 4.0 * standardError);
    EXPECT_NEAR(sumD / N, 0.5, 4.0 * standardError);
}

TEST(Pcg32, StreamsWithDifferentSequenceIndicesDiffer)
{
    // Same seed, sequence indices 0..15: the first 8 outputs of every pair of streams differ,
    // and re-seeding a stream reproduces it.
    constexpr int STREAMS = 16;
    constexpr int DRAWS = 8;
    std::vector<std::vector<uint32_t>> outputs(STREAMS);
    for (int s = 0; s < STREAMS; ++s) {
        Pcg32 rng(s, SEED);
        for (int i = 0; i < DRAWS; ++i) {
            outputs[s].push_back(rng.uniformUInt32());
        }
    }
    for (int s = 0; s < STREAMS; ++s) {
        for (int t = s + 1; t < STREAMS; ++t) {
            EXPECT_NE(outputs[s], outputs[t]) << "streams " << s << " and " << t;
        }
        Pcg32 again(s, SEED);
        for (int i = 0; i < DRAWS; ++i) {
            EXPECT_EQ(again.uniformUInt32(), outputs[s][i]) << "stream " << s << ", draw " << i;
        }
    }
}

} // namespace
