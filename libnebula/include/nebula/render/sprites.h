// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file sprites.h
/// Star sprites: each star's attenuated flux spread over a small Gaussian footprint.

#include "nebula/io/image.h"
#include "nebula/render/scene.h"

#include <array>
#include <cstddef>
#include <functional>
#include <vector>

namespace nebula {

/// Adds each star's attenuated sprite to the beauty and its star.<name> layer (renderFrame
/// does this unless !opts.drawStars).
/// @p colour, if set, gives star s's attenuated colour (linear sRGB, L_sun) from its V-band
/// optical depth from the eye; otherwise starColor[s] * exp(-r_c tau_V) per channel.
/// @p footprint, if set, is called for every pixel a sprite touches with the star, the pixel
/// index and the factor that turns the star's attenuated luminosity into the pixel's radiance
/// (for outputs other than R,G,B, e.g. spectral channels).
/// The sprite footprint's edge [pixels] for opts.spriteRadius: 2 ceil(2 radius) + 3.
double spriteFootprintEdge(const RenderOptions& opts);

/// Throws UsageError naming --sprite-radius (requireMemory()) if a star sprite's footprint
/// (spriteFootprintEdge()^2 weights) would not fit in memory. drawStarSprites() checks it;
/// the integrators check it before rendering, so that the render does not fail at its end.
void requireSpriteMemory(const RenderOptions& opts);

/// @p direct, if set (width * height * 3), gets the sprites too (the "direct" layer).
void drawStarSprites(Image& img, const RenderScene& scene, const RenderOptions& opts,
                     const std::function<std::array<double, 3>(std::size_t, double)>& colour = {},
                     const std::function<void(std::size_t, std::size_t, double)>& footprint = {},
                     std::vector<float>* direct = nullptr);

} // namespace nebula
