// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/spectral_grids.h"

#include "nebula/core/error.h"

#include <cmath>
#include <sstream>

namespace nebula {

namespace {

std::string inQuotes(const std::string& s)
{
    return "\"" + s + "\"";
}

} // namespace

std::vector<SpectralLine> gridLines(const openvdb::GridBase& grid, const std::string& source,
                                    const std::vector<SpectralLine>& fallback)
{
    const auto meta = grid[META_LINES];
    if (!meta) return fallback;
    const std::string where =
        source + ": grid " + inQuotes(grid.getName()) + " metadata " + META_LINES;
    const auto str = grid.getMetadata<openvdb::StringMetadata>(META_LINES);
    if (!str) throw Error(where + " is a " + meta->typeName() + ", expected a string");
    return parseLineList(str->value(), where);
}

std::vector<SpectralLine> gridAbsorptionLines(const openvdb::GridBase& grid,
                                              const std::string& source)
{
    const std::string where = source + ": absorption grid " + inQuotes(grid.getName());
    const auto meta = grid[META_ABSORPTION_LINES];
    if (!meta) {
        throw Error(where + " has no " + std::string(META_ABSORPTION_LINES) +
                    " metadata; expected the lines it absorbs, NAME:STRENGTH,... such as "
                    "\"Na I D2:1,Na I D1:0.5\" (STRENGTH in nm pc^-1 per unit of the grid)");
    }
    const auto str = grid.getMetadata<openvdb::StringMetadata>(META_ABSORPTION_LINES);
    const std::string key = where + " metadata " + META_ABSORPTION_LINES;
    if (!str) throw Error(key + " is a " + meta->typeName() + ", expected a string");
    return parseLineList(str->value(), key);
}

std::vector<std::string> absorptionGridNames(const GridSet& grids)
{
    std::vector<std::string> names;
    for (const auto& g : grids.grids)
        if (g && isAbsorptionGridName(g->getName())) names.push_back(g->getName());
    return names;
}

void requireValidTemperature(const openvdb::FloatGrid& grid, const std::string& source)
{
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        const float T = *it;
        if (std::isfinite(T) && T >= 0.0f) continue;
        const auto c = it.getCoord();
        std::ostringstream msg;
        msg << source << ": grid " << inQuotes(grid.getName()) << " has "
            << (std::isnan(T)   ? "a NaN"
                : std::isinf(T) ? "an infinite"
                                : "a negative")
            << " temperature " << T << " at voxel (" << c.x() << ", " << c.y() << ", " << c.z()
            << "); expected finite temperatures >= 0 [K]";
        throw Error(msg.str());
    }
}

openvdb::Vec3fGrid::Ptr velocityGrid(const GridSet& grids, const std::string& name,
                                     const std::string& option)
{
    const std::string opt = option.empty() ? "" : " (" + option + ")";
    const auto base = grids.find(name);
    if (!base) {
        std::string names;
        for (const auto& g : grids.grids)
            names += (names.empty() ? "" : ", ") + g->getName();
        throw Error(grids.source + ": no grid \"" + name + "\"" + opt +
                    " for the gas velocity; the file has " +
                    (names.empty() ? std::string("no grids") : "grids: " + names));
    }
    auto grid = openvdb::gridPtrCast<openvdb::Vec3fGrid>(base);
    if (!grid) {
        throw Error(grids.source + ": grid \"" + name + "\"" + opt + " is a " +
                    gridTypeName(*base) + " (" + base->type() +
                    "), expected a Vec3fGrid of velocities [km/s]");
    }
    requireAffine(*grid, grids.source);
    requireVoxelSize(*grid, grids.source);
    const auto bad = [&](const openvdb::Vec3f& v) {
        return !(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]));
    };
    if (bad(grid->background())) {
        throw Error(grids.source + ": grid \"" + name +
                    "\" has a non-finite background value; "
                    "expected finite velocities [km/s]");
    }
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        if (!bad(*it)) continue;
        const auto c = it.getCoord();
        const auto v = *it;
        std::ostringstream msg;
        msg << grids.source << ": grid \"" << name << "\" has a non-finite velocity (" << v[0]
            << ", " << v[1] << ", " << v[2] << ") at voxel (" << c.x() << ", " << c.y() << ", "
            << c.z() << "); expected finite velocities [km/s]";
        throw Error(msg.str());
    }
    return grid;
}

} // namespace nebula
