// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/image_check.h"

#include "nebula/core/error.h"

#include <fmt/format.h>

#include <cmath>
#include <cstddef>
#include <vector>

namespace nebula {

namespace {

/// Throws for the first non-finite value of @p values (@p stride values per pixel, named
/// @p names[k] + suffix).
void requireFinite(const std::vector<float>& values, std::size_t stride, int width,
                   const std::string& prefix, const char* const* names, const std::string& path)
{
    for (std::size_t i = 0; i < values.size(); ++i) {
        const float v = values[i];
        if (std::isfinite(v)) continue;
        const std::size_t pixel = i / stride;
        const std::size_t x = pixel % std::size_t(width), y = pixel / std::size_t(width);
        throw Error(fmt::format(
            "{}: pixel ({}, {}) has {} = {}; not writing an image with non-finite values. "
            "The radiance overflowed a float (3.4e38): a star's luminosity, kappa_V, "
            "--emission-scale, --blackbody-scale or --temperature-scale is too large, or the "
            "camera is (almost) at a star",
            path, x, y, prefix + names[i % stride],
            std::isnan(v) ? "NaN" : (v > 0 ? "inf" : "-inf")));
    }
}

} // namespace

void requireFinitePixels(const Image& image, const std::string& path)
{
    static const char* const RGBA[] = {"R", "G", "B", "A"};
    static const char* const NONE[] = {""};
    requireFinite(image.rgba, 4, image.width, "", RGBA, path);
    for (const auto& layer : image.layers)
        requireFinite(layer.rgb, 3, image.width, layer.name + ".", RGBA, path);
    for (const auto& channel : image.channels)
        requireFinite(channel.values, 1, image.width, channel.name, NONE, path);
}

} // namespace nebula
