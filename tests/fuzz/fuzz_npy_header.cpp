// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the .npy header parser (io/cube_io.h, parseNpyHeader()) on arbitrary bytes,
// and for headers it accepts, the header writer for the same shape parsed again. Anything but a
// clean nebula::Error is a finding.
#include "nebula/core/error.h"
#include "nebula/io/cube_io.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    try {
        const auto h = nebula::parseNpyHeader(bytes, "fuzz.npy");
        if (h.dataOffset > size) std::abort(); // the data must start inside what was read
        if (h.shape.size() <= 8) {
            const auto again =
                nebula::parseNpyHeader(nebula::npyHeader(h.shape, h.fortranOrder), "written.npy");
            if (again.shape != h.shape || again.fortranOrder != h.fortranOrder) std::abort();
        }
    } catch (const nebula::Error&) {
    }
    return 0;
}
