// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/stats.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"
#include "nebula/core/units.h"
#include "nebula/io/grid_values.h"
#include "nebula/stages/export.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <map>

namespace nebula {

using detail::numberText;

void StatsOptions::validate() const
{
    if (axis < 0 || axis > 2) throw UsageError("--axis must be x, y or z");
    validateBbox(bbox);
    if (kMin != 0.0 || kMax != 0.0) {
        if (!(kMin > 0.0 && kMax > kMin && std::isfinite(kMax))) {
            throw UsageError("--k-range must be KMIN,KMAX with 0 < KMIN < KMAX [cycles per map "
                             "edge], got " +
                             numberText(kMin) + "," + numberText(kMax));
        }
    }
    if (!(binWidth > 0.0 && binWidth <= 1.0)) {
        throw UsageError("--bin-width must be in (0, 1] (in ln N), got " + numberText(binWidth));
    }
    if (!(pdfFloor >= 0.0 && pdfFloor < 1.0)) {
        throw UsageError("--pdf-floor must be in [0, 1) (times the mean column), got " +
                         numberText(pdfFloor));
    }
    if (levels < 1 || levels > 100) throw UsageError("--levels must be in [1, 100]");
    if (minArea < 1) throw UsageError("--min-area must be >= 1 pixel");
}

namespace {

const char* axisName(int axis)
{
    return axis == 0 ? "x" : axis == 1 ? "y" : "z";
}

/// The map's axes (u, v) for a line of sight along @p axis: z -> (x, y), y -> (x, z),
/// x -> (y, z).
std::array<int, 2> mapAxes(int axis)
{
    return axis == 2   ? std::array<int, 2>{0, 1}
           : axis == 1 ? std::array<int, 2>{0, 2}
                       : std::array<int, 2>{1, 2};
}

} // namespace

CloudStats cloudStatistics(const GridSet& grids, const StatsOptions& opts)
{
    opts.validate();
    const auto grid = grids.floatGrid(opts.grid, "--grid");
    CloudStats st;
    st.grid = opts.grid;
    st.axis = opts.axis;
    if (grid->activeVoxelCount() == 0 && (opts.bbox == "auto" || opts.bbox == "active")) {
        throw UsageError("--grid " + opts.grid +
                         ": the grid has no active voxels: nothing to "
                         "measure");
    }
    st.box = exportBox(*grid, opts.bbox);
    const auto vs = grid->transform().voxelSize();
    if (std::abs(vs[0] - vs[1]) > 1e-9 * vs[0] || std::abs(vs[0] - vs[2]) > 1e-9 * vs[0]) {
        throw UsageError("--grid " + opts.grid + ": voxels are not cubes (" + numberText(vs[0]) +
                         " x " + numberText(vs[1]) + " x " + numberText(vs[2]) + " pc)");
    }
    st.voxelPc = vs[0];
    const bool density = opts.grid == "density";
    std::string units = "value";
    if (const auto meta = (*grid)["units"]) units = meta->str();
    st.columnUnit = density ? "cm^-2" : units + " pc";
    const double length = density ? st.voxelPc * PC_CM : st.voxelPc;

    // Plain variables, not a structured binding: lambdas below capture them (C++17).
    const std::array<int, 2> axes = mapAxes(opts.axis);
    const int ua = axes[0], va = axes[1];
    const auto& lo = st.box[0];
    const auto& hi = st.box[1];
    const std::int64_t nu = std::int64_t(hi[std::size_t(ua)]) - lo[std::size_t(ua)] + 1;
    const std::int64_t nv = std::int64_t(hi[std::size_t(va)]) - lo[std::size_t(va)] + 1;
    // The work and the memory follow the map, not the box's depth: refused before any of it
    // where the map is larger than nebstats measures (the power spectrum takes the square of
    // its longer edge) or than the machine holds.
    const bool given = opts.bbox != "auto" && opts.bbox != "active";
    const std::string where = fmt::format(
        "{}: grid \"{}\": the column map along {} over the box {},{},{} to {},{},{}", grids.source,
        opts.grid, axisName(opts.axis), lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    const auto refuse = [&](const std::string& why) {
        if (given) throw UsageError("--bbox " + opts.bbox + ": " + where + " " + why);
        throw Error(where + " " + why + "; give --bbox I0,J0,K0,I1,J1,K1 to measure a part");
    };
    if (std::max(nu, nv) > MAX_MAP_EDGE) {
        refuse(fmt::format("is {} x {} pixels, more than the {} a side nebstats measures", nu, nv,
                           MAX_MAP_EDGE));
    }
    const double edge2 = double(std::max(nu, nv)) * double(std::max(nu, nv));
    const double memory = MAP_BYTES_PER_PIXEL * edge2;
    if (const std::uint64_t have = physicalMemory(); have && memory > double(have)) {
        refuse(fmt::format("is {} x {} pixels; measuring it needs {} of memory, this machine has "
                           "{}",
                           nu, nv, bytesText(memory), bytesText(double(have))));
    }
    // A NaN or infinite voxel would make every figure NaN: refused, named, as every tool does.
    requireFinite(*grid, grids.source);

    st.map.nu = int(nu);
    st.map.nv = int(nv);
    st.map.values.assign(std::size_t(nu) * std::size_t(nv), 0.0);
    const auto pixel = [&](int u, int v) -> double& {
        return st.map.values[std::size_t(v - lo[std::size_t(va)]) * std::size_t(nu) +
                             std::size_t(u - lo[std::size_t(ua)])];
    };
    // Voxels one by one; tiles (8^3 to 4096^3 voxels of one value) analytically: a tile adds
    // value x its depth in the box to each pixel of its face, so the tiles of one size
    // stacked along the axis are summed first, and each face is spread over its pixels once.
    // The work is the active voxels plus the map's pixels (once per tile size), however
    // large the tiles.
    struct Face
    {
        openvdb::CoordBBox bb; ///< the face's clipped extent (along the axis: any)
        double column = 0.0;   ///< the tiles' sum of value x depth x length
    };
    std::map<std::array<int, 3>, Face> faces; // (tile edge, u, v of its origin)
    const openvdb::CoordBBox box(openvdb::Coord(lo[0], lo[1], lo[2]),
                                 openvdb::Coord(hi[0], hi[1], hi[2]));
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        const double v = *it;
        if (it.isVoxelValue()) {
            const openvdb::Coord c = it.getCoord();
            if (!box.isInside(c)) continue;
            pixel(c[ua], c[va]) += v * length;
            st.volume.add(v);
            continue;
        }
        openvdb::CoordBBox bb;
        it.getBoundingBox(bb);
        const openvdb::Coord tileMin = bb.min();
        const int tileEdge = bb.dim()[0];
        bb.intersect(box);
        if (bb.empty()) continue;
        const double depth = double(bb.dim()[opts.axis]);
        const double area = double(bb.dim()[ua]) * double(bb.dim()[va]);
        Face& f = faces[{tileEdge, tileMin[ua], tileMin[va]}];
        f.bb = bb;
        f.column += v * depth * length;
        st.volume.add(v, std::size_t(area * depth));
    }
    for (const auto& [key, f] : faces) {
        for (int j = f.bb.min()[va]; j <= f.bb.max()[va]; ++j) {
            for (int i = f.bb.min()[ua]; i <= f.bb.max()[ua]; ++i)
                pixel(i, j) += f.column;
        }
    }
    std::size_t pixels = 0;
    for (double v : st.map.values) {
        if (v > 0.0) {
            st.meanColumn += v;
            st.maxColumn = std::max(st.maxColumn, v);
            ++pixels;
        }
    }
    if (pixels == 0) {
        throw UsageError("--grid " + opts.grid + ": no positive column along " +
                         axisName(opts.axis) + " in the box");
    }
    st.meanColumn /= double(pixels);
    st.pdf = fitColumnPdf(st.map, opts.binWidth, opts.pdfFloor);
    const double edge = std::max(st.map.nu, st.map.nv);
    const double kMin = opts.kMin > 0.0 ? opts.kMin : std::max(1.0, edge / 40.0);
    const double kMax = opts.kMax > 0.0 ? opts.kMax : edge / 4.0;
    try {
        st.spectrum = powerSpectrum(st.map, kMin, kMax);
    } catch (const Error& e) {
        // A range the user asked for must hold; the default one on a map too small for it
        // leaves the spectrum unfitted and the rest of the report stands.
        if (opts.kMin > 0.0) throw UsageError(std::string("--k-range: ") + e.what());
        st.spectrum = SpectrumFit{};
        st.spectrum.kMin = kMin;
        st.spectrum.kMax = kMax;
    }
    st.contours = perimeterAreaDimension(st.map, opts.levels, opts.minArea);
    return st;
}

std::string statsReport(const CloudStats& s)
{
    const double edgePc = std::max(s.map.nu, s.map.nv) * s.voxelPc;
    std::string o = fmt::format("grid       {}, box {},{},{} to {},{},{}, voxel {:.3g} pc\n",
                                s.grid, s.box[0][0], s.box[0][1], s.box[0][2], s.box[1][0],
                                s.box[1][1], s.box[1][2], s.voxelPc);
    o += fmt::format("volume     ln(value): mean {:.3f}, sigma {:.3f} over {} voxels > 0\n",
                     s.volume.mean(), s.volume.sigma(), s.volume.count());
    o += fmt::format("column     along {}: {} x {} map; mean {:.3g} {}, max {:.3g}, over {} "
                     "pixels > 0\n",
                     axisName(s.axis), s.map.nu, s.map.nv, s.meanColumn, s.columnUnit, s.maxColumn,
                     s.map.positive());
    if (s.pdf.fitted) {
        o += fmt::format("pdf        lognormal sigma(ln N) {:.3f}, peak at ln(N/<N>) {:.3f} ({} "
                         "pixels with N >= {:g} <N>; {} bins of {:g} with >= 10 % of the peak; "
                         "sample sigma {:.3f})\n",
                         s.pdf.sigma, s.pdf.mu, s.pdf.pixels, s.pdf.floor, s.pdf.fitBins,
                         s.pdf.binWidth, s.pdf.sampleSigma);
        if (s.pdf.highSide) {
            o += fmt::format("pdf tail   {}: above peak + sigma, {:.2f}x the lognormal's pixels (a "
                             "tail from 2x); p(ln N) ~ N^{:.2f} over ln(N/<N>) {:.2f} to {:.2f} "
                             "({} bins)\n",
                             s.pdf.tail ? "power law" : "none", s.pdf.tailExcess, s.pdf.tailSlope,
                             s.pdf.tailFrom, s.pdf.tailTo, s.pdf.tailBins);
        } else {
            o += "pdf tail   none (fewer than 3 bins above the peak + sigma)\n";
        }
    } else {
        o += "pdf        not fitted (fewer than 3 bins about the peak)\n";
    }
    if (s.spectrum.fitted) {
        o += fmt::format("spectrum   P(k) ~ k^{:.2f} +- {:.2f} over k = {:.3g} to {:.3g} per map "
                         "edge (scales {:.3g} to {:.3g} pc, {} rings)\n",
                         s.spectrum.slope, s.spectrum.slopeError, s.spectrum.kMin, s.spectrum.kMax,
                         edgePc / s.spectrum.kMin, edgePc / s.spectrum.kMax, s.spectrum.bins);
        o += fmt::format("anisotropy {:.2f} (mean power across the map's {} axis over power "
                         "along it, same k range)\n",
                         s.spectrum.anisotropy, axisName(mapAxes(s.axis)[0]));
    } else {
        o += fmt::format("spectrum   not fitted (fewer than 3 rings of k between {:.3g} and "
                         "{:.3g} on a map of edge {}; --k-range sets them)\n",
                         s.spectrum.kMin, s.spectrum.kMax, std::max(s.map.nu, s.map.nv));
    }
    if (s.contours.fitted) {
        o += fmt::format("contours   perimeter-area dimension {:.3f} +- {:.3f} ({} contours at {} "
                         "levels, areas {:g} to {:g} pixels)\n",
                         s.contours.dimension, s.contours.error, s.contours.contours,
                         s.contours.levels, s.contours.areaMin, s.contours.areaMax);
    } else {
        o += fmt::format("contours   not fitted ({} closed contours; 5 or more spanning a factor "
                         "10 in area needed)\n",
                         s.contours.contours);
    }
    return o;
}

std::string statsJson(const CloudStats& s)
{
    nlohmann::json j;
    j["grid"] = s.grid;
    j["axis"] = axisName(s.axis);
    j["box"] = {{s.box[0][0], s.box[0][1], s.box[0][2]}, {s.box[1][0], s.box[1][1], s.box[1][2]}};
    j["voxel_pc"] = s.voxelPc;
    j["volume"] = {
        {"voxels", s.volume.count()}, {"mean_ln", s.volume.mean()}, {"sigma_ln", s.volume.sigma()}};
    j["column"] = {{"unit", s.columnUnit},       {"width", s.map.nu},    {"height", s.map.nv},
                   {"pixels", s.map.positive()}, {"mean", s.meanColumn}, {"max", s.maxColumn}};
    j["pdf"] = {{"fitted", s.pdf.fitted},
                {"sigma_ln", s.pdf.sigma},
                {"peak_ln", s.pdf.mu},
                {"bin_width", s.pdf.binWidth},
                {"floor", s.pdf.floor},
                {"pixels", s.pdf.pixels},
                {"fit_bins", s.pdf.fitBins},
                {"sample_sigma_ln", s.pdf.sampleSigma},
                {"tail", s.pdf.tail},
                {"tail_excess", s.pdf.tailExcess},
                {"tail_slope", s.pdf.tailSlope},
                {"tail_from", s.pdf.tailFrom},
                {"tail_to", s.pdf.tailTo},
                {"tail_bins", s.pdf.tailBins}};
    j["spectrum"] = {{"fitted", s.spectrum.fitted},
                     {"slope", s.spectrum.slope},
                     {"slope_error", s.spectrum.slopeError},
                     {"k_min", s.spectrum.kMin},
                     {"k_max", s.spectrum.kMax},
                     {"rings", s.spectrum.bins},
                     {"anisotropy", s.spectrum.anisotropy},
                     {"k", s.spectrum.k},
                     {"power", s.spectrum.power}};
    j["contours"] = {{"fitted", s.contours.fitted},   {"dimension", s.contours.dimension},
                     {"error", s.contours.error},     {"count", s.contours.contours},
                     {"levels", s.contours.levels},   {"area_min", s.contours.areaMin},
                     {"area_max", s.contours.areaMax}};
    return j.dump(1) + "\n";
}

} // namespace nebula
