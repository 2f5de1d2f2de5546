/// @file test_atomic_file.cpp
/// AtomicFile (core/atomic_file.h): the data goes to a temporary next to the target,
/// commit() renames it into place, and a destroyed uncommitted AtomicFile leaves neither a
/// temporary nor a changed target behind; checkOutputWritable() names the path.

#include "nebula/core/atomic_file.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

namespace fs = std::filesystem;

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

class AtomicFileTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        std::random_device rd;
        dir = fs::temp_directory_path() /
              ("nebula_atomic_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
        fs::create_directories(dir);
    }
    void TearDown() override
    {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }

    /// Every entry of the test folder, by name.
    std::vector<std::string> entries() const
    {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir))
            names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    }

    static void write(const std::string& path, const std::string& text)
    {
        std::ofstream out(path, std::ios::binary);
        out << text;
    }

    static std::string read(const std::string& path)
    {
        std::ifstream in(path, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }

    fs::path dir;
};

TEST_F(AtomicFileTest, TemporaryLivesNextToTheTarget)
{
    const std::string path = (dir / "out.vdb").string();
    nebula::AtomicFile file(path);
    EXPECT_EQ(file.path(), path);
    EXPECT_NE(file.tmpPath(), path);
    // Same folder (so the rename stays on one filesystem), and it exists already.
    EXPECT_EQ(fs::path(file.tmpPath()).parent_path(), dir);
    EXPECT_TRUE(fs::exists(file.tmpPath()));
    EXPECT_FALSE(fs::exists(path));
    // Two outputs to the same target get different temporaries.
    nebula::AtomicFile other(path);
    EXPECT_NE(other.tmpPath(), file.tmpPath());
}

TEST_F(AtomicFileTest, CommitRenamesIntoPlace)
{
    const std::string path = (dir / "frame.exr").string();
    std::string tmp;
    {
        nebula::AtomicFile file(path);
        tmp = file.tmpPath();
        write(tmp, "finished data");
        EXPECT_FALSE(fs::exists(path)); // nothing at the target before commit()
        file.commit();
        EXPECT_TRUE(fs::exists(path));
        EXPECT_FALSE(fs::exists(tmp));
    }
    // The destructor of a committed file removes nothing.
    EXPECT_EQ(read(path), "finished data");
    EXPECT_EQ(entries(), std::vector<std::string>{"frame.exr"});
}

TEST_F(AtomicFileTest, CommitReplacesAnExistingFile)
{
    const std::string path = (dir / "frame.png").string();
    write(path, "old");
    {
        nebula::AtomicFile file(path);
        write(file.tmpPath(), "new");
        EXPECT_EQ(read(path), "old"); // untouched until commit()
        file.commit();
    }
    EXPECT_EQ(read(path), "new");
    EXPECT_EQ(entries(), std::vector<std::string>{"frame.png"});
}

TEST_F(AtomicFileTest, UncommittedLeavesNoTemporaryAndNoOutput)
{
    const std::string path = (dir / "never.vdb").string();
    std::string tmp;
    {
        nebula::AtomicFile file(path);
        tmp = file.tmpPath();
        write(tmp, "half-written");
    }
    EXPECT_FALSE(fs::exists(tmp));
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(entries().empty());
}

TEST_F(AtomicFileTest, UncommittedDoesNotTouchAnExistingFile)
{
    const std::string path = (dir / "keep.vdb").string();
    write(path, "the previous output");
    const auto before = fs::last_write_time(path);
    {
        nebula::AtomicFile file(path);
        write(file.tmpPath(), "a failed run");
    } // e.g. an exception before commit()
    EXPECT_EQ(read(path), "the previous output");
    EXPECT_EQ(fs::last_write_time(path), before);
    EXPECT_EQ(entries(), std::vector<std::string>{"keep.vdb"});
}

TEST_F(AtomicFileTest, ExceptionBeforeCommitCleansUp)
{
    const std::string path = (dir / "thrown.vdb").string();
    try {
        nebula::AtomicFile file(path);
        write(file.tmpPath(), "x");
        throw nebula::Error("simulated failure");
    } catch (const nebula::Error&) {
    }
    EXPECT_TRUE(entries().empty());
}

TEST_F(AtomicFileTest, CommittedFileHasOrdinaryPermissions)
{
    // mkstemp() makes the temporary 0600; the output must get what open() would give it
    // (0666 minus the umask), not stay private to the owner.
    const mode_t mask = ::umask(0);
    ::umask(mask);
    const std::string path = (dir / "perm.vdb").string();
    {
        nebula::AtomicFile file(path);
        file.commit();
    }
    struct stat st
    {
    };
    ASSERT_EQ(::stat(path.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0666 & ~mask);
}

TEST_F(AtomicFileTest, FailedCommitThrowsNamingThePathAndCleansUp)
{
    // The target is a non-empty folder: rename() cannot replace it.
    const fs::path target = dir / "occupied";
    fs::create_directories(target / "inside");
    std::string msg;
    {
        nebula::AtomicFile file(target.string());
        write(file.tmpPath(), "data");
        msg = errorMessage([&] { file.commit(); });
    }
    EXPECT_EQ(msg.rfind(target.string() + ": ", 0), 0u) << msg;
    EXPECT_EQ(entries(), std::vector<std::string>{"occupied"}); // no temporary left
    EXPECT_TRUE(fs::is_directory(target / "inside"));
}

TEST_F(AtomicFileTest, MissingFolderThrowsNamingThePath)
{
    const std::string path = (dir / "no" / "such" / "folder" / "out.vdb").string();
    const std::string msg = errorMessage([&] { nebula::AtomicFile file(path); });
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, (dir / "no" / "such" / "folder").string())) << msg;
    EXPECT_FALSE(fs::exists(dir / "no"));
}

TEST_F(AtomicFileTest, CheckOutputWritable)
{
    EXPECT_NO_THROW(nebula::checkOutputWritable((dir / "fine.exr").string(), "EXR"));
    // A bare file name is in the current folder (which the tests can write to or not; the
    // call must not look for a folder called "").
    const bool cwdWritable = ::access(".", W_OK | X_OK) == 0;
    if (cwdWritable) {
        EXPECT_NO_THROW(nebula::checkOutputWritable("bare.exr", "EXR"));
    }

    const std::string path = (dir / "missing" / "x.png").string();
    const std::string msg = errorMessage([&] { nebula::checkOutputWritable(path, "PNG image"); });
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "PNG image")) << msg;
    EXPECT_TRUE(contains(msg, (dir / "missing").string())) << msg;
    EXPECT_THROW(nebula::checkOutputWritable(path, "PNG image"), nebula::Error);
    // A regular file where the folder should be.
    write((dir / "plain").string(), "");
    EXPECT_THROW(nebula::checkOutputWritable((dir / "plain" / "x.vdb").string(), "VDB"),
                 nebula::Error);
}

} // namespace
