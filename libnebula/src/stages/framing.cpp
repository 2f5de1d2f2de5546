// SPDX-License-Identifier: Apache-2.0
/// @file framing.cpp
/// --frame-nebula's target from the density grid (stages/framing.h).
#include "nebula/stages/framing.h"

#include "nebula/core/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace nebula {

namespace {

/// Calls @p f(world position, mass) for each positive active value of @p grid (a tile: its
/// value times its voxels, at its centre).
template <class F> void forEachMass(const openvdb::FloatGrid& grid, F&& f)
{
    const openvdb::math::Transform& xf = grid.transform();
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        const double v = *it;
        if (!(v > 0.0) || !std::isfinite(v)) continue;
        if (it.isVoxelValue()) {
            const openvdb::Vec3d p = xf.indexToWorld(it.getCoord());
            f(Vec3(p.x(), p.y(), p.z()), v);
        } else {
            openvdb::CoordBBox box;
            it.getBoundingBox(box);
            const openvdb::Vec3d p = xf.indexToWorld(box.getCenter());
            f(Vec3(p.x(), p.y(), p.z()), v * double(box.volume()));
        }
    }
}

} // namespace

FramingTarget dustFramingTarget(const GridSet& grids, const std::string& densityGrid)
{
    const auto grid = grids.floatGrid(densityGrid, "--density-grid");
    double mass = 0.0;
    Vec3 sum;
    forEachMass(*grid, [&](const Vec3& p, double m) {
        mass += m;
        sum = sum + p * m;
    });
    if (!(mass > 0.0)) {
        throw UsageError("--frame-nebula: the density grid \"" + densityGrid + "\" of " +
                         grids.source +
                         " holds no dust (no value above 0): there is nothing to frame");
    }
    FramingTarget t;
    t.centre = sum * (1.0 / mass);
    forEachMass(*grid, [&](const Vec3& p, double) {
        t.extent = std::max(t.extent, (p - t.centre).length());
    });
    // The radius holding the mass fraction, from a histogram of distances.
    constexpr int BINS = 8192;
    std::vector<double> hist(BINS, 0.0);
    const double scale = t.extent > 0.0 ? BINS / t.extent : 0.0;
    forEachMass(*grid, [&](const Vec3& p, double m) {
        const int b = std::min(BINS - 1, int((p - t.centre).length() * scale));
        hist[std::size_t(b)] += m;
    });
    double cumulative = 0.0;
    for (int b = 0; b < BINS; ++b) {
        cumulative += hist[std::size_t(b)];
        if (cumulative >= FRAMING_MASS_FRACTION * mass) {
            t.radius = std::min(t.extent, (b + 1) * t.extent / BINS);
            break;
        }
    }
    return t;
}

Camera frameNebula(const GridSet& grids, const std::string& densityGrid, const Camera& camera,
                   const FramingChoice& keep, const Run& run)
{
    const FramingTarget t = dustFramingTarget(grids, densityGrid);
    const Camera c = frameCamera(camera, t, keep);
    run.info(fmt::format("--frame-nebula: the dust of \"{}\": centroid {:.4g},{:.4g},{:.4g} pc, "
                         "{:.0f} % of its mass within {:.4g} pc, all within {:.4g} pc; --eye "
                         "{:.4g},{:.4g},{:.4g}{}, --look-at {:.4g},{:.4g},{:.4g}",
                         densityGrid, t.centre.x, t.centre.y, t.centre.z,
                         100.0 * FRAMING_MASS_FRACTION, t.radius, t.extent, c.eye.x, c.eye.y,
                         c.eye.z, keep.keepEye ? " (given)" : "", c.lookAt.x, c.lookAt.y,
                         c.lookAt.z));
    return c;
}

} // namespace nebula
