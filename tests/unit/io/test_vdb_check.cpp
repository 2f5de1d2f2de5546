// SPDX-License-Identifier: Apache-2.0
/// @file test_vdb_check.cpp
/// io/vdb_check.h: every file and stream OpenVDB writes passes (each compression setting,
/// half floats, every grid type nebula checks, instances, metadata); every truncation is
/// refused; damaged bytes are refused or read safely by OpenVDB; hand-crafted lengths and
/// offsets are refused with a message naming them, without allocating.

#include "nebula/io/vdb_check.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <openvdb/io/Compression.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/PointConversion.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

namespace fs = std::filesystem;

using nebula::checkVdbStructure;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

namespace io = openvdb::io;

/// Every compression setting OpenVDB offers (Archive::setCompression).
const std::vector<std::uint32_t> COMPRESSIONS = {io::COMPRESS_NONE,
                                                 io::COMPRESS_ACTIVE_MASK,
                                                 io::COMPRESS_ZIP,
                                                 io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK,
                                                 io::COMPRESS_BLOSC,
                                                 io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK,
                                                 io::COMPRESS_ZIP | io::COMPRESS_BLOSC |
                                                     io::COMPRESS_ACTIVE_MASK};

class VdbCheck : public ::testing::Test
{
protected:
    void SetUp() override
    {
        openvdb::initialize();
        std::random_device rd;
        dir = fs::temp_directory_path() /
              ("nebula_vdb_check_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
        fs::create_directories(dir);
    }
    void TearDown() override
    {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    std::string path(const std::string& name) const { return (dir / name).string(); }

    /// The bytes of a .vdb file (with grid offsets) that io::File writes.
    std::string fileBytes(const openvdb::GridPtrVec& grids, std::uint32_t compression,
                          const openvdb::MetaMap& meta = openvdb::MetaMap())
    {
        const auto p = path("written.vdb");
        io::File file(p);
        file.setCompression(compression);
        file.write(grids, meta);
        return readBytes(p);
    }

    static std::string readBytes(const std::string& p)
    {
        std::ifstream in(p, std::ios::binary);
        std::ostringstream out;
        out << in.rdbuf();
        return out.str();
    }

    void writeBytes(const std::string& p, const std::string& bytes) const
    {
        std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
    }

    /// OpenVDB reads @p bytes as a file (without, then with delayed loading) and as a stream,
    /// touching every grid; false if it throws. (Delayed loading only once a full read has
    /// succeeded: OpenVDB 10 crashes in ~LeafBuffer when a delayed load throws.)
    bool openvdbReads(const std::string& bytes)
    {
        try {
            const auto p = path("read.vdb");
            writeBytes(p, bytes);
            for (const bool delayLoad : {false, true}) {
                io::File file(p);
                file.open(delayLoad);
                const auto grids = file.getGrids();
                for (const auto& g : *grids) {
                    g->readNonresidentBuffers();
                    g->activeVoxelCount();
                }
                file.getMetadata();
                file.close();
            }
            std::istringstream in(bytes);
            io::Stream stream(in, /*delayLoad=*/false);
            const auto grids = stream.getGrids();
            for (const auto& g : *grids)
                g->activeVoxelCount();
            return true;
        } catch (const std::exception&) {
            return false;
        }
    }

    fs::path dir;
};

/// The bytes of a stream (no grid offsets) that io::Stream writes.
std::string streamBytes(const openvdb::GridPtrVec& grids, std::uint32_t compression,
                        const openvdb::MetaMap& meta = openvdb::MetaMap())
{
    std::ostringstream out(std::ios::binary);
    io::Stream stream(out);
    stream.setCompression(compression);
    stream.write(grids, meta);
    return out.str();
}

/// A leaf of @p tree at @p xyz filled with @p inactive (inactive), then @p actives voxels
/// activated with value 1: gives the mask-compression codes their cases.
void leafOf(openvdb::FloatTree& tree, const openvdb::Coord& xyz, float inactive, int actives)
{
    auto* leaf = tree.touchLeaf(xyz);
    leaf->fill(inactive, /*active=*/false);
    for (int i = 0; i < actives; ++i)
        leaf->setValueOn(openvdb::Index(i * 37 % 512), 1.0f);
}

/// A small FloatGrid with negative background -0.5: a few leaves covering every
/// mask-compression code, tiles at each level, and sparse voxels at negative coordinates.
openvdb::FloatGrid::Ptr floatGrid(const std::string& name = "density")
{
    auto g = openvdb::FloatGrid::create(-0.5f);
    g->setName(name);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
    auto& tree = g->tree();
    for (int i = 0; i < 12; ++i)
        tree.setValue(openvdb::Coord(i, 2 * i - 7, 3), float(i) + 0.25f); // code 0
    leafOf(tree, {64, 0, 0}, 0.5f, 3);                                    // 1: -background
    leafOf(tree, {80, 0, 0}, 7.0f, 5);                                    // 2: one value
    leafOf(tree, {96, 0, 0}, -0.5f, 0);                                   // 0, no actives
    tree.setValueOff(openvdb::Coord(96, 1, 1), 0.5f);                     // 3: +-background
    tree.setValueOff(openvdb::Coord(112, 0, 0), 7.0f);                    // 4: bg and one
    leafOf(tree, {128, 0, 0}, 7.0f, 2);
    tree.setValueOff(openvdb::Coord(128, 1, 1), 8.0f); // 5: two values
    tree.setValueOff(openvdb::Coord(144, 0, 0), 7.0f);
    tree.setValueOff(openvdb::Coord(144, 1, 0), 8.0f); // 6: three values
    tree.addTile(1, openvdb::Coord(1024, 0, 0), 3.0f, true);
    tree.addTile(2, openvdb::Coord(2048, 0, 0), 4.0f, false);
    tree.addTile(3, openvdb::Coord(8192, 0, 0), 5.0f, true);
    tree.setValue(openvdb::Coord(-5000, 3000, 77), 2.0f);
    tree.setValue(openvdb::Coord(-5001, -3000, -77), 2.5f);
    g->insertMeta("note", openvdb::StringMetadata("grid metadata"));
    g->insertMeta("scale", openvdb::FloatMetadata(1.5f));
    g->insertMeta("flag", openvdb::BoolMetadata(true));
    return g;
}

/// One grid of each other value type nebula checks.
openvdb::GridPtrVec otherGrids()
{
    openvdb::GridPtrVec grids;
    auto d = openvdb::DoubleGrid::create(1.0);
    d->tree().setValue(openvdb::Coord(1, 2, 3), 0.125);
    d->tree().setValueOff(openvdb::Coord(9, 2, 3), -1.0);
    grids.push_back(d);
    auto i = openvdb::Int32Grid::create(-3);
    i->tree().setValue(openvdb::Coord(-1, 2, 3), 42);
    grids.push_back(i);
    auto l = openvdb::Int64Grid::create(0);
    l->tree().setValue(openvdb::Coord(5, 5, 5), std::int64_t(1) << 40);
    grids.push_back(l);
    auto v = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
    v->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3f(1.5f, -2.0f, 3.0f));
    v->tree().addTile(1, openvdb::Coord(-64, 0, 0), openvdb::Vec3f(1.0f), true);
    grids.push_back(v);
    auto vd = openvdb::Vec3dGrid::create(openvdb::Vec3d(1.0));
    vd->tree().setValue(openvdb::Coord(100, 2, 3), openvdb::Vec3d(0.5, 0.25, 2.0));
    grids.push_back(vd);
    auto vi = openvdb::Vec3IGrid::create(openvdb::Vec3i(0));
    vi->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3i(1, 2, 3));
    grids.push_back(vi);
    auto b = openvdb::BoolGrid::create(false);
    b->tree().setValue(openvdb::Coord(1, 2, 3), true);
    b->tree().setValueOff(openvdb::Coord(2, 2, 3), true);
    b->tree().addTile(1, openvdb::Coord(800, 0, 0), true, true);
    grids.push_back(b);
    auto m = openvdb::MaskGrid::create(false);
    m->tree().setValueOn(openvdb::Coord(-7, 2, 3));
    m->tree().setValueOn(openvdb::Coord(300, 2, 3));
    grids.push_back(m);
    const char* names[] = {"double", "int32", "int64", "vec3s", "vec3d", "vec3i", "bool", "mask"};
    for (std::size_t k = 0; k < grids.size(); ++k)
        grids[k]->setName(names[k]);
    return grids;
}

