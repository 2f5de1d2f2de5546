// SPDX-License-Identifier: Apache-2.0
/// @file bench_kernels.cpp
/// Google Benchmark of the hot paths (STYLE "Determinism and speed"): noise and fBm
/// (nebgen), the exact column integrator (nebillum), the 4-channel trilinear lookup and the
/// phase functions (nebrender's inner loop), and a whole single-scattering frame, with and
/// without the effective phase-function table; and the machine's memory read bandwidth, the
/// yardstick the README measures the kernels against.
/// Every benchmark reports items per second; quote its figures as ratios.
///
///     build-bench/bench/nebula_bench --benchmark_min_time=0.2
///
/// Inputs are fixed-seed random, so runs are comparable. Each benchmark is short: the
/// machine is shared.

#include "nebula/cli/cli.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/noise.h"
#include "nebula/physics/optical_depth.h"
#include "nebula/render/fast.h"
#include "nebula/stages/generate.h"
#include "nebula/stages/illuminate.h"
#include "nebula/stages/scene_assembly.h"
#include "nebula/volume/volume.h"

#include <benchmark/benchmark.h>
#include <openvdb/openvdb.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

namespace {

constexpr std::uint64_t SEED = 20240601;
constexpr std::size_t POINTS = 4096; // inputs cycled through (fit in L1/L2 with the volume)

/// @p count fixed-seed random points, each coordinate uniform in [lo, hi).
std::vector<nebula::Vec3> randomPoints(std::size_t count, double lo, double hi,
                                       std::uint64_t seed = SEED)
{
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<nebula::Vec3> p(count);
    for (auto& q : p)
        q = nebula::Vec3(u(rng), u(rng), u(rng));
    return p;
}

/// An N^3 volume, lattice [0, N-1]^3, voxel 1, every channel uniform random in [0, 1).
nebula::SparseVolume randomVolume(int N, int channels)
{
    nebula::SparseVolume v({0, 0, 0}, {N, N, N}, channels);
    std::mt19937_64 rng(SEED);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        for (int c = 0; c < channels; ++c)
            v.writable(i)[c] = u(rng);
    return v;
}

// ---- noise.h: one call of perlinNoise / fbm per item (fbm: default 6 octaves) ----------

void BM_PerlinNoise(benchmark::State& state)
{
    const auto p = randomPoints(POINTS, -50.0, 50.0);
    std::size_t i = 0;
    for (auto _ : state) {
        const auto& q = p[i++ & (POINTS - 1)];
        benchmark::DoNotOptimize(nebula::perlinNoise(q.x, q.y, q.z));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PerlinNoise);

void BM_Fbm(benchmark::State& state)
{
    const auto p = randomPoints(POINTS, -5.0, 5.0);
    nebula::FbmParams params;
    params.octaves = int(state.range(0));
    std::size_t i = 0;
    for (auto _ : state) {
        const auto& q = p[i++ & (POINTS - 1)];
        benchmark::DoNotOptimize(nebula::fbm(q.x, q.y, q.z, params, 1));
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["octaves"] = benchmark::Counter(double(state.iterations()) * params.octaves,
                                                   benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Fbm)->Arg(6)->ArgName("octaves");

// ---- optical_depth.h: ColumnIntegrator on random segments through a random 64^3 volume -
// items = segments; "cells" = lattice cells the segments cross (sum over axes of the
// number of plane crossings, + 1), the integrator's unit of work. Every cell is dusty
// (no empty-space skipping): the worst case.

void BM_ColumnIntegrator(benchmark::State& state)
{
    constexpr int N = 64;
    const nebula::SparseVolume vol = randomVolume(N, 1);
    const nebula::ColumnIntegrator integrate(vol);
    const auto a = randomPoints(POINTS, 0.0, N - 1.0, SEED);
    const auto b = randomPoints(POINTS, 0.0, N - 1.0, SEED + 1);
    std::vector<double> cells(POINTS);
    for (std::size_t k = 0; k < POINTS; ++k) {
        double c = 1.0;
        for (int ax = 0; ax < 3; ++ax)
            c += std::abs(std::floor(b[k][ax]) - std::floor(a[k][ax]));
        cells[k] = c;
    }
    double crossed = 0.0;
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & (POINTS - 1);
        benchmark::DoNotOptimize(integrate(a[k], b[k]));
        crossed += cells[k];
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["cells"] = benchmark::Counter(crossed, benchmark::Counter::kIsRate);
    state.counters["cells/seg"] = crossed / double(state.iterations());
}
BENCHMARK(BM_ColumnIntegrator);

// ---- volume.h: SparseVolume::sample, 4 channels (nebrender: density, emission, 2 tau) ---

void BM_DenseSample4(benchmark::State& state)
{
    constexpr int N = 64;
    const nebula::SparseVolume vol = randomVolume(N, 4);
    const auto p = randomPoints(POINTS, 0.0, N - 1.0);
    float out[4];
    std::size_t i = 0;
    for (auto _ : state) {
        vol.sample(p[i++ & (POINTS - 1)], out);
        benchmark::DoNotOptimize(out);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DenseSample4);

// ---- the machine: memory read bandwidth ------------------------------------------------
// Sums 1 GiB of floats (far beyond every cache) with Arg threads, each its own contiguous
// part: bytes per second is the sustained read bandwidth the kernels' loads compete for.

void BM_MemoryRead(benchmark::State& state)
{
    static const std::vector<float> data(std::size_t(1) << 28, 1.0f); // 1 GiB, touched once
    const std::size_t threads = std::size_t(state.range(0));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<double> sums(threads);
    for (auto _ : state) {
        tbb::parallel_for(std::size_t(0), threads, [&](std::size_t t) {
            const std::size_t n = data.size() / threads;
            const float* p = data.data() + t * n;
            float acc[16] = {};
            for (std::size_t i = 0; i < n; i += 16)
                for (int k = 0; k < 16; ++k)
                    acc[k] += p[i + std::size_t(k)];
            double sum = 0.0;
            for (const float a : acc)
                sum += a;
            sums[t] = sum;
        });
        benchmark::DoNotOptimize(sums.data());
    }
    state.SetBytesProcessed(std::int64_t(state.iterations()) *
                            std::int64_t(data.size() * sizeof(float)));
}
BENCHMARK(BM_MemoryRead)->Arg(1)->Arg(2)->ArgName("threads")->UseRealTime();

// ---- dust.h: phaseFunction, per model (0 hg, 1 rayleigh, 2 hazy, 3 murky) --------------

void BM_PhaseFunction(benchmark::State& state)
{
    const auto model = static_cast<nebula::PhaseModel>(state.range(0));
    state.SetLabel(nebula::toString(model));
    std::mt19937_64 rng(SEED);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<double> mu(POINTS);
    for (double& m : mu)
        m = u(rng);
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(nebula::phaseFunction(model, mu[i++ & (POINTS - 1)], 0.6));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PhaseFunction)->DenseRange(0, 3)->ArgName("model");

// ---- render.h: a whole renderFrame ------------------------------------------------------
// The example nebula at 64^3 with one star (nebgen --res 64 --star alpha:0.4,0.3,-0.2:8000:
// B1V, nebillum), default camera at 128x128. items = samples (RenderStats: field lookups
// in occupied space); "rays" = rays that met the box. Arg: worker threads.

const nebula::RenderScene& smallScene()
{
    static const std::unique_ptr<nebula::RenderScene> scene = [] {
        openvdb::initialize();
        const nebula::Run run; // silent: no progress bars
        nebula::NebulaParams params;
        params.res = 64;
        nebula::Star alpha;
        alpha.name = "alpha";
        alpha.position = {0.4, 0.3, -0.2};
        alpha.luminosity = 8000.0;
        alpha.temperature = nebula::spectralClassTemperature("B1V");
        params.stars = {alpha};
        nebula::GridSet grids = nebula::generateNebula(params);
        nebula::IllumOptions illum;
        illum.dust = params.dust;
        nebula::illuminate(grids, illum, run);
        const nebula::RenderOptions opts; // a named value: GCC 12 misreads a temporary's string
        return std::make_unique<nebula::RenderScene>(nebula::buildScene(grids, opts, grids.dust()));
    }();
    return *scene;
}

void BM_RenderFrame(benchmark::State& state)
{
    const nebula::RenderScene& scene = smallScene();
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                std::size_t(state.range(0)));
    const nebula::Run run; // silent: no progress bars
    nebula::RenderOptions opts;
    opts.camera.width = opts.camera.height = 128;
    nebula::RenderStats stats;
    double samples = 0.0, rays = 0.0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(nebula::renderFrame(scene, opts, &run, &stats));
        samples += double(stats.samples);
        rays += double(stats.rays);
    }
    state.SetItemsProcessed(std::int64_t(samples));
    state.counters["rays"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.counters["samples/frame"] = samples / double(state.iterations());
}
BENCHMARK(BM_RenderFrame)
    ->Arg(1)
    ->Arg(2)
    ->ArgName("threads")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The same frame on one thread with the effective phase-function table (nebrender --phase),
// Arg 1, against Arg 0 without it: the cost of the table lookups. The table has the default
// shape (64 t x 128 mu); its values (a p(mu) in every row) do not change the lookup cost.
void BM_RenderFramePhaseTable(benchmark::State& state)
{
    const nebula::RenderScene& scene = smallScene();
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    nebula::RenderOptions opts;
    opts.camera.width = opts.camera.height = 128;
    if (state.range(0)) {
        auto table = std::make_shared<nebula::PhaseTable>();
        const nebula::PhaseTableSpec spec;
        table->tMin = spec.tMin;
        table->tMax = spec.tMax;
        table->tCount = spec.tCount;
        table->muBins = spec.muBins;
        table->photons.assign(std::size_t(spec.tCount), 1);
        for (int j = 0; j < spec.tCount; ++j)
            for (int i = 0; i < spec.muBins; ++i)
                table->phi.push_back(
                    float(0.6 * nebula::henyeyGreenstein(table->muCentre(i), 0.6)));
        table->error.assign(table->phi.size(), 0.0f);
        table->single = table->phi;
        opts.phaseTable = table;
    }
    nebula::RenderStats stats;
    double samples = 0.0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(nebula::renderFrame(scene, opts, nullptr, &stats));
        samples += double(stats.samples);
    }
    state.SetItemsProcessed(std::int64_t(samples));
}
BENCHMARK(BM_RenderFramePhaseTable)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("table")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

} // namespace
