// SPDX-License-Identifier: Apache-2.0
// freeDiskSpace(): the room left where an output goes, and none where no file system fills up.
#include "nebula/core/disk_space.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sys/statvfs.h>
#include <unistd.h>

namespace fs = std::filesystem;

TEST(DiskSpace, FreeSpaceOfTheOutputsFolder)
{
    const fs::path dir = fs::path(::testing::TempDir()) / "nebula_disk_space";
    fs::remove_all(dir);
    fs::create_directories(dir);
    struct statvfs st;
    ASSERT_EQ(::statvfs(dir.c_str(), &st), 0);
    const double expected = double(st.f_bavail) * double(st.f_frsize);
    const auto free = nebula::freeDiskSpace((dir / "new.npy").string());
    ASSERT_TRUE(free.has_value());
    // The same file system, asked a moment later: equal within what others wrote meanwhile.
    EXPECT_NEAR(double(*free), expected, 64.0 * 1024 * 1024);
    // An existing file and a symlink to it: their folder's file system.
    std::ofstream(dir / "old.npy") << "x";
    fs::create_symlink(dir / "old.npy", dir / "link.npy");
    EXPECT_TRUE(nebula::freeDiskSpace((dir / "old.npy").string()).has_value());
    EXPECT_TRUE(nebula::freeDiskSpace((dir / "link.npy").string()).has_value());
    // No file system to fill: stdout, a device, a folder that does not exist.
    EXPECT_FALSE(nebula::freeDiskSpace("-").has_value());
    EXPECT_FALSE(nebula::freeDiskSpace("/dev/null").has_value());
    EXPECT_FALSE(nebula::freeDiskSpace((dir / "missing" / "x.npy").string()).has_value());
    fs::remove_all(dir);
}
