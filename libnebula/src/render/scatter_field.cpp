// SPDX-License-Identifier: Apache-2.0
/// @file scatter_field.cpp
/// nebscatter's Monte Carlo (DESIGN §5b), see scatter_field.h: the field level, the field
/// over its sources with its report (computeField()), the spectral field, and the field as
/// the renderer adds it. Beneath computeField(), private to render/: the sources
/// (scatter_sources.cpp), the transport (scatter_transport.h/.cpp: Transport; and
/// scatter_packets.cpp: the packets and the flight walk), the tallies summed over threads
/// and ranks (scatter_tally.h/.cpp) and the cells from the tallies (scatter_reconstruct.h/.cpp).

#include "nebula/render/scatter_field.h"

#include "scatter_reconstruct.h"
#include "scatter_tally.h"
#include "scatter_transport.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/spherical_harmonics.h"
#include "nebula/volume/block_walk.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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
    if (opts.denoise < 0 || opts.denoise > MAX_DENOISE_RADIUS) {
        throw UsageError(fmt::format("--denoise must be in 0..{} (field cells on each side of "
                                     "the noise filter's neighbourhood; 0: none), got {}",
                                     MAX_DENOISE_RADIUS, opts.denoise));
    }
    if (opts.ranks && std::uint64_t(opts.ranks->size()) > opts.packets) {
        throw UsageError(fmt::format(
            "--packets {} is fewer than the {} MPI ranks sharing them: give at least one packet "
            "per rank (--packets {} or more), or start fewer ranks",
            opts.packets, opts.ranks->size(), opts.ranks->size()));
    }
}

