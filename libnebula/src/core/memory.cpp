// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/memory.h"

#include "nebula/core/error.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <sys/mman.h>
#include <unistd.h>

namespace nebula {

std::uint64_t physicalMemory()
{
    const long pages = ::sysconf(_SC_PHYS_PAGES);
    const long pageSize = ::sysconf(_SC_PAGESIZE);
    if (pages <= 0 || pageSize <= 0) return 0;
    return std::uint64_t(pages) * std::uint64_t(pageSize);
}

void* allocateLargePages(std::size_t bytes)
{
    const std::size_t rounded = (bytes + HUGE_PAGE_BYTES - 1) / HUGE_PAGE_BYTES * HUGE_PAGE_BYTES;
    if (rounded < bytes) throw std::bad_alloc();
    void* p = std::aligned_alloc(HUGE_PAGE_BYTES, rounded);
    if (!p) throw std::bad_alloc();
    // Advice only: where transparent huge pages are off, the block has 4 KiB pages.
    (void)::madvise(p, rounded, MADV_HUGEPAGE);
    return p;
}

void freeLargePages(void* p) noexcept
{
    std::free(p);
}

void* reserveAddressSpace(std::size_t bytes, const std::string& what)
{
    const std::size_t rounded = (bytes + HUGE_PAGE_BYTES - 1) / HUGE_PAGE_BYTES * HUGE_PAGE_BYTES;
    // One huge page more than asked, so that the block can start on a huge-page boundary.
    const std::size_t mapped = rounded + HUGE_PAGE_BYTES;
    if (rounded < bytes || mapped < rounded) {
        throw Error(what + ": " + bytesText(double(bytes)) + " of address space is too large");
    }
    void* p = ::mmap(nullptr, mapped, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (p == MAP_FAILED) {
        throw Error(what + ": cannot reserve " + bytesText(double(bytes)) + " of address space");
    }
    // Unmap the unaligned head and the tail beyond the block.
    const auto at = reinterpret_cast<std::uintptr_t>(p);
    const std::uintptr_t start = (at + HUGE_PAGE_BYTES - 1) / HUGE_PAGE_BYTES * HUGE_PAGE_BYTES;
    if (start > at) ::munmap(p, start - at);
    const std::size_t tail = (at + mapped) - (start + rounded);
    if (tail > 0) ::munmap(reinterpret_cast<void*>(start + rounded), tail);
    // Advice only: where transparent huge pages are off, the block has 4 KiB pages.
    if (rounded >= HUGE_PAGE_BYTES)
        (void)::madvise(reinterpret_cast<void*>(start), rounded, MADV_HUGEPAGE);
    return reinterpret_cast<void*>(start);
}

void releaseAddressSpace(void* p, std::size_t bytes) noexcept
{
    if (!p) return;
    const std::size_t rounded = (bytes + HUGE_PAGE_BYTES - 1) / HUGE_PAGE_BYTES * HUGE_PAGE_BYTES;
    ::munmap(p, rounded);
}

std::string bytesText(double bytes)
{
    static const char* const UNITS[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    constexpr int LAST = 6;
    if (!std::isfinite(bytes)) return "an unbounded amount";
    int unit = 0;
    while (unit < LAST && bytes >= 1024.0) {
        bytes /= 1024.0;
        ++unit;
    }
    // Three significant digits; whole numbers above 100 as they are ("512 B", "96 GiB").
    const std::string number = bytes >= 1e5     ? fmt::format("{:.2g}", bytes)
                               : bytes >= 100.0 ? fmt::format("{:.0f}", bytes)
                                                : fmt::format("{:.3g}", bytes);
    return number + " " + UNITS[unit];
}

void requireMemory(double bytes, const std::string& what, std::uint64_t available)
{
    if (available == 0 || bytes <= double(available)) return;
    throw UsageError(what + " needs " + bytesText(bytes) + " of memory; this machine has " +
                     bytesText(double(available)));
}

void requireMemory(double bytes, const std::string& what)
{
    requireMemory(bytes, what, physicalMemory());
}

} // namespace nebula
