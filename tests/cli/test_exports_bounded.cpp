// SPDX-License-Identifier: Apache-2.0
// Exports and statistics bounded and finite (issue 43): nebexport checks the output's size
// against the free disk and the memory its writer holds before the first byte; nebstats'
// work follows the active voxels and the map, not the box (a 4096^3 tile in a file of a few
// hundred bytes); a NaN or infinite voxel from a foreign VDB is refused, named as it is; an
// inverted --bbox is a usage error.
#include "cli_fixture.h"

#include "nebula/core/disk_space.h"
#include "nebula/core/memory.h"
#include "nebula/core/units.h"

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

/// What no error message may show: a library's exception text, an internal name.
const std::vector<std::string> INTERNALS = {
    "std::vector", "bad_alloc", "max_size", "what()",         "terminate",
    "nebula::",    "Assertion", "-nan",     "ArithmeticError"};

std::string readText(const std::string& p)
{
    std::ifstream in(p, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// A density grid of voxel size 1 pc named "density".
openvdb::FloatGrid::Ptr densityGrid()
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    return g;
}

} // namespace

class ExportsBounded : public Cli
{
protected:
    /// The command (under `timeout 60`) fails with @p code and one line that names
    /// @p mention and no internals; nothing is left behind; it took less than @p seconds.
    void expectClean(const std::string& cmd, int code, const std::string& mention,
                     double seconds = 60.0)
    {
        const auto before = entries();
        const auto t0 = std::chrono::steady_clock::now();
        const Result r = run("timeout 60 " + cmd);
        const double took =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        EXPECT_EQ(r.code, code) << cmd << "\n" << r.err;
        EXPECT_NE(r.err.find(mention), std::string::npos)
            << cmd << ": expected \"" << mention << "\" in: " << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << cmd << ": " << r.err;
        for (const auto& bad : INTERNALS) {
            EXPECT_EQ(r.err.find(bad), std::string::npos)
                << cmd << " shows \"" << bad << "\": " << r.err;
        }
        EXPECT_EQ(entries(), before) << "output or temporary left behind by: " << cmd;
        EXPECT_LT(took, seconds) << cmd << " took " << took << " s";
    }

    /// huge.vdb: one active 4096^3 tile of value 1 at the origin (a few hundred bytes), as
    /// another program writes it.
    void makeHugeTile()
    {
        auto g = densityGrid();
        g->tree().addTile(3, openvdb::Coord(0), 1.0f, true);
        ASSERT_EQ(g->activeVoxelCount(), openvdb::Index64(1) << 36);
        writeVdb(path("huge.vdb"), {g}, openvdb::MetaMap());
        ASSERT_LT(fs::file_size(path("huge.vdb")), 4096u);
    }

    /// @p name: a 6^3 block of 1s with voxel (1, 2, 3) set to @p bad (active), as another
    /// program writes it.
    void makeWithValue(const std::string& name, float bad)
    {
        auto g = densityGrid();
        g->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(5)), 1.0f, true);
        g->tree().voxelizeActiveTiles();
        g->tree().setValueOn(openvdb::Coord(1, 2, 3), bad);
        writeVdb(path(name), {g}, openvdb::MetaMap());
    }
};

// A 594-byte file declaring a 256 GiB cube: refused at once, before a byte is written,
// naming the output, the size and the free space (a .npy, streamed); FITS and HDF5, built in
// memory, are refused by the memory they would hold, to a file or to stdout (no disk check),
// as is the .npy stream's plane buffer of a flat box.
TEST_F(ExportsBounded, HugeCubesAreRefusedBeforeTheFirstByte)
{
    makeHugeTile();
    const auto free = nebula::freeDiskSpace(path("x.npy"));
    ASSERT_TRUE(free.has_value());
    const double cube = 4.0 * double(std::uint64_t(1) << 36); // 256 GiB
    const std::string head = ": the 4096 x 4096 x 4096 cube of grid \"density\" (huge.vdb, --bbox "
                             "auto: 0,0,0 to 4095,4095,4095) needs ";
    if (double(*free) < cube) {
        expectClean("nebexport -i huge.vdb -o x.npy", 1,
                    "-o x.npy" + head + "256 GiB on disk; the file system that holds it has ",
                    20.0);
        // The same box given explicitly is the option's fault: exit 2.
        expectClean("nebexport -i huge.vdb --bbox 0,0,0,4095,4095,4095 -o x.npy", 2,
                    "needs 256 GiB on disk", 20.0);
    } else {
        std::cerr << "skipped the disk cases: " << *free << " bytes free\n";
    }
    const std::uint64_t memory = nebula::physicalMemory();
    ASSERT_GT(memory, 0u);
    if (double(memory) < cube) {
        for (const char* out : {"-o x.fits", "-o - --format fits > /dev/null"}) {
            expectClean(std::string("nebexport -i huge.vdb ") + out, 1,
                        head + "256 GiB of memory; this machine has ", 20.0);
            expectClean(std::string("nebexport -i huge.vdb ") + out, 1,
                        "(the FITS file is built in memory); --bbox I0,J0,K0,I1,J1,K1 exports a "
                        "part",
                        20.0);
        }
        for (const char* out : {"-o x.h5", "-o - --format hdf5 > /dev/null"}) {
            expectClean(std::string("nebexport -i huge.vdb ") + out, 1,
                        head + "512 GiB of memory; this machine has ", 20.0);
        }
        // A .npy is streamed, but one z plane of 2^18 x 2^18 voxels is 256 GiB.
        expectClean("nebexport -i huge.vdb --bbox 0,0,0,262143,262143,0 -o - --format npy "
                    "> /dev/null",
                    2, "needs 256 GiB of memory; this machine has ", 20.0);
    } else {
        std::cerr << "skipped the memory cases: " << memory << " bytes of memory\n";
    }
    // A cube between the memory and the free disk: as FITS refused by the memory its writer
    // needs (exit 2: --bbox made it so), though the disk would hold it.
    const double between = (double(memory) + double(*free)) / 2.0;
    if (double(memory) * 1.05 < double(*free) && between < cube) {
        const long nz = long(between / (4.0 * 4096.0 * 4096.0));
        expectClean("nebexport -i huge.vdb --bbox 0,0,0,4095,4095," + std::to_string(nz - 1) +
                        " -o x.fits",
                    2, "of memory; this machine has", 20.0);
    } else {
        std::cerr << "skipped the memory case: " << memory << " bytes of memory, " << *free
                  << " bytes free\n";
    }
}

