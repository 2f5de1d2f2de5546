// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file fast.h
/// nebrender's fast integrator: the single-scattering ray caster with the effective phase
/// function and pyramid levels (DESIGN §3-5).

#include "nebula/core/run.h"
#include "nebula/io/image.h"
#include "nebula/render/scene.h"

namespace nebula {

/// Renders the single-scattering image: beauty R,G,B,A (A = 1 - T at the green channel),
/// layer "star.<name>" per star (its scattered light and sprite), layer "transmittance".
Image renderFrame(const RenderScene& scene, const RenderOptions& opts, const Run* run = nullptr,
                  RenderStats* stats = nullptr);

} // namespace nebula
