// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/vdb_check.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"

#include <openvdb/io/Compression.h>
#include <openvdb/points/StreamCompression.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <exception>
#include <istream>
#include <streambuf>
#include <string>
#include <utility>
#include <vector>

// The layout below follows OpenVDB 10.0.1: io/Archive.cc (header, grids), io/GridDescriptor.cc,
// MetaMap.cc and Metadata.h, io/DelayedLoadMetadata.cc, math/Transform.cc and math/Maps.h,
// tree/Tree.h, tree/RootNode.h, tree/InternalNode.h, tree/LeafNode*.h, io/Compression.h/.cc.

namespace nebula {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "VDB bytes are read as little-endian");

/// OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION (OpenVDB 3.0): per-grid compression flags and
/// mask-compression codes; older layouts differ in many places and are refused.
constexpr std::uint32_t FORMAT_OLDEST = 222;
/// OpenVDB 10 writes 224. OpenVDB 13 writes 225 (half grids) in the same layout, which
/// OpenVDB 10 reads with a warning; what comes later is unknown and refused.
constexpr std::uint32_t FORMAT_NEWEST = 225;
constexpr std::uint32_t COMPRESS_ZIP = 0x1, COMPRESS_ACTIVE_MASK = 0x2, COMPRESS_BLOSC = 0x4;
constexpr std::size_t BLOSC_HEADER_BYTES = 16;
constexpr std::size_t BLOSC_PAD_BYTES = 128; ///< compression::bloscCompress pads up to this
constexpr std::size_t LEAF_VALUES = 512;     ///< 8^3
constexpr std::size_t LEAF_MASK_BYTES = LEAF_VALUES / 8;
constexpr std::size_t NAME_CHARS = 60;
/// Fewest bytes one grid can take: descriptor (3 string lengths, 3 offsets), compression
/// flags, metadata count, map type length and the smallest map (TranslationMap, 24 bytes).
constexpr std::uint64_t MIN_GRID_BYTES = 12 + 24 + 4 + 4 + 4 + 24;
/// Fewest bytes one metadata entry can take: name, type and value lengths.
constexpr std::uint64_t MIN_META_BYTES = 12;
constexpr std::string_view HALF_SUFFIX = "_HalfFloat";
constexpr std::string_view DELAYED_LOAD_TYPE = "__delayedload";
constexpr std::string_view DELAYED_LOAD_NAME = "file_delayed_load";

using Coord = std::array<std::int64_t, 3>;

std::string coordText(const Coord& c)
{
    return "(" + std::to_string(c[0]) + ", " + std::to_string(c[1]) + ", " + std::to_string(c[2]) +
           ")";
}

/// @p name for a message: "name[N]" for the unique names OpenVDB gives same-named grids (as
/// GridDescriptor::nameAsString), non-printable bytes as \xNN, at most NAME_CHARS characters.
std::string shownName(std::string_view name)
{
    std::string text(name.substr(0, 4 * NAME_CHARS));
    const auto sep = text.find('\x1e');
    if (sep != std::string::npos) text = text.substr(0, sep) + "[" + text.substr(sep + 1) + "]";
    return detail::printable(text, NAME_CHARS);
}

std::uint32_t loadU32(std::string_view bytes, std::size_t at)
{
    std::uint32_t v;
    std::memcpy(&v, bytes.data() + at, sizeof v);
    return v;
}

/// The 64-bit words of a node mask (util::NodeMask stores whole words).
std::uint64_t maskWord(std::string_view mask, std::size_t w)
{
    std::uint64_t word;
    std::memcpy(&word, mask.data() + 8 * w, 8);
    return word;
}

/// Number of set bits of @p x (portable: no popcnt instruction assumed).
unsigned bitCount(std::uint64_t x)
{
    x -= (x >> 1) & 0x5555555555555555ull;
    x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
    x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0full;
    return unsigned((x * 0x0101010101010101ull) >> 56);
}

/// Number of set bits of a node mask (NodeMask::countOn).
std::uint64_t countOn(std::string_view mask)
{
    std::uint64_t n = 0;
    for (std::size_t w = 0; w < mask.size() / 8; ++w)
        n += bitCount(maskWord(mask, w));
    return n;
}

/// Calls @p f(i) for each set bit i of @p mask, in ascending order (NodeMask::OnIterator).
template <typename F> void forEachOn(std::string_view mask, const F& f)
{
    for (std::size_t w = 0; w < mask.size() / 8; ++w) {
        for (auto word = maskWord(mask, w); word != 0; word &= word - 1)
            f(w * 64 + std::size_t(__builtin_ctzll(word)));
    }
}

/// The first entry set in both masks, or -1.
std::int64_t firstOverlap(std::string_view a, std::string_view b)
{
    for (std::size_t w = 0; w < a.size() / 8; ++w) {
        const auto both = maskWord(a, w) & maskWord(b, w);
        if (both != 0) return std::int64_t(w * 64) + __builtin_ctzll(both);
    }
    return -1;
}

/// Value size of the fixed-size metadata types that openvdb::initialize() registers
/// (TypedMetadata<T>::readValue reads sizeof(T) bytes whatever the stored length says); 0 for
/// strings, the delayed-load metadata and types OpenVDB reads as raw bytes.
std::size_t fixedMetadataSize(std::string_view type)
{
    static constexpr std::pair<std::string_view, std::size_t> TYPES[] = {
        {"bool", 1},    {"double", 8},  {"float", 4},  {"int32", 4},  {"int64", 8},
        {"vec2i", 8},   {"vec2s", 8},   {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12},
        {"vec3d", 24},  {"vec4i", 16},  {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64},
        {"mat4d", 128}, {"ptidx32", 4}, {"ptidx64", 8}};
    for (const auto& [name, size] : TYPES) {
        if (name == type) return size;
    }
    return 0;
}

