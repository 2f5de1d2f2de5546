// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/grid_io.h"
#include "nebula/io/grid_values.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/file_format.h"
#include "nebula/core/format.h"
#include "nebula/core/input.h"
#include "nebula/core/version.h"
#include "nebula/io/checksum.h"
#include "nebula/io/vdb_check.h"

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tree/LeafManager.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <streambuf>
#include <sys/stat.h>
#include <type_traits>
#include <unistd.h>
#include <utility>
#include <vector>

namespace nebula {

openvdb::GridBase::Ptr GridSet::find(const std::string& name) const
{
    for (const auto& g : grids) {
        if (g && g->getName() == name) return g;
    }
    return nullptr;
}

void GridSet::replace(openvdb::GridBase::Ptr grid)
{
    for (auto& g : grids) {
        if (g && g->getName() == grid->getName()) {
            g = grid;
            return;
        }
    }
    grids.push_back(grid);
}

std::string gridTypeName(const openvdb::GridBase& g)
{
    if (g.isType<openvdb::FloatGrid>()) return "FloatGrid";
    if (g.isType<openvdb::DoubleGrid>()) return "DoubleGrid";
    if (g.isType<openvdb::Int32Grid>()) return "Int32Grid";
    if (g.isType<openvdb::Int64Grid>()) return "Int64Grid";
    if (g.isType<openvdb::BoolGrid>()) return "BoolGrid";
    if (g.isType<openvdb::MaskGrid>()) return "MaskGrid";
    if (g.isType<openvdb::Vec3fGrid>()) return "Vec3fGrid";
    if (g.isType<openvdb::Vec3dGrid>()) return "Vec3dGrid";
    if (g.isType<openvdb::Vec3IGrid>()) return "Vec3IGrid";
    return g.type();
}

openvdb::FloatGrid::Ptr GridSet::floatGrid(const std::string& name, const std::string& option) const
{
    const auto base = find(name);
    if (!base) {
        std::string names;
        for (const auto& g : grids)
            names += (names.empty() ? "" : ", ") + detail::printable(g->getName(), 60);
        throw Error(source + ": no grid \"" + name + "\"" +
                    (option.empty() ? "" : " (" + option + ")") + "; the file has " +
                    (names.empty() ? std::string("no grids") : "grids: " + names));
    }
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid) {
        throw Error(source + ": grid \"" + name + "\"" +
                    (option.empty() ? "" : " (" + option + ")") + " is a " + gridTypeName(*base) +
                    " (" + base->type() + "), expected a FloatGrid");
    }
    requireAffine(*grid, source);
    requireVoxelSize(*grid, source);
    return grid;
}

std::string GridSet::metaString(const std::string& key, const std::string& fallback) const
{
    const auto m = meta[key];
    if (!m) return fallback;
    return m->str();
}

void GridSet::setMetaString(const std::string& key, const std::string& value)
{
    meta.removeMeta(key); // a key of another type would make insertMeta throw
    meta.insertMeta(key, openvdb::StringMetadata(value));
}

std::vector<Star> GridSet::stars() const
{
    const std::string json = metaString(META_STARS);
    if (json.empty()) return {};
    return parseStars(json, source + ": metadata " + META_STARS);
}

void GridSet::setStars(const std::vector<Star>& stars)
{
    setMetaString(META_STARS, starsToJson(stars));
}

bool GridSet::hasDust() const
{
    return bool(meta[META_DUST]);
}

DustParams GridSet::dust() const
{
    const std::string json = metaString(META_DUST);
    if (json.empty()) return DustParams{};
    return DustParams::fromJson(json, source + ": metadata " + META_DUST);
}

DustParams GridSet::dust(const Run& run) const
{
    const std::string json = metaString(META_DUST);
    if (json.empty()) return DustParams{};
    std::vector<std::string> missing;
    const DustParams d = DustParams::fromJson(json, source + ": metadata " + META_DUST, &missing);
    if (!missing.empty()) {
        run.warn(source + ": metadata " + META_DUST + " lacks " +
                 (missing.size() == 1 ? "a field" : std::to_string(missing.size()) + " fields") +
                 "; using the defaults " + d.missingFieldsText(missing));
    }
    return d;
}

void GridSet::setDust(const DustParams& dust)
{
    setMetaString(META_DUST, dust.toJson());
}

