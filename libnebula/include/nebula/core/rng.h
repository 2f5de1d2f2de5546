// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file rng.h
/// PCG32 random number generator (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
/// Statistically Good Algorithms for Random Number Generation"), as in pbrt-v4's util/rng.h:
/// 64-bit LCG state, XSH RR output permutation, 2^63 selectable streams. Header-only.
///
/// Determinism (docs/DESIGN.md §1): give every photon / item its own stream with
/// setSequence(itemIndex, seed), so that results do not depend on which thread draws them or in
/// what order. Floats are made from the raw bits, never by dividing by a maximum, so the
/// same seed gives the same floats on every platform.

#include <cstdint>

namespace nebula {

/// Uniform float in [0, 1) from the top 24 bits of @p bits: k * 2^-24 for k in [0, 2^24).
/// Exact, evenly spaced, and never 1 (the largest value is 1 - 2^-24).
inline float unitFloatFromBits(uint32_t bits)
{
    return static_cast<float>(bits >> 8) * 0x1p-24f;
}

/// Uniform double in [0, 1) from the top 53 bits of @p bits: k * 2^-53 for k in [0, 2^53).
/// Exact, evenly spaced, and never 1 (the largest value is 1 - 2^-53).
inline double unitDoubleFromBits(uint64_t bits)
{
    return static_cast<double>(bits >> 11) * 0x1p-53;
}

/// PCG32: period 2^64 per stream, 2^63 streams. Same algorithm and seeding as O'Neill's
/// pcg32_srandom_r / pcg32_random_r, so setSequence(54, 42) reproduces the pcg32-demo output.
class Pcg32
{
public:
    static constexpr uint64_t MULTIPLIER = 6364136223846793005ULL;    ///< 0x5851f42d4c957f2d
    static constexpr uint64_t DEFAULT_STATE = 0x853c49e6748fea9bULL;  ///< PCG32_INITIALIZER
    static constexpr uint64_t DEFAULT_STREAM = 0xda3e39cb94b95bdbULL; ///< PCG32_INITIALIZER

    /// The reference implementation's default generator (PCG32_INITIALIZER).
    Pcg32() : mState(DEFAULT_STATE), mInc(DEFAULT_STREAM) {}

    /// Generator on stream @p sequenceIndex started from @p seed; see setSequence().
    Pcg32(uint64_t sequenceIndex, uint64_t seed) { setSequence(sequenceIndex, seed); }

    /// Selects stream @p sequenceIndex (only its low 63 bits count) and seeds it with @p seed.
    /// Equivalent to pcg32_srandom_r(rng, initstate = seed, initseq = sequenceIndex).
    void setSequence(uint64_t sequenceIndex, uint64_t seed)
    {
        mState = 0u;
        mInc = (sequenceIndex << 1u) | 1u; // the increment must be odd
        uniformUInt32();
        mState += seed;
        uniformUInt32();
    }

    /// Next 32 uniformly distributed bits: advance the LCG, then permute the old state
    /// (xorshift high, random rotation).
    uint32_t uniformUInt32()
    {
        const uint64_t oldState = mState;
        mState = oldState * MULTIPLIER + mInc;
        const auto xorShifted = static_cast<uint32_t>(((oldState >> 18u) ^ oldState) >> 27u);
        const auto rot = static_cast<uint32_t>(oldState >> 59u);
        return (xorShifted >> rot) | (xorShifted << ((~rot + 1u) & 31u));
    }

    /// Uniform float in [0, 1) with 24 random bits; consumes one uniformUInt32().
    float uniformFloat() { return unitFloatFromBits(uniformUInt32()); }

    /// Uniform double in [0, 1) with 53 random bits; consumes two uniformUInt32() (the first
    /// gives the high half).
    double uniformDouble()
    {
        const uint64_t hi = uniformUInt32();
        const uint64_t lo = uniformUInt32();
        return unitDoubleFromBits((hi << 32u) | lo);
    }

private:
    uint64_t mState; ///< LCG state
    uint64_t mInc;   ///< stream increment (odd)
};

} // namespace nebula
