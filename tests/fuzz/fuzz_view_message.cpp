// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: nebview's messages from the network (serve/view_protocol.h), every one of
// which passes parseClientMessage() before the server acts on it. A clean MalformedMessage
// (the connection is closed) or Error (answered) is the only acceptable failure; whatever
// parses must give a camera the renderer accepts (validated) and a path that evaluates.
#include "nebula/core/error.h"
#include "nebula/serve/view_protocol.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string text(reinterpret_cast<const char*>(data), size);
    const std::vector<std::string> stars{"star", "b"};
    const nebula::Camera base;
    try {
        const auto m = nebula::parseClientMessage(text, stars, base, "path.json");
        using Kind = nebula::ClientMessage::Kind;
        if (m.kind == Kind::View) {
            nebula::validateCamera(m.view.camera);
            (void)nebula::cameraJson(m.view.camera).dump();
        }
        if ((m.kind == Kind::Scrub || m.kind == Kind::SavePath) && !m.path.keys.empty()) {
            nebula::validateCamera(m.path.at(m.time, base));
            (void)nebula::pathJson(m.path).dump();
        }
        if (m.kind == Kind::LoadPath) (void)nebula::parseCameraPath(m.text, "load.json", base);
    } catch (const nebula::Error&) {
    }
    return 0;
}
