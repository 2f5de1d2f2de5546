// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: RADMC-3D's parsers (io/cube_io.h) on arbitrary bytes: amr_grid.inp text
// (parseRadmcGrid()) and the headers of dust_density.binp and dust_density.inp
// (parseRadmcDataHeader()). The first byte chooses the parser. Anything but a clean
// nebula::Error is a finding.
#include "nebula/core/error.h"
#include "nebula/io/cube_io.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size == 0) return 0;
    const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
    try {
        switch (data[0] % 3) {
        case 0: {
            const auto g = nebula::parseRadmcGrid(bytes, "amr_grid.inp");
            for (std::size_t a = 0; a < 3; ++a) {
                if (g.walls[a].size() != std::size_t(g.cells[a]) + 1) std::abort();
            }
            break;
        }
        case 1: {
            const auto h = nebula::parseRadmcDataHeader(bytes, true, "dust_density.binp");
            // The values the header announces lie inside the bytes.
            if (double(h.dataOffset) + double(h.cells) * double(h.species) * h.precision >
                double(bytes.size())) {
                std::abort();
            }
            break;
        }
        default: nebula::parseRadmcDataHeader(bytes, false, "dust_density.inp");
        }
    } catch (const nebula::Error&) {
    }
    return 0;
}
