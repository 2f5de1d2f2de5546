// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file frame_layers.h
/// The names of a rendered frame's layers (io/image.h's Image::layers), which the integrators
/// write and nebrender, --fits and nebview read by name: the EXR channels <name>.R/G/B.

#include <string>

namespace nebula {

/// Each star's light scattered towards the eye (and its sprite): "star.<name>".
inline std::string starLayerName(const std::string& star)
{
    return "star." + star;
}
/// Per channel, the transmittance along the pixel's ray (every integrator).
inline constexpr const char* TRANSMITTANCE_LAYER = "transmittance";
/// The path tracer's squared standard error of each pixel's mean.
inline constexpr const char* VARIANCE_LAYER = "variance";
/// The fast integrator's components (RenderOptions::componentLayers): the light scattered
/// more than once (nebscatter's field), the gas's glow, and the star sprites (the stars'
/// light that reached the eye unscattered).
inline constexpr const char* FIELD_LAYER = "field";
inline constexpr const char* EMISSION_LAYER = "emission";
inline constexpr const char* DIRECT_LAYER = "direct";

} // namespace nebula
