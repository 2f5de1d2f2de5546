// SPDX-License-Identifier: Apache-2.0
/// @file phase_table_vdb.cpp
/// The phase table as grids; see phase_table_vdb.h.

#include "nebula/io/phase_table_vdb.h"

#include "nebula/core/error.h"

namespace nebula {

namespace {

openvdb::FloatGrid::Ptr tableGrid(const PhaseTable& table, const std::vector<float>& values,
                                  const std::string& name)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName(name);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(1.0));
    auto acc = grid->getAccessor();
    for (int j = 0; j < table.tCount; ++j) {
        for (int i = 0; i < table.muBins; ++i) {
            // setValueOn keeps zero values active: every (mu, t) cell is part of the table.
            acc.setValueOn(openvdb::Coord(i, j, 0), values[std::size_t(j) * table.muBins + i]);
        }
    }
    return grid;
}

template <class MetaT, class T>
T required(const openvdb::GridBase& grid, const std::string& key, const std::string& source,
           const char* typeName)
{
    const auto m = grid.getMetadata<MetaT>(key);
    if (!m) {
        throw Error(source + ": grid \"" + grid.getName() + "\" has no " + typeName +
                    " metadata \"" + key + "\"; is this a phase table written by nebphase?");
    }
    return m->value();
}

} // namespace

void addPhaseTable(GridSet& grids, const PhaseTable& table)
{
    auto phi = tableGrid(table, table.phi, PHASE_GRID);
    phi->setGridClass(openvdb::GRID_UNKNOWN);
    phi->insertMeta("table", openvdb::StringMetadata(PHASE_TABLE_KIND));
    phi->insertMeta("units", openvdb::StringMetadata("1/sr per unit optical depth"));
    phi->insertMeta("t_min", openvdb::DoubleMetadata(table.tMin));
    phi->insertMeta("t_max", openvdb::DoubleMetadata(table.tMax));
    phi->insertMeta("t_count", openvdb::Int32Metadata(table.tCount));
    phi->insertMeta("t_spacing", openvdb::StringMetadata("log"));
    phi->insertMeta("mu_bins", openvdb::Int32Metadata(table.muBins));
    phi->insertMeta(
        "mu_binning",
        openvdb::StringMetadata(
            "equal-cos over [-1, 1], voxel x = bin, centre -1 + (x + 0.5) * 2 / mu_bins"));
    phi->insertMeta("albedo", openvdb::DoubleMetadata(table.medium.albedo));
    phi->insertMeta("g", openvdb::DoubleMetadata(table.medium.g));
    phi->insertMeta("phase", openvdb::StringMetadata(toString(table.medium.phase)));
    phi->insertMeta("seed", openvdb::Int64Metadata(openvdb::Int64(table.seed)));
    phi->insertMeta("target_error", openvdb::DoubleMetadata(table.targetError));
    phi->insertMeta("error_t_max", openvdb::DoubleMetadata(table.errorTMax));
    openvdb::Int64 total = 0, least = std::numeric_limits<openvdb::Int64>::max();
    std::string perRow;
    for (std::size_t j = 0; j < table.photons.size(); ++j) {
        total += openvdb::Int64(table.photons[j]);
        least = std::min(least, openvdb::Int64(table.photons[j]));
        perRow += (j ? "," : "") + std::to_string(table.photons[j]);
    }
    phi->insertMeta("photons", openvdb::StringMetadata(perRow));
    phi->insertMeta("photons_total", openvdb::Int64Metadata(total));
    phi->insertMeta("photons_min", openvdb::Int64Metadata(least));
    grids.replace(phi);

    if (!table.single.empty()) {
        auto single = tableGrid(table, table.single, PHASE_SINGLE_GRID);
        single->insertMeta("units",
                           openvdb::StringMetadata(
                               "single-scattering part of phase, 1/sr per unit optical depth"));
        grids.replace(single);
    }
    auto err = tableGrid(table, table.error, PHASE_ERROR_GRID);
    err->insertMeta(
        "units", openvdb::StringMetadata("standard error of phase, 1/sr per unit optical depth"));
    grids.replace(err);
}

