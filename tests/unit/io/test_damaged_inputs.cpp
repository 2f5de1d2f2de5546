// SPDX-License-Identifier: Apache-2.0
/// @file test_damaged_inputs.cpp
/// readGrids() on damaged copies of a small file nebula wrote (README "Failure behaviour"):
/// every truncation is refused, and of a fixed set of 400 mutations (1-4 bytes, fixed seed)
/// none is accepted with different contents: each is refused with a one-line message, or
/// reads back identical grids and metadata (the flipped bytes were ones nothing reads, such
/// as the UUID). The files of tests/fuzz/regressions (inputs the fuzzer once failed on) are
/// refused or read, never crash. gridChecksum() changes with any value, state or name.

#include "nebula/core/error.h"
#include "nebula/io/checksum.h"
#include "nebula/io/grid_io.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>

#include <unistd.h>

namespace fs = std::filesystem;

namespace {

/// A small file as the tools write it: two float grids (leaves, a tile, a negative
/// background), a vector grid, stars and dust metadata; via a file or a stream.
std::string smallNebulaFile(bool stream)
{
    openvdb::initialize();
    nebula::GridSet set;
    auto density = openvdb::FloatGrid::create(0.0f);
    density->setName("density");
    density->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
    auto acc = density->getAccessor();
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 9; ++j)
            acc.setValue(openvdb::Coord(i, j, i % 5), float(i * 9 + j) * 0.5f);
    density->tree().addTile(1, openvdb::Coord(64, 0, 0), 3.0f, true);
    auto tau = openvdb::FloatGrid::create(-1.0f);
    tau->setName("tau.star");
    tau->tree().setValue(openvdb::Coord(1, 2, 3), 0.75f);
    auto velocity = openvdb::Vec3fGrid::create();
    velocity->setName("velocity");
    velocity->tree().setValue(openvdb::Coord(4, 4, 4), openvdb::Vec3f(1, 2, 3));
    set.grids = {density, tau, velocity};
    set.setStars({nebula::Star{"star", {0.0, 0.0, 0.0}, 1000.0, 20000.0}});
    set.setDust(nebula::DustParams{});

    const std::string path =
        (fs::temp_directory_path() / ("nebula_damaged_" + std::to_string(::getpid()) + ".vdb"))
            .string();
    if (stream) {
        std::ostringstream out;
        auto* old = std::cout.rdbuf(out.rdbuf());
        try {
            nebula::writeGrids("-", set, "test", "test");
        } catch (...) {
            std::cout.rdbuf(old);
            throw;
        }
        std::cout.rdbuf(old);
        return out.str();
    }
    nebula::writeGrids(path, set, "test", "test");
    std::ifstream in(path, std::ios::binary);
    std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    fs::remove(path);
    return bytes;
}

/// Checksums of every grid and of the metadata: equal iff the contents are.
std::string fingerprint(const nebula::GridSet& set)
{
    std::string f = nebula::metadataChecksum(set.meta, "");
    for (const auto& g : set.grids)
        f += " " + g->getName() + ":" + nebula::gridChecksum(*g);
    return f;
}

} // namespace

TEST(DamagedInputs, EveryTruncationIsRefused)
{
    for (const bool stream : {false, true}) {
        const std::string bytes = smallNebulaFile(stream);
        ASSERT_NO_THROW(nebula::readGridsFromMemory(bytes, "whole.vdb"));
        for (std::size_t size = 0; size < bytes.size(); ++size) {
            try {
                nebula::readGridsFromMemory(bytes.substr(0, size), "cut.vdb");
                ADD_FAILURE() << (stream ? "stream" : "file") << " cut to " << size << " of "
                              << bytes.size() << " bytes was accepted";
            } catch (const nebula::Error& e) {
                const std::string msg = e.what();
                EXPECT_EQ(msg.rfind("cut.vdb: ", 0), 0u) << msg;
                EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
                EXPECT_LT(msg.size(), 400u) << msg;
            }
        }
    }
}

