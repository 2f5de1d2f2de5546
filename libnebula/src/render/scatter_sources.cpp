// SPDX-License-Identifier: Apache-2.0
/// @file scatter_sources.cpp
/// nebscatter's sources (DESIGN §5b "Sources"), see scatter_transport.h: each source's
/// strength per voxel and the sampler its packets start from.

#include "scatter_transport.h"

#include "nebula/core/units.h"

#include <algorithm>
#include <cstdint>

namespace nebula::detail {

Sampler buildSampler(const SparseVolume& eta)
{
    Sampler s;
    const auto& lo = eta.lo();
    const auto& d = eta.dims();
    VoxelBits cells(eta, false);
    eta.forEachStoredBrick([&](std::size_t first) {
        for (std::size_t v = first; v < first + SparseVolume::BRICK_VOXELS; ++v) {
            if (!(eta.voxel(v)[0] > 0.0f)) continue;
            const auto p = eta.point(v);
            for (int c = 0; c < 8; ++c) { // the cells with corner p
                const int i = p[0] - (c & 1), j = p[1] - (c >> 1 & 1), k = p[2] - (c >> 2);
                if (i < lo[0] || j < lo[1] || k < lo[2] || i >= lo[0] + d[0] - 1 ||
                    j >= lo[1] + d[1] - 1 || k >= lo[2] + d[2] - 1)
                    continue;
                cells.set(eta.index(i, j, k));
            }
        }
    });
    double sum = 0.0;
    std::size_t brick = SIZE_MAX;
    const float* q[8];
    cells.forEachSet([&](std::size_t idx) {
        const auto p = eta.point(idx);
        eta.cellCorners(p[0], p[1], p[2], idx, q);
        double m = 0.0;
        for (int c = 0; c < 8; ++c)
            m += q[c][0];
        if (!(m > 0.0)) return;
        const std::size_t br = idx / SparseVolume::BRICK_VOXELS;
        if (br != brick) {
            if (brick != SIZE_MAX) s.brickCdf.push_back(sum);
            s.brickFirst.push_back(s.local.size());
            s.brickSlot.push_back(br);
            brick = br;
        }
        s.local.push_back(std::uint16_t(idx % SparseVolume::BRICK_VOXELS));
        s.proxy.push_back(float(m / 8.0));
        sum += double(s.proxy.back());
    });
    if (brick != SIZE_MAX) s.brickCdf.push_back(sum);
    s.brickFirst.push_back(s.local.size());
    s.total = sum;
    return s;
}

Sampler sourceSampler(const Transport& tr, const SourceSpec& spec)
{
    const SparseVolume& f = tr.mScene.fields;
    const int C = tr.channels();
    const double rmin2 = tr.rmin2();
    // Source strength per voxel, summed over channels: eta = k_c a E_c (stars) or
    // 4 pi j (emission, colour 1 in every channel).
    SparseVolume eta(f.lo(), f.dims(), 1); // stored where eta > 0
    eta.indexToWorld = f.indexToWorld;
    for (int k = f.lo()[2]; k < f.lo()[2] + f.dims()[2]; ++k)
        for (int j = f.lo()[1]; j < f.lo()[1] + f.dims()[1]; ++j)
            for (int i = f.lo()[0]; i < f.lo()[0] + f.dims()[0]; ++i) {
                const std::size_t v = f.index(i, j, k);
                const float* fv = f.voxel(v);
                double e = 0.0;
                if (spec.stars.empty()) {
                    e = double(C) * 4.0 * PI * double(fv[1]);
                } else if (fv[0] > 0.0f) {
                    const Vec3 xw = f.indexToWorld.apply(Vec3(i, j, k));
                    for (const std::size_t s : spec.stars) {
                        const Vec3 dv = xw - tr.starPos()[s];
                        double es[MAX_CHANNELS];
                        tr.firstScatteringSource(s, fv[0], std::max(dv.dot(dv), rmin2),
                                                 double(fv[2 + s]), es);
                        for (int c = 0; c < C; ++c)
                            e += es[c];
                    }
                }
                if (e != 0.0) eta.writable(v)[0] = float(e);
            }
    return buildSampler(eta);
}

} // namespace nebula::detail
