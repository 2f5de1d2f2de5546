// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: filter files (physics/filters.h parseFilterFile()) on arbitrary text, and
// what a tool does next with a filter it read: the pivot wavelength, a band average and the
// 3-node band quadrature. The first byte chooses the default wavelength unit. Anything but a
// clean nebula::Error is a finding; so are a non-finite result of a parsed filter and a
// quadrature whose weights do not sum to 1.
#include "nebula/core/error.h"
#include "nebula/physics/filters.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size == 0) return 0;
    const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
    const auto unit = static_cast<nebula::FilterWavelengthUnit>(data[0] % 3);
    try {
        const nebula::Filter filter = nebula::parseFilterFile(text, "filter.dat", unit);
        const double pivot = nebula::pivotWavelength(filter);
        const double average = nebula::bandAverageFnu(filter, [](double l) { return 1.0 / l; });
        const nebula::BandQuadrature q = nebula::bandQuadrature(filter, 3);
        double sum = 0.0;
        for (double w : q.weight)
            sum += w;
        if (!std::isfinite(pivot) || !std::isfinite(average) || std::abs(sum - 1.0) > 1e-9)
            std::abort();
    } catch (const nebula::Error&) {
    }
    return 0;
}