// nebstats on one active 4096^3 tile: the column is the tile's value times its depth,
// computed from the tile, not voxel by voxel (it was still running after 400 s); a map
// larger than nebstats measures is refused before any work, naming the grid, the box, the
// limit and --bbox.
TEST_F(ExportsBounded, NebstatsWorkFollowsTheActiveVoxels)
{
    makeHugeTile();
    const auto t0 = std::chrono::steady_clock::now();
    const Result r = run("timeout 60 nebstats -i huge.vdb --json > stats.json");
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_LT(took, 60.0);
    const auto j = nlohmann::json::parse(readText(path("stats.json")));
    EXPECT_EQ(j["column"]["width"].get<int>(), 4096);
    EXPECT_EQ(j["column"]["height"].get<int>(), 4096);
    EXPECT_EQ(j["column"]["pixels"].get<long long>(), 4096LL * 4096LL);
    // N_H = n_H x depth x voxel edge: 1 cm^-3 x 4096 pc (the mean: a sum of 2^24 pixels).
    EXPECT_NEAR(j["column"]["mean"].get<double>() / (4096.0 * nebula::PC_CM), 1.0, 1e-9);
    EXPECT_NEAR(j["column"]["max"].get<double>() / (4096.0 * nebula::PC_CM), 1.0, 1e-12);
    EXPECT_EQ(j["volume"]["voxels"].get<long long>(), 1LL << 36);
    EXPECT_NEAR(j["volume"]["mean_ln"].get<double>(), 0.0, 1e-12);
    // A box cut through the tile: the depth in the box counts.
    ASSERT_EQ(run("timeout 60 nebstats -i huge.vdb --bbox 0,0,0,63,31,9 --json > cut.json").code,
              0);
    const auto cut = nlohmann::json::parse(readText(path("cut.json")));
    EXPECT_EQ(cut["column"]["width"].get<int>(), 64);
    EXPECT_EQ(cut["column"]["height"].get<int>(), 32);
    EXPECT_NEAR(cut["column"]["mean"].get<double>() / (10.0 * nebula::PC_CM), 1.0, 1e-12);
    EXPECT_EQ(cut["volume"]["voxels"].get<long long>(), 64LL * 32LL * 10LL);

    // Two tiles 12288 voxels apart along x: a 16384 x 4096 map, refused from the file (exit
    // 1), or from --bbox (exit 2).
    {
        auto g = densityGrid();
        g->tree().addTile(3, openvdb::Coord(0), 1.0f, true);
        g->tree().addTile(3, openvdb::Coord(12288, 0, 0), 2.0f, true);
        writeVdb(path("wide.vdb"), {g}, openvdb::MetaMap());
    }
    expectClean("nebstats -i wide.vdb", 1,
                "wide.vdb: grid \"density\": the column map along z over the box 0,0,0 to "
                "16383,4095,4095 is 16384 x 4096 pixels, more than the 8192 a side nebstats "
                "measures; give --bbox",
                20.0);
    expectClean("nebstats -i wide.vdb --bbox 0,0,0,9999,0,0", 2,
                "--bbox 0,0,0,9999,0,0: wide.vdb: grid \"density\": the column map along z", 20.0);
    // Along x the same grid's map is 4096 x 4096: measured.
    const Result x = run("timeout 60 nebstats -i wide.vdb --axis x --json > x.json");
    ASSERT_EQ(x.code, 0) << x.err;
    const auto jx = nlohmann::json::parse(readText(path("x.json")));
    // Each pixel: 4096 voxels of 1 and 4096 of 2 along x.
    EXPECT_NEAR(jx["column"]["mean"].get<double>() / (3.0 * 4096.0 * nebula::PC_CM), 1.0, 1e-9);
    EXPECT_NEAR(jx["column"]["max"].get<double>() / (3.0 * 4096.0 * nebula::PC_CM), 1.0, 1e-12);
}

