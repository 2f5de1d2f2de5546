// SPDX-License-Identifier: Apache-2.0
/// @file test_atomic_file.cpp
/// AtomicFile (core/atomic_file.h): the data goes to a temporary next to the target,
/// commit() renames it into place, and a destroyed uncommitted AtomicFile leaves neither a
/// temporary nor a changed target behind; write errors (a full disk, simulated with
/// RLIMIT_FSIZE) leave the old file; commitAll() is all or none; targets that are not regular
/// files are refused unless written through; a signal removes the temporary, and temporaries
/// of dead writers are removed by the next run; checkOutputWritable() names the path.

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

#include <csignal>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
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
        file.stream() << "finished data";
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
        file.stream() << "new";
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
        file.stream() << "half-written";
        file.finish(); // even when finished
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
        file.stream() << "a failed run";
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
        file.stream() << "x";
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
    // The temporary vanished (someone cleaned the folder): rename() fails.
    const std::string path = (dir / "out.vdb").string();
    std::string msg;
    {
        nebula::AtomicFile file(path);
        file.stream() << "data";
        fs::remove(file.tmpPath());
        msg = errorMessage([&] { file.commit(); });
    }
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "No such file")) << msg;
    EXPECT_TRUE(entries().empty());
}

TEST_F(AtomicFileTest, AFolderAsTargetIsRefused)
{
    const fs::path target = dir / "occupied";
    fs::create_directories(target / "inside");
    const std::string msg = errorMessage([&] { nebula::AtomicFile file(target.string()); });
    EXPECT_EQ(msg.rfind(target.string() + ": ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "folder")) << msg;
    EXPECT_EQ(entries(), std::vector<std::string>{"occupied"});
    EXPECT_TRUE(fs::is_directory(target / "inside"));
}

/// Files may grow to @p bytes only, as on a nearly full disk: a write beyond fails with
/// EFBIG instead of raising SIGXFSZ. Restores the limit when destroyed.
class FileSizeLimit
{
public:
    explicit FileSizeLimit(rlim_t bytes)
    {
        ::getrlimit(RLIMIT_FSIZE, &mOld);
        mOldHandler = std::signal(SIGXFSZ, SIG_IGN);
        struct rlimit lim = mOld;
        lim.rlim_cur = bytes;
        ::setrlimit(RLIMIT_FSIZE, &lim);
    }
    ~FileSizeLimit()
    {
        ::setrlimit(RLIMIT_FSIZE, &mOld);
        std::signal(SIGXFSZ, mOldHandler);
    }

private:
    struct rlimit mOld;
    void (*mOldHandler)(int);
};

TEST_F(AtomicFileTest, AFailedWriteKeepsTheOldFileAndNamesTheOsError)
{
    const std::string path = (dir / "big.vdb").string();
    write(path, "the previous output");
    std::string msg;
    {
        nebula::AtomicFile file(path);
        FileSizeLimit limit(4096);
        file.stream() << std::string(3 << 20, 'x'); // larger than the limit
        msg = errorMessage([&] { file.commit(); });
    }
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "write failed (File too large)")) << msg;
    EXPECT_EQ(read(path), "the previous output");
    EXPECT_EQ(entries(), std::vector<std::string>{"big.vdb"});
}

