// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/import.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/physics/lines.h"

#include <fmt/format.h>
#include <openvdb/tools/Prune.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <sys/stat.h>

namespace nebula {

namespace {

using FloatLeaf = openvdb::FloatTree::LeafNodeType;
constexpr int LEAF = int(FloatLeaf::DIM); // 8: a slab of planes is one layer of leaves

bool pathExists(const std::string& path)
{
    struct stat st
    {
    };
    return ::stat(path.c_str(), &st) == 0;
}

std::string coordText(const openvdb::Coord& c)
{
    return fmt::format("({}, {}, {})", c.x(), c.y(), c.z());
}

/// Reads @p cube in slabs of LEAF planes, each value checked (finite; >= 0 unless
/// @p allowNegative) and multiplied by @p factor, and hands each slab to @p slab(first plane,
/// planes, values): plane p's value at (u, v) is values[(p * nv + v) * nu + u].
template <typename SlabFn>
void forEachSlab(CubeSource& cube, double factor, bool allowNegative, const std::string& what,
                 const Run& run, SlabFn&& slab)
{
    const CubeInfo& info = cube.info();
    const std::size_t planeSize = std::size_t(info.planeSize());
    requireMemory(double(planeSize) * (8.0 + 4.0 * LEAF),
                  info.name + ": a slab of " + std::to_string(LEAF) + " planes");
    std::vector<double> raw(planeSize);
    std::vector<float> values(planeSize * LEAF);
    const std::int64_t planes = info.planeCount();
    Progress progress(run, run.tool() + " " + what, std::uint64_t(planes));
    for (std::int64_t first = 0; first < planes; first += LEAF) {
        const int count = int(std::min<std::int64_t>(LEAF, planes - first));
        for (int p = 0; p < count; ++p) {
            cube.readPlane(first + p, raw.data());
            float* out = values.data() + std::size_t(p) * planeSize;
            for (std::size_t i = 0; i < planeSize; ++i) {
                const double v = raw[i];
                if (!std::isfinite(v) || (!allowNegative && v < 0.0)) {
                    openvdb::Coord c;
                    c[info.planeAxis] = int(first + p);
                    c[info.fastAxis] = int(i % std::size_t(info.dims[std::size_t(info.fastAxis)]));
                    c[info.slowAxis] = int(i / std::size_t(info.dims[std::size_t(info.fastAxis)]));
                    throw Error(
                        info.name + ": " + what + " at voxel " + coordText(c) + " is " +
                        fmt::format("{}", v) +
                        (std::isfinite(v) ? ", expected >= 0" : ", expected a finite number"));
                }
                const double x = v * factor;
                if (!(std::abs(x) <= double(std::numeric_limits<float>::max()))) {
                    throw Error(info.name + ": " + what +
                                fmt::format(" {} is beyond float range", x));
                }
                out[i] = float(x);
            }
            progress.add(1);
        }
        slab(first, count, values.data());
    }
}

/// The leaf (@p ib, @p jb) of the slab whose planes @p first ... @p first + @p count - 1 are
/// @p values (forEachSlab()): its values > @p cut active; null if it has none.
std::unique_ptr<FloatLeaf> slabLeaf(const CubeInfo& info, const float* values, std::int64_t first,
                                    int count, int ib, int jb, float cut)
{
    const int nu = int(info.dims[std::size_t(info.fastAxis)]);
    const int nv = int(info.dims[std::size_t(info.slowAxis)]);
    openvdb::Coord c;
    c[info.planeAxis] = int(first);
    c[info.fastAxis] = ib * LEAF;
    c[info.slowAxis] = jb * LEAF;
    std::unique_ptr<FloatLeaf> leaf;
    const int u1 = std::min(nu, (ib + 1) * LEAF), v1 = std::min(nv, (jb + 1) * LEAF);
    for (int p = 0; p < count; ++p) {
        c[info.planeAxis] = int(first) + p;
        for (int v = jb * LEAF; v < v1; ++v) {
            const float* line =
                values + (std::size_t(p) * std::size_t(nv) + std::size_t(v)) * std::size_t(nu);
            c[info.slowAxis] = v;
            for (int u = ib * LEAF; u < u1; ++u) {
                if (!(line[u] > cut)) continue;
                c[info.fastAxis] = u;
                if (!leaf) leaf = std::make_unique<FloatLeaf>(c, 0.0f);
                leaf->setValueOn(c, line[u]);
            }
        }
    }
    return leaf;
}

/// The sparse grid of @p cube (values times @p factor): voxels > @p threshold active, built
/// leaf by leaf per slab; errors name the cube @p what.
openvdb::FloatGrid::Ptr readSparse(CubeSource& cube, double factor, double threshold,
                                   const std::string& what, const Run& run)
{
    const CubeInfo& info = cube.info();
    auto grid = openvdb::FloatGrid::create(0.0f);
    auto& tree = grid->tree();
    const int bu = int((info.dims[std::size_t(info.fastAxis)] + LEAF - 1) / LEAF);
    const int bv = int((info.dims[std::size_t(info.slowAxis)] + LEAF - 1) / LEAF);
    std::vector<std::vector<FloatLeaf*>> rows(static_cast<std::size_t>(bv));
    const auto slab = [&](std::int64_t first, int count, const float* values) {
        // The slab's leaves in parallel over rows of leaves, then added in order.
        tbb::parallel_for(0, bv, [&](int jb) {
            for (int ib = 0; ib < bu; ++ib) {
                auto leaf = slabLeaf(info, values, first, count, ib, jb, float(threshold));
                if (leaf) rows[std::size_t(jb)].push_back(leaf.release());
            }
        });
        for (auto& row : rows) {
            for (auto* leaf : row)
                tree.addLeaf(leaf);
            row.clear();
        }
    };
    forEachSlab(cube, factor, false, what, run, slab);
    openvdb::tools::prune(tree);
    return grid;
}

/// Fills the active voxels of @p grid (the density's topology) from @p cube: @p set(value,
/// voxel value) for each, slab by slab.
template <typename GridT, typename SetFn>
void fillOnTopology(GridT& grid, CubeSource& cube, bool allowNegative, const std::string& what,
                    const Run& run, SetFn&& set)
{
    const CubeInfo& info = cube.info();
    const int nu = int(info.dims[std::size_t(info.fastAxis)]);
    const int nv = int(info.dims[std::size_t(info.slowAxis)]);
    using LeafT = typename GridT::TreeType::LeafNodeType;
    std::vector<std::vector<LeafT*>> bySlab(std::size_t((info.planeCount() + LEAF - 1) / LEAF));
    for (auto it = grid.tree().beginLeaf(); it; ++it) {
        const auto slab = std::size_t(it->origin()[info.planeAxis] / LEAF);
        if (slab < bySlab.size()) bySlab[slab].push_back(&*it);
    }
    forEachSlab(cube, 1.0, allowNegative, what, run,
                [&](std::int64_t first, int, const float* values) {
                    auto& leaves = bySlab[std::size_t(first / LEAF)];
                    tbb::parallel_for(std::size_t(0), leaves.size(), [&](std::size_t l) {
                        for (auto it = leaves[l]->beginValueOn(); it; ++it) {
                            const openvdb::Coord c = it.getCoord();
                            const int p = c[info.planeAxis] - int(first);
                            const int u = c[info.fastAxis], v = c[info.slowAxis];
                            if (u >= nu || v >= nv) continue;
                            set(it, values[(std::size_t(p) * std::size_t(nv) + std::size_t(v)) *
                                               std::size_t(nu) +
                                           std::size_t(u)]);
                        }
                    });
                });
}

/// The density unit of the cube: --unit, the file's own, or an error asking for --unit.
DensityUnit densityUnit(const ImportOptions& opts, const CubeInfo& info)
{
    std::optional<DensityUnit> fileUnit;
    if (!info.unit.empty()) {
        fileUnit = parseDensityUnit(info.unit);
        if (!fileUnit) {
            throw Error(info.name + ": unknown density unit \"" + detail::printable(info.unit, 40) +
                        "\" (expected cm-3, g/cm3, g/cm3-dust or Msun/pc3)");
        }
    }
    if (!opts.unit.empty()) {
        const auto given = parseDensityUnit(opts.unit);
        if (!given) {
            throw UsageError("--unit: unknown density unit \"" + opts.unit +
                             "\" (expected cm-3, g/cm3, g/cm3-dust or Msun/pc3)");
        }
        if (fileUnit && *fileUnit != *given) {
            throw Error(info.name + ": the file says its unit is \"" +
                        detail::printable(info.unit, 40) + "\" (" + densityUnitName(*fileUnit) +
                        "), but --unit says " + densityUnitName(*given) +
                        "; drop --unit or fix the file");
        }
        return *given;
    }
    if (!fileUnit) {
        throw UsageError(info.name + ": the file does not say its unit; give --unit (cm-3, g/cm3, "
                                     "g/cm3-dust or Msun/pc3)");
    }
    return *fileUnit;
}

/// The voxel size and origin [pc] of the cube and what gave them, for messages.
struct Placement
{
    std::array<double, 3> spacing{}, origin{};
    std::string stepSource, originSource;
    bool stepOption = false, originOption = false; ///< given by --voxel-size, --origin

