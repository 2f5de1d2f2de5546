#include "nebula/generate.h"

#include "nebula/error.h"

#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Prune.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nebula {

namespace {

double smoothstep(double e0, double e1, double x)
{
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

/// Shapes fBm (about [-1, 1]) into a clumpy non-negative field: zero in the voids below
/// the threshold, growing as a power into the clumps.
double shape(double f, double threshold, double contrast, double exponent)
{
    const double v = contrast * (f - threshold);
    return v > 0.0 ? std::pow(v, exponent) : 0.0;
}

} // namespace

std::vector<Star> exampleStars()
{
    Star alpha;
    alpha.name = "alpha";
    alpha.position = {0.4, 0.3, -0.2};
    alpha.luminosity = 8000.0;
    alpha.temperature = spectralClassTemperature("B1V");
    Star beta;
    beta.name = "beta";
    beta.position = {-2.6, -1.5, 1.2};
    beta.luminosity = 60.0;
    beta.temperature = spectralClassTemperature("A0V");
    return {alpha, beta};
}

GridSet generateNebula(const NebulaParams& p, const std::function<void(std::size_t)>& progress)
{
    if (p.res < 2 || p.res > 2048) throw UsageError("--res must be in [2, 2048]");
    if (!(p.size > 0.0) || !std::isfinite(p.size)) throw UsageError("--size must be > 0 pc");
    if (!(p.densityPeak >= 0.0)) throw UsageError("--density must be >= 0 cm^-3");
    if (!(p.emissionPeak >= 0.0)) throw UsageError("--emission must be >= 0");
    if (p.fbm.octaves < 1 || p.fbm.octaves > 16) throw UsageError("--octaves must be in [1, 16]");
    if (!(p.cavity >= 0.0)) throw UsageError("--cavity must be >= 0 pc");
    if (!(p.contrast > 0.0)) throw UsageError("--contrast must be > 0");
    if (!(p.exponent > 0.0)) throw UsageError("--exponent must be > 0");
    p.dust.validate();

    const int n = p.res;
    const double voxel = p.size / n;
    // Voxel centres at integer index coordinates, the cube centred on the world origin.
    auto xform = openvdb::math::Transform::createLinearTransform(voxel);
    xform->postTranslate(openvdb::Vec3d(-0.5 * (n - 1) * voxel));

    const openvdb::CoordBBox box(openvdb::Coord(0), openvdb::Coord(n - 1));
    openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> density(box, 0.0f), emission(box, 0.0f);
    const std::uint64_t seed = p.seed;
    const std::uint64_t seedWarp = seed * 0x9E3779B97F4A7C15ull + 1;

    tbb::parallel_for(0, n, [&](int k) {
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
                // Position in cube units, [-0.5, 0.5]^3.
                const double x = (i + 0.5) / n - 0.5, y = (j + 0.5) / n - 0.5,
                             z = (k + 0.5) / n - 0.5;
                const double r = std::sqrt(x * x + y * y + z * z);
                const openvdb::Coord c(i, j, k);
                // Domain warp: displace the lookup by a vector fBm for filaments and lanes.
                const double f = p.frequency;
                const double wx = fbm(x * f, y * f, z * f, p.fbm, seedWarp);
                const double wy = fbm(x * f + 31.4, y * f, z * f, p.fbm, seedWarp);
                const double wz = fbm(x * f, y * f + 47.2, z * f, p.fbm, seedWarp);
                const double qx = x + p.warp * wx, qy = y + p.warp * wy, qz = z + p.warp * wz;
                // Soft spherical envelope, perturbed so the edge is not a sphere.
                // (capped at the cube's inscribed sphere so no face cuts the cloud).
                const double edge = std::min(0.5, p.envelope * (1.0 + 0.35 * wx));
                const double env = 1.0 - smoothstep(0.25 * edge, edge, r);
                double dens = 0.0;
                if (env > 0.0) {
                    const double d = fbm(qx * f, qy * f, qz * f, p.fbm, seed);
                    dens = p.densityPeak * env * shape(d, p.threshold, p.contrast, p.exponent);
                }
                for (const auto& s : p.stars) {
                    if (p.cavity <= 0.0) break;
                    const double sx = x * p.size - s.position[0], sy = y * p.size - s.position[1],
                                 sz = z * p.size - s.position[2];
                    const double dist = std::sqrt(sx * sx + sy * sy + sz * sz);
                    dens *= smoothstep(0.5 * p.cavity, p.cavity, dist);
                }
                double em = 0.0;
                const double envEm = 1.0 - smoothstep(0.4 * p.emissionRadius, p.emissionRadius, r);
                if (envEm > 0.0 && p.emissionPeak > 0.0) {
                    const double e = fbm(qx * f * 1.5, qy * f * 1.5, qz * f * 1.5, p.fbm, seed + 7);
                    em = p.emissionPeak * envEm * shape(e, p.threshold - 0.1, p.contrast, p.exponent);
                }
                density.setValue(c, float(dens));
                emission.setValue(c, float(em));
            }
        }
        if (progress) progress(1);
    });

    // Zero voxels stay inactive (tolerance 0 keeps every non-zero value active).
    auto dGrid = openvdb::FloatGrid::create(0.0f);
    openvdb::tools::copyFromDense(density, dGrid->tree(), 0.0f);
    openvdb::tools::prune(dGrid->tree());
    dGrid->setTransform(xform);
    dGrid->setName("density");
    dGrid->setGridClass(openvdb::GRID_FOG_VOLUME);
    dGrid->insertMeta("units", openvdb::StringMetadata("n_H [cm^-3]"));

    auto eGrid = openvdb::FloatGrid::create(0.0f);
    openvdb::tools::copyFromDense(emission, eGrid->tree(), 0.0f);
    openvdb::tools::prune(eGrid->tree());
    eGrid->setTransform(xform->copy());
    eGrid->setName("emission");
    eGrid->setGridClass(openvdb::GRID_FOG_VOLUME);
    eGrid->insertMeta("units", openvdb::StringMetadata("emission [L_sun pc^-3 sr^-1]"));

    GridSet set;
    set.source = "nebgen";
    set.grids = {dGrid, eGrid};
    set.setStars(p.stars);
    set.setDust(p.dust);
    return set;
}

} // namespace nebula
