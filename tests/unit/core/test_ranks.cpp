// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/ranks.h"

#include <gtest/gtest.h>

#include <cstdint>

using namespace nebula;

namespace {

/// Rank r of s, for checking share() without MPI.
class FixedRanks final : public Ranks
{
public:
    FixedRanks(int r, int s) : mRank(r), mSize(s) {}
    int rank() const override { return mRank; }
    int size() const override { return mSize; }

private:
    int mRank, mSize;
};

} // namespace

TEST(Ranks, OneProcessHasEverything)
{
    const Ranks one;
    EXPECT_TRUE(one.root());
    EXPECT_EQ(one.size(), 1);
    EXPECT_EQ(one.share(7), (std::pair<std::uint64_t, std::uint64_t>(0, 7)));
    std::int64_t x[2] = {3, -4};
    one.sumToRoot(x, 2); // nothing to add
    EXPECT_EQ(x[0], 3);
    EXPECT_EQ(x[1], -4);
}

TEST(Ranks, SharesAreContiguousInRankOrderAndEven)
{
    for (const int size : {1, 2, 3, 4, 7, 64}) {
        for (const std::uint64_t n :
             {std::uint64_t(0), std::uint64_t(1), std::uint64_t(5), std::uint64_t(64),
              std::uint64_t(1000003), std::uint64_t(1) << 40}) {
            std::uint64_t next = 0, least = UINT64_MAX, most = 0;
            for (int r = 0; r < size; ++r) {
                const auto [first, last] = FixedRanks(r, size).share(n);
                EXPECT_EQ(first, next) << "rank " << r << " of " << size << ", n " << n;
                ASSERT_LE(first, last);
                least = std::min(least, last - first);
                most = std::max(most, last - first);
                next = last;
            }
            EXPECT_EQ(next, n) << size << " ranks must cover all " << n << " items";
            EXPECT_LE(most - least, 1u);
        }
    }
}