/// Bytes that MapBase::read() reads for the linear map types openvdb::initialize()
/// registers (math/Maps.h), or 0.
std::size_t linearMapSize(std::string_view type)
{
    static constexpr std::pair<std::string_view, std::size_t> MAPS[] = {
        {"AffineMap", 128},
        {"UnitaryMap", 128},
        {"ScaleMap", 120},
        {"UniformScaleMap", 120},
        {"TranslationMap", 24},
        {"ScaleTranslateMap", 144},
        {"UniformScaleTranslateMap", 144}};
    for (const auto& [name, size] : MAPS) {
        if (name == type) return size;
    }
    return 0;
}

/// NonlinearFrustumMap::read(): a BBoxd, taper and depth, then a second (linear) map.
constexpr std::size_t FRUSTUM_BYTES = 48 + 8 + 8;

/// How a tree's leaves store their values.
enum class LeafKind { Values, Bool, Mask };

/// A tree configuration the checker reads to the last byte.
struct TreeKind
{
    std::string_view typeName;
    std::size_t valueSize; ///< bytes of one value (tiles, backgrounds, raw chunks)
    std::size_t halfSize;  ///< bytes of one value saved as half float; 0 if never half
    LeafKind leaf;
    bool boolValues() const { return leaf != LeafKind::Values; }
};

constexpr TreeKind TREE_KINDS[] = {
    {"Tree_float_5_4_3", 4, 2, LeafKind::Values},  {"Tree_double_5_4_3", 8, 2, LeafKind::Values},
    {"Tree_int32_5_4_3", 4, 0, LeafKind::Values},  {"Tree_int64_5_4_3", 8, 0, LeafKind::Values},
    {"Tree_vec3s_5_4_3", 12, 6, LeafKind::Values}, {"Tree_vec3d_5_4_3", 24, 6, LeafKind::Values},
    {"Tree_vec3i_5_4_3", 12, 0, LeafKind::Values}, {"Tree_bool_5_4_3", 1, 0, LeafKind::Bool},
    {"Tree_mask_5_4_3", 1, 0, LeafKind::Mask}};

const TreeKind* findTreeKind(std::string_view type)
{
    for (const auto& kind : TREE_KINDS) {
        if (kind.typeName == type) return &kind;
    }
    return nullptr;
}

/// Item names of one node level's compressed values, for messages.
struct ValueNames
{
    const char* values;
    const char* inactive;
    const char* selection;
};

constexpr ValueNames LEAF_NAMES{"leaf buffer", "leaf buffer's inactive value",
                                "leaf buffer's selection mask"};

/// An internal node level of the 5-4-3 tree.
struct InternalLevel
{
    unsigned log2Dim;   ///< 5 or 4
    unsigned childLog2; ///< log2 of the child node's width in voxels (7 or 3)
    const char* childMaskName;
    ValueNames names;
    std::size_t numValues() const { return std::size_t(1) << (3 * log2Dim); }
    std::size_t maskBytes() const { return numValues() / 8; }
};

constexpr InternalLevel UPPER{5,
                              7,
                              "upper internal node child mask",
                              {"upper internal node values", "upper internal node inactive value",
                               "upper internal node selection mask"}};
constexpr InternalLevel LOWER{4,
                              3,
                              "lower internal node child mask",
                              {"lower internal node values", "lower internal node inactive value",
                               "lower internal node selection mask"}};
constexpr std::int64_t ROOT_CHILD_DIM = 4096; ///< 2^(5+4+3) voxels

/// Bounds-checked reading of the bytes in place, and the one-line messages.
class Reader
{
public:
    Reader(std::string_view bytes, const std::string& source)
        : mBytes(bytes), mSource(detail::printable(source, 100))
    {}

    std::string_view bytes() const { return mBytes; }
    std::size_t pos() const { return mPos; }
    std::size_t remaining() const { return mBytes.size() - mPos; }
    /// Moves to @p pos (<= size(), which the caller has checked).
    void seek(std::size_t pos) { mPos = pos; }
    /// Names the grid in later messages ("grid \"name\" "); empty: none.
    void setGrid(std::string_view name) { mGrid = "grid \"" + shownName(name) + "\" "; }
    void clearGrid() { mGrid.clear(); }

    /// The next @p n bytes (then skipped); Error "truncated: ..." if fewer remain.
    std::string_view take(std::uint64_t n, std::string_view item)
    {
        if (n > remaining()) truncated(mPos, item, n);
        const auto view = mBytes.substr(mPos, std::size_t(n));
        mPos += std::size_t(n);
        return view;
    }

    template <typename T> T read(std::string_view item)
    {
        T value;
        std::memcpy(&value, take(sizeof(T), item).data(), sizeof(T));
        return value;
    }

    /// A length-prefixed string (readString() of util/Name.h).
    std::string_view string(std::string_view item)
    {
        const auto size = read<std::uint32_t>(item);
        return take(size, item);
    }

    /// Throws "<source>: [grid "g" ]<item> at byte <at> <problem>".
    [[noreturn]] void fail(std::size_t at, std::string_view item, const std::string& problem) const
    {
        raise(mGrid + std::string(item) + " at byte " + std::to_string(at) + " " + problem);
    }

