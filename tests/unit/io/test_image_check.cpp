// SPDX-License-Identifier: Apache-2.0
/// @file test_image_check.cpp
/// io/image_check.h: a frame with a NaN or infinite pixel is refused before it is written,
/// naming the file, the first bad pixel and its channel, and the likely cause.

#include "nebula/io/image_check.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using nebula::Image;
using nebula::requireFinitePixels;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

Image frame()
{
    Image img(4, 3);
    img.layers.push_back({"star.a", std::vector<float>(4 * 3 * 3, 0.5f)});
    img.channels.push_back({"S0.550nm", std::vector<float>(4 * 3, 0.25f)});
    return img;
}

TEST(ImageCheck, FinitePixelsPass)
{
    Image img = frame();
    img.rgba[5] = std::numeric_limits<float>::max();
    img.rgba[6] = -1.0f;
    EXPECT_NO_THROW(requireFinitePixels(img, "f.exr"));
}

TEST(ImageCheck, TheFirstBadPixelIsNamedWithItsChannel)
{
    Image img = frame();
    // Pixel (2, 1) is index 6; its G is rgba[6 * 4 + 1]; a later one is also bad.
    img.rgba[6 * 4 + 1] = std::numeric_limits<float>::infinity();
    img.rgba[11 * 4 + 0] = std::nanf("");
    const std::string msg = errorMessage([&] { requireFinitePixels(img, "f.exr"); });
    EXPECT_EQ(msg.rfind("f.exr: pixel (2, 1) has G = inf; not writing an image with non-finite "
                        "values.",
                        0),
              0u)
        << msg;
    EXPECT_TRUE(contains(msg, "luminosity")) << msg;
    EXPECT_THROW(requireFinitePixels(img, "f.exr"), nebula::Error);

    Image layer = frame();
    layer.layers[0].rgb[3 * 3 + 2] = -std::numeric_limits<float>::infinity(); // (3, 0).B
    EXPECT_EQ(errorMessage([&] {
                  requireFinitePixels(layer, "f.exr");
              }).rfind("f.exr: pixel (3, 0) has star.a.B = -inf;", 0),
              0u);

    Image channel = frame();
    channel.channels[0].values[4] = std::nanf(""); // (0, 1)
    EXPECT_EQ(errorMessage([&] {
                  requireFinitePixels(channel, "f.exr");
              }).rfind("f.exr: pixel (0, 1) has S0.550nm = NaN;", 0),
              0u);
}

} // namespace
