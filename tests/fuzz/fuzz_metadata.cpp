// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the metadata parsers (stars JSON, dust JSON, nebscatter's field's
// nebula:scatter) on arbitrary text. The first byte chooses the parser: below 0x80 its
// parity (stars, dust), else the field's. Anything but a clean nebula::Error is a finding.
#include "nebula/core/error.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/scatter_field_vdb.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/stars.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size == 0) return 0;
    const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
    try {
        if (data[0] >= 0x80) {
            nebula::GridSet grids;
            grids.source = "field.vdb";
            grids.setMetaString(nebula::META_SCATTER, text);
            (void)nebula::readScatterFieldMeta(grids, false);
        } else if (data[0] % 2 == 0) {
            const auto stars = nebula::parseStars(text, "stars.json");
            (void)nebula::starsToJson(stars);
        } else {
            std::vector<std::string> missing;
            const auto dust = nebula::DustParams::fromJson(text, "nebula:dust", &missing);
            (void)dust.toJson();
            (void)dust.missingFieldsText(missing);
        }
    } catch (const nebula::Error&) {
    }
    return 0;
}