    /// Throws "<source>: truncated: [grid "g" ]<item> at byte <at> needs N bytes, R remain".
    [[noreturn]] void truncated(std::size_t at, std::string_view item, std::uint64_t need) const
    {
        raise("truncated: " + mGrid + std::string(item) + " at byte " + std::to_string(at) +
              " needs " + std::to_string(need) + " byte" + (need == 1 ? "" : "s") + ", " +
              std::to_string(mBytes.size() - std::min(at, mBytes.size())) + " remain");
    }

    /// Throws "<source>: <what>" (bounded to one short line).
    [[noreturn]] void raise(const std::string& what) const
    {
        std::string line = mSource + ": " + what;
        if (line.size() > 290) line = line.substr(0, 287) + "...";
        throw Error(line);
    }

private:
    std::string_view mBytes;
    std::string mSource;
    std::string mGrid;
    std::size_t mPos = 0;
};

/// A read-only std::streambuf over bytes in place.
class ViewBuf : public std::streambuf
{
public:
    explicit ViewBuf(std::string_view bytes)
    {
        char* p = const_cast<char*>(bytes.data()); // never written: get area only
        setg(p, p, p + bytes.size());
    }
};

/// A Blosc chunk's header fields (blosc.h: nbytes at byte 4, cbytes at byte 12).
struct BloscSizes
{
    std::uint32_t nbytes;
    std::uint32_t cbytes;
};

/// Header sizes of the Blosc chunk @p payload; Error if it is shorter than the header.
BloscSizes bloscSizes(const Reader& r, std::string_view payload, std::size_t at,
                      std::string_view item)
{
    if (payload.size() < BLOSC_HEADER_BYTES) {
        r.fail(at, item,
               "is a Blosc chunk of " + std::to_string(payload.size()) +
                   " bytes, shorter than the 16-byte Blosc header");
    }
    return {loadU32(payload, 4), loadU32(payload, 12)};
}

/// What the delayed-load metadata ("__delayedload") of a grid holds, found in place.
struct DelayedLoad
{
    std::size_t at = 0;      ///< offset of the metadata value
    std::uint32_t count = 0; ///< leaves it describes
    std::string_view masks;  ///< mask codes: raw, or a Blosc chunk
    bool masksBlosc = false;
    std::string_view sizes; ///< compressed sizes: raw, or a Blosc chunk
    bool sizesBlosc = false;
    bool hasSizes = false;
};

/// One leaf: where its topology lies, and what its buffer held.
struct LeafRecord
{
    std::size_t maskAt; ///< offset of the topology mask (a mask leaf's values)
    Coord origin;
    std::size_t bufferAt = 0;
    std::int8_t code = 6;         ///< mask-compression code of its buffer
    std::int64_t chunkBytes = -1; ///< bytes of its zip/Blosc chunk with the count; -1: none
};

/// Result of one readCompressedValues().
struct ValuesRead
{
    std::int8_t code;
    std::int64_t chunkBytes; ///< -1 when no zip/Blosc chunk was read
};

/// The tree of one grid: topology, then buffers (Tree::readTopology/readBuffers).
class TreeChecker
{
public:
    TreeChecker(Reader& r, const TreeKind& kind, bool half, std::uint32_t compression)
        : mR(r), mKind(kind), mHalf(half && kind.halfSize != 0), mCompression(compression)
    {}

    void topology()
    {
        const auto at = mR.pos();
        const auto bufferCount = mR.read<std::int32_t>("tree buffer count");
        if (bufferCount != 1) {
            mR.fail(at, "tree buffer count", "is " + std::to_string(bufferCount) + ", expected 1");
        }
        root();
    }

    void buffers()
    {
        for (auto& leaf : mLeaves)
            leafBuffer(leaf);
    }

    const std::vector<LeafRecord>& leaves() const { return mLeaves; }

private:
    /// RootNode::readTopology: background, tile and child counts, tiles, then children.
    void root()
    {
        values(mR.take(mKind.valueSize, "root background"), "root background");
        const auto countsAt = mR.pos();
        const auto numTiles = mR.read<std::uint32_t>("root tile count");
        const auto numChildren = mR.read<std::uint32_t>("root child count");
        const std::uint64_t tileBytes = 12 + mKind.valueSize + 1;
        if (numTiles > mR.remaining() / tileBytes) {
            mR.truncated(countsAt, "root tile count", std::uint64_t(numTiles) * tileBytes);
        }
        std::vector<Coord> tiles; // at most what the remaining bytes hold
        tiles.reserve(numTiles);
        for (std::uint32_t n = 0; n < numTiles; ++n)
            tiles.push_back(rootTile(tiles));
        rootChildren(numChildren, tiles);
    }

    /// The children follow in ascending order of origin (the order of the root's std::map,
    /// which is also the order of their buffers), none where a tile is.
    void rootChildren(std::uint32_t numChildren, const std::vector<Coord>& tiles)
    {
        Coord previous{};
        for (std::uint32_t n = 0; n < numChildren; ++n) {
            const auto at = mR.pos();
            const auto origin = rootKey("root child origin");
            if (n > 0 && !(previous < origin)) {
                mR.fail(at, "root child origin",
                        coordText(origin) + " does not follow " + coordText(previous) +
                            " (root children are stored in ascending order)");
            }
            if (std::binary_search(tiles.begin(), tiles.end(), origin)) {
                mR.fail(at, "root child origin", coordText(origin) + " is also a root tile");
            }
            previous = origin;
            internal(UPPER, origin);
        }
    }

