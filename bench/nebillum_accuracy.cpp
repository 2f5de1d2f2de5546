// SPDX-License-Identifier: Apache-2.0
// nebillum's production optical depth against the independent reference, on the example
// nebula:   nebillum_accuracy [RES] [SAMPLES]
// Generates the example nebula at RES^3 (default 256), times the production path
// (opticalDepthAt over the active voxels and their neighbours, as nebillum runs it) for each
// star, then integrates the reference for SAMPLES random output voxels (default 20000) and
// prints the worst transmittance error where tau < 5 (the target: 0.5 %).
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/optical_depth.h"
#include "nebula/stages/generate.h"
#include "nebula/stages/illuminate.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

int main(int argc, char** argv)
{
    openvdb::initialize();
    nebula::NebulaParams params;
    params.res = argc > 1 ? std::stoi(argv[1]) : 256;
    const int samples = argc > 2 ? std::stoi(argv[2]) : 20000;
    params.stars = nebula::exampleStars();

    const auto grids = nebula::generateNebula(params);
    const auto density = grids.floatGrid("density", "");
    const auto n = nebula::volumeFromGrids({density}, nebula::activeBounds({density}, 1), "bench");
    const std::vector<std::uint32_t> points =
        nebula::tauSupportPoints(*nebula::tauSupport(*density), n);
    std::printf("res %d^3: %zu output voxels (active + neighbours) of %zu lattice points\n",
                params.res, points.size(), n.voxelCount());

    std::mt19937_64 rng(42);
    std::uniform_int_distribution<std::size_t> pick(0, points.size() - 1);
    for (const auto& star : params.stars) {
        const nebula::Vec3 s = n.indexToWorld.inverse().apply(
            nebula::Vec3(star.position[0], star.position[1], star.position[2]));
        const auto t0 = std::chrono::steady_clock::now();
        const auto tau = nebula::opticalDepthAt(n, s, params.dust.kappa_V, points);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        double worstT = 0.0, maxTau = 0.0;
        for (int k = 0; k < samples; ++k) {
            const std::size_t idx = points[pick(rng)];
            const auto p = n.point(idx);
            const nebula::Vec3 v(p[0], p[1], p[2]);
            const double ref = params.dust.kappa_V * nebula::columnDensityReference(n, s, v);
            maxTau = std::max(maxTau, ref);
            if (ref < 5.0) worstT = std::max(worstT, std::abs(std::exp(ref - tau[idx]) - 1.0));
        }
        std::printf("star %-6s: %.3f s (%.0f ns per output voxel); vs reference at %d voxels "
                    "(max tau %.2f): worst |dT/T| %.2e for tau < 5\n",
                    star.name.c_str(), seconds, 1e9 * seconds / double(points.size()), samples,
                    maxTau, worstT);
    }
    return 0;
}