void requireAffine(const openvdb::GridBase& grid, const std::string& source)
{
    if (!grid.transform().isLinear()) {
        throw Error(source + ": grid \"" + grid.getName() + "\" has a non-affine transform (" +
                    grid.transform().mapType() +
                    "); only affine (linear) transforms are supported");
    }
}

void requireVoxelSize(const openvdb::GridBase& grid, const std::string& source)
{
    const auto& xform = grid.transform();
    const std::string where = source + ": grid \"" + grid.getName() + "\" ";
    // The linear map read off by applying it (as affineFromTransform() does): no inverse is
    // taken, so a singular map cannot throw here.
    const auto o = xform.indexToWorld(openvdb::Vec3d(0, 0, 0));
    openvdb::Vec3d axis[3];
    for (int i = 0; i < 3; ++i) {
        openvdb::Vec3d e(0, 0, 0);
        e[i] = 1.0;
        axis[i] = xform.indexToWorld(e) - o;
    }
    const auto axisText = [&](int i) {
        return "(" + detail::numberText(axis[i][0]) + ", " + detail::numberText(axis[i][1]) + ", " +
               detail::numberText(axis[i][2]) + ")";
    };
    for (int i = 0; i < 3; ++i) {
        const double length = axis[i].length();
        if (!std::isfinite(o[i]) || !std::isfinite(length)) {
            throw Error(where + "has a transform with non-finite values (voxel axis " +
                        std::string(1, char('x' + i)) + " " + axisText(i) +
                        "); expected a finite voxel size > 0");
        }
        if (!(length > 0.0)) {
            throw Error(where + "has voxel size 0 along its " + std::string(1, char('x' + i)) +
                        " axis (a singular transform); expected a finite voxel size > 0");
        }
    }
    // Invertible: the voxel's volume is not negligible next to its edges (axes not parallel).
    const double volume = std::fabs(axis[0].dot(axis[1].cross(axis[2])));
    const double edges = axis[0].length() * axis[1].length() * axis[2].length();
    if (!(volume > 1e-9 * edges)) {
        throw Error(where + "has a singular transform: its voxel axes " + axisText(0) + ", " +
                    axisText(1) + ", " + axisText(2) +
                    " span no volume; expected a finite voxel size > 0");
    }
}

namespace {

/// Whether @p ok(value) holds for every active value of @p tree: the leaves in parallel,
/// straight from their buffers, then the tiles. @p count, if given, gets the number of active
/// entries (a tile counts once, as the tree's value iterator counts it).
template <typename TreeT, typename Ok>
bool everyActiveValue(const TreeT& tree, const Ok& ok, std::size_t* count = nullptr)
{
    std::atomic<bool> bad{false};
    std::atomic<std::size_t> entries{0};
    openvdb::tree::LeafManager<const TreeT> leaves(tree);
    leaves.foreach ([&](const typename TreeT::LeafNodeType& leaf, std::size_t) {
        const auto* values = leaf.buffer().data();
        std::size_t on = 0;
        bool good = true;
        for (auto it = leaf.getValueMask().beginOn(); it; ++it, ++on)
            good = good && ok(values[it.pos()]);
        if (!good) bad = true;
        entries += on;
    });
    auto tile = tree.cbeginValueOn();
    tile.setMaxDepth(TreeT::ValueOnCIter::LEAF_DEPTH - 1); // tiles only
    for (; tile; ++tile, ++entries)
        if (!ok(*tile)) bad = true;
    if (count) *count = entries;
    return !bad;
}

} // namespace

std::size_t requireFiniteNonNegative(const openvdb::FloatGrid& grid, const std::string& source)
{
    // Only where a value is bad does the serial walk below run, to name the first one in the
    // tree's order.
    const auto finiteNonNegative = [](float v) { // false for NaN and inf too
        return v >= 0.0f && v <= std::numeric_limits<float>::max();
    };
    std::size_t count = 0;
    if (everyActiveValue(grid.tree(), finiteNonNegative, &count)) return count;
    std::size_t n = 0;
    for (auto it = grid.cbeginValueOn(); it; ++it, ++n) {
        const float v = *it;
        if (!std::isfinite(v) || v < 0.0f) {
            const auto c = it.getCoord();
            std::ostringstream msg;
            msg << source << ": grid \"" << grid.getName() << "\" has "
                << (std::isnan(v)   ? "a NaN"
                    : std::isinf(v) ? "an infinite"
                                    : "a negative")
                << " value " << valueText(v) << " at voxel (" << c.x() << ", " << c.y() << ", "
                << c.z() << "); expected finite values >= 0";
            throw Error(msg.str());
        }
    }
    return n;
}