    /// A root table key: three int32, each a multiple of the root child width.
    Coord rootKey(const char* item)
    {
        const auto at = mR.pos();
        const auto raw = mR.take(12, item);
        Coord c{};
        for (std::size_t i = 0; i < 3; ++i)
            c[i] = std::int32_t(loadU32(raw, 4 * i));
        for (const auto v : c) {
            if (v % ROOT_CHILD_DIM != 0) {
                mR.fail(at, item, coordText(c) + " is not a multiple of 4096 (a root table key)");
            }
        }
        return c;
    }

    Coord rootTile(const std::vector<Coord>& tiles)
    {
        const auto at = mR.pos();
        const auto origin = rootKey("root tile");
        if (!tiles.empty() && !(tiles.back() < origin)) {
            mR.fail(at, "root tile",
                    coordText(origin) + " does not follow " + coordText(tiles.back()) +
                        " (root tiles are stored in ascending order)");
        }
        values(mR.take(mKind.valueSize, "root tile value"), "root tile value");
        activeFlag("root tile active flag");
        return origin;
    }

    void activeFlag(const char* item)
    {
        const auto at = mR.pos();
        const auto flag = mR.read<std::uint8_t>(item);
        if (flag > 1) mR.fail(at, item, "is " + std::to_string(flag) + ", expected 0 or 1");
    }

    /// InternalNode::readTopology: child mask, value mask, values, then the children.
    void internal(const InternalLevel& level, const Coord& origin)
    {
        const auto at = mR.pos();
        const auto childMask = mR.take(level.maskBytes(), level.childMaskName);
        const auto valueMask = mR.take(level.maskBytes(), "internal node value mask");
        const auto both = firstOverlap(childMask, valueMask);
        if (both >= 0) {
            mR.fail(at, level.childMaskName,
                    "and the value mask both mark entry " + std::to_string(both));
        }
        compressedValues(level.numValues(), valueMask, level.names);
        const unsigned dimBits = level.log2Dim, dim = 1u << dimBits;
        forEachOn(childMask, [&](std::size_t i) {
            const Coord local{std::int64_t(i >> (2 * dimBits)),
                              std::int64_t((i >> dimBits) & (dim - 1)),
                              std::int64_t(i & (dim - 1))};
            Coord child{};
            for (std::size_t k = 0; k < 3; ++k)
                child[k] = origin[k] + (local[k] << level.childLog2);
            if (level.log2Dim == UPPER.log2Dim) {
                internal(LOWER, child);
            } else {
                mLeaves.push_back({mR.pos(), child});
                mR.take(LEAF_MASK_BYTES,
                        mKind.leaf == LeafKind::Mask ? "mask leaf values" : "leaf value mask");
            }
        });
    }

    /// LeafNode::readBuffers for each leaf kind.
    void leafBuffer(LeafRecord& leaf)
    {
        const auto topology = mR.bytes().substr(leaf.maskAt, LEAF_MASK_BYTES);
        leaf.bufferAt = mR.pos();
        if (mKind.leaf == LeafKind::Mask) {
            sameMask(topology, leaf, "mask leaf buffer");
            sameOrigin(leaf.origin);
            return;
        }
        sameMask(topology, leaf, "leaf buffer value mask");
        if (mKind.leaf == LeafKind::Bool) {
            sameOrigin(leaf.origin);
            mR.take(LEAF_MASK_BYTES, "bool leaf values");
            return;
        }
        const auto read = compressedValues(LEAF_VALUES, topology, LEAF_NAMES);
        leaf.code = read.code;
        leaf.chunkBytes = read.chunkBytes;
    }

    /// The leaf mask stored again with the buffer must equal the topology's (OpenVDB uses
    /// one or the other, depending on whether it reads a file or a stream).
    void sameMask(std::string_view topology, const LeafRecord& leaf, const char* item)
    {
        const auto at = mR.pos();
        if (mR.take(LEAF_MASK_BYTES, item) != topology) {
            mR.fail(at, item,
                    "differs from the leaf's topology mask at byte " + std::to_string(leaf.maskAt));
        }
    }

    void sameOrigin(const Coord& expected)
    {
        const auto at = mR.pos();
        const auto raw = mR.take(12, "leaf origin");
        Coord c{};
        for (std::size_t i = 0; i < 3; ++i)
            c[i] = std::int32_t(loadU32(raw, 4 * i));
        if (c != expected) {
            mR.fail(at, "leaf origin",
                    "is " + coordText(c) + ", but the leaf lies at " + coordText(expected));
        }
    }

    /// io::readCompressedValues(): the mask-compression code, up to two inactive values, a
    /// selection mask, then the values (all of them, or only the active ones).
    ValuesRead compressedValues(std::size_t numValues, std::string_view valueMask,
                                const ValueNames& names)
    {
        const auto at = mR.pos();
        const auto code = mR.read<std::int8_t>(names.values);
        const bool maskCompression = mCompression & COMPRESS_ACTIVE_MASK;
        if (code < 0 || code > 6 || (!maskCompression && code != 6)) {
            mR.fail(at, names.values,
                    "has mask-compression code " + std::to_string(code) + ", expected " +
                        (maskCompression ? "0-6" : "6 (the grid has no active-mask compression)"));
        }
        if (code == 2 || code == 4 || code == 5) { // one inactive value
            values(mR.take(mKind.valueSize, names.inactive), names.inactive);
        }
        if (code == 5) values(mR.take(mKind.valueSize, names.inactive), names.inactive);
        if (code == 3 || code == 4 || code == 5) mR.take(valueMask.size(), names.selection);

        const std::uint64_t count = (maskCompression && code != 6) ? countOn(valueMask) : numValues;
        if (mHalf && count == 0) return {code, -1}; // HalfReader reads nothing
        const std::size_t valueBytes = mHalf ? mKind.halfSize : mKind.valueSize;
        return {code, chunk(count * valueBytes, names.values)};
    }

