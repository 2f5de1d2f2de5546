// SPDX-License-Identifier: Apache-2.0
#include "nebula/render/scene.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace nebula {

using detail::numberText;

std::vector<std::array<double, 3>> starColors(const std::vector<Star>& stars,
                                              const RenderOptions& opts)
{
    std::vector<std::array<double, 3>> colors;
    for (const auto& s : stars) {
        if (opts.monochromatic) {
            std::array<double, 3> L;
            for (std::size_t c = 0; c < 3; ++c)
                L[c] =
                    blackbodySpectralLuminosity(s.luminosity, s.temperature, opts.wavelengths[c]);
            colors.push_back(L);
            continue;
        }
        const auto c = blackbodyLinearSRGB(s.temperature);
        colors.push_back({c[0] * s.luminosity, c[1] * s.luminosity, c[2] * s.luminosity});
    }
    return colors;
}

ChannelDust channelDust(const DustParams& dust, const std::array<double, 3>& wavelengths)
{
    ChannelDust out;
    static_cast<DustParams&>(out) = dust;
    for (int c = 0; c < 3; ++c) {
        try {
            out.r[c] = extinctionRatio(dust, wavelengths[c]);
        } catch (const Error& e) { // a wavelength outside the curve: the option's fault
            throw UsageError("--wavelengths: " + std::string(e.what()));
        }
    }
    return out;
}

double latticeDiagonal(const RenderScene& scene)
{
    const auto& d = scene.fields.dims();
    return std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
}

void requireRayStep(const RenderScene& scene, double step)
{
    if (!(step > 0.0) || !std::isfinite(step)) {
        throw UsageError("--step must be a finite number > 0 [voxels], got " + numberText(step));
    }
    const auto& d = scene.fields.dims();
    const double diagonal = latticeDiagonal(scene);
    const double smallest = diagonal / MAX_STEPS_PER_RAY;
    if (step >= smallest) return;
    const double voxel = voxelSize(scene.fields.indexToWorld); // [pc]
    throw UsageError(fmt::format(
        "--step {}: a ray across this grid ({}x{}x{} voxels, {:.4g} voxels corner to corner) "
        "would take {:.3g} steps, more than the limit of {:.0e}; the smallest step for this "
        "grid is {:.3g} voxels ({:.3g} pc)",
        numberText(step), d[0], d[1], d[2], diagonal, diagonal / step, MAX_STEPS_PER_RAY, smallest,
        smallest * voxel));
}

namespace {

/// Per block of a grid of @p n blocks, the largest of @p from over the block and the 26
/// around it (the max norm's neighbours): one axis at a time.
template <class T>
std::vector<T> widenBlocks(const std::vector<T>& from, const std::array<int, 3>& n)
{
    std::vector<T> to = from;
    for (int axis = 0; axis < 3; ++axis) {
        const std::vector<T> before = to;
        const std::ptrdiff_t stride = axis == 0 ? 1 : axis == 1 ? n[0] : n[0] * n[1];
        for (int k = 0; k < n[2]; ++k)
            for (int j = 0; j < n[1]; ++j)
                for (int i = 0; i < n[0]; ++i) {
                    const int at[3] = {i, j, k};
                    const std::size_t b = (std::size_t(k) * n[1] + j) * n[0] + i;
                    if (at[axis] > 0) to[b] = std::max(to[b], before[b - stride]);
                    if (at[axis] + 1 < n[std::size_t(axis)])
                        to[b] = std::max(to[b], before[b + stride]);
                }
    }
    return to;
}

} // namespace

void RenderScene::buildOccupancy()
{
    // A lattice cell is occupied if any of its 8 corners has dust or emission.
    std::vector<std::array<float, 2>> maxima;
    blockMaxima(fields, blocks, maxima);
    occupied.resize(maxima.size());
    for (std::size_t b = 0; b < maxima.size(); ++b) {
        occupied[b] = maxima[b][0] > 0.0f || maxima[b][1] > 0.0f;
    }
    // Distance to the nearest occupied block in blocks (max norm), up to 2.
    const auto one = widenBlocks(occupied, blocks), two = widenBlocks(one, blocks);
    detailReach.resize(occupied.size());
    for (std::size_t b = 0; b < occupied.size(); ++b)
        detailReach[b] = occupied[b] ? 0 : one[b] ? 1 : two[b] ? 3 : 255;
    // The largest density within one block and within two.
    std::vector<float> density(maxima.size());
    for (std::size_t b = 0; b < maxima.size(); ++b)
        density[b] = maxima[b][0];
    const auto within1 = widenBlocks(density, blocks), within2 = widenBlocks(within1, blocks);
    detailDensity.resize(maxima.size());
    for (std::size_t b = 0; b < maxima.size(); ++b)
        detailDensity[b] = {within1[b], within2[b]};
    detail.clear();
    column.clear();
}

const ColumnIntegrator& DensityColumn::get(const SparseVolume& fields) const
{
    const std::lock_guard<std::mutex> lock(mMutex);
    if (!mColumn) mColumn = std::make_unique<ColumnIntegrator>(fields);
    return *mColumn;
}

void DensityColumn::clear()
{
    const std::lock_guard<std::mutex> lock(mMutex);
    mColumn.reset();
}

const SparseVolume& DetailLevels::level(const SparseVolume& fields, int level) const
{
    const std::lock_guard<std::mutex> lock(mMutex);
    while (int(mLevels.size()) < level) {
        const SparseVolume& finer = mLevels.empty() ? fields : *mLevels.back();
        // Channels 2 + s: optical depths, averaged so that the light each star gives the
        // dust (n e^-tau) keeps its mean.
        mLevels.push_back(std::make_unique<SparseVolume>(finer.halfResolution(2, 0)));
    }
    return *mLevels[std::size_t(level - 1)];
}

int DetailLevels::built() const
{
    const std::lock_guard<std::mutex> lock(mMutex);
    return int(mLevels.size());
}

void DetailLevels::clear()
{
    const std::lock_guard<std::mutex> lock(mMutex);
    mLevels.clear();
}

} // namespace nebula
