// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the grid reader (io/grid_io.h readGridsFromMemory: the structural check,
// OpenVDB's parse, the checksums) on arbitrary bytes. Anything but a clean nebula::Error is a
// finding: a crash, a sanitizer report, another exception, a leak, or a timeout.
#include "nebula/core/error.h"
#include "nebula/io/grid_io.h"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    openvdb::initialize();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    try {
        const nebula::GridSet set = nebula::readGridsFromMemory(bytes, "fuzz.vdb");
        // What the tools do next with a file that reads: its metadata.
        (void)set.stars();
        (void)set.dust();
        (void)set.history();
    } catch (const nebula::Error&) {
        // A refusal with a message is the right outcome for damaged input.
    }
    return 0;
}