std::string valueText(double v)
{
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0.0 ? "inf" : "-inf";
    return detail::numberText(v);
}

std::size_t requireFinite(const openvdb::FloatGrid& grid, const std::string& source,
                          const openvdb::CoordBBox* box)
{
    const std::string where = source + ": grid \"" + grid.getName() + "\" has ";
    const auto refuse = [&](float v, const char* what, const openvdb::Coord& c) {
        throw Error(where + what + " value " + valueText(v) + " at voxel (" +
                    std::to_string(c.x()) + ", " + std::to_string(c.y()) + ", " +
                    std::to_string(c.z()) + "); expected finite values");
    };
    const auto finite = [](float v) { return std::isfinite(v); };
    // Only where a value is not finite does a serial walk run, to name the first one in the
    // tree's order.
    std::size_t count = 0;
    if (!everyActiveValue(grid.tree(), finite, &count)) {
        for (auto it = grid.cbeginValueOn(); it; ++it) {
            if (!std::isfinite(*it)) refuse(*it, "the", it.getCoord());
        }
    }
    if (!box) return count;
    if (!std::isfinite(grid.background())) {
        throw Error(where + "the background value " + valueText(grid.background()) +
                    " (its inactive voxels' value); expected a finite value");
    }
    // The inactive values inside the box: leaf voxels (in parallel, then serially to name
    // the first), then the tiles.
    std::atomic<bool> bad{false};
    openvdb::tree::LeafManager<const openvdb::FloatTree> leaves(grid.tree());
    const auto badOff = [&](const openvdb::FloatTree::LeafNodeType& leaf,
                            openvdb::Coord* at) -> bool {
        if (!box->hasOverlap(leaf.getNodeBoundingBox())) return false;
        const float* values = leaf.buffer().data();
        for (auto it = leaf.getValueMask().beginOff(); it; ++it) {
            const openvdb::Coord c = leaf.offsetToGlobalCoord(it.pos());
            if (!std::isfinite(values[it.pos()]) && box->isInside(c)) {
                if (at) *at = c;
                return true;
            }
        }
        return false;
    };
    leaves.foreach ([&](const openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
        if (badOff(leaf, nullptr)) bad = true;
    });
    if (bad) {
        for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
            openvdb::Coord c;
            if (badOff(*leaf, &c)) refuse(leaf->getValue(c), "the inactive", c);
        }
    }
    auto tile = grid.tree().cbeginValueOff();
    tile.setMaxDepth(openvdb::FloatTree::ValueOffCIter::LEAF_DEPTH - 1); // tiles only
    for (; tile; ++tile) {
        if (std::isfinite(*tile)) continue;
        openvdb::CoordBBox bb;
        tile.getBoundingBox(bb);
        if (box->hasOverlap(bb)) refuse(*tile, "the inactive", bb.min());
    }
    return count;
}

nlohmann::json GridSet::history() const
{
    const std::string text = metaString(META_HISTORY);
    if (!text.empty()) {
        const auto history =
            detail::parseJson(text, source, std::string("metadata ") + META_HISTORY + " is ");
        if (!history.is_array()) {
            throw Error(source + ": metadata " + META_HISTORY + " is not a JSON array");
        }
        return history;
    }
    // A file from before nebula:history: its last stage is all that it recorded.
    nlohmann::json history = nlohmann::json::array();
    if (!metaString(META_TOOL).empty()) {
        history.push_back({{"tool", metaString(META_TOOL)},
                           {"version", metaString(META_VERSION)},
                           {"command", metaString(META_COMMAND)}});
    }
    return history;
}

nlohmann::json GridSet::historyWith(const std::string& tool, const std::string& command) const
{
    nlohmann::json history = this->history();
    history.push_back({{"tool", tool}, {"version", NEBULA_VERSION_STRING}, {"command", command}});
    return history;
}