// NaN, +inf and -inf voxels from a foreign VDB are refused by every read path of nebexport
// (npy, FITS, HDF5) and nebstats, the value named as it is and the voxel given.
TEST_F(ExportsBounded, NonFiniteVoxelsAreRefusedAndNamed)
{
    struct Case
    {
        const char* file;
        float value;
        const char* text;
    };
    const float inf = std::numeric_limits<float>::infinity();
    for (const Case& c : {Case{"nan.vdb", std::numeric_limits<float>::quiet_NaN(), "nan"},
                          Case{"negnan.vdb", -std::numeric_limits<float>::quiet_NaN(), "nan"},
                          Case{"inf.vdb", inf, "inf"}, Case{"neginf.vdb", -inf, "-inf"}}) {
        makeWithValue(c.file, c.value);
        const std::string mention = std::string(c.file) + ": grid \"density\" has the value " +
                                    c.text + " at voxel (1, 2, 3); expected finite values";
        for (const char* out : {"x.npy", "x.fits", "x.h5"})
            expectClean(std::string("nebexport -i ") + c.file + " -o " + out, 1, mention);
        expectClean(std::string("nebexport -i ") + c.file + " -o - --format npy > /dev/null", 1,
                    mention);
        expectClean(std::string("nebstats -i ") + c.file, 1, mention);
        expectClean(std::string("nebstats -i ") + c.file + " --json", 1, mention);
        fs::remove(path(c.file));
    }
    // An active tile of +inf: named at the tile's first voxel, by the tile-wise nebstats too.
    {
        auto g = densityGrid();
        g->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(15)), 1.0f, true);
        g->tree().addTile(1, openvdb::Coord(8, 8, 8), inf, true);
        writeVdb(path("tile.vdb"), {g}, openvdb::MetaMap());
    }
    expectClean("nebstats -i tile.vdb", 1, "has the value inf at voxel (8, 8, 8)");
    expectClean("nebexport -i tile.vdb -o x.npy", 1, "has the value inf at voxel (8, 8, 8)");
    // What a dense cube holds besides the active values: an inactive voxel inside the box,
    // and the background. nebstats reads the active values only.
    {
        auto g = densityGrid();
        g->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(7)), 1.0f, true);
        g->tree().voxelizeActiveTiles();
        g->tree().setValueOff(openvdb::Coord(2, 3, 4), -inf);
        writeVdb(path("off.vdb"), {g}, openvdb::MetaMap());
    }
    expectClean("nebexport -i off.vdb -o x.fits", 1,
                "off.vdb: grid \"density\" has the inactive value -inf at voxel (2, 3, 4)");
    EXPECT_EQ(run("nebstats -i off.vdb > off.txt").code, 0);
    // Outside the box the inactive value is not exported: the cube is written.
    EXPECT_EQ(run("nebexport -i off.vdb --bbox 3,0,0,7,7,7 -o part.npy").code, 0);
    {
        auto g = openvdb::FloatGrid::create(std::numeric_limits<float>::quiet_NaN());
        g->setName("density");
        g->tree().setValueOn(openvdb::Coord(0), 1.0f);
        g->tree().setValueOn(openvdb::Coord(3), 1.0f);
        writeVdb(path("bg.vdb"), {g}, openvdb::MetaMap());
    }
    expectClean("nebexport -i bg.vdb -o x.h5", 1,
                "bg.vdb: grid \"density\" has the background value nan");
}

// An inverted --bbox is a usage error naming the option and the axis, in both tools.
TEST_F(ExportsBounded, InvertedBoxesAreUsageErrors)
{
    makeWithValue("ok.vdb", 1.0f);
    for (const char* tool : {"nebstats -i ok.vdb", "nebexport -i ok.vdb -o x.npy"}) {
        expectClean(std::string(tool) + " --bbox 5,0,0,1,3,3", 2,
                    "--bbox 5,0,0,1,3,3: the minimum must be <= the maximum on each axis, and "
                    "on x it is 5 > 1");
        expectClean(std::string(tool) + " --bbox 0,0,3,3,3,-1", 2, "on z it is 3 > -1");
    }
    // A box of one voxel is not inverted.
    EXPECT_EQ(run("nebexport -i ok.vdb --bbox 1,2,3,1,2,3 -o one.npy").code, 0);
}
