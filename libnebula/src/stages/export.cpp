// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/export.h"

#include "nebula/core/disk_space.h"
#include "nebula/core/error.h"
#include "nebula/core/memory.h"
#include "nebula/core/run.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/grid_values.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <climits>
#include <cmath>

namespace nebula {

namespace {

/// "1,2,3,4,5,6" as six integers, or nullopt.
std::optional<std::array<int, 6>> sixIntegers(const std::string& text)
{
    std::array<int, 6> v{};
    std::size_t pos = 0;
    for (int i = 0; i < 6; ++i) {
        const std::size_t end = i < 5 ? text.find(',', pos) : text.size();
        if (end == std::string::npos) return std::nullopt;
        const std::string part = text.substr(pos, end - pos);
        if (part.empty() || part.size() > 11 ||
            part.find_first_not_of("-0123456789") != std::string::npos) {
            return std::nullopt;
        }
        const long long n = std::stoll(part);
        if (n < INT_MIN / 2 || n > INT_MAX / 2) return std::nullopt;
        v[std::size_t(i)] = int(n);
        pos = end + 1;
    }
    return v;
}

bool startsWith(const std::string& s, const char* head)
{
    return s.rfind(head, 0) == 0;
}

/// The grid's nebula:cube record (import), or null.
nlohmann::json cubeRecord(const openvdb::GridBase& grid)
{
    const auto meta = grid.getMetadata<openvdb::StringMetadata>("nebula:cube");
    if (!meta) return nullptr;
    try {
        return nlohmann::json::parse(meta->value());
    } catch (const nlohmann::json::exception&) {
        return nullptr;
    }
}

/// The WCS to write: the imported one, its reference pixel moved with the box, while it
/// still describes @p spacing and @p origin [pc]; else null (CTYPE X/Y/Z in pc).
nlohmann::json keptWcs(const nlohmann::json& record, const std::array<double, 3>& spacing,
                       const std::array<double, 3>& origin, const std::array<int, 3>& lo)
{
    if (!record.is_object() || !record.contains("wcs")) return nullptr;
    try {
        nlohmann::json wcs = record["wcs"];
        for (std::size_t a = 0; a < 3; ++a) {
            const double f = *lengthUnitPc(wcs["cunit"][a].get<std::string>());
            const double cdelt = wcs["cdelt"][a].get<double>();
            const double crpix = wcs["crpix"][a].get<double>() - double(lo[a]);
            const double crval = wcs["crval"][a].get<double>();
            const double s = cdelt * f, o = (crval + cdelt * (1.0 - crpix)) * f;
            const double tol = 1e-9 * std::abs(s);
            if (std::abs(s - spacing[a]) > tol || std::abs(o - origin[a]) > tol) return nullptr;
            wcs["crpix"][a] = crpix;
        }
        return wcs;
    } catch (const std::exception&) {
        return nullptr;
    }
}

} // namespace

CubeCost cubeCost(const CubeFormat& format, const std::array<std::int64_t, 3>& dims,
                  double headerBytes)
{
    CubeCost c;
    c.voxels = double(dims[0]) * double(dims[1]) * double(dims[2]);
    const double data = 4.0 * c.voxels;
    c.fileBytes = data + headerBytes;
    if (format.writerMemory) {
        const WriterMemory m = format.writerMemory(dims, c.fileBytes);
        c.memoryBytes = m.bytes;
        c.memoryUse = m.use;
    }
    return c;
}

void validateBbox(const std::string& text)
{
    if (text == "auto" || text == "active") return;
    const auto v = sixIntegers(text);
    if (!v) {
        throw UsageError("--bbox: expected auto, active or I0,J0,K0,I1,J1,K1, got \"" + text +
                         "\"");
    }
    static const char* const AXIS[3] = {"x", "y", "z"};
    for (std::size_t a = 0; a < 3; ++a) {
        if ((*v)[a] > (*v)[a + 3]) {
            throw UsageError(fmt::format("--bbox {}: the minimum must be <= the maximum on each "
                                         "axis, and on {} it is {} > {}",
                                         text, AXIS[a], (*v)[a], (*v)[a + 3]));
        }
    }
}

void ExportOptions::validate() const
{
    validateBbox(bbox);
    if (grid.empty()) throw UsageError("--grid: empty name");
}

std::array<std::array<int, 3>, 2> exportBox(const openvdb::FloatGrid& grid, const std::string& text)
{
    if (text == "auto") {
        const auto record = cubeRecord(grid);
        if (record.is_object() && record.contains("dims") && record["dims"].is_array() &&
            record["dims"].size() == 3) {
            std::array<int, 3> hi{};
            bool ok = true;
            for (std::size_t a = 0; a < 3; ++a) {
                const auto& d = record["dims"][a];
                ok = ok && d.is_number_integer() && d.get<long long>() >= 1 &&
                     d.get<long long>() <= INT_MAX;
                if (ok) hi[a] = int(d.get<long long>() - 1);
            }
            if (ok) return {std::array<int, 3>{0, 0, 0}, hi};
        }
    }
    if (text == "auto" || text == "active") {
        const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
        if (box.empty()) {
            throw Error("grid \"" + grid.getName() +
                        "\" has no active voxels: nothing to export "
                        "(give --bbox I0,J0,K0,I1,J1,K1)");
        }
        return {std::array<int, 3>{box.min().x(), box.min().y(), box.min().z()},
                std::array<int, 3>{box.max().x(), box.max().y(), box.max().z()}};
    }
    validateBbox(text);
    const auto v = sixIntegers(text);
    return {std::array<int, 3>{(*v)[0], (*v)[1], (*v)[2]},
            std::array<int, 3>{(*v)[3], (*v)[4], (*v)[5]}};
}

std::string cubeUnit(const openvdb::GridBase& grid)
{
    const std::string name = grid.getName();
    if (name == "density" || startsWith(name, "density.")) return "cm-3";
    if (startsWith(name, "tau.") || startsWith(name, "phase")) return "";
    if (name == "temperature") return "K";
    if (name == "emission" || startsWith(name, "emission.")) return "Lsun pc-3 sr-1";
    if (startsWith(name, "scatter.") && name.find(".J.") != std::string::npos) {
        return "Lsun pc-2 sr-1";
    }
    const auto meta = grid.getMetadata<openvdb::StringMetadata>("units");
    if (!meta) return "";
    // "n_H [cm^-3]": the part in brackets.
    const std::string& u = meta->value();
    const std::size_t a = u.find('['), b = u.find(']');
    if (a != std::string::npos && b != std::string::npos && b > a)
        return u.substr(a + 1, b - a - 1);
    return u;
}

void exportCube(const GridSet& grids, const ExportOptions& opts, const Run& run)
{
    opts.validate();
    const CubeFormat* format = opts.format ? opts.format : cubeFormatOf(opts.output);
    if (!format || !format->write) {
        std::string hints;
        for (const CubeFormat* f : cubeFormats())
            if (f->write) hints += (hints.empty() ? "" : ", ") + f->hint;
        throw UsageError("-o " + opts.output + ": cannot tell the format from the name (" + hints +
                         "); give --format");
    }
    const auto grid = grids.floatGrid(opts.grid, "--grid");
    const auto box = exportBox(*grid, opts.bbox);
    CubeHeader h;
    for (std::size_t a = 0; a < 3; ++a)
        h.dims[a] = std::int64_t(box[1][a]) - box[0][a] + 1;

    // Axis-aligned transforms only: a dense cube's axes are the grid's.
    const openvdb::math::Mat4d m = grid->transform().baseMap()->getAffineMap()->getMat4();
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            if (i != j && m[i][j] != 0.0) {
                throw Error(grids.source + ": grid \"" + opts.grid +
                            "\" is rotated or sheared; a cube's axes must be the world's");
            }
        }
    }
    const openvdb::Vec3d lo = grid->indexToWorld(openvdb::Vec3d(box[0][0], box[0][1], box[0][2]));
    for (std::size_t a = 0; a < 3; ++a) {
        h.spacing[a] = m[int(a)][int(a)];
        h.origin[a] = lo[int(a)];
    }
    h.unit = cubeUnit(*grid);
    h.name = opts.grid;
    h.wcs = keptWcs(cubeRecord(*grid), h.spacing, h.origin, box[0]);
    for (const auto& stage : grids.historyWith(run.tool(), run.command())) {
        h.history.push_back(stage.value("tool", "?") + ": " + stage.value("command", ""));
    }
    double headerBytes = CUBE_HEADER_BYTES;
    for (const auto& line : h.history) // FITS: 80-byte cards of up to 70 characters
        headerBytes += 80.0 * double(line.size() / 70 + 1);
    const CubeCost cost = cubeCost(*format, h.dims, headerBytes);
    // Where the size comes from: --bbox (a usage error), else the grid itself.
    const bool given = opts.bbox != "auto" && opts.bbox != "active";
    const std::string boxText =
        given ? opts.bbox
              : fmt::format("{}: {},{},{} to {},{},{}", opts.bbox, box[0][0], box[0][1], box[0][2],
                            box[1][0], box[1][1], box[1][2]);
    const std::string what =
        fmt::format("-o {}: the {} x {} x {} cube of grid \"{}\" ({}, --bbox {})", opts.output,
                    h.dims[0], h.dims[1], h.dims[2], opts.grid, grids.source, boxText);
    const auto refuse = [&](const std::string& why) {
        const std::string hint = given ? "" : "; --bbox I0,J0,K0,I1,J1,K1 exports a part";
        if (given) throw UsageError(what + " " + why + hint);
        throw Error(what + " " + why + hint);
    };
    if (cost.voxels > double(MAX_CUBE_VOXELS)) {
        refuse(fmt::format("is {:.3g} voxels, more than the 2^36 (4096^3) a cube may have",
                           cost.voxels));
    }
    // Bounded before the first large allocation and the first byte: what the writer holds in
    // memory against the machine's memory (FITS and HDF5 fill it before the disk), then the
    // file's size against the free space of the file system that will hold it (the
    // temporary and the old file are both there until the rename).
    if (const std::uint64_t memory = physicalMemory();
        memory && cost.memoryBytes > double(memory)) {
        refuse(fmt::format("needs {} of memory; this machine has {} ({})",
                           bytesText(cost.memoryBytes), bytesText(double(memory)), cost.memoryUse));
    }
    if (const auto free = freeDiskSpace(opts.output); free && cost.fileBytes > double(*free)) {
        refuse(fmt::format("needs {} on disk; the file system that holds it has {} free",
                           bytesText(cost.fileBytes), bytesText(double(*free))));
    }
    // Every value the cube holds is finite: the active ones (as every tool reads them) and
    // the background and inactive ones inside the box, which the cube holds too.
    const openvdb::CoordBBox vbox(openvdb::Coord(box[0][0], box[0][1], box[0][2]),
                                  openvdb::Coord(box[1][0], box[1][1], box[1][2]));
    requireFinite(*grid, grids.source, &vbox);
    run.info(fmt::format("{}: grid {} as a {} x {} x {} cube from index ({}, {}, {}), unit \"{}\"",
                         opts.output, opts.grid, h.dims[0], h.dims[1], h.dims[2], box[0][0],
                         box[0][1], box[0][2], h.unit));

    const auto& tree = grid->tree();
    // Progress over the cube's voxels, a plane at a time as the writer asks for them.
    Progress progress(run, run.tool() + " " + opts.output,
                      std::uint64_t(h.dims[0]) * std::uint64_t(h.dims[1]) *
                          std::uint64_t(h.dims[2]));
    const PlaneFunction plane = [&](const PlaneOrder& order, std::int64_t k, float* out) {
        const int nu = int(h.dims[std::size_t(order.fastAxis)]);
        const int nv = int(h.dims[std::size_t(order.slowAxis)]);
        tbb::parallel_for(0, nv, [&](int v) {
            openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(tree);
            openvdb::Coord c;
            c[order.planeAxis] = box[0][std::size_t(order.planeAxis)] + int(k);
            c[order.slowAxis] = box[0][std::size_t(order.slowAxis)] + v;
            float* line = out + std::size_t(v) * std::size_t(nu);
            for (int u = 0; u < nu; ++u) {
                c[order.fastAxis] = box[0][std::size_t(order.fastAxis)] + u;
                line[u] = acc.getValue(c);
            }
        });
        progress.add(std::uint64_t(nu) * std::uint64_t(nv));
    };
    const std::string dataset = opts.dataset.empty() ? "/" + opts.grid : opts.dataset;
    writeCube(*format, opts.output, h, dataset, plane);
}

} // namespace nebula