namespace {

/// A read-only, seekable std::streambuf over an input's bytes (no copy). It hands them out in
/// windows and, for a mapped file, releases the pages well behind the reader
/// (InputBytes::release()), so a file being parsed into grids does not also stay in memory.
class MemoryBuf : public std::streambuf
{
public:
    explicit MemoryBuf(const InputBytes& bytes) : mBytes(bytes) { setWindow(0); }

protected:
    int_type underflow() override
    {
        const std::size_t pos = std::size_t(gptr() - eback());
        if (pos >= mBytes.view().size()) return traits_type::eof();
        setWindow(pos);
        return traits_type::to_int_type(*gptr());
    }
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override
    {
        const off_type size = off_type(mBytes.view().size());
        const off_type base = dir == std::ios_base::beg   ? 0
                              : dir == std::ios_base::cur ? off_type(gptr() - eback())
                                                          : size;
        const off_type pos = base + off;
        if (pos < 0 || pos > size) return pos_type(off_type(-1));
        setWindow(std::size_t(pos));
        return pos_type(pos);
    }
    pos_type seekpos(pos_type pos, std::ios_base::openmode mode) override
    {
        return seekoff(off_type(pos), std::ios_base::beg, mode);
    }

private:
    static constexpr std::size_t WINDOW = std::size_t(8) << 20;
    /// Kept behind the reader: OpenVDB seeks back a little (to a grid's descriptor).
    static constexpr std::size_t KEEP = std::size_t(4) << 20;

    void setWindow(std::size_t pos)
    {
        if (mBytes.mapped() && pos > mReleased + KEEP + WINDOW) {
            mBytes.release(mReleased, pos - KEEP);
            mReleased = pos - KEEP;
        }
        const std::string_view data = mBytes.view();
        char* p = const_cast<char*>(data.data()); // the get area is never written
        setg(p, p + pos, p + std::min(data.size(), pos + WINDOW));
    }

    const InputBytes& mBytes;
    std::size_t mReleased = 0;
};

/// The VDB magic number's 8 bytes (vdb_check.cpp checks them again with the rest).
bool vdbHead(std::string_view head, bool atEnd, const std::string& source)
{
    static const std::string_view magic("\x20\x42\x44\x56\0\0\0\0", 8);
    const std::string_view have = head.substr(0, std::min(head.size(), magic.size()));
    if (have != magic.substr(0, have.size())) {
        throw Error(source + ": not a VDB file (no VDB magic number at byte 0)");
    }
    if (have.size() == magic.size()) return true;
    if (atEnd) {
        throw Error(source + (head.empty() ? ": empty, not a VDB file"
                                           : ": truncated: shorter than a VDB header"));
    }
    return false;
}

[[noreturn]] void damaged(const GridSet& set, const std::string& what)
{
    throw Error(set.source + ": damaged: " + what +
                " does not match the checksum nebula wrote with it (nebula:checksums); if "
                "another program changed it on purpose, remove nebula:checksums from the file "
                "metadata");
}

} // namespace

std::string contentDigest(const GridSet& grids)
{
    // verifyChecksums() has checked what nebula:checksums lists when the set was read.
    nlohmann::json listed = nlohmann::json::object();
    const std::string text = grids.metaString(META_CHECKSUMS);
    if (!text.empty()) {
        try {
            const auto sums = nlohmann::json::parse(text);
            if (sums.is_object() && sums.contains("grids") && sums["grids"].is_object())
                listed = sums["grids"];
        } catch (const std::exception&) {
        }
    }
    std::string digest = "metadata " + metadataChecksum(grids.meta, META_CHECKSUMS) + "\n";
    for (const auto& grid : grids.grids) {
        const std::string name = grid->getName();
        const auto it = listed.find(name);
        const std::string sum =
            it != listed.end() && it->is_string() ? it->get<std::string>() : gridChecksum(*grid);
        digest += name + " " + sum + "\n";
    }
    return digest;
}

