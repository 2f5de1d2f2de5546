#pragma once
/// @file memory.h
/// Memory checks before a big allocation whose size comes from an option (image size, sprite
/// footprint, grid resolution): refuse it with a usage error that says how much memory it
/// would need and how much the machine has, instead of dying with std::bad_alloc.

#include <cstdint>
#include <string>

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

} // namespace nebula
