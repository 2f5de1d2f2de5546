/// @file scatter_field.cpp
/// nebscatter's Monte Carlo (DESIGN §5b), see scatter_field.h: the field level, the walk over
/// the sources with its tallies and report (computeField()), the spectral field, and the field
/// as the renderer adds it. Beneath it: scatter_transport.h (Transport) and
/// scatter_packets.cpp (runPacket()).

#include "nebula/render/scatter_field.h"

#include "scatter_transport.h"

#include "nebula/core/error.h"
#include "nebula/core/rng.h"
#include "nebula/core/units.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/render/star_depth.h"
#include "nebula/volume/block_walk.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>

namespace nebula {

using namespace detail; // scatter_transport.h: the Monte Carlo beneath computeField()

Affine fieldLevelMap(const Affine& level0, int level)
{
    const double s = std::ldexp(1.0, level), off = 0.5 * (s - 1.0);
    Affine a;
    for (std::size_t i = 0; i < 9; ++i)
        a.m[i] = level0.m[i] * s;
    a.t = level0.apply(Vec3(off, off, off));
    return a;
}

namespace {

/// The grid's own extent along its longest axis [voxels]: the dense lattice has a one-voxel
/// zero border on each side.
int gridExtent(const RenderScene& scene)
{
    const auto& d = scene.fields.dims();
    return std::max({d[0], d[1], d[2]}) - 2;
}

/// The coarsest field level whose cells are not larger than a grid of @p extent voxels.
int coarsestFieldLevel(int extent)
{
    int k = 0;
    while ((2 << k) <= std::max(extent, 1))
        ++k;
    return k;
}

} // namespace

FieldLevelChoice autoFieldLevel(const RenderScene& scene, int order, int channels, double refineTau)
{
    FieldLevelChoice c;
    const auto& d = scene.fields.dims();
    const int extent = gridExtent(scene);
    // About 64 cells across: 45 to 90.
    while (double(extent) >= 64.0 * std::sqrt(2.0) * std::ldexp(1.0, c.gridLevel))
        ++c.gridLevel;
    const int coarsest = coarsestFieldLevel(extent);
    // The densest 1 % of the dust voxels.
    std::vector<float> n;
    for (std::size_t i = 0; i < scene.fields.voxelCount(); ++i)
        if (const float v = scene.fields.voxel(i)[0]; v > 0.0f) n.push_back(v);
    double n99 = 0.0;
    if (!n.empty()) {
        const auto k = std::size_t(0.99 * double(n.size() - 1));
        std::nth_element(n.begin(), n.begin() + std::ptrdiff_t(k), n.end());
        n99 = n[k];
    }
    const double voxel = voxelSize(scene.fields.indexToWorld);
    c.voxelTau = scene.dust.kappa_V * n99 * voxel;
    const double perCell = double(shCount(order)) * double(channels) * 8.0;
    const auto tallyBytes = [&](int k) {
        if (k >= 0) { // every cell of the box: a bound
            double cells = 1.0;
            for (int a = 0; a < 3; ++a)
                cells *= double(((d[a] - 2) >> k) + 2);
            return cells * perCell;
        }
        // Half-voxel cells: adaptive ones tally a voxel (a block) whole unless it is
        // thicker than refineTau across (or next to a star), and then each of its 8 cells;
        // twice the slots for the active cells round the dust; and the lattice's per-cell
        // bookkeeping (13 bytes a cell). The field itself holds every cell (4-byte moments,
        // nearly every brick of a cloud is stored), in nebscatter and in nebrender: it must
        // fit in the budget too, which keeps half-voxel cells to grids of about 74^3 at
        // L = 4 (the larger of the two is returned).
        double thick = double(n.size());
        if (refineTau > 0.0) {
            const double nThick = refineTau / (scene.dust.kappa_V * voxel);
            thick = double(
                std::count_if(n.begin(), n.end(), [&](float v) { return double(v) > nThick; }));
        }
        const double slots = 2.0 * (8.0 * thick + (double(n.size()) - thick));
        double cells = 1.0;
        for (int a = 0; a < 3; ++a)
            cells *= 2.0 * double(d[a]) + 1.0;
        return std::max(slots * perCell + cells * 13.0, cells * perCell / 2.0);
    };
    c.level = c.gridLevel;
    while (c.level > MIN_FIELD_LEVEL && std::ldexp(c.voxelTau, c.level) > AUTO_FIELD_MAX_CELL_TAU &&
           tallyBytes(c.level - 1) <= AUTO_FIELD_MAX_TALLY_BYTES)
        --c.level;
    while (c.level < coarsest && tallyBytes(c.level) > AUTO_FIELD_MAX_TALLY_BYTES)
        ++c.level; // many channels (a spectral field)
    c.cellTau = std::ldexp(c.voxelTau, c.level);
    c.tallyBytes = tallyBytes(c.level);
    return c;
}

void validateScatterOptions(const RenderScene& scene, const ScatterOptions& opts)
{
    if (opts.order < 0 || opts.order > SH_MAX_DEGREE) {
        throw UsageError("--order must be in 0.." + std::to_string(SH_MAX_DEGREE) +
                         " (the degree of the spherical harmonics), got " +
                         std::to_string(opts.order));
    }
    if (opts.packets == 0 || opts.packets > MAX_PACKETS) {
        throw UsageError(fmt::format(
            "--packets must be in [1, {:g}] per source, got {} (the default 1e6 takes 15-25 s "
            "per star on 2 cores, so {:g} would take 4-7 hours and more would not finish)",
            double(MAX_PACKETS), opts.packets, double(MAX_PACKETS)));
    }
    const auto& d = scene.fields.dims();
    const int extent = gridExtent(scene);
    if (opts.fieldLevel < MIN_FIELD_LEVEL || opts.fieldLevel > coarsestFieldLevel(extent)) {
        throw UsageError(fmt::format(
            "--field-level {}: use a level in {}..{} (cells of {} to {} voxels; the grid is "
            "{}x{}x{} voxels, and cells of {} voxels would be {})",
            opts.fieldLevel, MIN_FIELD_LEVEL, coarsestFieldLevel(extent),
            fieldCellVoxels(MIN_FIELD_LEVEL), fieldCellVoxels(coarsestFieldLevel(extent)), d[0] - 2,
            d[1] - 2, d[2] - 2, fieldCellVoxels(opts.fieldLevel),
            opts.fieldLevel < MIN_FIELD_LEVEL ? "finer than the walk's half-voxel lattice"
                                              : "larger than the grid"));
    }
    if (!(opts.refineTau >= 0.0 && opts.refineTau <= MAX_REFINE_TAU)) {
        throw UsageError(fmt::format(
            "--refine-tau must be in [0, {:g}] (the optical depth tau_V across a block of "
            "2x2x2 field cells above which its cells are tallied each; 0: every cell), got {:g}",
            MAX_REFINE_TAU, opts.refineTau));
    }
    if (opts.ranks && std::uint64_t(opts.ranks->size()) > opts.packets) {
        throw UsageError(fmt::format(
            "--packets {} is fewer than the {} MPI ranks sharing them: give at least one packet "
            "per rank (--packets {} or more), or start fewer ranks",
            opts.packets, opts.ranks->size(), opts.ranks->size()));
    }
}

namespace {

/// computeScatterField() for the channels @p channels (R, G, B or a spectral field's
/// wavelengths): one walk carries them all.
ScatterField computeField(const RenderScene& scene, const RenderOptions& ropts,
                          const ScatterOptions& opts, Channels channels, const Run* run)
{
    validateScatterOptions(scene, opts);
    const Transport tr(scene, ropts, opts, std::move(channels));
    const int C = tr.channels();
    const std::size_t UC = std::size_t(C);
    const SparseVolume& f = scene.fields;
    const std::size_t S = scene.stars.size();
    const double detA = std::pow(voxelSize(f.indexToWorld), 3); // world volume of a voxel

    std::vector<SourceSpec> specs;
    if (opts.perStar) {
        for (std::size_t s = 0; s < S; ++s)
            specs.push_back({ScatterSource::oneStar(s), {s}});
    } else if (S > 0) {
        SourceSpec all{ScatterSource::allStars(), {}};
        for (std::size_t s = 0; s < S; ++s)
            all.stars.push_back(s);
        specs.push_back(all);
    }
    bool hasEmission = false;
    for (std::size_t i = 0; i < f.voxelCount() && !hasEmission; ++i)
        hasEmission = f.voxel(i)[1] > 0.0f;
    if (opts.emission && hasEmission) specs.push_back({ScatterSource::emission(), {}});

    ScatterField field;
    field.order = opts.order;
    field.level = opts.fieldLevel;
    const auto& fLo = tr.fieldLo();
    const auto& fDims = tr.fieldDims();
    const int nm = tr.moments();
    const Affine fieldMap = fieldLevelMap(f.indexToWorld, opts.fieldLevel);
    const double rmin2 = tr.rmin2();

    field.active = tr.active();
    if (run && tr.adaptive()) {
        std::size_t active = 0, own = 0;
        for (std::size_t c = 0; c < field.active.size(); ++c) {
            if (!field.active[c]) continue;
            ++active;
            own += tr.slotBlock()[std::size_t(tr.slots()[c])] < 0;
        }
        run->info(fmt::format(
            "adaptive cells: {} of {} active field cells tallied each (their blocks of 2x2x2 "
            "thicker than tau_V {:g} across, next to a star, or bordering such a block), the "
            "rest by blocks: {} tallies ({:.0f} MiB a set)",
            own, active, opts.refineTau, tr.slotCount(),
            double(tr.slotCount()) * double(tr.moments()) * double(tr.channels()) * 8.0 /
                (1024.0 * 1024.0)));
    }
    const std::vector<double>& cellDust = tr.cellDust(); // the noise report's weights

    for (std::size_t si = 0; si < specs.size(); ++si) {
        const SourceSpec& spec = specs[si];
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
        const Sampler sampler = buildSampler(eta);
        eta = SparseVolume();

        ScatterSourceField out;
        out.source = spec.source;
        const std::string name = scatterSourceName(spec.source, scene.stars);
        out.packets = opts.packets;
        out.power.assign(UC, 0.0);
        out.escaped.assign(UC, 0.0);
        out.absorbed.assign(UC, 0.0);
        out.moments = SparseVolume(fLo, fDims, nm * C);
        out.moments.indexToWorld = fieldMap;
        if (sampler.total > 0.0) {
            // Integer sums: per-thread buffers added at the end, or one shared buffer with
            // atomic additions; the same sums either way, whatever the threads.
            const double quantum = fixedQuantum(opts.packets, opts.fieldLevel);
            const std::size_t slots = tr.slotCount();
            const std::size_t sumSize = slots * std::size_t(nm) * UC;
            // Per-thread buffers: one set per thread, the first of which becomes the sum.
            const double bytes =
                double(sumSize + slots) * 8.0 * double(tbb::this_task_arena::max_concurrency());
            const bool perThread = bytes <= opts.perThreadTallyBytes;
            std::vector<std::int64_t> sumAll, sqAll;
            if (!perThread) {
                sumAll.assign(sumSize, 0);
                sqAll.assign(slots, 0);
            }
            tbb::enumerable_thread_specific<
                std::pair<std::vector<std::int64_t>, std::vector<std::int64_t>>>
                local;
            Transport::Tally shared;
            shared.sum = sumAll.data();
            shared.sq = sqAll.data();
            shared.atomic = true;
            shared.invQ = 1.0 / quantum;
            shared.invQSq = 1.0 / (quantum * 256.0);
            EnergySums energy;
            // This rank's packets (all of them in one process): the same streams, so the
            // ranks' summed tallies are one process's.
            const auto [first, last] =
                opts.ranks ? opts.ranks->share(opts.packets)
                           : std::pair<std::uint64_t, std::uint64_t>(0, opts.packets);
            {
                Progress bar(run, "nebscatter " + name, last - first);
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
                                          runPacket(tr, spec, sampler, p, opts.seed, si, tally,
                                                    energy, scratch);
                                      bar.add(r.size());
                                  });
            }
            for (auto& buf : local) {
                if (sumAll.empty()) { // the first thread's buffers hold the sum
                    sumAll = std::move(buf.first);
                    sqAll = std::move(buf.second);
                    continue;
                }
                for (std::size_t i = 0; i < sumSize; ++i)
                    sumAll[i] += buf.first[i];
                for (std::size_t i = 0; i < slots; ++i)
                    sqAll[i] += buf.second[i];
                buf = {};
            }
            local.clear();
            if (sumAll.empty()) { // no packets ran here
                sumAll.assign(sumSize, 0);
                sqAll.assign(slots, 0);
            }
            if (opts.ranks && opts.ranks->size() > 1) {
                opts.ranks->sumToRoot(sumAll.data(), sumAll.size());
                opts.ranks->sumToRoot(sqAll.data(), sqAll.size());
                for (std::int64_t* e : {energy.power, energy.escaped, energy.absorbed})
                    opts.ranks->sumToRoot(e, MAX_CHANNELS);
                std::uint64_t flights = energy.flights.load();
                opts.ranks->sumToRoot(&flights, 1);
                energy.flights = flights;
                if (!opts.ranks->root()) { // rank 0 holds the field
                    field.sources.push_back(std::move(out));
                    continue;
                }
            }
            // Unit of the weights: the source's power over C N (w_c is about 1).
            const double U = sampler.total * detA / (double(C) * double(opts.packets));
            for (int c = 0; c < C; ++c) {
                out.power[c] = double(energy.power[c]) * quantum * U;
                out.escaped[c] = double(energy.escaped[c]) * quantum * U;
                out.absorbed[c] = double(energy.absorbed[c]) * quantum * U;
            }
            out.flights = energy.flights.load();
            // c_lm = sum (w U) (length) Y_lm / V over the cell.
            const std::size_t per = std::size_t(nm) * UC;
            const auto volumeOf = [&](int I, int J, int K) {
                return tr.cellVolume({I + fLo[0], J + fLo[1], K + fLo[2]}) * detA;
            };
            // Adaptive cells: each block's moments, from its own tally or its refined
            // cells', over the volume of its active cells (the tallied ones).
            std::vector<std::int32_t> blockIndex;
            std::vector<double> blockValue, blockVol, blockS1, blockSq;
            if (tr.adaptive()) {
                blockIndex.assign(tr.blockRefined().size(), -1);
                std::size_t nb = 0;
                for (int K = 0; K < fDims[2]; ++K)
                    for (int J = 0; J < fDims[1]; ++J)
                        for (int I = 0; I < fDims[0]; ++I) {
                            const std::size_t c = (std::size_t(K) * fDims[1] + J) * fDims[0] + I;
                            const double vol = volumeOf(I, J, K);
                            if (!(vol > 0.0) || tr.slots()[c] < 0) continue;
                            std::int32_t& bi = blockIndex[tr.blockOf(c)];
                            if (bi < 0) {
                                bi = std::int32_t(nb++);
                                blockValue.resize(nb * per, 0.0);
                                blockVol.push_back(0.0);
                                blockS1.push_back(0.0);
                                blockSq.push_back(0.0);
                            }
                            blockVol[std::size_t(bi)] += vol;
                            const std::int32_t slot = tr.slots()[c];
                            if (tr.slotBlock()[std::size_t(slot)] >= 0) continue; // below
                            const std::int64_t* t = sumAll.data() + std::size_t(slot) * per;
                            for (std::size_t q = 0; q < per; ++q)
                                blockValue[std::size_t(bi) * per + q] += double(t[q]);
                        }
                for (std::size_t slot = 0; slot < slots; ++slot) {
                    const std::int64_t blk = tr.slotBlock()[slot];
                    if (blk < 0 || blockIndex[std::size_t(blk)] < 0) continue;
                    const std::size_t bi = std::size_t(blockIndex[std::size_t(blk)]);
                    const std::int64_t* t = sumAll.data() + slot * per;
                    for (std::size_t q = 0; q < per; ++q)
                        blockValue[bi * per + q] += double(t[q]);
                    blockS1[bi] = double(t[tr.noiseChannel()]) * quantum;
                    blockSq[bi] = double(sqAll[slot]) * quantum * 256.0;
                }
                for (std::size_t bi = 0; bi < nb; ++bi)
                    for (std::size_t q = 0; q < per; ++q)
                        blockValue[bi * per + q] *= quantum * U * tr.voxel() / blockVol[bi];
            }
            // A cell of an unrefined block: the block's value plus its slope along each axis
            // times the cell's offset from the block's centre (+-1/4 block). The slope is the
            // monotonised central difference of the neighbouring blocks' values (limited:
            // no new extremes at a shadow's edge), 0 where a neighbour has no active cells.
            // The eight cells' offsets cancel, so the block's mean is kept.
            const auto blockAt = [&](const int* B) -> std::int32_t {
                for (int a = 0; a < 3; ++a)
                    if (B[a] < 0 || B[a] >= tr.blockDims()[a]) return -1;
                return blockIndex[(std::size_t(B[2]) * tr.blockDims()[1] + std::size_t(B[1])) *
                                      tr.blockDims()[0] +
                                  std::size_t(B[0])];
            };
            const auto reconstructCell = [&](int I, int J, int K, float* m) {
                const int X[3] = {I + fLo[0], J + fLo[1], K + fLo[2]};
                int B[3];
                double offset[3];
                for (int a = 0; a < 3; ++a) {
                    const int b = Transport::blockCoord(X[a]);
                    B[a] = b - tr.blockLo()[a];
                    offset[a] = X[a] - 2 * b == 0 ? -0.25 : 0.25;
                }
                const std::size_t own = std::size_t(blockAt(B));
                std::int32_t lower[3], upper[3];
                for (int a = 0; a < 3; ++a) {
                    int N[3] = {B[0], B[1], B[2]};
                    N[a] = B[a] - 1;
                    lower[a] = blockAt(N);
                    N[a] = B[a] + 1;
                    upper[a] = blockAt(N);
                }
                for (std::size_t q = 0; q < per; ++q) {
                    const double v = blockValue[own * per + q];
                    double value = v;
                    for (int a = 0; a < 3; ++a) {
                        if (lower[a] < 0 || upper[a] < 0) continue;
                        const double dl = v - blockValue[std::size_t(lower[a]) * per + q];
                        const double du = blockValue[std::size_t(upper[a]) * per + q] - v;
                        if (!(dl * du > 0.0)) continue; // an extreme: flat
                        const double mag = std::min(
                            {0.5 * std::abs(dl + du), 2.0 * std::abs(dl), 2.0 * std::abs(du)});
                        value += std::copysign(mag, du) * offset[a];
                    }
                    m[q] = float(value);
                }
            };
            double errW = 0.0, errSum = 0.0;
            for (int K = 0; K < fDims[2]; ++K)
                for (int J = 0; J < fDims[1]; ++J)
                    for (int I = 0; I < fDims[0]; ++I) {
                        const std::size_t c = (std::size_t(K) * fDims[1] + J) * fDims[0] + I;
                        const double vol = volumeOf(I, J, K);
                        const std::int32_t slot = tr.slots()[c];
                        if (!(vol > 0.0) || slot < 0) continue; // not active: stays 0
                        float* m = out.moments.writable(
                            out.moments.index(I + fLo[0], J + fLo[1], K + fLo[2]));
                        const std::int64_t blk =
                            tr.adaptive() ? tr.slotBlock()[std::size_t(slot)] : -1;
                        double s1 = 0.0, sq = 0.0, density = 0.0; // the noise report
                        if (blk >= 0) {
                            reconstructCell(I, J, K, m);
                            const std::size_t bi = std::size_t(blockIndex[std::size_t(blk)]);
                            s1 = blockS1[bi];
                            sq = blockSq[bi];
                            density = s1 / blockVol[bi];
                        } else {
                            const double scale = quantum * U * tr.voxel() / vol;
                            const std::int64_t* t = sumAll.data() + std::size_t(slot) * per;
                            for (std::size_t q = 0; q < per; ++q)
                                m[q] = float(double(t[q]) * scale);
                            s1 = double(t[tr.noiseChannel()]) * quantum;
                            sq = double(sqAll[std::size_t(slot)]) * quantum * 256.0;
                            density = s1 / vol;
                        }
                        if (cellDust[c] > 0.0 && s1 > 0.0) {
                            // Y_00 folded out: the noise channel's J tally is t[c] / Y_00.
                            const double rel = std::sqrt(sq) / (s1 / (0.5 / std::sqrt(PI)));
                            const double wgt = cellDust[c] * density;
                            errW += wgt;
                            errSum += wgt * rel;
                        }
                    }
            out.relativeError = errW > 0.0 ? errSum / errW : 0.0;
            // The border cells (outside the walked box) copy their nearest cell, so the
            // trilinear field does not fall towards zero at the grid's edge.
            for (int K = 0; K < fDims[2]; ++K)
                for (int J = 0; J < fDims[1]; ++J)
                    for (int I = 0; I < fDims[0]; ++I) {
                        const int I2 = std::clamp(I, 1, fDims[0] - 2);
                        const int J2 = std::clamp(J, 1, fDims[1] - 2);
                        const int K2 = std::clamp(K, 1, fDims[2] - 2);
                        if (I2 == I && J2 == J && K2 == K) continue;
                        const float* src = out.moments.voxel(
                            out.moments.index(I2 + fLo[0], J2 + fLo[1], K2 + fLo[2]));
                        float* dst = out.moments.writable(
                            out.moments.index(I + fLo[0], J + fLo[1], K + fLo[2]));
                        std::copy(src, src + nm * C, dst);
                    }
        }
        if (run) {
            // R, G, B; a spectral field: its first, middle and last wavelengths.
            const std::size_t a = 0, b = std::size_t(tr.noiseChannel()), e = UC - 1;
            const auto& wl = tr.channelSet().wavelengths;
            const std::string which =
                wl.empty() ? std::string("R,G,B")
                           : fmt::format("at {:g}, {:g}, {:g} nm", wl[a], wl[b], wl[e]);
            run->info(fmt::format(
                "{}: {} packets, {} flights ({:.3g} per packet); collided power {} {:.4g} "
                "{:.4g} {:.4g} L_sun{}: escaped {:.4g} {:.4g} {:.4g}, absorbed {:.4g} {:.4g} "
                "{:.4g}; noise of J {:.2g} % (mean relative standard error per field cell, "
                "weighted by its scattered light)",
                name, out.packets, out.flights, double(out.flights) / double(out.packets), which,
                out.power[a], out.power[b], out.power[e], wl.empty() ? "" : " nm^-1",
                out.escaped[a], out.escaped[b], out.escaped[e], out.absorbed[a], out.absorbed[b],
                out.absorbed[e], 100.0 * out.relativeError));
        }
        field.sources.push_back(std::move(out));
    }
    return field;
}

} // namespace