    /// io::readData(): zip or Blosc with an int64 byte count (<= 0: that many raw bytes), or
    /// raw. Returns the bytes of a zip/Blosc chunk including its count, else -1.
    std::int64_t chunk(std::uint64_t expected, const char* item)
    {
        if (!(mCompression & (COMPRESS_BLOSC | COMPRESS_ZIP))) {
            values(mR.take(expected, item), item);
            return -1;
        }
        const auto at = mR.pos();
        const auto count = mR.read<std::int64_t>(item);
        if (count <= 0) {
            const std::uint64_t raw = std::uint64_t(0) - std::uint64_t(count);
            if (raw != expected) {
                mR.fail(at, item,
                        "is an uncompressed chunk of " + std::to_string(raw) + " bytes, expected " +
                            std::to_string(expected));
            }
            values(mR.take(raw, item), item);
        } else {
            const auto payload = mR.take(std::uint64_t(count), item);
            if (mCompression & COMPRESS_BLOSC) {
                bloscChunk(payload, expected, at, item);
            } else {
                zipChunk(payload, expected, at, item);
            }
            if (mKind.boolValues()) decodedBools(at, expected, item);
        }
        return std::int64_t(mR.pos() - at);
    }

    /// OpenVDB loads decompressed bool values as bool, so a damaged payload that decodes to
    /// other bytes is undefined behaviour: bool chunks (internal nodes of bool and mask trees,
    /// at most 32 KiB) are decompressed here, with OpenVDB's own reader, now that their counts
    /// are known to be sound.
    void decodedBools(std::size_t at, std::uint64_t expected, const char* item)
    {
        const auto chunk = mR.bytes().substr(at, mR.pos() - at);
        ViewBuf buf(chunk);
        std::istream in(&buf);
        std::string values(expected, '\0');
        try {
            if (mCompression & COMPRESS_BLOSC) {
                openvdb::io::bloscFromStream(in, values.data(), values.size());
            } else {
                openvdb::io::unzipFromStream(in, values.data(), values.size());
            }
        } catch (const std::exception&) {
            mR.fail(at, item, "does not decompress");
        }
        for (std::size_t i = 0; i < values.size(); ++i) {
            if (std::uint8_t(values[i]) > 1) {
                mR.fail(at, item,
                        "decompresses to a bool byte " + std::to_string(std::uint8_t(values[i])) +
                            " (value " + std::to_string(i) + "), expected 0 or 1");
            }
        }
    }

    /// bloscFromStream() hands the chunk to blosc_decompress_ctx(), which trusts the header:
    /// it must decompress to exactly the expected bytes and span exactly the chunk.
    void bloscChunk(std::string_view payload, std::uint64_t expected, std::size_t at,
                    const char* item)
    {
        const auto sizes = bloscSizes(mR, payload, at, item);
        if (sizes.nbytes != expected) {
            mR.fail(at, item,
                    "is a Blosc chunk that decompresses to " + std::to_string(sizes.nbytes) +
                        " bytes, expected " + std::to_string(expected));
        }
        if (sizes.cbytes != payload.size()) {
            mR.fail(at, item,
                    "is a Blosc chunk of " + std::to_string(payload.size()) +
                        " bytes whose header claims " + std::to_string(sizes.cbytes));
        }
    }

    /// zipToStream() stores data compressed only if that makes it smaller; a zlib stream
    /// starts with a deflate header whose check bits make it a multiple of 31.
    void zipChunk(std::string_view payload, std::uint64_t expected, std::size_t at,
                  const char* item)
    {
        if (payload.size() >= expected) {
            mR.fail(at, item,
                    "is a zip chunk of " + std::to_string(payload.size()) +
                        " bytes, not smaller than the " + std::to_string(expected) +
                        " bytes it holds");
        }
        const auto cmf = std::uint8_t(payload[0]);
        const auto flg = payload.size() > 1 ? std::uint8_t(payload[1]) : 0;
        if (payload.size() < 8 || (cmf & 0x0f) != 8 || (cmf >> 4) > 7 ||
            ((cmf << 8) | flg) % 31 != 0 || (flg & 0x20) != 0) {
            mR.fail(at, item, "is not a zlib stream");
        }
    }

    /// Bool values (bool and mask trees) must be bytes 0 or 1; others are any bits.
    void values(std::string_view raw, const char* item)
    {
        if (!mKind.boolValues()) return;
        for (std::size_t i = 0; i < raw.size(); ++i) {
            const auto b = std::uint8_t(raw[i]);
            if (b > 1) {
                mR.fail(std::size_t(raw.data() - mR.bytes().data()) + i, item,
                        "holds a bool byte " + std::to_string(b) + ", expected 0 or 1");
            }
        }
    }

    Reader& mR;
    const TreeKind& mKind;
    const bool mHalf;
    const std::uint32_t mCompression;
    std::vector<LeafRecord> mLeaves;
};