/// File-level metadata of several types.
openvdb::MetaMap fileMeta()
{
    openvdb::MetaMap meta;
    meta.insertMeta("note", openvdb::StringMetadata("hello"));
    meta.insertMeta("count", openvdb::Int32Metadata(7));
    meta.insertMeta("big", openvdb::Int64Metadata(std::int64_t(1) << 40));
    meta.insertMeta("ratio", openvdb::DoubleMetadata(0.5));
    meta.insertMeta("on", openvdb::BoolMetadata(false));
    meta.insertMeta("origin", openvdb::Vec3DMetadata(openvdb::Vec3d(1, 2, 3)));
    meta.insertMeta("xform", openvdb::Mat4DMetadata(openvdb::Mat4d::identity()));
    return meta;
}

std::string refusal(const std::string& bytes, const std::string& source = "in.vdb")
{
    return errorMessage([&] { checkVdbStructure(bytes, source); });
}

void expectPasses(const std::string& bytes, const std::string& what)
{
    try {
        checkVdbStructure(bytes, what);
    } catch (const nebula::Error& e) {
        ADD_FAILURE() << what << ": " << e.what();
    }
}

std::int64_t loadI64(const std::string& bytes, std::size_t at)
{
    std::int64_t v;
    std::memcpy(&v, bytes.data() + at, 8);
    return v;
}

