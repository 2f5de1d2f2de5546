// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: every JSON consumer on arbitrary text, each through its own entry point
// (so through the bounded parser, detail::parseJson/checkJsonBounds): the first byte chooses
// the consumer. Anything but a clean nebula::Error is a finding; so is a crash on a deep or
// wide document (the seed corpus holds some).
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/stars.h"
#include "nebula/render/camera.h"
#include "nebula/render/camera_path.h"
#include "nebula/stages/tone.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size == 0) return 0;
    const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
    try {
        switch (data[0] % 7) {
        case 0: { // --stars files and nebula:stars
            const auto stars = nebula::parseStars(text, "stars.json");
            (void)nebula::starsToJson(stars);
            break;
        }
        case 1: { // nebula:dust
            std::vector<std::string> missing;
            const auto dust = nebula::DustParams::fromJson(text, "nebula:dust", &missing);
            (void)dust.toJson();
            (void)dust.missingFieldsText(missing);
            break;
        }
        case 2: { // --camera-path
            const nebula::Camera defaults;
            const auto path = nebula::parseCameraPath(text, "path.json", defaults);
            if (path.frameCount() > 0) (void)path.at(path.frameTime(path.frameCount()), defaults);
            break;
        }
        case 3: { // nebula:history
            nebula::GridSet set;
            set.source = "history.vdb";
            set.setMetaString(nebula::META_HISTORY, text);
            (void)set.historyWith("nebfuzz", "nebfuzz --flag").dump();
            break;
        }
        case 4: // nebtone: an EXR's nebula:luminance
            (void)nebula::luminanceAttributeWhite(text, 99.5, "f.0001.exr");
            break;
        case 5: // nebtone: an EXR's nebula:frame
            (void)nebula::frameAttributeFps(text, "f.0001.exr");
            break;
        default: // the bounded parser itself (nebula:checksums, nebula:scatter use it too)
            (void)nebula::detail::parseJson(text, "metadata").dump();
            break;
        }
    } catch (const nebula::Error&) {
    }
    return 0;
}
