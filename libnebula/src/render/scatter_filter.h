// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_filter.h
/// Internal to render/: nebscatter's noise filter (--denoise, DESIGN §5b "Noise filter"), in
/// scatter_filter.cpp. A local Wiener (Lee) filter in field space, driven by the field's
/// own noise estimate: each cell moves towards the plane fitted to its neighbourhood only as
/// far as its noise exceeds the spread about that plane that the noise does not explain.

#include "nebula/volume/volume.h"

#include <array>
#include <vector>

namespace nebula::detail {

/// What one filter pass did, for -v.
struct DenoiseReport
{
    std::size_t cells = 0;   ///< active cells filtered
    double meanWeight = 0.0; ///< mean k over them (0: kept, 1: replaced by the mean)
    /// The mean relative standard error of J over the cells whose noise is known, before
    /// and (estimated: (1 - k)^2 sigma^2 + k^2 times the neighbourhood's mean noise variance
    /// over its cell count, the cells' noises independent) after.
    double noiseBefore = 0.0, noiseAfter = 0.0;
};

/// A cell of the noise map: inactive (not in the field), or active with no packets (its
/// noise unknown: it takes its neighbours' mean).
inline constexpr float NOISE_INACTIVE = -2.0f;
inline constexpr float NOISE_UNKNOWN = -1.0f;

/// Filters @p moments (every channel: moments x colour channels) over the box @p lo, @p dims
/// of field cells, in place. @p relError: per cell of the box (x fastest), the relative
/// standard error of its channel @p noiseChannel (c_00 of the noise colour), or
/// NOISE_INACTIVE / NOISE_UNKNOWN. Over the active cells of the (2 radius + 1)^3 cells
/// around a cell, a plane a + b . (offset) is fitted by least squares to each channel (the
/// mean where fewer than 5 cells or cells in a plane do not fix one; in a whole box the
/// plane's value at the centre is the mean, and a gradient leaves it unbiased); v is the
/// noise channel's residual variance about its plane, n the mean of the cells' noise
/// variances (rel x)^2, the signal's own spread s^2 = max(0, v - n), the cell's weight
/// k = sigma^2 / (sigma^2 + s^2) (1 where its noise is unknown); then every channel q of the
/// cell becomes y_q + k (plane_q - y_q). A field whose spread is all noise is averaged over
/// the neighbourhood; curvature or an edge the noise cannot explain is kept. Same field
/// whatever the thread count.
DenoiseReport denoiseField(SparseVolume& moments, const std::array<int, 3>& lo,
                           const std::array<int, 3>& dims, const std::vector<float>& relError,
                           int noiseChannel, int radius);

} // namespace nebula::detail