template <typename T> void store(std::string& bytes, std::size_t at, T value)
{
    std::memcpy(&bytes[at], &value, sizeof(T));
}

/// Offset of the int64 count of the zip/Blosc chunk that ends the bytes (the last leaf's).
std::size_t lastChunkCount(const std::string& bytes)
{
    for (std::size_t p = bytes.size() - 9; p > 0; --p) {
        if (loadI64(bytes, p) == std::int64_t(bytes.size() - p - 8)) return p;
    }
    ADD_FAILURE() << "no chunk count found";
    return 0;
}

/// A small FloatGrid: a few leaves and a tile under one root child, and grid metadata.
openvdb::FloatGrid::Ptr smallGrid()
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    for (int i = 0; i < 40; ++i)
        g->tree().setValue(openvdb::Coord(i * 3, i % 7, i), 0.5f * float(i));
    g->tree().addTile(1, openvdb::Coord(512, 0, 0), 2.0f, true);
    g->insertMeta("note", openvdb::StringMetadata("grid metadata"));
    return g;
}

/// One grid with one full leaf (512 active values, no mask compression): 2048 bytes.
openvdb::GridPtrVec oneLeafGrid()
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    auto* leaf = g->tree().touchLeaf(openvdb::Coord(0));
    for (openvdb::Index i = 0; i < 512; ++i)
        leaf->setValueOn(i, float(i % 16) * 0.5f);
    return {g};
}

long maxRssKb()
{
    struct rusage usage;
    ::getrusage(RUSAGE_SELF, &usage);
    return usage.ru_maxrss;
}

} // namespace

TEST_F(VdbCheck, EveryCompressionOfFilesAndStreamsPasses)
{
    for (const auto c : COMPRESSIONS) {
        for (const bool half : {false, true}) {
            auto g = floatGrid();
            g->setSaveFloatAsHalf(half);
            openvdb::GridPtrVec grids{g};
            const std::string what = "compression " + std::to_string(c) + (half ? " half" : "");
            const auto file = fileBytes(grids, c, fileMeta());
            const auto stream = streamBytes(grids, c, fileMeta());
            expectPasses(file, what + " file");
            expectPasses(stream, what + " stream");
            EXPECT_TRUE(openvdbReads(file)) << what;
        }
    }
}

TEST_F(VdbCheck, EveryCheckedGridTypePasses)
{
    for (const auto c : COMPRESSIONS) {
        auto grids = otherGrids();
        for (std::size_t k = 0; k < 5; ++k)
            grids[k]->setSaveFloatAsHalf(c & io::COMPRESS_ACTIVE_MASK); // half for some
        grids.push_back(floatGrid());
        const auto file = fileBytes(grids, c, fileMeta());
        expectPasses(file, "file, compression " + std::to_string(c));
        expectPasses(streamBytes(grids, c), "stream, compression " + std::to_string(c));
        if (c == COMPRESSIONS.back()) {
            EXPECT_TRUE(openvdbReads(file));
        }
    }
}