ScatterField computeScatterField(const RenderScene& scene, const RenderOptions& ropts,
                                 const ScatterOptions& opts, const Run* run)
{
    return computeField(scene, ropts, opts, rgbChannels(scene), run);
}

void addScatterMoments(SparseVolume& total, const SparseVolume& src,
                       const std::vector<double>& factor, double c00Factor)
{
    const std::size_t C = std::size_t(src.channels());
    const std::size_t per = factor.size();          // channels per moment: it divides C
    src.forEachStoredBrick([&](std::size_t first) { // zeros add nothing
        const float* a = src.voxel(first);
        float* b = total.writable(first);
        for (std::size_t i = 0; i < SparseVolume::BRICK_VOXELS * C; ++i) {
            const std::size_t q = i % C; // k * per + c
            b[i] += float(factor[q % per] * a[i] * (q < per ? c00Factor : 1.0));
        }
    });
}

std::vector<double> spectralFieldWavelengths(int n)
{
    if (n < 2) {
        throw UsageError("a spectral field needs at least 2 wavelengths, got " + std::to_string(n));
    }
    std::vector<double> wl;
    for (int i = 0; i < n; ++i)
        wl.push_back(SPECTRAL_FIELD_MIN_NM +
                     (SPECTRAL_FIELD_MAX_NM - SPECTRAL_FIELD_MIN_NM) * i / double(n - 1));
    return wl;
}