namespace {

/// Verifies the grids and the file metadata against `nebula:checksums`, where the file has it.
void verifyChecksums(const GridSet& set)
{
    const std::string text = set.metaString(META_CHECKSUMS);
    if (text.empty()) return;
    const std::string key = std::string("metadata ") + META_CHECKSUMS;
    nlohmann::json sums;
    detail::checkJsonBounds(text, set.source, key + " is ");
    try {
        sums = nlohmann::json::parse(text);
    } catch (const std::exception&) {
        throw Error(set.source + ": damaged: " + key + " is not valid JSON");
    }
    if (!sums.is_object() || !sums.contains("algorithm") || !sums["algorithm"].is_string() ||
        sums["algorithm"].get<std::string>() != CHECKSUM_ALGORITHM) {
        throw Error(set.source + ": " + key +
                    " names no checksum algorithm this nebula knows (expected " +
                    CHECKSUM_ALGORITHM + "): the file is damaged or from a newer nebula");
    }
    if (!sums.is_object() || !sums.contains("grids") || !sums["grids"].is_object() ||
        !sums.contains("metadata") || !sums["metadata"].is_string()) {
        throw Error(set.source + ": damaged: " + key +
                    " is not {\"grids\": {...}, \"metadata\": \"...\"}");
    }
    if (metadataChecksum(set.meta, META_CHECKSUMS) != sums["metadata"].get<std::string>()) {
        damaged(set, "the file metadata");
    }
    std::vector<std::pair<std::string, openvdb::GridBase::Ptr>> listed;
    for (const auto& [name, sum] : sums["grids"].items()) {
        const auto grid = set.find(name);
        if (!grid) {
            throw Error(set.source + ": damaged: grid \"" + detail::printable(name, 60) +
                        "\", which nebula wrote into it, is missing");
        }
        if (!sum.is_string()) damaged(set, "grid \"" + detail::printable(name, 60) + "\"");
        listed.emplace_back(name, grid);
    }
    // The grids' checksums in parallel (a file of nebscatter's has 150 grids); the first
    // mismatch in the file's order is the one reported.
    std::vector<std::string> actual(listed.size());
    tbb::parallel_for(std::size_t(0), listed.size(),
                      [&](std::size_t i) { actual[i] = gridChecksum(*listed[i].second); });
    for (std::size_t i = 0; i < listed.size(); ++i) {
        const std::string& name = listed[i].first;
        if (!actual[i].empty() && actual[i] != sums["grids"][name].get<std::string>()) {
            damaged(set, "grid \"" + detail::printable(name, 60) + "\"");
        }
    }
}

/// Throws Error "<source>: two grids are named ..." if two of @p grids share a name.
void requireUniqueNames(const openvdb::GridPtrVec& grids, const std::string& source)
{
    std::map<std::string, std::size_t> seen;
    for (std::size_t i = 0; i < grids.size(); ++i) {
        const auto [it, fresh] = seen.emplace(grids[i]->getName(), i);
        if (!fresh) {
            throw Error(source + ": grids " + std::to_string(it->second + 1) + " and " +
                        std::to_string(i + 1) + " are both named \"" +
                        detail::printable(it->first, 60) +
                        "\"; a nebula file holds each grid name once");
        }
    }
}

} // namespace

GridSet readGrids(const std::string& path, const std::string& option)
{
    InputSpec spec;
    spec.option = option;
    spec.format = "a VDB file";
    spec.limit = MAX_GRID_INPUT_BYTES;
    spec.head = vdbHead;
    spec.checkMemory = true;
    return readGridsFromBytes(mapInput(path, spec), inputName(path));
}

GridSet readGridsFromMemory(const std::string& bytes, const std::string& source)
{
    return readGridsFromBytes(InputBytes::borrow(bytes), source);
}

GridSet readGridsFromBytes(const InputBytes& bytes, const std::string& source)
{
    openvdb::initialize(); // the grid types (idempotent): a program of one's own needs no call
    GridSet set;
    set.source = source;
    // Structure first: OpenVDB trusts the lengths in the file (a damaged one can make it
    // allocate gigabytes or overrun a buffer).
    checkVdbStructure(bytes.view(), set.source);
    bytes.release(0, bytes.view().size()); // checked; read back as the parser goes
    try {
        MemoryBuf buf(bytes);
        std::istream in(&buf);
        openvdb::io::Stream stream(in, /*delayLoad=*/false);
        set.grids = *stream.getGrids();
        if (auto m = stream.getMetadata()) set.meta = *m;
        bytes.release(0, bytes.view().size());
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(set.source + ": not a valid, complete VDB file (" +
                    detail::printable(e.what()) + ")");
    }
    for (const auto& g : set.grids) {
        if (!g) throw Error(set.source + ": not a valid, complete VDB file (empty grid entry)");
    }
    requireUniqueNames(set.grids, set.source);
    try {
        verifyChecksums(set);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) { // OpenVDB on a grid it read but cannot use
        throw Error(set.source + ": not a valid VDB file (" + detail::printable(e.what()) + ")");
    }
    return set;
}