TEST_F(VdbCheck, FogVolumesInstancesAndEmptyGridsPass)
{
    auto fog = floatGrid("fog");
    fog->setGridClass(openvdb::GRID_FOG_VOLUME); // OpenVDB drops zip for fog volumes
    auto shared = fog->copyGrid();               // shares the tree: written as an instance
    shared->setName("fog");                      // same name: unique names "fog\x1e0", "fog\x1e1"
    auto empty = openvdb::FloatGrid::create(1.0f);
    empty->setName("");
    openvdb::GridPtrVec grids{fog, shared, empty};
    for (const auto c : COMPRESSIONS) {
        const auto file = fileBytes(grids, c);
        expectPasses(file, "file, compression " + std::to_string(c));
        expectPasses(streamBytes(grids, c), "stream, compression " + std::to_string(c));
        EXPECT_TRUE(openvdbReads(file));
    }
    expectPasses(streamBytes({}, io::COMPRESS_BLOSC), "no grids");
}

TEST_F(VdbCheck, EveryMapTypePasses)
{
    namespace math = openvdb::math;
    const openvdb::Vec3d s(1, 2, 3), t(-4, 5, 0.5);
    math::Mat4d rotation = math::Mat4d::identity();
    rotation.setToRotation(math::Z_AXIS, 0.3);
    const std::vector<math::MapBase::Ptr> maps{
        std::make_shared<math::AffineMap>(rotation),
        std::make_shared<math::UnitaryMap>(math::Mat3d::identity()),
        std::make_shared<math::ScaleMap>(s),
        std::make_shared<math::UniformScaleMap>(0.5),
        std::make_shared<math::TranslationMap>(t),
        std::make_shared<math::ScaleTranslateMap>(s, t),
        std::make_shared<math::UniformScaleTranslateMap>(0.5, t),
        math::Transform::createFrustumTransform(
            openvdb::BBoxd(openvdb::Vec3d(0), openvdb::Vec3d(10)), 0.5, 2.0, 0.1)
            ->baseMap()};
    std::set<std::string> written;
    for (const auto& map : maps) {
        auto g = smallGrid();
        g->setTransform(std::make_shared<math::Transform>(map)); // simplifies linear maps
        const auto type = g->transform().mapType();
        written.insert(type);
        expectPasses(fileBytes({g}, io::COMPRESS_BLOSC), type + " file");
        expectPasses(streamBytes({g}, io::COMPRESS_ZIP), type + " stream");
    }
    EXPECT_GE(written.size(), 5u);
    // Transform never keeps these two (it simplifies them): spliced into a stream instead.
    const auto valid = streamBytes({smallGrid()}, io::COMPRESS_BLOSC);
    const auto at = valid.find("UniformScaleMap");
    ASSERT_NE(at, std::string::npos);
    const auto spliced = [&](const std::string& type, const std::string& data) {
        std::string bytes = valid.substr(0, at - 4);
        const auto size = std::uint32_t(type.size());
        bytes.append(reinterpret_cast<const char*>(&size), 4);
        return bytes + type + data + valid.substr(at + 15 + 120);
    };
    const math::Mat4d identity = math::Mat4d::identity();
    const auto unitary = spliced(
        "UnitaryMap", std::string(reinterpret_cast<const char*>(identity.asPointer()), 128));
    const auto translation =
        spliced("TranslationMap", std::string(reinterpret_cast<const char*>(&t), 24));
    for (const auto& bytes : {unitary, translation}) {
        expectPasses(bytes, "spliced map");
        EXPECT_TRUE(openvdbReads(bytes));
    }
}

TEST_F(VdbCheck, PointGridsAreSkippedInFilesAndRefusedInStreams)
{
    const std::vector<openvdb::Vec3R> positions{{0, 1, 2}, {1.5, -2, 3}, {10, 10, 10}};
    auto transform = openvdb::math::Transform::createLinearTransform(0.5);
    auto points =
        openvdb::points::createPointDataGrid<openvdb::points::NullCodec,
                                             openvdb::points::PointDataGrid>(positions, *transform);
    points->setName("points");
    openvdb::GridPtrVec grids{floatGrid(), points, floatGrid("after")};
    expectPasses(fileBytes(grids, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK), "points file");
    const auto msg = refusal(streamBytes(grids, io::COMPRESS_BLOSC), "<stdin>");
    EXPECT_TRUE(contains(msg, "<stdin>: grid \"points\" has type Tree_ptdataidx32_5_4_3, which "
                              "nebula cannot check in a stream; save it to a file"))
        << msg;
}

