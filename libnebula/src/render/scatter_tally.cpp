// SPDX-License-Identifier: Apache-2.0
/// @file scatter_tally.cpp
/// nebscatter's tallies (scatter_tally.h, DESIGN §5b "Determinism" and "Ranks"): one
/// source's packets over the threads, their integer tallies summed over the threads and the
/// ranks.

#include "scatter_tally.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <string>
#include <utility>

namespace nebula::detail {

namespace {

/// A thread's own tallies: moments and squares.
using ThreadTallies = std::pair<std::vector<std::int64_t>, std::vector<std::int64_t>>;

/// The threads' tallies @p local added into @p out (the first thread's buffers become the
/// sum, none extra), or zeros where no packet ran.
void sumOverThreads(tbb::enumerable_thread_specific<ThreadTallies>& local, std::size_t sumSize,
                    std::size_t slots, SourceTallies& out)
{
    for (auto& buf : local) {
        if (out.sum.empty()) { // the first thread's buffers hold the sum
            out.sum = std::move(buf.first);
            out.sq = std::move(buf.second);
            continue;
        }
        for (std::size_t i = 0; i < sumSize; ++i)
            out.sum[i] += buf.first[i];
        for (std::size_t i = 0; i < slots; ++i)
            out.sq[i] += buf.second[i];
        buf = {};
    }
    local.clear();
    if (out.sum.empty()) { // no packets ran here
        out.sum.assign(sumSize, 0);
        out.sq.assign(slots, 0);
    }
}

} // namespace

void runSourcePackets(const Transport& tr, const SourceSpec& spec, std::uint64_t sourceIndex,
                      const Sampler& sampler, const ScatterOptions& opts, const Run* run,
                      SourceTallies& out)
{
    // Integer sums: per-thread buffers added at the end, or one shared buffer with
    // atomic additions; the same sums either way, whatever the threads.
    out.quantum = fixedQuantum(opts.packets, opts.fieldLevel);
    const std::size_t slots = tr.slotCount();
    const std::size_t sumSize = slots * std::size_t(tr.moments()) * std::size_t(tr.channels());
    // Per-thread buffers: one set per thread, the first of which becomes the sum.
    const double bytes =
        double(sumSize + slots) * 8.0 * double(tbb::this_task_arena::max_concurrency());
    const bool perThread = bytes <= opts.perThreadTallyBytes;
    if (!perThread) {
        out.sum.assign(sumSize, 0);
        out.sq.assign(slots, 0);
    }
    tbb::enumerable_thread_specific<ThreadTallies> local;
    Transport::Tally shared;
    shared.sum = out.sum.data();
    shared.sq = out.sq.data();
    shared.atomic = true;
    shared.invQ = 1.0 / out.quantum;
    shared.invQSq = 1.0 / (out.quantum * 256.0);
    // This rank's packets (all of them in one process): the same streams, so the
    // ranks' summed tallies are one process's.
    const auto [first, last] = opts.ranks
                                   ? opts.ranks->share(opts.packets)
                                   : std::pair<std::uint64_t, std::uint64_t>(0, opts.packets);
    {
        Progress bar(run, "nebscatter " + scatterSourceName(spec.source, tr.mScene.stars),
                     last - first);
        tbb::parallel_for(tbb::blocked_range<std::uint64_t>(first, last, 4096),
                          [&](const tbb::blocked_range<std::uint64_t>& r) {
                              Transport::Tally tally = shared;
                              if (perThread) {
                                  auto& buf = local.local();
                                  if (buf.first.empty()) {
                                      buf.first.assign(sumSize, 0);
                                      buf.second.assign(slots, 0);
                                  }
                                  tally.sum = buf.first.data();
                                  tally.sq = buf.second.data();
                                  tally.atomic = false;
                              }
                              PacketScratch scratch;
                              scratch.pieces.reserve(1024);
                              for (std::uint64_t p = r.begin(); p != r.end(); ++p)
                                  runPacket(tr, spec, sampler, p, opts.seed, sourceIndex, tally,
                                            out.energy, scratch);
                              bar.add(r.size());
                          });
    }
    sumOverThreads(local, sumSize, slots, out);
}

bool sumOverRanks(SourceTallies& t, const Ranks* ranks)
{
    if (!ranks || ranks->size() <= 1) return true;
    ranks->sumToRoot(t.sum.data(), t.sum.size());
    ranks->sumToRoot(t.sq.data(), t.sq.size());
    for (std::int64_t* e : {t.energy.power, t.energy.escaped, t.energy.absorbed})
        ranks->sumToRoot(e, MAX_CHANNELS);
    std::uint64_t flights = t.energy.flights.load();
    ranks->sumToRoot(&flights, 1);
    t.energy.flights = flights;
    return ranks->root(); // rank 0 holds the field
}

} // namespace nebula::detail
