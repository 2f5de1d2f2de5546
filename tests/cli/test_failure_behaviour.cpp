// SPDX-License-Identifier: Apache-2.0
// README "Failure behaviour", end to end: a full disk (a small tmpfs the test mounts), outputs
// that are not regular files or that name an input, temporaries of killed writers, truncated
// files and streams, and stars far from the cloud.
#include "cli_fixture.h"

#include "nebula/core/atomic_file.h"

#include <sys/mount.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>

namespace nebula::clitest {
namespace {

std::string readBytes(const std::string& p)
{
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A 2 MiB tmpfs at <test folder>/full, filled up after the files a test puts there.
class FullDisk : public Cli
{
protected:
    void SetUp() override
    {
        Cli::SetUp();
        full = path("full");
        fs::create_directories(full);
        if (::mount("tmpfs", full.c_str(), "tmpfs", 0, "size=2m") != 0) {
            mounted = false;
            GTEST_SKIP() << "cannot mount a tmpfs at " << full << " (" << std::strerror(errno)
                         << "): the full-disk tests need root or CAP_SYS_ADMIN";
        }
        mounted = true;
    }
    void TearDown() override
    {
        if (mounted) ::umount2(full.c_str(), MNT_DETACH);
        Cli::TearDown();
    }
    /// Fills the tmpfs to the last page.
    void fill()
    {
        run("dd if=/dev/zero of=full/fill1 bs=64k 2>/dev/null; "
            "dd if=/dev/zero of=full/fill2 bs=4k 2>/dev/null; "
            "dd if=/dev/zero of=full/fill3 bs=1 2>/dev/null; true");
    }
    /// Runs @p cmd on the full disk: exit 1 naming the OS error, and every file in full/ as it
    /// was (no temporary, the old outputs intact).
    void expectDiskFull(const std::string& cmd)
    {
        std::map<std::string, std::string> before;
        for (const auto& e : fs::directory_iterator(full))
            before[e.path().filename()] = readBytes(e.path());
        const Result r = run(cmd);
        EXPECT_EQ(r.code, 1) << cmd << "\n" << r.err;
        EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << cmd << "\n" << r.err;
        std::map<std::string, std::string> after;
        for (const auto& e : fs::directory_iterator(full))
            after[e.path().filename()] = readBytes(e.path());
        EXPECT_EQ(after.size(), before.size()) << cmd;
        for (const auto& [name, bytes] : before)
            EXPECT_TRUE(after[name] == bytes) << cmd << ": " << name << " changed";
    }

    std::string full;
    bool mounted = false;
};

TEST_F(FullDisk, EveryToolKeepsTheOldFileAndExits1)
{
    makeLit();
    // Old outputs, and an input edited in place, on the small disk.
    ASSERT_EQ(run("cp small.vdb full/in.vdb && cp lit.vdb full/out.vdb && "
                  "echo old-exr > full/out.exr && echo old-png > full/out.png && "
                  "echo old-json > full/table.json")
                  .code,
              0);
    fill();
    expectDiskFull("nebgen --res 24 --seed 3 -o full/out.vdb");
    expectDiskFull("nebillum -i full/in.vdb -o full/in.vdb"); // in place: the input survives
    expectDiskFull("nebpyramid -i lit.vdb -o full/out.vdb --levels 2");
    expectDiskFull("nebphase --t-count 4 --mu-bins 16 --photons 2048 --max-photons 8192 "
                   "-o full/out.vdb --json full/table.json");
    expectDiskFull("nebrender -i lit.vdb --res 32x32 -o full/out.exr");
    // The EXR fits but the PNG does not: neither is replaced.
    ASSERT_EQ(run("rm full/fill3 full/fill2").code, 0); // a few pages free
    const Result r = run("nebrender -i lit.vdb --res 8x8 -o full/out.exr --png full/out.png");
    if (r.code == 1) {
        EXPECT_EQ(readBytes(full + "/out.exr"), "old-exr\n");
        EXPECT_EQ(readBytes(full + "/out.png"), "old-png\n");
    }
}

TEST_F(Cli, OutputsThatAreNotRegularFilesOrNameAnInputAreRefused)
{
    makeLit();
    ASSERT_EQ(run("mkfifo fifo.exr && ln -s lit.vdb link.vdb").code, 0);
    expectFailure("nebrender -i lit.vdb --res 8x8 -o fifo.exr --no-png", 2, "--write-through");
    expectFailure("nebillum -i small.vdb -o link.vdb", 2, "symbolic link");
    expectFailure("nebrender -i lit.vdb --res 8x8 -o a.exr --png a.exr", 2, "same file");
    expectFailure("nebrender -i lit.vdb --res 8x8 -o a.exr --png lit.vdb", 2,
                  "would destroy the input");
    expectFailure("nebrender -i lit.vdb --res 8x8 -o a.exr --png ./a.exr", 2, "same file");
    std::ofstream(path("stars.json"))
        << R"([{"name": "a", "position": [0, 0, 0], "luminosity": 10, "temperature": 9000}])";
    expectFailure("nebillum -i small.vdb -o stars.json --stars stars.json", 2, "is the input");
    // In place is fine where the input is passed through; the input was read completely first.
    EXPECT_EQ(run("cp small.vdb inplace.vdb && nebillum -i inplace.vdb -o inplace.vdb").code, 0);
    EXPECT_TRUE(read(path("inplace.vdb")).find("density"));

    // --write-through writes a FIFO in place (a reader copies it) and a symlink's target.
    const Result r = run("mkfifo pipe.vdb && { cat pipe.vdb > copy.vdb & } && "
                         "nebillum -i small.vdb -o pipe.vdb --write-through && wait");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_GT(read(path("copy.vdb")).grids.size(), 1u); // density and the tau grids
    EXPECT_EQ(run("nebillum -i small.vdb -o link.vdb --write-through").code, 0);
    EXPECT_TRUE(fs::is_symlink(path("link.vdb")));
}

TEST_F(Cli, TemporariesOfAKilledWriterAreRemovedByTheNextRun)
{
    makeLit();
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) ::_exit(0);
    ::waitpid(child, nullptr, 0);
    const std::string stale = "out.vdb.tmp." + std::to_string(child) + ".k1LLed";
    std::ofstream(path(stale)) << "what a SIGKILL left";
    ASSERT_EQ(run("nebillum -i small.vdb -o out.vdb").code, 0);
    EXPECT_FALSE(fs::exists(path(stale)));
}

TEST_F(Cli, TruncatedFilesAndStreamsAreRefused)
{
    makeLit();
    const std::string bytes = readBytes(path("lit.vdb"));
    for (const std::size_t size : {std::size_t(10), std::size_t(100), bytes.size() / 2,
                                   bytes.size() - 32, bytes.size() - 17, bytes.size() - 1}) {
        std::ofstream(path("cut.vdb"), std::ios::binary) << bytes.substr(0, size);
        const std::string n = std::to_string(size);
        expectFailure("nebrender -i cut.vdb --res 8x8 -o a.exr", 1, "cut.vdb: truncated");
        expectFailure("head -c " + n + " lit.vdb | nebillum -i - -o b.vdb", 1,
                      "<stdin>: truncated");
    }
    // The whole file still reads, from a file and a pipe.
    EXPECT_EQ(run("cat lit.vdb | nebillum -i - -o c.vdb").code, 0);
}

TEST_F(Cli, FarStarsGiveTheSameTauAsNearOnesInTheirDirection)
{
    ASSERT_EQ(run("nebgen --res 24 --seed 3 -o small.vdb").code, 0);
    // From 1e5 pc on, the rays from a star on the +x axis are parallel to within 1e-4, so
    // tau barely changes with distance; before rays were clipped, 1e9 gave tau = 0 everywhere
    // and 1e20 crashed.
    std::vector<double> maxTau;
    for (const char* x : {"1e5", "1e9", "1e20", "1e100"}) {
        const std::string out = std::string("far") + x + ".vdb";
        const Result r =
            run(std::string("nebillum -i small.vdb --star far:") + x + ",0,0:100:9000 -o " + out);
        ASSERT_EQ(r.code, 0) << x << ": " << r.err;
        const auto grid = read(path(out)).floatGrid("tau.far", "");
        double m = 0.0;
        for (auto it = grid->cbeginValueOn(); it; ++it) {
            ASSERT_TRUE(std::isfinite(*it));
            m = std::max(m, double(*it));
        }
        maxTau.push_back(m);
    }
    ASSERT_GT(maxTau[0], 0.1);
    for (double m : maxTau)
        EXPECT_NEAR(m, maxTau[0], 1e-3 * maxTau[0]);
}

} // namespace
} // namespace nebula::clitest
