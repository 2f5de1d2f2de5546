// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file ranks.h
/// The processes one computation is shared by: nebscatter's packets over MPI ranks
/// (README, "nebscatter over MPI"). The library sees only this interface: which share of
/// the work is this process's, and exact sums of integer arrays onto rank 0. The base class
/// is one process; cli/process_ranks.h gives the MPI ranks a tool was started as.

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace nebula {

/// A group of processes that split work and sum integer results onto rank 0. The base
/// class is the single process (rank 0 of 1, sums are no-ops).
class Ranks
{
public:
    Ranks() = default;
    Ranks(const Ranks&) = delete;
    Ranks& operator=(const Ranks&) = delete;
    virtual ~Ranks() = default;

    virtual int rank() const { return 0; }
    virtual int size() const { return 1; }
    bool root() const { return rank() == 0; }

    /// On rank 0, replaces @p data[0..n) by its sum over the ranks (integer: exact and
    /// independent of the ranks' order); on the other ranks @p data is left unspecified.
    /// Every rank must call it, in the same order, with the same @p n.
    virtual void sumToRoot(std::int64_t* data, std::size_t n) const
    {
        (void)data;
        (void)n;
    }
    virtual void sumToRoot(std::uint64_t* data, std::size_t n) const
    {
        (void)data;
        (void)n;
    }

    /// Where the ranks' @p digests first differ from rank 0's (one digest per option and input,
    /// so that every rank can check it runs the same computation): {the lowest index at which
    /// some rank's digest (or count of digests) differs from rank 0's, the lowest such rank},
    /// or {@p digests.size(), -1} when every rank agrees. Every rank gets the same answer and
    /// must call it.
    virtual std::pair<std::size_t, int>
    firstDisagreement(const std::vector<std::uint64_t>& digests) const
    {
        return {digests.size(), -1};
    }

    /// This rank's share [first, last) of @p n items: contiguous, in rank order, sizes
    /// differing by at most one.
    std::pair<std::uint64_t, std::uint64_t> share(std::uint64_t n) const
    {
        const auto r = std::uint64_t(rank()), s = std::uint64_t(size());
        const std::uint64_t q = n / s, m = n % s;
        const std::uint64_t first = r * q + (r < m ? r : m);
        return {first, first + q + (r < m ? 1 : 0)};
    }
};

} // namespace nebula