double starSpectralPower(const Star& star, double lambda_nm)
{
    // Y of the unit black body: the spectrum linear between 1 nm nodes against the CMFs.
    constexpr int NODES = 471; // 360..830 nm
    static const std::vector<XYZ> weights = hatWeights(360.0, 1.0, NODES);
    double Y = 0.0;
    for (int j = 0; j < NODES; ++j)
        Y += weights[std::size_t(j)][1] * planckPerNm(360.0 + j, star.temperature);
    return star.luminosity * planckPerNm(lambda_nm, star.temperature) / Y;
}

ScatterField computeSpectralScatterField(const RenderScene& scene, const RenderOptions& ropts,
                                         const ScatterOptions& opts,
                                         const std::vector<double>& wavelengths, const Run* run)
{
    const std::size_t N = wavelengths.size();
    if (N < 2 || N > SPECTRAL_FIELD_MAX_WAVELENGTHS) {
        throw UsageError(fmt::format("a spectral field has 2..{} wavelengths, got {}",
                                     SPECTRAL_FIELD_MAX_WAVELENGTHS, N));
    }
    Channels ch;
    ch.wavelengths = wavelengths;
    for (const double lam : wavelengths) {
        try {
            ch.r.push_back(extinctionRatio(scene.dust, lam));
        } catch (const Error& e) {
            throw UsageError("spectral field: " + std::string(e.what()));
        }
    }
    for (const auto& star : scene.stars) {
        ch.starPower.emplace_back();
        for (const double lam : wavelengths)
            ch.starPower.back().push_back(starSpectralPower(star, lam));
    }
    ScatterOptions o = opts;
    o.emission = false; // the spectral renderer does not scatter the gas's glow
    ScatterField field = computeField(scene, ropts, o, std::move(ch), run);
    field.wavelengths = wavelengths;
    return field;
}

