// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/error.h"
#include "nebula/serve/view_server.h"

#include "nebula_view_page.h"

#include <turbojpeg.h>

#include <memory>

namespace nebula {

std::string jpegBytes(const std::vector<std::uint8_t>& rgba, int width, int height, int quality)
{
    if (width <= 0 || height <= 0 || rgba.size() != std::size_t(width) * std::size_t(height) * 4) {
        throw Error("JPEG: the pixels are not " + std::to_string(width) + "x" +
                    std::to_string(height) + " RGBA");
    }
    if (quality < 1 || quality > 100) throw Error("JPEG: quality must be in [1, 100]");
    const std::unique_ptr<void, int (*)(tjhandle)> tj(tjInitCompress(), tjDestroy);
    if (!tj) throw Error(std::string("JPEG: ") + tjGetErrorStr2(nullptr));
    unsigned char* out = nullptr;
    unsigned long size = 0;
    if (tjCompress2(tj.get(), rgba.data(), width, 0, height, TJPF_RGBA, &out, &size, TJSAMP_420,
                    quality, TJFLAG_FASTDCT) != 0) {
        const std::string why = tjGetErrorStr2(tj.get());
        tjFree(out);
        throw Error("JPEG: " + why);
    }
    std::string bytes(reinterpret_cast<const char*>(out), size);
    tjFree(out);
    return bytes;
}

const std::string& viewerPage()
{
    static const std::string page(reinterpret_cast<const char*>(detail::NEBULA_VIEW_PAGE),
                                  sizeof detail::NEBULA_VIEW_PAGE);
    return page;
}

} // namespace nebula