/// The whole archive: header, file metadata, then each grid (Archive, io::File, io::Stream).
class ArchiveChecker
{
public:
    ArchiveChecker(std::string_view bytes, const std::string& source) : mR(bytes, source) {}

    void run()
    {
        header();
        metaMap("file metadata count", nullptr);
        grids();
    }

private:
    /// A grid being read: its descriptor, and what its metadata said.
    struct Grid
    {
        std::string_view name;
        std::string_view parent;
        const TreeKind* kind = nullptr;
        bool half = false;
        std::uint32_t compression = 0;
        std::int64_t gridPos = 0, blockPos = 0, endPos = 0;
        std::size_t descriptorAt = 0;
        bool hasDelayedLoad = false;
        DelayedLoad delayedLoad;
    };

    void header()
    {
        const std::string_view magic("\x20\x42\x44\x56\0\0\0\0", 8);
        const auto head = mR.bytes().substr(0, 8);
        if (head != magic.substr(0, head.size())) {
            mR.raise("not a VDB file (no VDB magic number at byte 0)");
        }
        mR.take(8, "magic number");
        const auto version = mR.read<std::uint32_t>("file format version");
        if (version < FORMAT_OLDEST) {
            mR.raise("VDB file format version " + std::to_string(version) +
                     " predates OpenVDB 3 (version 222), which nebula reads; re-save it with a "
                     "newer OpenVDB");
        }
        if (version > FORMAT_NEWEST) {
            mR.raise("VDB file format version " + std::to_string(version) +
                     " is newer than nebula knows (225, OpenVDB 13)");
        }
        mR.take(8, "library version");
        const auto flagAt = mR.pos();
        const auto flag = mR.read<std::uint8_t>("grid-offsets flag");
        if (flag > 1) {
            mR.fail(flagAt, "grid-offsets flag",
                    "is " + std::to_string(flag) + ", expected 0 or 1");
        }
        mHasOffsets = flag == 1;
        uuid();
    }

    /// The UUID as boost::uuids writes it: 36 characters, 8-4-4-4-12 hex digits.
    void uuid()
    {
        const auto at = mR.pos();
        const auto text = mR.take(36, "UUID");
        for (std::size_t i = 0; i < text.size(); ++i) {
            const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
            const char c = text[i];
            const bool ok = dash ? c == '-' : std::isxdigit(static_cast<unsigned char>(c)) != 0;
            if (!ok) mR.fail(at, "UUID", "is not of the form xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx");
        }
    }

    /// MetaMap::readMeta: a count, then name, type name and length-prefixed value each.
    void metaMap(const char* countItem, Grid* grid)
    {
        const auto at = mR.pos();
        const auto count = mR.read<std::uint32_t>(countItem);
        if (count > mR.remaining() / MIN_META_BYTES) {
            mR.truncated(at, countItem, std::uint64_t(count) * MIN_META_BYTES);
        }
        for (std::uint32_t i = 0; i < count; ++i)
            metadata(grid);
    }

    void metadata(Grid* grid)
    {
        const auto name = mR.string("metadata name");
        const std::string item = "metadata \"" + shownName(name) + "\"";
        const auto type = mR.string(item + " type name");
        const auto sizeAt = mR.pos();
        const auto numBytes = mR.read<std::uint32_t>(item);
        if (type == DELAYED_LOAD_TYPE) { // what readCompressedValues() uses is by this name
            delayedLoad(numBytes, item, name == DELAYED_LOAD_NAME ? grid : nullptr);
            return;
        }
        const auto value = mR.take(numBytes, item);
        const auto fixed = fixedMetadataSize(type);
        if (fixed != 0 && numBytes != fixed) {
            mR.fail(sizeAt, item,
                    "of type " + shownName(type) + " has a " + std::to_string(numBytes) +
                        "-byte value, expected " + std::to_string(fixed));
        }
        if (type == "bool" && std::uint8_t(value[0]) > 1) {
            mR.fail(sizeAt + 4, item,
                    "is a bool of value " + std::to_string(std::uint8_t(value[0])) +
                        ", expected 0 or 1");
        }
    }

    /// DelayedLoadMetadata::readValue: leaf count, mask codes, then compressed sizes (each
    /// raw or Blosc-compressed). OpenVDB sizes its arrays by the count, so the count is
    /// bounded here, and checked against the grid's leaves once the tree has been read.
    void delayedLoad(std::uint32_t numBytes, const std::string& item, Grid* grid)
    {
        const auto at = mR.pos();
        mR.take(numBytes, item);
        mR.seek(at);
        if (numBytes == 0) return;
        DelayedLoad d;
        d.at = at;
        d.count = mR.read<std::uint32_t>(item);
        if (d.count > mR.remaining() / LEAF_MASK_BYTES) { // each leaf has a 64-byte mask
            mR.truncated(at, item + " (" + std::to_string(d.count) + " leaves)",
                         std::uint64_t(d.count) * LEAF_MASK_BYTES);
        }
        const auto masksBytes = mR.read<std::uint32_t>(item);
        d.masksBlosc = masksBytes > 0;
        d.masks = mR.take(d.masksBlosc ? masksBytes : d.count, item);
        if (d.masksBlosc) delayedLoadBlosc(d.masks, d.count, at, item);
        const auto sizesBytes = mR.read<std::uint32_t>(item);
        d.hasSizes = sizesBytes != 0xffffffffu;
        if (d.hasSizes) {
            d.sizesBlosc = sizesBytes > 0;
            d.sizes = mR.take(d.sizesBlosc ? sizesBytes : std::uint64_t(d.count) * 8, item);
            if (d.sizesBlosc) delayedLoadBlosc(d.sizes, std::uint64_t(d.count) * 8, at, item);
        }
        if (mR.pos() - at > numBytes) {
            mR.fail(at, item,
                    "takes " + std::to_string(mR.pos() - at) + " bytes, more than the " +
                        std::to_string(numBytes) + " its length gives");
        }
        mR.seek(at + numBytes); // OpenVDB skips what it does not know
        if (grid) {
            grid->hasDelayedLoad = true;
            grid->delayedLoad = d;
        }
    }