ScatterField spectralFieldSubset(const ScatterField& field, std::size_t stride)
{
    ScatterField sub = field;
    const std::size_t N = field.wavelengths.size();
    std::vector<std::size_t> keep;
    sub.wavelengths.clear();
    for (std::size_t i = 0; i < N; i += std::max<std::size_t>(stride, 1)) {
        keep.push_back(i);
        sub.wavelengths.push_back(field.wavelengths[i]);
    }
    const int nm = shCount(field.order);
    for (std::size_t si = 0; si < field.sources.size(); ++si) {
        const SparseVolume& a = field.sources[si].moments;
        SparseVolume b(a.lo(), a.dims(), nm * int(keep.size()));
        b.indexToWorld = a.indexToWorld;
        a.forEachStoredBrick([&](std::size_t first) {
            for (std::size_t v = first; v < first + SparseVolume::BRICK_VOXELS; ++v) {
                float* q = b.writable(v);
                for (int k = 0; k < nm; ++k)
                    for (std::size_t i = 0; i < keep.size(); ++i)
                        q[std::size_t(k) * keep.size() + i] =
                            a.voxel(v)[std::size_t(k) * N + keep[i]];
            }
        });
        ScatterSourceField& out = sub.sources[si];
        out.moments = std::move(b);
        for (auto* per : {&out.power, &out.escaped, &out.absorbed}) {
            std::vector<double> kept;
            for (const std::size_t i : keep)
                kept.push_back((*per)[i]);
            *per = std::move(kept);
        }
    }
    return sub;
}

SceneScatterField sceneScatterField(const ScatterField& field, const RenderOptions& opts)
{
    SceneScatterField out;
    if (field.sources.empty()) return out;
    out.order = field.order;
    out.level = field.level;
    out.wavelengths = field.wavelengths;
    out.moments = field.sources[0].moments;
    out.moments.setZero();
    for (const auto& src : field.sources) {
        std::vector<double> factor(field.wavelengths.empty() ? 3 : field.wavelengths.size(), 1.0);
        if (src.source.kind == ScatterSource::Kind::Emission && field.wavelengths.empty()) {
            for (std::size_t c = 0; c < 3; ++c)
                factor[c] = opts.emissionScale * opts.emissionColor[c];
        }
        addScatterMoments(out.moments, src.moments, factor);
    }
    out.description = "scattered-light field (in memory)";
    return out;
}

} // namespace nebula