    /// An Error about the file's geometry, a UsageError about an option's.
    [[noreturn]] void refuse(bool option, const std::string& message) const
    {
        if (option) throw UsageError(message);
        throw Error(message);
    }
};

/// Snaps steps equal within CUBIC_STEP_TOLERANCE to the first one (-v says so): nebstats and
/// the path tracer want exactly cubic voxels. Steps further apart are refused.
void snapSteps(Placement& p, const Run& run)
{
    const double first = std::abs(p.spacing[0]);
    double worst = 0.0;
    for (std::size_t a = 1; a < 3; ++a)
        worst = std::max(worst, std::abs(std::abs(p.spacing[a]) - first) / first);
    if (worst == 0.0) return;
    if (!(worst <= CUBIC_STEP_TOLERANCE)) {
        throw Error(p.stepSource + fmt::format(": the voxels are not cubes ({} x {} x {} pc); "
                                               "nebula needs equal steps (give --voxel-size to "
                                               "override)",
                                               std::abs(p.spacing[0]), std::abs(p.spacing[1]),
                                               std::abs(p.spacing[2])));
    }
    for (std::size_t a = 1; a < 3; ++a)
        p.spacing[a] = std::copysign(first, p.spacing[a]);
    run.info(fmt::format("{} differ by {:.2g} relative; voxels taken as cubes of {} pc",
                         p.stepSource, worst, first));
}

/// Refuses a voxel size or origin the other tools would refuse when they read the grid: each
/// step MIN_VOXEL_SIZE_PC to MAX_VOXEL_SIZE_PC, each corner's world coordinates at most
/// MAX_WORLD_COORDINATE_PC and MAX_WORLD_COORDINATE_VOXELS voxels in magnitude.
void checkPlacement(const Placement& p, const std::array<std::int64_t, 3>& dims)
{
    for (std::size_t a = 0; a < 3; ++a) {
        const double s = std::abs(p.spacing[a]);
        if (!(s >= MIN_VOXEL_SIZE_PC && s <= MAX_VOXEL_SIZE_PC)) {
            p.refuse(p.stepOption,
                     p.stepSource + ": voxels of " + detail::numberText(s) + " pc; expected " +
                         detail::numberText(MIN_VOXEL_SIZE_PC) + " to " +
                         detail::numberText(MAX_VOXEL_SIZE_PC) + " pc (" +
                         (s < MIN_VOXEL_SIZE_PC
                              ? "smaller cannot be an OpenVDB transform"
                              : "larger, a voxel's volume overflows in the tools that read it") +
                         "; the units are pc)");
        }
    }
    // Every corner within reach of a camera, and at a voxel's precision.
    const double voxel = std::abs(p.spacing[0]);
    const double limit = std::min(MAX_WORLD_COORDINATE_PC, MAX_WORLD_COORDINATE_VOXELS * voxel);
    for (std::size_t a = 0; a < 3; ++a) {
        const double far = p.origin[a] + double(dims[a] - 1) * p.spacing[a];
        for (const double x : {p.origin[a], far}) {
            if (!(std::abs(x) <= limit)) {
                p.refuse(p.originOption,
                         p.originSource +
                             fmt::format(": the cube reaches {} = {} pc; expected world "
                                         "coordinates of at most {} pc in magnitude ({} voxels "
                                         "of {} pc, and at most {} pc)",
                                         "xyz"[a], detail::numberText(x), detail::numberText(limit),
                                         detail::numberText(MAX_WORLD_COORDINATE_VOXELS),
                                         detail::numberText(voxel),
                                         detail::numberText(MAX_WORLD_COORDINATE_PC)));
            }
        }
    }
}

/// The cube's voxel size and origin [pc]: --voxel-size, --origin, the file's, else centred on
/// the world origin; checked and snapped (every source's geometry passes here).
Placement cubePlacement(const ImportOptions& opts, const CubeInfo& info, const Run& run,
                        nlohmann::json& record)
{
    Placement p;
    bool fileOrigin = false;
    if (opts.voxelSize) {
        p.spacing.fill(*opts.voxelSize);
        p.stepSource = "--voxel-size";
        p.stepOption = true;
        if (info.geometry) {
            run.warn(fmt::format("--voxel-size {} pc replaces the file's {} pc", *opts.voxelSize,
                                 std::abs(info.geometry->spacing[0])));
        }
    } else if (!info.geometryError.empty()) {
        throw Error(info.geometryError);
    } else if (info.geometry) {
        p.spacing = info.geometry->spacing;
        p.stepSource = info.name + ": " + info.geometry->stepSource;
        if (info.geometry->origin) {
            p.origin = *info.geometry->origin;
            p.originSource = info.name + ": " + info.geometry->originSource;
            fileOrigin = true;
        }
        if (!info.geometry->wcs.is_null()) record["wcs"] = info.geometry->wcs;
    } else {
        throw UsageError(info.name + ": the file gives no voxel size; give --voxel-size (e.g. "
                                     "0.01pc, 200au)");
    }
    for (std::size_t a = 0; a < 3; ++a) {
        if (!std::isfinite(p.spacing[a]) || p.spacing[a] == 0.0) {
            throw Error(p.stepSource + ": a step of " + detail::numberText(p.spacing[a]) +
                        " pc; expected a finite voxel size > 0");
        }
    }
    snapSteps(p, run);
    if (opts.origin) {
        p.origin = *opts.origin;
        p.originSource = "--origin";
        p.originOption = true;
        fileOrigin = true;
        record.erase("wcs");
    }
    if (!fileOrigin) {
        // Centred on the world origin, as nebgen's cubes are.
        for (std::size_t a = 0; a < 3; ++a)
            p.origin[a] = -0.5 * double(info.dims[a] - 1) * p.spacing[a];
        p.originSource = p.stepSource;
        p.originOption = p.stepOption;
    }
    if (record.contains("wcs")) {
        // The WCS's steps as snapped, in each axis's unit, so that nebexport writes them back.
        for (std::size_t a = 0; a < 3; ++a) {
            const double was = record["wcs"]["cdelt"][a].get<double>();
            const double pc = std::abs(info.geometry->spacing[a]);
            record["wcs"]["cdelt"][a] = was * (std::abs(p.spacing[a]) / pc);
        }
    }
    checkPlacement(p, info.dims);
    return p;
}

/// The index -> world transform [pc] and the geometry's record for nebula:cube.
openvdb::math::Transform::Ptr cubeTransform(const ImportOptions& opts, const CubeInfo& info,
                                            const Run& run, nlohmann::json& record)
{
    const Placement p = cubePlacement(opts, info, run, record);
    const auto& spacing = p.spacing;
    const auto& origin = p.origin;
    record["voxel_size_pc"] = spacing;
    record["origin_pc"] = origin;
    try {
        if (spacing[0] > 0 && spacing[0] == spacing[1] && spacing[1] == spacing[2]) {
            auto xform = openvdb::math::Transform::createLinearTransform(spacing[0]);
            xform->postTranslate(openvdb::Vec3d(origin[0], origin[1], origin[2]));
            return xform;
        }
        openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
        for (int a = 0; a < 3; ++a) {
            m[a][a] = spacing[std::size_t(a)];
            m[3][a] = origin[std::size_t(a)];
        }
        return openvdb::math::Transform::createLinearTransform(m);
    } catch (const openvdb::Exception&) {
        // checkPlacement() keeps OpenVDB's limits: this is a guard, in nebula's words.
        throw Error(p.stepSource + fmt::format(": voxels of {} x {} x {} pc at ({}, {}, {}) pc "
                                               "make no invertible transform",
                                               spacing[0], spacing[1], spacing[2], origin[0],
                                               origin[1], origin[2]));
    }
}

/// Opens FILE[:SELECTOR] as a cube the shape of @p dims (component @p component of a 4-D one).
std::unique_ptr<CubeSource> openSide(const std::string& text, const std::string& option,
                                     int component, const std::array<std::int64_t, 3>& dims)
{
    const auto [file, selector] = splitCubeSelector(text);
    CubeSelect sel;
    sel.option = option;
    sel.component = component;
    const CubeFormat* format = cubeFormatOf(file);
    if (format && format->selector) sel.*(format->selector) = selector;
    auto cube = openCube(file, sel);
    if (cube->info().dims != dims) {
        const auto& d = cube->info().dims;
        throw Error(option + ": " + cube->info().name +
                    fmt::format(": {} x {} x {} voxels, but the density has {} x {} x {}", d[0],
                                d[1], d[2], dims[0], dims[1], dims[2]));
    }
    return cube;
}

/// The temperature grid [K] on the density's active voxels.
openvdb::FloatGrid::Ptr readTemperature(const ImportOptions& opts,
                                        const openvdb::FloatGrid& density,
                                        const std::array<std::int64_t, 3>& dims, const Run& run)
{
    auto cube = openSide(opts.temperature, "--temperature", -1, dims);
    const std::string& unit = cube->info().unit;
    if (!unit.empty() && unit != "K" && unit != "k") {
        throw Error("--temperature: " + cube->info().name + ": unit \"" +
                    detail::printable(unit, 40) + "\", expected K");
    }
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->tree().topologyUnion(density.tree());
    fillOnTopology(*grid, *cube, false, "temperature", run,
                   [](auto& it, float v) { it.setValue(v); });
    grid->setName("temperature");
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->insertMeta("units", openvdb::StringMetadata("K"));
    return grid;
}

/// The emission grid [L_sun pc^-3 sr^-1], active where the emissivity is > 0 (the gas may
/// glow where there is little dust), with nebula:lines from --lines.
openvdb::FloatGrid::Ptr readEmission(const ImportOptions& opts,
                                     const std::array<std::int64_t, 3>& dims, const Run& run)
{
    auto cube = openSide(opts.emission, "--emission", -1, dims);
    const std::string& fileUnit = cube->info().unit;
    const std::string unit = opts.emissionUnit.empty() ? fileUnit : opts.emissionUnit;
    if (unit.empty()) {
        throw Error("--emission: " + cube->info().name +
                    " says nothing of its unit: give --emission-unit Lsun/pc3/sr or "
                    "erg/s/cm3/sr");
    }
    const auto factor = emissivityUnitFactor(unit);
    if (!factor) {
        throw Error("--emission: " + cube->info().name + ": unknown emissivity unit \"" +
                    detail::printable(unit, 40) + "\" (expected Lsun/pc3/sr or erg/s/cm3/sr)");
    }
    if (!opts.emissionUnit.empty() && !fileUnit.empty() && emissivityUnitFactor(fileUnit) &&
        *emissivityUnitFactor(fileUnit) != *factor) {
        throw Error("--emission: " + cube->info().name + " says its unit is \"" +
                    detail::printable(fileUnit, 40) + "\", but --emission-unit says \"" +
                    detail::printable(opts.emissionUnit, 40) + "\"");
    }
    auto grid = readSparse(*cube, *factor, 0.0, "emission", run);
    grid->setName("emission");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta("units", openvdb::StringMetadata("L_sun pc^-3 sr^-1"));
    if (!opts.lines.empty()) {
        grid->insertMeta(META_LINES, openvdb::StringMetadata(
                                         lineListToString(parseLineList(opts.lines, "--lines"))));
    }
    run.info(fmt::format("emission: {} active voxels (x {} -> L_sun pc^-3 sr^-1)",
                         grid->activeVoxelCount(), *factor));
    return grid;
}

/// The velocity grid [km/s] on the density's active voxels: three cubes or one 4-D one.
openvdb::Vec3fGrid::Ptr readVelocity(const ImportOptions& opts, const openvdb::FloatGrid& density,
                                     const std::array<std::int64_t, 3>& dims, const Run& run)
{
    std::vector<std::string> parts;
    if (!pathExists(opts.velocity) && opts.velocity.find(',') != std::string::npos) {
        std::string rest = opts.velocity;
        std::size_t pos;
        while ((pos = rest.find(',')) != std::string::npos) {
            parts.push_back(rest.substr(0, pos));
            rest = rest.substr(pos + 1);
        }
        parts.push_back(rest);
        if (parts.size() != 3) {
            throw UsageError("--velocity: expected FX,FY,FZ (three cubes) or one 4-D cube, got " +
                             std::to_string(parts.size()) + " names");
        }
    }
    auto grid = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
    grid->tree().topologyUnion(density.tree());
    for (int c = 0; c < 3; ++c) {
        auto cube = parts.empty() ? openSide(opts.velocity, "--velocity", c, dims)
                                  : openSide(parts[std::size_t(c)], "--velocity", -1, dims);
        const std::string& unit = cube->info().unit;
        double factor = 1.0;
        if (unit == "m/s" || unit == "m s-1") {
            factor = 1e-3;
        } else if (unit == "cm/s" || unit == "cm s-1") {
            factor = 1e-5;
        } else if (!unit.empty() && unit != "km/s" && unit != "km s-1") {
            throw Error("--velocity: " + cube->info().name + ": unit \"" +
                        detail::printable(unit, 40) + "\", expected km/s, m/s or cm/s");
        }
        fillOnTopology(*grid, *cube, true, std::string("velocity ") + "xyz"[c], run,
                       [c, factor](auto& it, float v) {
                           openvdb::Vec3f x = it.getValue();
                           x[c] = float(double(v) * factor);
                           it.setValue(x);
                       });
    }
    grid->setName("velocity");
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
    grid->insertMeta("units", openvdb::StringMetadata("km/s"));
    return grid;
}

} // namespace

void ImportOptions::validate() const
{
    if (!(mu > 0.0) || !std::isfinite(mu)) throw UsageError("--mu must be a finite number > 0");
    if (!(dustToGas > 0.0) || !std::isfinite(dustToGas)) {
        throw UsageError("--dust-to-gas must be a finite number > 0");
    }
    if (voxelSize && (!(*voxelSize > 0.0) || !std::isfinite(*voxelSize))) {
        throw UsageError("--voxel-size must be a finite length > 0");
    }
    if (!(threshold >= 0.0) || !std::isfinite(threshold)) {
        throw UsageError("--threshold must be a finite number >= 0 [cm^-3]");
    }
    if (!unit.empty() && !parseDensityUnit(unit)) {
        throw UsageError("--unit: unknown density unit \"" + unit +
                         "\" (expected cm-3, g/cm3, g/cm3-dust or Msun/pc3)");
    }
    if (select.species < 1) throw UsageError("--species must be 1 or more");
    if (emission.empty() && (!emissionUnit.empty() || !lines.empty())) {
        throw UsageError(std::string(lines.empty() ? "--emission-unit" : "--lines") +
                         " is for the emission cube: give --emission FILE");
    }
    if (!emissionUnit.empty() && !emissivityUnitFactor(emissionUnit)) {
        throw UsageError("--emission-unit: unknown emissivity unit \"" +
                         detail::printable(emissionUnit, 40) +
                         "\" (expected Lsun/pc3/sr or erg/s/cm3/sr)");
    }
    if (!lines.empty()) {
        try {
            parseLineList(lines, "--lines");
        } catch (const Error& e) {
            throw UsageError(e.what());
        }
    }
}

std::optional<double> emissivityUnitFactor(const std::string& unit)
{
    // nebexport writes "Lsun pc-3 sr-1" (an emission grid's BUNIT): it reads back.
    if (unit == "Lsun/pc3/sr" || unit == "Lsun pc-3 sr-1" || unit == "L_sun pc^-3 sr^-1")
        return 1.0;
    if (unit == "erg/s/cm3/sr" || unit == "erg s-1 cm-3 sr-1" || unit == "erg/(s cm3 sr)") {
        return PC_CM * PC_CM * PC_CM / L_SUN_CGS;
    }
    return std::nullopt;
}

double parseLength(const std::string& text, const std::string& option)
{
    std::size_t used = 0;
    double value = 0.0;
    try {
        value = std::stod(text, &used);
    } catch (const std::exception&) {
        throw UsageError(option + ": \"" + text + "\" is not a length (e.g. 0.01pc, 200au)");
    }
    std::string unit = text.substr(used);
    while (!unit.empty() && unit.front() == ' ')
        unit.erase(0, 1);
    if (unit.empty()) {
        throw UsageError(option + ": \"" + text + "\" has no unit (e.g. 0.01pc, 200au, 3e16cm)");
    }
    const auto pc = lengthUnitPc(unit);
    if (!pc) {
        throw UsageError(option + ": unknown length unit \"" + unit +
                         "\" (expected pc, au, cm, m, km or kpc)");
    }
    const double v = value * *pc;
    if (!(v > 0.0) || !std::isfinite(v)) {
        throw UsageError(option + ": \"" + text + "\" must be a finite length > 0");
    }
    return v;
}

std::pair<std::string, std::string> splitCubeSelector(const std::string& text)
{
    const std::size_t colon = text.find_last_of(':');
    if (pathExists(text) || colon == std::string::npos || !pathExists(text.substr(0, colon))) {
        return {text, ""};
    }
    return {text.substr(0, colon), text.substr(colon + 1)};
}

std::vector<std::pair<std::string, std::string>> importInputFiles(const ImportOptions& opts)
{
    std::vector<std::pair<std::string, std::string>> files{{"-i", opts.input}};
    const auto add = [&](const std::string& option, const std::string& text) {
        if (!text.empty()) files.emplace_back(option, splitCubeSelector(text).first);
    };
    add("--temperature", opts.temperature);
    add("--emission", opts.emission);
    if (!pathExists(opts.velocity) && opts.velocity.find(',') != std::string::npos) {
        std::size_t start = 0, comma;
        while ((comma = opts.velocity.find(',', start)) != std::string::npos) {
            add("--velocity", opts.velocity.substr(start, comma - start));
            start = comma + 1;
        }
        add("--velocity", opts.velocity.substr(start));
    } else {
        add("--velocity", opts.velocity);
    }
    return files;
}

GridSet importCube(const ImportOptions& opts, const Run& run)
{
    opts.validate();
    if (opts.input == "-") {
        throw UsageError("-i: nebimport reads files (FITS, HDF5, .npy need to seek), not stdin");
    }
    auto cube = openCube(opts.input, opts.select);
    const CubeInfo info = cube->info(); // a copy: the cube is closed once read
    for (const auto& w : info.warnings)
        run.warn(w);
    const DensityUnit unit = densityUnit(opts, info);
    const double factor = densityToNH(unit, opts.mu, opts.dustToGas);
    nlohmann::json record;
    record["source"] = opts.input;
    record["format"] = (opts.select.format ? opts.select.format : cubeFormatOf(opts.input))->name;
    record["unit"] = densityUnitName(unit);
    record["to_n_H"] = factor;
    record["dims"] = info.dims;
    auto xform = cubeTransform(opts, info, run, record);
    run.info(fmt::format("{}: {} x {} x {} voxels, unit {} (x {} -> n_H [cm^-3]), voxel {} pc",
                         info.name, info.dims[0], info.dims[1], info.dims[2], densityUnitName(unit),
                         factor, xform->voxelSize()[0]));

    auto density = readSparse(*cube, factor, opts.threshold, "density", run);
    cube.reset();
    density->setTransform(xform);
    density->setName(opts.gridName);
    density->setGridClass(openvdb::GRID_FOG_VOLUME);
    density->insertMeta("units", openvdb::StringMetadata("n_H [cm^-3]"));
    density->insertMeta("nebula:cube", openvdb::StringMetadata(record.dump()));
    const double total = double(info.dims[0]) * double(info.dims[1]) * double(info.dims[2]);
    run.info(fmt::format("{} active voxels of {} ({:.3g}%), {} leaves", density->activeVoxelCount(),
                         total, 100.0 * double(density->activeVoxelCount()) / total,
                         density->tree().leafCount()));

    GridSet set;
    set.source = opts.input;
    set.grids.push_back(density);
    if (!opts.temperature.empty()) {
        auto t = readTemperature(opts, *density, info.dims, run);
        t->setTransform(xform->copy());
        set.grids.push_back(t);
    }
    if (!opts.velocity.empty()) {
        auto v = readVelocity(opts, *density, info.dims, run);
        v->setTransform(xform->copy());
        set.grids.push_back(v);
    }
    if (!opts.emission.empty()) {
        auto e = readEmission(opts, info.dims, run);
        e->setTransform(xform->copy());
        set.grids.push_back(e);
    }
    set.setStars(opts.stars);
    set.setDust(DustParams{});
    return set;
}

} // namespace nebula
