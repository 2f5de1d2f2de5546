// SPDX-License-Identifier: Apache-2.0
/// @file bench_montecarlo.cpp
/// Google Benchmark of the Monte Carlo core (montecarlo.h) on one thread: interactions
/// ("events") per second for the MCML estimator in a slab and for the next-event estimator
/// in nebphase's voxel, whose cost per event grows with the number of mu bins (one escape
/// estimate per bin). items = interactions; photons/s as a counter.
///
///     build-bench/bench/nebula_bench --benchmark_filter=MonteCarlo --benchmark_min_time=0.2

#include "nebula/physics/montecarlo.h"

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

namespace {

void run(benchmark::State& state, bool cube, nebula::McEstimator estimator, int bins, double tau)
{
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    nebula::ScatteringMedium medium; // a = 0.6, g = 0.6
    nebula::McSettings set;
    set.estimator = estimator;
    set.muBins = bins;
    const std::uint64_t batch = 4096;
    std::uint64_t first = 0, events = 0;
    for (auto _ : state) {
        const auto tally = cube ? nebula::simulateCube(medium, tau, set, first, batch)
                                : nebula::simulateSlab(medium, tau, 1.0, set, first, batch);
        events += tally.events;
        first += batch;
    }
    state.SetItemsProcessed(std::int64_t(events));
    state.counters["photons"] = benchmark::Counter(double(first), benchmark::Counter::kIsRate);
}

void BM_MonteCarloSlabAnalog(benchmark::State& state)
{
    run(state, false, nebula::McEstimator::Analog, 40, double(state.range(0)));
}
BENCHMARK(BM_MonteCarloSlabAnalog)->Arg(1)->Arg(10)->ArgName("tau")->Unit(benchmark::kMillisecond);

void BM_MonteCarloCubeNextEvent(benchmark::State& state)
{
    run(state, true, nebula::McEstimator::NextEvent, int(state.range(0)), 1.0);
}
BENCHMARK(BM_MonteCarloCubeNextEvent)
    ->Arg(16)
    ->Arg(128)
    ->ArgName("bins")
    ->Unit(benchmark::kMillisecond);

} // namespace
