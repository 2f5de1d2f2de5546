// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file path_tracer.h
/// nebrender --integrator path: the reference path tracer (DESIGN §6).

#include "nebula/core/run.h"
#include "nebula/io/image.h"
#include "nebula/render/scene.h"

namespace nebula {

/// The reference integrator (DESIGN §6): unbiased volumetric path tracing of the same scene,
/// each RGB channel its own random walk (one walk for all three in grey dust, where their
/// extinctions are equal). Free flights by delta tracking against a majorant
/// that is constant on each occupancy block (kappa_V r_c times the block's largest density);
/// emission by the collision estimator at every tentative collision (the majorant has a floor
/// of two collisions per voxel where there is gas); at every real collision the weight is
/// multiplied by the albedo, every star is sampled (next-event estimation, transmittance by
/// ratio tracking, 1/r^2 clamped as in renderFrame), and the walk continues in a
/// phase-sampled direction; Russian roulette after a few bounces. opts.spp walks per pixel
/// and channel, each pixel and sample with its own PCG32 stream (deterministic for a seed,
/// whatever the thread count). Output: the beauty R,G,B (the mean), A = 1 - T_G, layers
/// star.<name> (sprites only), "transmittance" (ratio-tracked, per channel) and "variance"
/// (variance of each channel's pixel mean, i.e. the squared standard error).
/// Throws UsageError unless opts.spp > 0 and opts.spp x the pixels is at most MAX_PATH_WALKS
/// (the estimate and the bound in the message). nebrender checks it before loading the scene.
void requirePathWalks(const RenderOptions& opts);

Image renderPathTraced(const RenderScene& scene, const RenderOptions& opts,
                       const Run* run = nullptr, RenderStats* stats = nullptr);

} // namespace nebula
