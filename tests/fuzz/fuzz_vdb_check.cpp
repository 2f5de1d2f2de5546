// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the structural check alone (io/vdb_check.h checkVdbStructure), the guard
// that stands between damaged bytes and OpenVDB. It does no OpenVDB work, so it runs orders of
// magnitude faster than fuzz_grid_reader and explores the format's lengths and counts deeply.
// Anything but a clean nebula::Error is a finding.
#include "nebula/core/error.h"
#include "nebula/io/vdb_check.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    try {
        nebula::checkVdbStructure(std::string_view(reinterpret_cast<const char*>(data), size),
                                  "fuzz.vdb");
    } catch (const nebula::Error&) {
    }
    return 0;
}
