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
