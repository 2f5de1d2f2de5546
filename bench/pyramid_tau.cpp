// SPDX-License-Identifier: Apache-2.0
// nebpyramid's two tau methods compared on the example nebula:   pyramid_tau [RES] [LEVELS]
// Generates the example nebula at RES^3 (default 128) and its level-0 tau.<star> (nebillum),
// builds levels 1 .. LEVELS (default 3) of the density, then tau.<star>.L<k> both ways:
// recompute (the exact integrator through the coarse density) and average (the mean of the
// level-0 tau over each block; the exact level-0 tau at the centres of the coarse voxels
// next to dust whose blocks hold none). Prints per level the time of each method and the
// max and RMS difference in transmittance exp(-tau) over the coarse voxels where the
// recomputed tau < 5, also split into dusty voxels (coarse density active) and their empty
// neighbours; then how far each method is from the exact optical depth of the level-0
// density at the coarse voxel centres (columnDensity through the level-0 lattice).
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/optical_depth.h"
#include "nebula/stages/generate.h"
#include "nebula/stages/illuminate.h"
#include "nebula/stages/pyramid.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

namespace {

double secondsSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

struct Diff
{
    double max = 0.0, sumSq = 0.0;
    std::size_t count = 0;
    void add(double d)
    {
        max = std::max(max, std::fabs(d));
        sumSq += d * d;
        ++count;
    }
    double rms() const { return count ? std::sqrt(sumSq / double(count)) : 0.0; }
};

} // namespace

int main(int argc, char** argv)
{
    openvdb::initialize();
    nebula::NebulaParams params;
    params.res = argc > 1 ? std::stoi(argv[1]) : 128;
    const int levels = argc > 2 ? std::stoi(argv[2]) : 3;
    params.stars = nebula::exampleStars();

    const nebula::Run run; // silent

    auto grids = nebula::generateNebula(params);
    nebula::IllumOptions illum;
    illum.dust = grids.dust();
    auto start = std::chrono::steady_clock::now();
    nebula::illuminate(grids, illum, run);
    std::printf("res %d^3, %zu stars: level-0 tau (nebillum) %.3f s\n", params.res,
                params.stars.size(), secondsSince(start));
    const auto density = grids.floatGrid("density", "");
    const auto stars = grids.stars();
    const auto dust = grids.dust();

    // The level-0 dense lattice that --tau average needs for the voxels it has no level-0
    // tau for (built once for all levels), and the exact reference.
    start = std::chrono::steady_clock::now();
    const auto fine = nebula::volumeFromGrids({density}, nebula::activeBounds({density}, 1), "");
    const nebula::ColumnIntegrator column(fine);
    const nebula::Affine worldToFine = fine.indexToWorld.inverse();
    std::printf("level-0 dense lattice for --tau average (once): %.3f s\n", secondsSince(start));

    std::printf("level  voxels   recompute   average   |dT| over coarse voxels with tau < 5:"
                " all (max, RMS) / dusty / empty neighbours\n");
    for (int k = 1; k <= levels; ++k) {
        const auto coarse = nebula::boxAverage(*density, k);
        const std::string suffix = ".L" + std::to_string(k);

        start = std::chrono::steady_clock::now();
        nebula::GridSet recomputed;
        nebula::addOpticalDepths(recomputed, *coarse, stars, dust, suffix, run);
        const double tRecompute = secondsSince(start);

        start = std::chrono::steady_clock::now();
        std::vector<openvdb::FloatGrid::Ptr> averaged;
        for (const auto& star : stars) {
            const auto& p = star.position;
            averaged.push_back(nebula::averageOpticalDepth(
                *grids.floatGrid(nebula::tauGridName(star.name), ""), *coarse, k, column,
                worldToFine.apply(nebula::Vec3(p[0], p[1], p[2])), dust.kappa_V));
        }
        const double tAverage = secondsSince(start);

        Diff all, dusty, empty, recVsExact, avgVsExact;
        std::size_t missing = 0;
        const auto densityAcc = coarse->getConstAccessor();
        for (std::size_t s = 0; s < stars.size(); ++s) {
            const auto rec = recomputed.floatGrid(
                nebula::levelGridName(nebula::tauGridName(stars[s].name), k), "");
            const auto avg = averaged[s]->getConstAccessor();
            const auto& p = stars[s].position;
            const nebula::Vec3 star = worldToFine.apply(nebula::Vec3(p[0], p[1], p[2]));
            const double half = 0.5 * ((1 << k) - 1);
            for (auto it = rec->cbeginValueOn(); it; ++it) {
                float a = 0.0f;
                if (!avg.probeValue(it.getCoord(), a)) {
                    ++missing;
                    continue;
                }
                if (!(*it < 5.0f)) continue;
                const double d = std::exp(-double(a)) - std::exp(-double(*it));
                all.add(d);
                (densityAcc.isValueOn(it.getCoord()) ? dusty : empty).add(d);
                const auto& I = it.getCoord();
                const nebula::Vec3 centre((1 << k) * I.x() + half, (1 << k) * I.y() + half,
                                          (1 << k) * I.z() + half);
                const double exact = std::exp(-dust.kappa_V * column(star, centre));
                recVsExact.add(std::exp(-double(*it)) - exact);
                avgVsExact.add(std::exp(-double(a)) - exact);
            }
        }
        std::printf("L%d  %7zu  %8.3f s  %7.3f s   all %.4f, %.4f / dusty %.4f, %.4f / "
                    "empty %.4f, %.4f  (%zu voxels; %zu recomputed without an average)\n",
                    k, std::size_t(coarse->activeVoxelCount()), tRecompute, tAverage, all.max,
                    all.rms(), dusty.max, dusty.rms(), empty.max, empty.rms(), all.count, missing);
        std::printf("          vs the exact tau of the level-0 density at the coarse centres: "
                    "recompute %.4f, %.4f / average %.4f, %.4f (max, RMS)\n",
                    recVsExact.max, recVsExact.rms(), avgVsExact.max, avgVsExact.rms());
    }
    return 0;
}