TEST(DamagedInputs, NoMutationIsAcceptedWithDifferentContents)
{
    for (const bool stream : {false, true}) {
        const std::string bytes = smallNebulaFile(stream);
        const std::string original = fingerprint(nebula::readGridsFromMemory(bytes, "whole.vdb"));
        std::mt19937 rng(20261202);
        std::uniform_int_distribution<std::size_t> where(0, bytes.size() - 1);
        std::uniform_int_distribution<int> flips(1, 4), value(1, 255);
        int refused = 0, identical = 0;
        for (int m = 0; m < 400; ++m) {
            std::string damaged = bytes;
            for (int f = flips(rng); f > 0; --f)
                damaged[where(rng)] ^= char(value(rng));
            try {
                const auto set = nebula::readGridsFromMemory(damaged, "mutant.vdb");
                EXPECT_EQ(fingerprint(set), original)
                    << "mutation " << m << " was accepted with different contents";
                ++identical;
            } catch (const nebula::Error& e) {
                const std::string msg = e.what();
                EXPECT_EQ(msg.rfind("mutant.vdb: ", 0), 0u) << msg;
                EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
                for (char c : msg)
                    EXPECT_TRUE(c >= 32 && c < 127) << "raw byte in: " << msg;
                ++refused;
            }
        }
        std::cout << (stream ? "stream" : "file") << " of " << bytes.size()
                  << " bytes, 400 mutations: " << refused << " refused, " << identical
                  << " read back identical\n";
        EXPECT_GT(refused, 300);
    }
}

TEST(DamagedInputs, FuzzRegressionsAreRefusedOrRead)
{
    const fs::path folder = fs::path(NEBULA_SOURCE_DIR) / "tests" / "fuzz" / "regressions";
    int files = 0;
    for (const auto& entry : fs::directory_iterator(folder)) {
        if (!entry.is_regular_file() || entry.path().filename() == "README.md") continue;
        std::ifstream in(entry.path(), std::ios::binary);
        const std::string bytes{std::istreambuf_iterator<char>(in),
                                std::istreambuf_iterator<char>()};
        try {
            nebula::readGridsFromMemory(bytes, entry.path().filename().string());
        } catch (const nebula::Error&) {
        }
        ++files;
    }
    EXPECT_GT(files, 0) << "no regression inputs in " << folder;
}

TEST(DamagedInputs, ChecksumChangesWithValuesStatesAndNames)
{
    openvdb::initialize();
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->tree().setValue(openvdb::Coord(1, 2, 3), 1.0f);
    const std::string base = nebula::gridChecksum(*g);
    ASSERT_EQ(base.size(), 16u);
    auto value = g->deepCopy();
    value->tree().setValue(openvdb::Coord(1, 2, 3), std::nextafter(1.0f, 2.0f));
    auto state = g->deepCopy();
    state->tree().setValueOff(openvdb::Coord(1, 2, 3));
    auto name = g->deepCopy();
    name->setName("densitz");
    auto tile = g->deepCopy();
    tile->tree().addTile(2, openvdb::Coord(4096, 0, 0), 0.0f, true);
    for (const auto& other : {value, state, name, tile})
        EXPECT_NE(nebula::gridChecksum(*other), base);
    EXPECT_EQ(nebula::gridChecksum(*g->deepCopy()), base);
}