    /// compression::bloscDecompress() accepts the exact size or, for up to 128 bytes, the
    /// 128 bytes it pads small arrays to.
    void delayedLoadBlosc(std::string_view payload, std::uint64_t expected, std::size_t at,
                          const std::string& item)
    {
        const auto sizes = bloscSizes(mR, payload, at, item);
        const bool padded = sizes.nbytes == BLOSC_PAD_BYTES && expected <= BLOSC_PAD_BYTES;
        if ((sizes.nbytes != expected && !padded) || sizes.cbytes != payload.size()) {
            mR.fail(at, item,
                    "holds a Blosc chunk of " + std::to_string(payload.size()) +
                        " bytes that claims " + std::to_string(sizes.cbytes) + " bytes for " +
                        std::to_string(sizes.nbytes) + " bytes of data, expected " +
                        std::to_string(expected));
        }
    }

    void grids()
    {
        const auto at = mR.pos();
        const auto count = mR.read<std::int32_t>("grid count");
        if (count < 0) mR.fail(at, "grid count", "is negative (" + std::to_string(count) + ")");
        if (std::uint64_t(count) > mR.remaining() / MIN_GRID_BYTES) {
            mR.truncated(at, "grid count " + std::to_string(count),
                         std::uint64_t(count) * MIN_GRID_BYTES);
        }
        for (std::int32_t i = 0; i < count; ++i)
            grid();
        mR.clearGrid();
        if (!mHasOffsets && mR.remaining() > 0) {
            const auto n = mR.remaining();
            mR.raise(std::to_string(n) + (n == 1 ? " byte follows" : " bytes follow") +
                     " the last grid, at byte " + std::to_string(mR.pos()) +
                     " (a stream must end with its last grid)");
        }
        instanceParents();
    }

    /// GridDescriptor::read, then Archive::readGrid.
    void grid()
    {
        Grid g;
        g.descriptorAt = mR.pos();
        mR.clearGrid();
        g.name = mR.string("grid name");
        mR.setGrid(g.name);
        auto type = mR.string("type name");
        g.parent = mR.string("instance parent name");
        g.gridPos = mR.read<std::int64_t>("grid offset");
        g.blockPos = mR.read<std::int64_t>("block offset");
        g.endPos = mR.read<std::int64_t>("end offset");
        if (type.size() >= HALF_SUFFIX.size() &&
            type.substr(type.size() - HALF_SUFFIX.size()) == HALF_SUFFIX) {
            g.half = true;
            type.remove_suffix(HALF_SUFFIX.size());
        }
        g.kind = findTreeKind(type);
        const bool instance = !g.parent.empty();
        if (mHasOffsets) {
            offsets(g, instance);
        } else if (!g.kind && !instance) {
            mR.raise("grid \"" + shownName(g.name) + "\" has type " + shownName(type) +
                     ", which nebula cannot check in a stream; save it to a file");
        }
        gridBody(g, instance);
        mNames.push_back(g.name);
        if (instance) mInstances.emplace_back(g.name, g.parent);
    }

    /// Compression flags, metadata, transform, and the tree where there is one.
    void gridBody(Grid& g, bool instance)
    {
        const auto at = mR.pos();
        g.compression = mR.read<std::uint32_t>("compression flags");
        if (g.compression & ~(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC)) {
            mR.fail(at, "compression flags",
                    "have unknown bits (" + std::to_string(g.compression) + ")");
        }
        metaMap("metadata count", &g);
        transform();
        if (instance) {
            endsAt(g.endPos, "instance");
            return;
        }
        if (!g.kind) {
            if (g.blockPos < std::int64_t(mR.pos())) {
                mR.fail(g.descriptorAt, "block offset",
                        std::to_string(g.blockPos) + " points before the grid's tree at byte " +
                            std::to_string(mR.pos()));
            }
            mR.seek(std::size_t(g.endPos)); // not checkable: skipped by its offsets
            return;
        }
        TreeChecker tree(mR, *g.kind, g.half, g.compression);
        tree.topology();
        endsAt(g.blockPos, "topology");
        tree.buffers();
        endsAt(g.endPos, "buffers");
        if (g.hasDelayedLoad) checkDelayedLoad(g, tree.leaves());
    }

    /// In a file, each grid's bytes lie between its offsets, right after its descriptor.
    void offsets(const Grid& g, bool instance)
    {
        const auto here = std::int64_t(mR.pos());
        const auto size = std::int64_t(mR.bytes().size());
        const auto at = g.descriptorAt;
        if (g.gridPos != here) {
            mR.fail(at, "descriptor",
                    "gives grid offset " + std::to_string(g.gridPos) + ", expected " +
                        std::to_string(here) + " (just past the descriptor)");
        }
        if (g.endPos < here) {
            mR.fail(at, "descriptor",
                    "gives end offset " + std::to_string(g.endPos) + ", before the grid at byte " +
                        std::to_string(here));
        }
        if (g.endPos > size) {
            mR.raise("truncated: grid \"" + shownName(g.name) + "\" ends at byte " +
                     std::to_string(g.endPos) + " (its end offset), but there are only " +
                     std::to_string(size) + " bytes");
        }
        const bool blockOk =
            (g.blockPos >= here && g.blockPos <= g.endPos) || (instance && g.blockPos == 0);
        if (!blockOk) {
            mR.fail(at, "descriptor",
                    "gives block offset " + std::to_string(g.blockPos) + ", outside the grid (" +
                        std::to_string(here) + "-" + std::to_string(g.endPos) + ")");
        }
    }