PhaseTable readPhaseTable(const GridSet& grids)
{
    const std::string& src = grids.source;
    const auto base = grids.find(PHASE_GRID);
    if (!base) {
        throw Error(src + ": no grid \"phase\"; is this a phase table written by nebphase?");
    }
    const auto phi = openvdb::GridBase::grid<openvdb::FloatGrid>(base);
    const auto kind = base->getMetadata<openvdb::StringMetadata>("table");
    if (!phi || !kind || kind->value() != PHASE_TABLE_KIND) {
        throw Error(src +
                    ": grid \"phase\" is not a phase table written by nebphase (expected a "
                    "FloatGrid with metadata table = \"" +
                    std::string(PHASE_TABLE_KIND) + "\")");
    }
    PhaseTable t;
    t.tMin = required<openvdb::DoubleMetadata, double>(*phi, "t_min", src, "double");
    t.tMax = required<openvdb::DoubleMetadata, double>(*phi, "t_max", src, "double");
    t.tCount = required<openvdb::Int32Metadata, int>(*phi, "t_count", src, "int32");
    t.muBins = required<openvdb::Int32Metadata, int>(*phi, "mu_bins", src, "int32");
    const auto spacing =
        required<openvdb::StringMetadata, std::string>(*phi, "t_spacing", src, "string");
    if (spacing != "log") {
        throw Error(src + ": phase table: t_spacing is \"" + spacing + "\", expected \"log\"");
    }
    t.medium.albedo = required<openvdb::DoubleMetadata, double>(*phi, "albedo", src, "double");
    t.medium.g = required<openvdb::DoubleMetadata, double>(*phi, "g", src, "double");
    t.medium.phase = phaseModelFromString(
        required<openvdb::StringMetadata, std::string>(*phi, "phase", src, "string"));
    t.seed =
        std::uint64_t(required<openvdb::Int64Metadata, openvdb::Int64>(*phi, "seed", src, "int64"));
    t.targetError = required<openvdb::DoubleMetadata, double>(*phi, "target_error", src, "double");
    t.errorTMax = required<openvdb::DoubleMetadata, double>(*phi, "error_t_max", src, "double");
    const auto least =
        required<openvdb::Int64Metadata, openvdb::Int64>(*phi, "photons_min", src, "int64");
    if (least <= 0) {
        throw Error(src + ": phase table: photons_min is " + std::to_string(least) +
                    "; a table needs photons > 0 in every row");
    }
    const auto perRow =
        required<openvdb::StringMetadata, std::string>(*phi, "photons", src, "string");
    for (std::size_t pos = 0; pos <= perRow.size();) {
        const auto comma = std::min(perRow.find(',', pos), perRow.size());
        try {
            t.photons.push_back(std::stoull(perRow.substr(pos, comma - pos)));
        } catch (const std::exception&) {
            throw Error(
                src +
                ": phase table: metadata \"photons\" is not a comma-separated list of counts");
        }
        pos = comma + 1;
    }
    if (t.tCount < 2 || t.muBins < 2 || t.muBins % 2 != 0) {
        throw Error(src +
                    ": phase table: needs t_count >= 2 and an even mu_bins >= 2, got t_count = " +
                    std::to_string(t.tCount) + ", mu_bins = " + std::to_string(t.muBins));
    }
    if (t.photons.size() != std::size_t(t.tCount)) {
        throw Error(src + ": phase table: metadata \"photons\" has " +
                    std::to_string(t.photons.size()) +
                    " entries for t_count = " + std::to_string(t.tCount));
    }
    const openvdb::CoordBBox axes(openvdb::Coord(0, 0, 0),
                                  openvdb::Coord(t.muBins - 1, t.tCount - 1, 0));
    const auto readValues = [&](const openvdb::FloatGrid& grid, std::vector<float>& out) {
        const auto box = grid.evalActiveVoxelBoundingBox();
        if (box != axes || grid.activeVoxelCount() != axes.volume()) {
            throw Error(src + ": grid \"" + grid.getName() +
                        "\" does not match its axes: expected " + std::to_string(t.muBins) + " x " +
                        std::to_string(t.tCount) + " x 1 active voxels (mu bins x t values)");
        }
        out.resize(std::size_t(t.tCount) * t.muBins);
        const auto acc = grid.getConstAccessor();
        for (int j = 0; j < t.tCount; ++j)
            for (int i = 0; i < t.muBins; ++i)
                out[std::size_t(j) * t.muBins + i] = acc.getValue(openvdb::Coord(i, j, 0));
    };
    readValues(*phi, t.phi);
    if (const auto e = grids.find(PHASE_ERROR_GRID)) {
        const auto eg = openvdb::GridBase::grid<openvdb::FloatGrid>(e);
        if (!eg) throw Error(src + ": grid \"phase.error\" is not a FloatGrid");
        readValues(*eg, t.error);
    } else {
        t.error.assign(t.phi.size(), 0.0f);
    }
    if (const auto e = grids.find(PHASE_SINGLE_GRID)) {
        const auto sg = openvdb::GridBase::grid<openvdb::FloatGrid>(e);
        if (!sg) throw Error(src + ": grid \"phase.single\" is not a FloatGrid");
        readValues(*sg, t.single);
    }
    t.validate(src);
    return t;
}

} // namespace nebula