TEST_F(VdbCheck, EveryTruncationIsRefused)
{
    auto vec = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
    vec->setName("velocity");
    vec->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3f(1.5f, -2.0f, 3.0f));
    for (const std::uint32_t c : std::vector<std::uint32_t>{
             io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK, io::COMPRESS_ACTIVE_MASK}) {
        for (const bool stream : {false, true}) {
            const auto bytes = stream ? streamBytes({smallGrid()}, c, fileMeta())
                                      : fileBytes({smallGrid(), vec}, c, fileMeta());
            std::size_t refused = 0;
            for (std::size_t n = 0; n < bytes.size(); ++n) {
                try {
                    checkVdbStructure(std::string_view(bytes).substr(0, n), "cut.vdb");
                    ADD_FAILURE() << (stream ? "stream" : "file") << " cut to " << n << " of "
                                  << bytes.size() << " bytes passes";
                } catch (const nebula::Error& e) {
                    ++refused;
                    if (!contains(e.what(), "cut.vdb: truncated: ")) {
                        ADD_FAILURE() << "cut to " << n << ": " << e.what();
                    }
                }
            }
            EXPECT_EQ(refused, bytes.size());
        }
    }
}

TEST_F(VdbCheck, StreamMustEndWithItsLastGrid)
{
    const auto bytes = streamBytes({floatGrid()}, io::COMPRESS_BLOSC);
    EXPECT_TRUE(contains(refusal(bytes + "x"), "1 byte follows the last grid"))
        << refusal(bytes + "x");
    const auto file = fileBytes({floatGrid()}, io::COMPRESS_BLOSC);
    expectPasses(file + "trailing bytes", "file with trailing bytes"); // io::File seeks past
}

TEST_F(VdbCheck, DamagedBytesAreRefusedOrReadSafely)
{
    std::mt19937 rng(20240611);
    int refused = 0, readFine = 0, threw = 0;
    for (const std::uint32_t c : std::vector<std::uint32_t>{
             io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK,
             io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK, io::COMPRESS_ACTIVE_MASK}) {
        auto g = smallGrid(); // and a dense 16^3 block: payload as well as structure
        for (int i = 0; i < 16; ++i)
            for (int j = 0; j < 16; ++j)
                for (int k = 0; k < 16; ++k)
                    g->tree().setValue(openvdb::Coord(64 + i, j, k), float((7 * i + j * k) % 17));
        const auto valid = fileBytes({g}, c, fileMeta());
        std::uniform_int_distribution<std::size_t> where(0, valid.size() - 1);
        std::uniform_int_distribution<int> flips(1, 4), bits(1, 255);
        for (int n = 0; n < 150; ++n) {
            std::string bytes = valid;
            for (int f = flips(rng); f > 0; --f)
                bytes[where(rng)] ^= char(bits(rng));
            try {
                checkVdbStructure(bytes, "damaged.vdb");
            } catch (const nebula::Error& e) {
                ++refused;
                EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
                EXPECT_LT(std::string(e.what()).size(), 300u);
                continue;
            }
            (openvdbReads(bytes) ? readFine : threw) += 1;
        }
    }
    std::cout << "[ mutations ] " << refused << " refused by the checker, " << readFine
              << " passed and read by OpenVDB, " << threw << " passed and OpenVDB threw\n";
    RecordProperty("refused", refused);
    RecordProperty("read_fine", readFine);
    RecordProperty("openvdb_threw", threw);
    EXPECT_EQ(refused + readFine + threw, 450);
    EXPECT_GT(refused, 225);
}