TEST_F(AtomicFileTest, CommitAllReplacesEveryTargetOrNone)
{
    const std::string a = (dir / "a.exr").string(), b = (dir / "a.png").string();
    write(a, "old exr");
    {
        nebula::AtomicFile fa(a), fb(b);
        fa.stream() << "new exr";
        fb.stream() << "new png";
        nebula::commitAll({&fa, &fb});
    }
    EXPECT_EQ(read(a), "new exr");
    EXPECT_EQ(read(b), "new png");
    EXPECT_EQ(entries(), (std::vector<std::string>{"a.exr", "a.png"}));

    // The second rename fails: the first target gets its old contents back, and the second,
    // which did not exist, stays absent.
    const std::string c = (dir / "c.png").string();
    std::string msg;
    {
        nebula::AtomicFile fa(a), fc(c);
        fa.stream() << "newer exr";
        fc.stream() << "newer png";
        fs::remove(fc.tmpPath());
        msg = errorMessage([&] { nebula::commitAll({&fa, &fc}); });
    }
    EXPECT_EQ(msg.rfind(c + ": ", 0), 0u) << msg;
    EXPECT_EQ(read(a), "new exr");
    EXPECT_EQ(entries(), (std::vector<std::string>{"a.exr", "a.png"}));

    // A write error in either: neither target changes.
    {
        nebula::AtomicFile fa(a), fb(b);
        FileSizeLimit limit(4096);
        fa.stream() << "small";
        fb.stream() << std::string(3 << 20, 'y');
        msg = errorMessage([&] { nebula::commitAll({&fa, &fb}); });
    }
    EXPECT_EQ(msg.rfind(b + ": ", 0), 0u) << msg;
    EXPECT_EQ(read(a), "new exr");
    EXPECT_EQ(read(b), "new png");
    EXPECT_EQ(entries(), (std::vector<std::string>{"a.exr", "a.png"}));
}

TEST_F(AtomicFileTest, TargetsThatAreNotRegularFilesAreRefusedUnlessWrittenThrough)
{
    const std::string fifo = (dir / "pipe.exr").string();
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const std::string real = (dir / "real.vdb").string(), link = (dir / "link.vdb").string();
    write(real, "old");
    fs::create_symlink(real, link);

    for (const std::string& path : {fifo, link, std::string("/dev/null")}) {
        std::string msg;
        try {
            nebula::AtomicFile file(path);
            ADD_FAILURE() << path << " accepted";
        } catch (const nebula::UsageError& e) {
            msg = e.what();
        }
        EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, "--write-through")) << msg;
    }
    EXPECT_EQ(read(real), "old");
    EXPECT_TRUE(fs::is_fifo(fifo));

    nebula::setWriteThrough(true);
    {
        // A symlink: its target is replaced atomically, the link stays a link.
        nebula::AtomicFile file(link);
        file.stream() << "through the link";
        file.commit();
    }
    EXPECT_TRUE(fs::is_symlink(link));
    EXPECT_EQ(read(real), "through the link");
    {
        // A device: written directly.
        nebula::AtomicFile file("/dev/null");
        EXPECT_TRUE(file.tmpPath().empty());
        file.stream() << "discarded";
        file.commit();
    }
    nebula::setWriteThrough(false);
    EXPECT_EQ(entries(), (std::vector<std::string>{"link.vdb", "pipe.exr", "real.vdb"}));
}

TEST_F(AtomicFileTest, ASignalRemovesTheTemporary)
{
    const std::string path = (dir / "killed.vdb").string();
    write(path, "old");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        nebula::AtomicFile file(path);
        file.stream() << "half";
        std::raise(SIGTERM);
        ::_exit(0); // not reached
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << status;
    EXPECT_EQ(read(path), "old");
    EXPECT_EQ(entries(), std::vector<std::string>{"killed.vdb"});
}

TEST_F(AtomicFileTest, TemporariesOfDeadWritersAreRemovedByTheNextRun)
{
    const std::string path = (dir / "out.exr").string();
    // A writer killed with SIGKILL: its pid is gone.
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) ::_exit(0);
    ASSERT_EQ(::waitpid(child, nullptr, 0), child);
    const std::string dead = path + ".tmp." + std::to_string(child) + ".Ab12Cd";
    write(dead, "half of a killed write");
    // A live writer (pid 1 started before its temporary was written) and another file's
    // temporary are left alone.
    const std::string live = path + ".tmp.1.Xy34Zw";
    const std::string other = (dir / "other.exr.tmp.").string() + std::to_string(child) + ".Qq11Qq";
    write(live, "in progress");
    write(other, "not ours");
    {
        nebula::AtomicFile file(path);
        file.commit();
    }
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(live));
    EXPECT_TRUE(fs::exists(other));
    EXPECT_EQ(nebula::removeStaleTemporaries(path), 0);
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
