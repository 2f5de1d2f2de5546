// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_tally.h
/// Internal to render/: nebscatter's tallies (DESIGN §5b "Determinism"): the fixed point
/// every flight adds in, and one source's packets run over the threads with their tallies
/// summed over the threads (runSourcePackets()) and the MPI ranks (sumOverRanks()), in
/// scatter_tally.cpp. Integer sums do not depend on their order: the same field whatever the
/// threads, the buffers or the ranks.

#include "scatter_transport.h"

#include "nebula/core/ranks.h"
#include "nebula/core/run.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

namespace nebula::detail {

/// Fixed-point quantum 2^-e of the tallies (weight x length in voxels; weights): the
/// finest for which @p packets packets cannot overflow an int64 sum (a bound of 64 flights
/// per packet crossing a cell, weights up to 16, field cells of 2^level voxels) and one
/// addition stays below 2^50 quanta. 2^-28 for 2 million packets at level 1: one addition
/// of 10^-6 is rounded by at most 2e-3 of itself, errors that average out over additions.
inline double fixedQuantum(std::uint64_t packets, int level)
{
    // One addition: weight (up to 4, times 1 / TAIL_KEEP in a flight's tail) x length
    // (2^level voxels, up to 2 across) x |Y_lm| (below 1), at most 2^50 quanta (roundFixed()).
    const double one = 16.0 * 2.0 * std::ldexp(1.0, level);
    const double bound = double(packets) * 64.0 * one;
    const int e = std::min({40, int(std::floor(62.0 - std::log2(std::max(bound, 1.0)))),
                            int(std::floor(50.0 - std::log2(one)))});
    return std::ldexp(1.0, -e);
}

/// @p x rounded to the nearest integer (ties to even) for |x| < 2^51, without a branch or a
/// library call: the integer is in the low bits of 1.5 * 2^52 + x.
inline std::int64_t roundFixed(double x)
{
    const double y = x + 6755399441055744.0; // 1.5 * 2^52
    std::int64_t bits;
    std::memcpy(&bits, &y, sizeof bits);
    return bits - std::int64_t(0x4338000000000000);
}

/// Adds @p scaled (a value over the quantum, |scaled| < 2^51) to @p p, rounded to the nearest
/// integer (roundFixed()), as an integer addition (atomic when @p atomic): the sum does not
/// depend on the order.
inline void addFixed(std::int64_t* p, double scaled, bool atomic)
{
    const std::int64_t q = roundFixed(scaled);
    if (q == 0) return;
    if (atomic) {
        __atomic_fetch_add(p, q, __ATOMIC_RELAXED);
    } else {
        *p += q;
    }
}
/// One source's tallies: per tally slot its moments (k, c) and its noise channel's squared
/// J, and the energy sums, all fixed point (quantum; squares quantum * 2^8), summed over the
/// threads and, on rank 0, over the ranks.
struct SourceTallies
{
    double quantum = 1.0;
    std::vector<std::int64_t> sum; ///< per slot, moment k and channel c: (slot * nm + k) * C + c
    std::vector<std::int64_t> sq;  ///< per slot
    EnergySums energy;
};

/// Runs this rank's share of source @p spec's packets (all of them in one process; the
/// source's index @p sourceIndex seeds their streams) over the threads, and sums their
/// tallies over the threads into @p out: per-thread buffers added at the end into the first
/// thread's, or one shared buffer with atomic additions where per-thread buffers would pass
/// ScatterOptions::perThreadTallyBytes.
void runSourcePackets(const Transport& tr, const SourceSpec& spec, std::uint64_t sourceIndex,
                      const Sampler& sampler, const ScatterOptions& opts, const Run* run,
                      SourceTallies& out);

/// Sums @p t over @p ranks onto rank 0 (nothing in one process); returns whether this
/// process holds the field (rank 0, or the only process).
bool sumOverRanks(SourceTallies& t, const Ranks* ranks);

} // namespace nebula::detail