TEST_F(VdbCheck, ChunkCountsAreChecked)
{
    const long rssBefore = maxRssKb();
    for (const std::uint32_t c : std::vector<std::uint32_t>{io::COMPRESS_BLOSC, io::COMPRESS_ZIP}) {
        const auto valid = streamBytes(oneLeafGrid(), c);
        const auto at = lastChunkCount(valid);
        std::string bigger = valid + std::string(4096, '\0');
        store(bigger, at, std::int64_t(-4096)); // raw bytes, more than the leaf holds
        const auto msg = refusal(bigger);
        EXPECT_TRUE(contains(msg, "in.vdb: grid \"density\" leaf buffer at byte " +
                                      std::to_string(at) +
                                      " is an uncompressed chunk of 4096 bytes, expected 2048"))
            << msg;
        std::string huge = valid;
        store(huge, at, std::int64_t(1) << 62);
        EXPECT_TRUE(contains(refusal(huge), "in.vdb: truncated: grid \"density\" leaf buffer at "
                                            "byte " +
                                                std::to_string(at + 8) +
                                                " needs 4611686018427387904 bytes"))
            << refusal(huge);
    }
    const auto blosc = streamBytes(oneLeafGrid(), io::COMPRESS_BLOSC);
    const auto at = lastChunkCount(blosc);
    std::string nbytes = blosc;
    store(nbytes, at + 8 + 4, std::uint32_t(1) << 30); // Blosc header: decompressed size
    EXPECT_TRUE(contains(refusal(nbytes), "decompresses to 1073741824 bytes, expected 2048"))
        << refusal(nbytes);
    std::string cbytes = blosc;
    store(cbytes, at + 8 + 12, std::uint32_t(1) << 30); // Blosc header: compressed size
    EXPECT_TRUE(contains(refusal(cbytes), "whose header claims 1073741824")) << refusal(cbytes);
    EXPECT_LT(maxRssKb() - rssBefore, 100 * 1024);
}

TEST_F(VdbCheck, LengthsCountsAndOffsetsAreChecked)
{
    const long rssBefore = maxRssKb();
    const auto withMeta = streamBytes(oneLeafGrid(), io::COMPRESS_BLOSC, fileMeta());
    const auto hello = withMeta.find("hello");
    std::string longString = withMeta;
    store(longString, hello - 4, std::uint32_t(1) << 31);
    EXPECT_TRUE(contains(refusal(longString), "in.vdb: truncated: metadata \"note\" at byte " +
                                                  std::to_string(hello) +
                                                  " needs 2147483648 bytes"))
        << refusal(longString);

    // A stream without file metadata: header (57 bytes), metadata count, grid count.
    std::string manyGrids = streamBytes(oneLeafGrid(), io::COMPRESS_BLOSC);
    store(manyGrids, 61, std::int32_t(0x7fffffff));
    EXPECT_TRUE(contains(refusal(manyGrids), "in.vdb: truncated: grid count 2147483647 at byte 61"))
        << refusal(manyGrids);

    // A file's first descriptor: name "density", type, parent, then three offsets.
    const auto file = fileBytes(oneLeafGrid(), io::COMPRESS_BLOSC);
    const std::size_t offsets = 65 + 4 + 7 + 4 + std::strlen("Tree_float_5_4_3") + 4;
    ASSERT_EQ(loadI64(file, offsets), std::int64_t(offsets + 24));
    std::string beyond = file;
    store(beyond, offsets + 16, std::int64_t(file.size() + 1000));
    EXPECT_TRUE(contains(refusal(beyond), "in.vdb: truncated: grid \"density\" ends at byte " +
                                              std::to_string(file.size() + 1000)))
        << refusal(beyond);
    std::string gridPos = file;
    store(gridPos, offsets, std::int64_t(1) << 40);
    EXPECT_TRUE(contains(refusal(gridPos), "gives grid offset 1099511627776")) << refusal(gridPos);
    std::string blockPos = file;
    store(blockPos, offsets + 8, loadI64(file, offsets + 8) + 1);
    EXPECT_TRUE(contains(refusal(blockPos), "end of the topology")) << refusal(blockPos);
    EXPECT_LT(maxRssKb() - rssBefore, 100 * 1024);
}

TEST_F(VdbCheck, HeaderAndTransformAreChecked)
{
    const auto valid = streamBytes(oneLeafGrid(), io::COMPRESS_NONE);
    EXPECT_EQ(refusal("hello, world: not a vdb"),
              "in.vdb: not a VDB file (no VDB magic number at byte 0)");
    std::string version = valid;
    store(version, 8, std::uint32_t(221));
    EXPECT_TRUE(contains(refusal(version), "format version 221 predates OpenVDB 3"));
    store(version, 8, std::uint32_t(225)); // OpenVDB 13: the same layout
    expectPasses(version, "format version 225");
    store(version, 8, std::uint32_t(226));
    EXPECT_TRUE(contains(refusal(version), "format version 226 is newer than nebula knows"));
    std::string uuid = valid;
    uuid[21 + 8] = 'x'; // the first dash
    EXPECT_TRUE(contains(refusal(uuid), "UUID at byte 21 is not of the form")) << refusal(uuid);
    std::string map = valid;
    const auto at = map.find("UniformScaleMap");
    ASSERT_NE(at, std::string::npos);
    map[at] = 'X';
    EXPECT_TRUE(contains(refusal(map), "has map type \"XniformScaleMap\", which OpenVDB does not"))
        << refusal(map);
}

