// SPDX-License-Identifier: Apache-2.0
/// @file test_memory.cpp
/// core/memory.h: the machine's memory, byte counts in words, and requireMemory()'s usage
/// error that names the allocation and both sizes.

#include "nebula/core/memory.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>

using nebula::bytesText;
using nebula::HUGE_PAGE_BYTES;
using nebula::LargeFloatArray;
using nebula::requireMemory;
using nebula::test::errorMessage;

namespace {

constexpr double GiB = 1024.0 * 1024.0 * 1024.0;

TEST(Memory, PhysicalMemoryIsKnownOnThisMachine)
{
    EXPECT_GT(nebula::physicalMemory(), std::uint64_t(1) << 20);
}

TEST(Memory, BytesInTheLargestUnitToThreeDigits)
{
    EXPECT_EQ(bytesText(0), "0 B");
    EXPECT_EQ(bytesText(512), "512 B");
    EXPECT_EQ(bytesText(1536), "1.5 KiB");
    EXPECT_EQ(bytesText(96 * GiB), "96 GiB");
    EXPECT_EQ(bytesText(23.4 * GiB), "23.4 GiB");
    EXPECT_EQ(bytesText(1023 * GiB), "1023 GiB");
    EXPECT_EQ(bytesText(7.5 * 1024 * GiB), "7.5 TiB");
    EXPECT_EQ(bytesText(1.1e5 * std::ldexp(1.0, 60)), "1.1e+05 EiB");
    EXPECT_EQ(bytesText(INFINITY), "an unbounded amount");
}

TEST(Memory, RequireMemoryNamesTheAllocationAndBothSizes)
{
    const auto available = std::uint64_t(23 * GiB);
    EXPECT_NO_THROW(requireMemory(23 * GiB, "x", available));
    EXPECT_NO_THROW(requireMemory(1.0, "x", available));
    EXPECT_EQ(
        errorMessage([&] { requireMemory(96 * GiB, "--res 65536x65536: the image", available); }),
        "--res 65536x65536: the image needs 96 GiB of memory; this machine has 23 GiB");
    EXPECT_THROW(requireMemory(96 * GiB, "x", available), nebula::UsageError);
    // A product of huge sizes, as a double, neither wraps around nor passes.
    EXPECT_THROW(requireMemory(1e300, "x", available), nebula::UsageError);
    EXPECT_THROW(requireMemory(INFINITY, "x", available), nebula::UsageError);
    // The machine's own memory: nothing fits 1e30 bytes.
    EXPECT_THROW(requireMemory(1e30, "x"), nebula::UsageError);
    EXPECT_NO_THROW(requireMemory(1024.0, "x"));
}

// Large arrays sit on 2 MiB boundaries (so that the kernel can back them with huge pages),
// small ones come from the ordinary allocator; both are zeroed and usable end to end.
TEST(Memory, LargeArraysAreAlignedForHugePages)
{
    LargeFloatArray big(3 * HUGE_PAGE_BYTES / sizeof(float) + 5);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(big.data()) % HUGE_PAGE_BYTES, 0u);
    EXPECT_EQ(big.front(), 0.0f);
    EXPECT_EQ(big.back(), 0.0f);
    big.back() = 2.5f;
    LargeFloatArray copy = big; // the copy is on huge pages too
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(copy.data()) % HUGE_PAGE_BYTES, 0u);
    EXPECT_EQ(copy.back(), 2.5f);
    LargeFloatArray small(100, 1.0f);
    EXPECT_EQ(small[99], 1.0f);
    small.resize(HUGE_PAGE_BYTES / sizeof(float)); // grows from ordinary into huge pages
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data()) % HUGE_PAGE_BYTES, 0u);
    EXPECT_EQ(small[99], 1.0f);
    EXPECT_EQ(small.back(), 0.0f);
}

} // namespace
