// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file memory.h
/// Memory checks before a big allocation whose size comes from an option (image size, sprite
/// footprint, grid resolution): refuse it with a usage error that says how much memory it
/// would need and how much the machine has, instead of dying with std::bad_alloc.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <vector>

namespace nebula {

/// The machine's physical memory [bytes]: sysconf(_SC_PHYS_PAGES) * page size (0 if unknown).
std::uint64_t physicalMemory();

/// @p bytes in the largest binary unit that keeps the number >= 1, to three significant
/// digits: "512 B", "1.5 KiB", "96 GiB", "1.1e+05 EiB".
std::string bytesText(double bytes);

/// Throws UsageError "<what> needs <N> of memory; this machine has <M>" if @p bytes (a double,
/// so that a product of huge sizes cannot wrap around) exceeds the physical memory. @p what
/// names the option and the allocation, e.g. "--res 65536x65536: the image".
void requireMemory(double bytes, const std::string& what);

/// requireMemory() against @p available bytes instead of the machine's memory (for tests).
void requireMemory(double bytes, const std::string& what, std::uint64_t available);

/// Blocks of at least this many bytes are given transparent huge pages (LargePageAllocator).
inline constexpr std::size_t HUGE_PAGE_BYTES = std::size_t(2) << 20;

/// A block of @p bytes (>= HUGE_PAGE_BYTES) aligned to, and rounded up to, HUGE_PAGE_BYTES
/// and marked madvise(MADV_HUGEPAGE), so that the kernel backs it with 2 MiB pages: one page
/// fault where 4 KiB pages take 512, and one TLB entry where they take 512 (zeroing an 86 MB
/// volume: 330 ms with 4 KiB pages, 40 ms with 2 MiB ones on a 2-core VM). Throws
/// std::bad_alloc if there is no memory. Free it with freeLargePages().
void* allocateLargePages(std::size_t bytes);
void freeLargePages(void* p) noexcept;

/// std::allocator, except that blocks of HUGE_PAGE_BYTES and more come from
/// allocateLargePages(): for the big dense arrays (volumes, tallies, images).
template <typename T> struct LargePageAllocator
{
    using value_type = T;
    LargePageAllocator() = default;
    template <typename U> LargePageAllocator(const LargePageAllocator<U>&) noexcept {}
    T* allocate(std::size_t n)
    {
        if (n > std::size_t(-1) / sizeof(T)) throw std::bad_alloc();
        if (n * sizeof(T) >= HUGE_PAGE_BYTES) {
            return static_cast<T*>(allocateLargePages(n * sizeof(T)));
        }
        return std::allocator<T>().allocate(n);
    }
    void deallocate(T* p, std::size_t n) noexcept
    {
        if (n * sizeof(T) >= HUGE_PAGE_BYTES) {
            freeLargePages(p);
        } else {
            std::allocator<T>().deallocate(p, n);
        }
    }
    template <typename U> bool operator==(const LargePageAllocator<U>&) const noexcept
    {
        return true;
    }
    template <typename U> bool operator!=(const LargePageAllocator<U>&) const noexcept
    {
        return false;
    }
};

/// @p bytes of address space, aligned to HUGE_PAGE_BYTES, that costs no memory until a page is
/// written (mmap with MAP_NORESERVE; reads of unwritten pages see zeros), marked for
/// transparent huge pages when large: SparseVolume's bricks are allocated from it one after
/// another, so the memory used follows the bricks written. Throws Error naming @p what if the
/// address space cannot be reserved. Release it with releaseAddressSpace().
void* reserveAddressSpace(std::size_t bytes, const std::string& what);
void releaseAddressSpace(void* p, std::size_t bytes) noexcept;

/// A float array on huge pages when large (the big dense arrays).
using LargeFloatArray = std::vector<float, LargePageAllocator<float>>;

} // namespace nebula