namespace {

/// The sources of a field: the stars together ("stars") or each on its own (perStar), and
/// the gas emission where the scene has any.
std::vector<SourceSpec> fieldSources(const RenderScene& scene, const ScatterOptions& opts)
{
    const SparseVolume& f = scene.fields;
    const std::size_t S = scene.stars.size();
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
    return specs;
}

/// -v: how many active field cells the adaptive cells tally each, and the tallies' size.
void reportAdaptiveCells(const Transport& tr, const ScatterOptions& opts, const Run& run)
{
    std::size_t active = 0, own = 0;
    for (std::size_t c = 0; c < tr.active().size(); ++c) {
        if (!tr.active()[c]) continue;
        ++active;
        own += tr.slotBlock()[std::size_t(tr.slots()[c])] < 0;
    }
    run.info(fmt::format(
        "adaptive cells: {} of {} active field cells tallied each (their blocks of 2x2x2 "
        "thicker than tau_V {:g} across, next to a star, or bordering such a block), the "
        "rest by blocks: {} tallies ({:.0f} MiB a set)",
        own, active, opts.refineTau, tr.slotCount(),
        double(tr.slotCount()) * double(tr.moments()) * double(tr.channels()) * 8.0 /
            (1024.0 * 1024.0)));
}

/// The noise of J (the -v figure) below which a frame shows no colour blotches: the
/// chromaticity of two seeds' frames then differs by less than 0.3 % RMS over the faint
/// cloud. Measured on the 128^3 reflection preset (bench/colour_noise.sh): 0.70 % at a noise
/// of J of 3.9 % (1e6 packets), falling as the noise does (1/sqrt(packets)).
constexpr double CLEAN_FRAME_J_NOISE = 0.3 / 0.70 * 0.039;

/// -v: a source's packets, flights, power and noise.
void reportSource(const Transport& tr, const ScatterSourceField& out, const Run& run)
{
    // R, G, B; a spectral field: its first, middle and last wavelengths.
    const std::size_t a = 0, b = std::size_t(tr.noiseChannel()), e = std::size_t(tr.channels()) - 1;
    const auto& wl = tr.channelSet().wavelengths;
    const std::string which = wl.empty()
                                  ? std::string("R,G,B")
                                  : fmt::format("at {:g}, {:g}, {:g} nm", wl[a], wl[b], wl[e]);
    run.info(fmt::format(
        "{}: {} packets, {} flights ({:.3g} per packet); collided power {} {:.4g} "
        "{:.4g} {:.4g} L_sun{}: escaped {:.4g} {:.4g} {:.4g}, absorbed {:.4g} {:.4g} "
        "{:.4g}; noise of J {:.2g} % (mean relative standard error per field cell, "
        "weighted by its scattered light)",
        scatterSourceName(out.source, tr.mScene.stars), out.packets, out.flights,
        double(out.flights) / double(out.packets), which, out.power[a], out.power[b], out.power[e],
        wl.empty() ? "" : " nm^-1", out.escaped[a], out.escaped[b], out.escaped[e], out.absorbed[a],
        out.absorbed[b], out.absorbed[e], 100.0 * out.relativeError));
    if (out.relativeError > CLEAN_FRAME_J_NOISE) {
        // The noise falls as 1/sqrt(N): N (noise / clean)^2, rounded up to 2 digits.
        const double n = double(out.packets) * std::pow(out.relativeError / CLEAN_FRAME_J_NOISE, 2);
        const double step = std::pow(10.0, std::floor(std::log10(n)) - 1.0);
        run.info(fmt::format(
            "{}: a frame free of colour blotches in the faint cloud (a dome master of any size: "
            "the blotches are the field's cells, not pixels) needs the noise of J below about "
            "{:.2g} %: --packets {:.0f} or more",
            scatterSourceName(out.source, tr.mScene.stars), 100.0 * CLEAN_FRAME_J_NOISE,
            std::ceil(n / step) * step));
    }
}

/// A source's field before its packets run: its name, packet count, zero energies and an
/// empty moment volume on the field lattice.
ScatterSourceField emptySourceField(const Transport& tr, const SourceSpec& spec,
                                    const ScatterOptions& opts)
{
    const std::size_t C = std::size_t(tr.channels());
    ScatterSourceField out;
    out.source = spec.source;
    out.packets = opts.packets;
    out.power.assign(C, 0.0);
    out.escaped.assign(C, 0.0);
    out.absorbed.assign(C, 0.0);
    out.moments = SparseVolume(tr.fieldLo(), tr.fieldDims(), tr.moments() * int(C));
    out.moments.indexToWorld = fieldLevelMap(tr.mScene.fields.indexToWorld, opts.fieldLevel);
    return out;
}

/// The summed tallies @p t of a source (unit of the weights @p U, a voxel's world volume
/// @p detA) into its field @p out: energies, flights, every cell's moments and the noise.
void fillSourceField(const Transport& tr, const SourceTallies& t, double U, double detA,
                     int denoise, const Run* run, ScatterSourceField& out)
{
    const double quantum = t.quantum;
    for (int c = 0; c < tr.channels(); ++c) {
        out.power[c] = double(t.energy.power[c]) * quantum * U;
        out.escaped[c] = double(t.energy.escaped[c]) * quantum * U;
        out.absorbed[c] = double(t.energy.absorbed[c]) * quantum * U;
    }
    out.flights = t.energy.flights.load();
    const FieldBlocks blocks = gatherBlocks(tr, t, U, detA);
    std::vector<float> relError;
    out.relativeError =
        fillFieldCells(tr, t, blocks, U, detA, out.moments, denoise > 0 ? &relError : nullptr);
    if (denoise > 0) {
        const DenoiseReport r = denoiseField(out.moments, tr.fieldLo(), tr.fieldDims(), relError,
                                             tr.noiseChannel(), denoise);
        if (run) {
            run->info(fmt::format(
                "noise filter (--denoise {}): {} cells, mean weight {:.2f} towards their "
                "{}^3 neighbourhood; noise of J per cell (unweighted mean) {:.2g} % before, "
                "about {:.2g} % after",
                denoise, r.cells, r.meanWeight, 2 * denoise + 1, 100.0 * r.noiseBefore,
                100.0 * r.noiseAfter));
        }
    }
    copyBorderCells(tr, out.moments);
}

/// computeScatterField() for the channels @p channels (R, G, B or a spectral field's
/// wavelengths): one walk carries them all. Per source: its sampler, its packets over the
/// threads and ranks, and, on rank 0, its tallies turned into the field.
ScatterField computeField(const RenderScene& scene, const RenderOptions& ropts,
                          const ScatterOptions& opts, Channels channels, const Run* run)
{
    validateScatterOptions(scene, opts);
    const Transport tr(scene, ropts, opts, std::move(channels));
    const double detA = std::pow(voxelSize(scene.fields.indexToWorld), 3); // a voxel [pc^3]
    const std::vector<SourceSpec> specs = fieldSources(scene, opts);

    ScatterField field;
    field.order = opts.order;
    field.level = opts.fieldLevel;
    field.active = tr.active();
    if (run && tr.adaptive()) reportAdaptiveCells(tr, opts, *run);
    for (std::size_t si = 0; si < specs.size(); ++si) {
        const SourceSpec& spec = specs[si];
        const Sampler sampler = sourceSampler(tr, spec);
        ScatterSourceField out = emptySourceField(tr, spec, opts);
        if (sampler.total > 0.0) {
            SourceTallies tallies;
            runSourcePackets(tr, spec, si, sampler, opts, run, tallies);
            if (!sumOverRanks(tallies, opts.ranks)) { // rank 0 holds the field
                field.sources.push_back(std::move(out));
                continue;
            }
            // Unit of the weights: the source's power over C N (w_c is about 1).
            const double U = sampler.total * detA / (double(tr.channels()) * double(opts.packets));
            fillSourceField(tr, tallies, U, detA, opts.denoise, run, out);
        }
        if (run) reportSource(tr, out, *run);
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