TEST_F(VdbCheck, BoolBytesAndNamesInMessages)
{
    auto b = openvdb::BoolGrid::create(false);
    b->setName(std::string("bad\nname ") + std::string(100, 'x'));
    b->tree().setValue(openvdb::Coord(1, 2, 3), true);
    std::string bytes = streamBytes({b}, io::COMPRESS_NONE);
    // The bool leaf's values are the last 64 bytes; the value at (1, 2, 3) is bit 83.
    bytes[bytes.size() - 64 + 10] = char(4);
    expectPasses(bytes, "bool leaf values are bits"); // a bit mask: any byte is fine there
    std::string background = streamBytes({b}, io::COMPRESS_NONE);
    const auto root = background.find("Tree_bool_5_4_3");
    ASSERT_NE(root, std::string::npos);
    // After the transform comes the tree: buffer count (4 bytes), then the background byte.
    const auto map = background.find("UniformScaleMap", root);
    const std::size_t bg = map + std::strlen("UniformScaleMap") + 120 + 4;
    ASSERT_EQ(background[bg], char(0));
    background[bg] = char(2);
    const auto msg = refusal(background);
    EXPECT_TRUE(contains(msg, "grid \"bad\\x0aname xxxxxxxxxx")) << msg;
    EXPECT_TRUE(contains(msg, "...\" root background at byte " + std::to_string(bg) +
                                  " holds a bool byte 2, expected 0 or 1"))
        << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos);
    EXPECT_LT(msg.size(), 300u);
}

TEST_F(VdbCheck, BoolPayloadsAreDecoded)
{
    auto b = openvdb::BoolGrid::create(false);
    b->setName("mask");
    b->tree().setValue(openvdb::Coord(1, 2, 3), true);
    for (const std::uint32_t c : std::vector<std::uint32_t>{io::COMPRESS_ZIP, io::COMPRESS_BLOSC}) {
        // The lower internal node's 4096 bool values, all false, as OpenVDB compresses them.
        const auto compressed = [&](const std::vector<char>& values) {
            std::ostringstream out(std::ios::binary);
            if (c == io::COMPRESS_ZIP) {
                io::zipToStream(out, values.data(), values.size());
            } else {
                io::bloscToStream(out, values.data(), 1, values.size());
            }
            return out.str();
        };
        std::vector<char> values(4096, 0);
        const auto original = compressed(values);
        std::string bytes = streamBytes({b}, c);
        const auto at = bytes.find(original);
        ASSERT_NE(at, std::string::npos);
        ASSERT_EQ(bytes.find(original, at + 1), std::string::npos);
        values[17] = 2; // not a bool
        bytes.replace(at, original.size(), compressed(values));
        const auto msg = refusal(bytes);
        EXPECT_TRUE(contains(msg, "grid \"mask\" lower internal node values at byte " +
                                      std::to_string(at) +
                                      " decompresses to a bool byte 2 (value 17), expected 0 or 1"))
            << msg;
    }
}

TEST_F(VdbCheck, DenseGridPasses)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("dense");
    const int n = 64;
    auto acc = g->getAccessor();
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k)
                acc.setValue(openvdb::Coord(i, j, k), float(i * j + k));
    for (const std::uint32_t c : std::vector<std::uint32_t>{
             io::COMPRESS_NONE, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK}) {
        const auto bytes = fileBytes({g}, c);
        const auto start = std::chrono::steady_clock::now();
        checkVdbStructure(bytes, "dense.vdb");
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::cout << "[ throughput ] " << n << "^3 dense FloatGrid, compression " << c << ": "
                  << bytes.size() << " bytes checked in " << s * 1e3 << " ms ("
                  << double(bytes.size()) / 1e6 / std::max(s, 1e-9) << " MB/s)\n";
    }
}