namespace {

/// Archive::write(ostream, grids, seekable, meta) is protected; io::File::write calls it on a
/// std::ofstream it never checks. This calls it on an AtomicFile's checked stream.
class CheckedArchive : public openvdb::io::Archive
{
public:
    void writeTo(std::ostream& os, const openvdb::GridPtrVec& grids,
                 const openvdb::MetaMap& meta) const
    {
        Archive::write(os, grids, /*seekable=*/true, meta);
    }
};

/// Stamps provenance and checksums into @p grids before a write.
/// The first active value (or background) of a float grid that is not finite, named.
template <typename GridT> void requireFiniteGrid(const GridT& grid, const std::string& where)
{
    const auto finite = [](const auto& v) {
        if constexpr (std::is_floating_point_v<std::decay_t<decltype(v)>>) {
            return std::isfinite(v);
        } else {
            return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
        }
    };
    const std::string name = "grid \"" + detail::printable(grid.getName(), 60) + "\"";
    if (!finite(grid.background())) {
        throw Error(where + ": " + name + " has a non-finite background; refusing to write it");
    }
    // The serial walk below only where a value is not finite, to name the first one.
    if (everyActiveValue(grid.tree(), finite)) return;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        if (!finite(*it)) {
            const auto ijk = it.getCoord();
            throw Error(where + ": " + name + " has a non-finite value at voxel (" +
                        std::to_string(ijk.x()) + ", " + std::to_string(ijk.y()) + ", " +
                        std::to_string(ijk.z()) +
                        "); refusing to write it (a physical parameter overflowed)");
        }
    }
}

/// No tool writes two grids of one name or a non-finite voxel (as requireFinitePixels() for
/// images).
void requireWritable(const GridSet& grids, const std::string& where)
{
    requireUniqueNames(grids.grids, where);
    for (const auto& g : grids.grids) {
        if (const auto f = openvdb::GridBase::constGrid<openvdb::FloatGrid>(g)) {
            requireFiniteGrid(*f, where);
        } else if (const auto d = openvdb::GridBase::constGrid<openvdb::DoubleGrid>(g)) {
            requireFiniteGrid(*d, where);
        } else if (const auto v = openvdb::GridBase::constGrid<openvdb::Vec3SGrid>(g)) {
            requireFiniteGrid(*v, where);
        }
    }
}

void stamp(GridSet& grids, const std::string& tool, const std::string& command)
{
    const nlohmann::json history = grids.historyWith(tool, command);
    grids.setMetaString(META_TOOL, tool);
    grids.setMetaString(META_VERSION, NEBULA_VERSION_STRING);
    grids.setMetaString(META_COMMAND, command);
    grids.setMetaString(META_HISTORY, history.dump());
    for (auto& g : grids.grids)
        if (g->getCreator().empty()) g->setCreator(tool + " " NEBULA_VERSION_STRING);
    std::vector<std::string> sum(grids.grids.size()); // the grids' checksums in parallel
    tbb::parallel_for(std::size_t(0), sum.size(),
                      [&](std::size_t i) { sum[i] = gridChecksum(*grids.grids[i]); });
    nlohmann::json sums = nlohmann::json::object();
    for (std::size_t i = 0; i < sum.size(); ++i)
        if (!sum[i].empty()) sums[grids.grids[i]->getName()] = sum[i];
    grids.meta.removeMeta(META_CHECKSUMS);
    const nlohmann::json all = {{"algorithm", CHECKSUM_ALGORITHM},
                                {"grids", sums},
                                {"metadata", metadataChecksum(grids.meta, META_CHECKSUMS)}};
    grids.setMetaString(META_CHECKSUMS, all.dump());
}

} // namespace

