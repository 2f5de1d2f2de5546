// SPDX-License-Identifier: Apache-2.0
/// @file test_cube_hdf5.cpp
/// io/cube_hdf5.cpp through openHdf5Memory() (nebimport's HDF5 reader over bytes in memory):
/// the fuzzer's seed corpus (tests/fuzz/corpus/hdf5, written by h5py) read or refused as each
/// seed's name says, and the HDF5 inputs the fuzzer once failed on (tests/fuzz/regressions/hdf5,
/// when there are any) refused or read, never a crash.

#include "nebula/io/cube_io.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using nebula::test::errorMessage;

namespace {

const std::filesystem::path FUZZ = std::filesystem::path(NEBULA_SOURCE_DIR) / "tests" / "fuzz";

std::string seed(const std::string& name)
{
    std::ifstream in(FUZZ / "corpus" / "hdf5" / name, std::ios::binary);
    EXPECT_TRUE(in) << name;
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::unique_ptr<nebula::CubeSource> open(const std::string& name, const std::string& dataset = "")
{
    nebula::CubeSelect select;
    select.dataset = dataset;
    return nebula::openHdf5Memory(seed(name), name, select);
}

std::string refusal(const std::string& name, const std::string& dataset = "")
{
    return errorMessage([&] { open(name, dataset); });
}

} // namespace

TEST(Hdf5, PlainCubeWithItsAttributes)
{
    auto cube = open("plain");
    const auto& info = cube->info();
    EXPECT_EQ(info.dims, (std::array<std::int64_t, 3>{4, 4, 4}));
    EXPECT_EQ(info.unit, "cm-3");
    ASSERT_TRUE(info.geometry);
    EXPECT_EQ(info.geometry->spacing, (std::array<double, 3>{0.5, 0.5, 0.5}));
    ASSERT_TRUE(info.geometry->origin);
    EXPECT_EQ(*info.geometry->origin, (std::array<double, 3>{1.0, -2.0, 0.25}));
    // x planes (C order), z fastest: value (16 x + 4 y + z) / 8.
    EXPECT_EQ(info.planeAxis, 0);
    EXPECT_EQ(info.fastAxis, 2);
    std::vector<double> plane(16);
    for (int x = 0; x < 4; ++x) {
        cube->readPlane(x, plane.data());
        for (int y = 0; y < 4; ++y)
            for (int z = 0; z < 4; ++z)
                EXPECT_EQ(plane[std::size_t(y * 4 + z)], (16 * x + 4 * y + z) / 8.0);
    }
}

TEST(Hdf5, GzipShuffleFletcherChunksAndTheFillValue)
{
    auto cube = open("gzip");
    EXPECT_EQ(cube->info().dims, (std::array<std::int64_t, 3>{6, 5, 4}));
    EXPECT_EQ(cube->info().unit, "g/cm3");
    std::vector<double> plane(20);
    for (int x = 0; x < 6; ++x) {
        cube->readPlane(x, plane.data());
        for (int i = 0; i < 20; ++i) {
            // x < 4: linspace(0, 1, 80) in C order; x >= 4 never written: the fill value 0.5.
            const double want = x < 4 ? double(float((x * 20 + i) / 79.0)) : 0.5;
            EXPECT_NEAR(plane[std::size_t(i)], want, 1e-7) << x << " " << i;
        }
    }
}

TEST(Hdf5, BigEndianIntegersAndFixedLengthUnitsOnTheRoot)
{
    auto cube = open("int16-be");
    EXPECT_EQ(cube->info().unit, "cm-3"); // np.bytes_("cm-3"): 4 bytes, NULLPAD, all kept
    std::vector<double> plane(16);
    for (int x = 0; x < 3; ++x) {
        cube->readPlane(x, plane.data());
        for (int i = 0; i < 16; ++i)
            EXPECT_EQ(plane[std::size_t(i)], double((x * 16 + i) % 7));
    }
}

TEST(Hdf5, OtherFilesAreRefusedByName)
{
    const auto ext = refusal("external");
    EXPECT_NE(ext.find("external: dataset /density keeps its values in another file "
                       "(\"/etc/passwd\") (HDF5 external storage)"),
              std::string::npos)
        << ext;
    const auto vds = refusal("virtual");
    EXPECT_NE(vds.find("virtual: dataset /density is a virtual dataset"), std::string::npos) << vds;
    const auto soft = refusal("links", "/soft");
    EXPECT_NE(soft.find("/soft is a soft link to \"/real\""), std::string::npos) << soft;
    const auto elink = refusal("links", "other");
    EXPECT_NE(elink.find("/other is an external link to \"other.h5\" (object \"/density\")"),
              std::string::npos)
        << elink;
    // Without --dataset the only hard-linked cube is chosen; the links are not followed.
    EXPECT_EQ(open("links")->info().name, "links: dataset /real");
}

TEST(Hdf5, MissingFiltersAndUnwrittenDataAreRefused)
{
    const auto lzf = refusal("lzf");
    EXPECT_NE(lzf.find("lzf: dataset /density is compressed with filter 32000 (lzf), which "
                       "this build cannot read; save it with gzip or without compression"),
              std::string::npos)
        << lzf;
    const auto unwritten = refusal("unwritten");
    EXPECT_NE(unwritten.find("unwritten: dataset /density has no stored values: its 64 x 64 x "
                             "64 voxels were declared but never written"),
              std::string::npos)
        << unwritten;
    const auto tiny = errorMessage(
        [] { nebula::openHdf5Memory("\x89HDF\r\n\x1a\n", "tiny.h5", nebula::CubeSelect{}); });
    EXPECT_NE(tiny.find("tiny.h5: not an HDF5 file"), std::string::npos) << tiny;
}

TEST(Hdf5, FuzzRegressionsAreRefusedOrRead)
{
    // tests/fuzz/regressions/hdf5 (HDF5 bytes fuzz_hdf5 once failed on) and the seeds, read as
    // the fuzzer reads them: refused with an Error or read, never a crash.
    int files = 0;
    for (const char* sub : {"regressions/hdf5", "corpus/hdf5"}) {
        const auto folder = FUZZ / sub;
        if (!std::filesystem::exists(folder)) continue;
        for (const auto& entry : std::filesystem::directory_iterator(folder)) {
            std::ifstream in(entry.path(), std::ios::binary);
            const std::string bytes{std::istreambuf_iterator<char>(in),
                                    std::istreambuf_iterator<char>()};
            try {
                auto cube = nebula::openHdf5Memory(bytes, entry.path().filename().string(), {});
                const auto& info = cube->info();
                if (double(info.planeSize()) * double(info.planeCount()) <= 65536.0) {
                    std::vector<double> plane(std::size_t(info.planeSize()));
                    for (std::int64_t k = 0; k < info.planeCount(); ++k)
                        cube->readPlane(k, plane.data());
                }
            } catch (const nebula::Error&) {
            }
            ++files;
        }
    }
    EXPECT_GT(files, 0);
}