namespace {

/// The tiles gridChecksum() hashes, in order, from OpenVDB's tree value iterators (the
/// definition the checksum's own walk must follow, for files written before it).
template <typename TreeT> std::vector<std::string> tilesByIterators(const TreeT& tree)
{
    std::vector<std::string> out;
    auto on = tree.cbeginValueOn();
    on.setMaxDepth(TreeT::ValueOnCIter::LEAF_DEPTH - 1);
    for (; on; ++on)
        out.push_back("on " + on.getCoord().asVec3i().str() + " " + std::to_string(on.getDepth()) +
                      " " + std::to_string(double(*on)));
    auto off = tree.cbeginValueOff();
    off.setMaxDepth(TreeT::ValueOffCIter::LEAF_DEPTH - 1);
    for (; off; ++off) {
        if (*off == tree.background()) continue;
        out.push_back("off " + off.getCoord().asVec3i().str() + " " +
                      std::to_string(off.getDepth()) + " " + std::to_string(double(*off)));
    }
    return out;
}

/// A grid with active and inactive tiles at every level (root, both internal levels), some
/// between others and leaves, in several root entries (negative origins too).
template <typename GridT>
typename GridT::Ptr tiledGrid(typename GridT::ValueType a, typename GridT::ValueType b)
{
    auto g = GridT::create(typename GridT::ValueType(0));
    auto& t = g->tree();
    t.addTile(3, openvdb::Coord(-4096, 0, 0), a, true);    // root tiles
    t.addTile(3, openvdb::Coord(8192, 4096, 0), b, false); //
    t.addTile(2, openvdb::Coord(128, 0, 0), a, true);      // upper internal tiles
    t.addTile(2, openvdb::Coord(0, 128, 256), b, false);
    t.addTile(1, openvdb::Coord(8, 0, 0), b, true); // lower internal tiles
    t.addTile(1, openvdb::Coord(0, 16, 8), a, false);
    t.addTile(1, openvdb::Coord(0, -8, -8), a, true);
    t.setValue(openvdb::Coord(1, 2, 3), a); // leaves among them
    t.setValue(openvdb::Coord(200, 5, 5), b);
    t.setValue(openvdb::Coord(-5000, -7, 9), a);
    t.setValueOff(openvdb::Coord(0, 0, 0), b);
    return g;
}

} // namespace

// gridChecksum() walks the tree's tables itself (detail::forEachTile()) rather than with
// OpenVDB's value iterators, which step through every voxel of every leaf: the hash of files
// written before must stay the same, so the walk must give the same tiles in the same order.
TEST(DamagedInputs, ChecksumWalksTilesInTheIteratorsOrder)
{
    openvdb::initialize();
    const auto byWalk = [](const auto& tree) {
        std::vector<std::string> out;
        for (const bool active : {true, false})
            nebula::detail::forEachTile(
                tree, active, [&](const openvdb::Coord& c, openvdb::Index depth, const auto& v) {
                    out.push_back(std::string(active ? "on " : "off ") + c.asVec3i().str() + " " +
                                  std::to_string(depth) + " " + std::to_string(double(v)));
                });
        return out;
    };
    const auto f = tiledGrid<openvdb::FloatGrid>(1.5f, -2.0f);
    const auto expected = tilesByIterators(f->tree());
    EXPECT_GE(expected.size(), 8u); // the tiles added, and those the leaves' parents hold
    EXPECT_EQ(byWalk(f->tree()), expected);
    const auto i = tiledGrid<openvdb::Int32Grid>(7, 9);
    EXPECT_EQ(byWalk(i->tree()), tilesByIterators(i->tree()));
    const auto b = tiledGrid<openvdb::BoolGrid>(true, true);
    EXPECT_EQ(byWalk(b->tree()), tilesByIterators(b->tree()));
    auto m = openvdb::MaskGrid::create();
    m->tree().addTile(2, openvdb::Coord(128, 0, 0), true, true);
    m->tree().addTile(3, openvdb::Coord(-4096, 0, 0), true, true);
    m->tree().setValueOn(openvdb::Coord(1, 2, 3));
    EXPECT_EQ(byWalk(m->tree()), tilesByIterators(m->tree()));
    // Each tile counts: one tile's value or state changes the checksum.
    const std::string base = nebula::gridChecksum(*f);
    auto v = f->deepCopy();
    v->tree().addTile(1, openvdb::Coord(0, 16, 8), 1.25f, false);
    EXPECT_NE(nebula::gridChecksum(*v), base);
    auto s = f->deepCopy();
    s->tree().addTile(3, openvdb::Coord(8192, 4096, 0), -2.0f, true);
    EXPECT_NE(nebula::gridChecksum(*s), base);
}