void writeGrids(AtomicFile& file, GridSet grids, const std::string& tool,
                const std::string& command)
{
    checkOutputName(file.path(), "output", FileFormat::Vdb);
    requireWritable(grids, file.path());
    stamp(grids, tool, command);
    try {
        CheckedArchive().writeTo(file.stream(), grids.grids, grids.meta);
    } catch (const openvdb::ArithmeticError&) {
        // OpenVDB's text ("Non-zero scale values required") names no grid: find the grid
        // whose transform cannot be written and say why in nebula's words.
        struct Discard : std::streambuf
        {
            int overflow(int c) override { return c; }
            std::streamsize xsputn(const char*, std::streamsize n) override { return n; }
        };
        for (const auto& g : grids.grids) {
            try {
                Discard discard;
                std::ostream probe(&discard);
                openvdb::io::Stream(probe).write(openvdb::GridCPtrVec{g});
            } catch (const openvdb::ArithmeticError&) {
                const auto vs = g->transform().voxelSize();
                const auto o = g->transform().indexToWorld(openvdb::Vec3d(0, 0, 0));
                throw Error(file.path() + ": cannot write grid \"" +
                            detail::printable(g->getName(), 60) + "\": its transform (voxels " +
                            detail::numberText(vs[0]) + " x " + detail::numberText(vs[1]) + " x " +
                            detail::numberText(vs[2]) + " at (" + detail::numberText(o[0]) + ", " +
                            detail::numberText(o[1]) + ", " + detail::numberText(o[2]) +
                            ")) has a voxel size of 0 or one lost next to its coordinates");
            }
        }
        throw Error(file.path() + ": cannot write VDB file: a grid's transform or values "
                                  "overflow (an arithmetic error while writing)");
    } catch (const std::exception& e) {
        if (file.stream()) {
            throw Error(file.path() + ": cannot write VDB file (" + detail::printable(e.what()) +
                        ")");
        }
    }
    file.finish(); // names the OS error of a failed write
}

void writeGrids(const std::string& path, GridSet grids, const std::string& tool,
                const std::string& command)
{
    if (path == "-") {
        refuseBinaryToTerminal(path, "-o");
        requireWritable(grids, "<stdout>");
        stamp(grids, tool, command);
        // A fresh ostream over stdout's buffer: OpenVDB leaves a pointer to its (then freed)
        // stream metadata in the stream it wrote to, so a second write to std::cout itself
        // would crash.
        std::ostream out(std::cout.rdbuf());
        openvdb::io::Stream(out).write(grids.grids, grids.meta);
        out.flush();
        if (!out) throw Error("<stdout>: write failed (" + std::string(std::strerror(errno)) + ")");
        return;
    }
    AtomicFile out(path);
    writeGrids(out, std::move(grids), tool, command);
    out.commit();
}

void refuseBinaryToTerminal(const std::string& path, const std::string& option)
{
    if (path == "-" && ::isatty(STDOUT_FILENO)) {
        throw UsageError(option + " -: refusing to write binary data to a terminal; "
                                  "redirect stdout or give a file name");
    }
}

std::string describeGrids(const GridSet& grids)
{
    std::string text =
        std::to_string(grids.grids.size()) + (grids.grids.size() == 1 ? " grid" : " grids");
    // A run of more than 3 grids whose names share their first two dot-separated parts
    // (nebscatter's scatter.stars.c2_-1.R, ...) is one entry: "scatter.stars.* (75)".
    const auto family = [&](std::size_t i) {
        const std::string& name = grids.grids[i]->getName();
        const auto first = name.find('.');
        const auto second = first == std::string::npos ? first : name.find('.', first + 1);
        return second == std::string::npos ? std::string() : name.substr(0, second + 1);
    };
    for (std::size_t i = 0; i < grids.grids.size();) {
        const std::string f = family(i);
        std::size_t end = i + 1;
        while (!f.empty() && end < grids.grids.size() && family(end) == f)
            ++end;
        text += i ? ", " : ": ";
        if (end - i > 3) {
            text += f + "* (" + std::to_string(end - i) + ")";
        } else {
            for (std::size_t k = i; k < end; ++k)
                text += (k > i ? ", " : "") + grids.grids[k]->getName();
        }
        i = end;
    }
    return text;
}

GridSet readGrids(const std::string& path, const Run& run, const std::string& option)
{
    GridSet grids = readGrids(path, option);
    run.info("read " + grids.source + ": " + describeGrids(grids));
    return grids;
}

void writeGrids(const std::string& path, GridSet grids, const Run& run)
{
    const std::string what = describeGrids(grids);
    writeGrids(path, std::move(grids), run.tool(), run.command());
    run.info("wrote " + (path == "-" ? std::string("<stdout>") : path) + ": " + what);
}

} // namespace nebula