    /// In a file, a part of the grid must end where its offset says.
    void endsAt(std::int64_t offset, const char* part)
    {
        if (mHasOffsets && std::int64_t(mR.pos()) != offset) {
            mR.fail(mR.pos(), std::string("end of the ") + part,
                    "does not match the offset " + std::to_string(offset) + " in its descriptor");
        }
    }

    /// Transform::read: a map type name, then the map's data.
    void transform()
    {
        const auto at = mR.pos();
        const auto type = mR.string("transform map type");
        if (type == "NonlinearFrustumMap") {
            mR.take(FRUSTUM_BYTES, "frustum map");
            const auto innerAt = mR.pos();
            const auto inner = mR.string("frustum map's linear map type");
            linearMap(inner, innerAt);
            return;
        }
        linearMap(type, at);
    }

    void linearMap(std::string_view type, std::size_t at)
    {
        const auto size = linearMapSize(type);
        if (size == 0) {
            mR.fail(at, "transform",
                    "has map type \"" + shownName(type) + "\", which OpenVDB does not know");
        }
        mR.take(size, "transform " + std::string(type));
    }

    /// With delayed loading, OpenVDB seeks over leaf buffers by the delayed-load metadata
    /// (mask codes, compressed sizes) instead of reading them: they must describe the leaves.
    void checkDelayedLoad(const Grid& g, const std::vector<LeafRecord>& leaves)
    {
        const auto& d = g.delayedLoad;
        const std::string item = "delayed-load metadata";
        if (d.count != leaves.size()) {
            mR.fail(d.at, item,
                    "describes " + std::to_string(d.count) + " leaves, but the tree has " +
                        std::to_string(leaves.size()));
        }
        if (g.kind->leaf != LeafKind::Values || leaves.empty()) return;
        const bool compressed = g.compression & (COMPRESS_BLOSC | COMPRESS_ZIP);
        if (compressed && !d.hasSizes) {
            mR.fail(d.at, item, "lacks the compressed sizes of the leaf buffers");
        }
        std::string masksStorage, sizesStorage;
        const auto masks = delayedLoadArray(d.masks, d.masksBlosc, d.count, d.at, masksStorage);
        const auto sizes = compressed
                               ? delayedLoadArray(d.sizes, d.sizesBlosc, std::size_t(d.count) * 8,
                                                  d.at, sizesStorage)
                               : std::string_view();
        for (std::size_t i = 0; i < leaves.size(); ++i) {
            if ((g.compression & COMPRESS_ACTIVE_MASK) && std::int8_t(masks[i]) != leaves[i].code) {
                mR.fail(d.at, item,
                        "gives leaf " + std::to_string(i) + " mask-compression code " +
                            std::to_string(int(std::int8_t(masks[i]))) +
                            ", but its buffer at byte " + std::to_string(leaves[i].bufferAt) +
                            " has " + std::to_string(int(leaves[i].code)));
            }
            std::int64_t size = 0;
            if (compressed) std::memcpy(&size, sizes.data() + 8 * i, 8);
            if (compressed && leaves[i].chunkBytes >= 0 && size != leaves[i].chunkBytes) {
                mR.fail(d.at, item,
                        "gives leaf " + std::to_string(i) + " a " + std::to_string(size) +
                            "-byte buffer, but its buffer at byte " +
                            std::to_string(leaves[i].bufferAt) + " has a " +
                            std::to_string(leaves[i].chunkBytes) + "-byte chunk");
            }
        }
    }

    /// One array of the delayed-load metadata: in place, or decompressed into @p storage (of
    /// the size of the tree's leaves, counted, not claimed).
    std::string_view delayedLoadArray(std::string_view stored, bool blosc, std::size_t bytes,
                                      std::size_t at, std::string& storage)
    {
        if (!blosc) return stored;
        storage.assign(std::max(bytes, BLOSC_PAD_BYTES) + BLOSC_HEADER_BYTES, '\0');
        try {
            openvdb::compression::bloscDecompress(storage.data(), bytes, storage.size(),
                                                  stored.data());
        } catch (const std::exception&) {
            mR.fail(at, "delayed-load metadata", "holds a Blosc chunk that does not decompress");
        }
        return storage;
    }

    void instanceParents()
    {
        for (const auto& [name, parent] : mInstances) {
            if (std::find(mNames.begin(), mNames.end(), parent) == mNames.end()) {
                mR.raise("grid \"" + shownName(name) + "\" is an instance of grid \"" +
                         shownName(parent) + "\", which is not in the file");
            }
        }
    }

    Reader mR;
    bool mHasOffsets = false;
    std::vector<std::string_view> mNames;
    std::vector<std::pair<std::string_view, std::string_view>> mInstances;
};

} // namespace

void checkVdbStructure(std::string_view bytes, const std::string& source)
{
    ArchiveChecker(bytes, source).run();
}

} // namespace nebula
