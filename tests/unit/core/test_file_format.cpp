// SPDX-License-Identifier: Apache-2.0
// core/file_format.h: the names each output format goes by, and the check every writer and
// the command line make with them.
#include "nebula/core/error.h"
#include "nebula/core/file_format.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace nebula;

namespace {

/// The UsageError text of checkOutputName(), or "" when it passes.
std::string refusal(const std::string& path, FileFormat format)
{
    try {
        checkOutputName(path, "-o", format);
        return "";
    } catch (const UsageError& e) {
        return e.what();
    }
}

} // namespace

TEST(FileFormat, NamesByTheirEnding)
{
    EXPECT_EQ(formatOfName("a/b/cloud.vdb"), FileFormat::Vdb);
    EXPECT_EQ(formatOfName("CLOUD.VDB"), FileFormat::Vdb);
    EXPECT_EQ(formatOfName("x.fit"), FileFormat::Fits);
    EXPECT_EQ(formatOfName("x.hdf5"), FileFormat::Hdf5);
    EXPECT_EQ(formatOfName("f.####.exr"), FileFormat::Exr);
    EXPECT_EQ(formatOfName("x.fits.gz"), std::nullopt); // nebula writes no compressed FITS
    EXPECT_EQ(formatOfName("dir.vdb/x"), std::nullopt); // the folder's ending is not the name's
    EXPECT_EQ(formatOfName(".vdb"), std::nullopt);      // a hidden name, no ending
    EXPECT_EQ(formatOfName("x.npy.txt"), std::nullopt);
    EXPECT_STREQ(formatName(FileFormat::Npy), "NumPy .npy");
    EXPECT_EQ(formatExtensions(FileFormat::Json).front(), ".json");
}

TEST(FileFormat, OutputNamesMustSayTheirFormat)
{
    EXPECT_EQ(refusal("out.vdb", FileFormat::Vdb), "");
    EXPECT_EQ(refusal("OUT.Fits", FileFormat::Fits), "");
    EXPECT_EQ(refusal("-", FileFormat::Vdb), "");         // stdout has no name
    EXPECT_EQ(refusal("/dev/null", FileFormat::Vdb), ""); // a device (--write-through)
    EXPECT_EQ(refusal("out.fits", FileFormat::Vdb),
              "-o out.fits: the name says FITS, but this output is VDB; name it *.vdb");
    EXPECT_EQ(refusal("out", FileFormat::Png),
              "-o out: the name has no ending, but this output is PNG; name it *.png");
    EXPECT_EQ(refusal("d.fits.gz", FileFormat::Fits),
              "-o d.fits.gz: the name ends in \".gz\", but this output is FITS; name it *.fits, "
              "*.fit, *.fts");
    // An existing regular file is judged by its name like a new one.
    const auto dir = std::filesystem::path(::testing::TempDir()) / "nebula_file_format";
    std::filesystem::create_directories(dir);
    const std::string existing = (dir / "old.npy").string();
    std::ofstream(existing) << "x";
    EXPECT_NE(refusal(existing, FileFormat::Vdb), "");
    std::filesystem::remove_all(dir);
}
