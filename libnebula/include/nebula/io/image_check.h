// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file image_check.h
/// The check a frame passes before it is written: no pixel may be NaN or infinite.

#include "nebula/io/image.h"

#include <string>

namespace nebula {

/// Throws Error naming @p path, the first pixel (x, y; top row 0) whose value is NaN or
/// infinite, its channel (R, G, B, A, a layer's <name>.R/G/B or a single channel) and the
/// likely cause (a luminosity or scale too large for float radiance, or a star next to the
/// camera), so that no image with non-finite pixels is written. The beauty R,G,B,A are
/// checked first, then each layer and channel in order.
void requireFinitePixels(const Image& image, const std::string& path);

} // namespace nebula
