// SPDX-License-Identifier: Apache-2.0
/// @file test_run.cpp
/// Run and Progress (core/run.h): what a run says on stderr under -q, by default and under
/// -v, and the progress bar, which only a run on a terminal draws.

#include "nebula/core/run.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using nebula::test::CerrCapture;

/// Points file descriptor 2 (stderr, also what fprintf(stderr) writes to) at @p fd for its
/// lifetime, flushing both sides.
class Fd2Redirect
{
public:
    explicit Fd2Redirect(int fd)
    {
        std::fflush(stderr);
        std::cerr.flush();
        mSaved = ::dup(STDERR_FILENO);
        ::dup2(fd, STDERR_FILENO);
    }
    ~Fd2Redirect()
    {
        std::fflush(stderr);
        std::cerr.flush();
        ::dup2(mSaved, STDERR_FILENO);
        ::close(mSaved);
    }
    Fd2Redirect(const Fd2Redirect&) = delete;
    Fd2Redirect& operator=(const Fd2Redirect&) = delete;

private:
    int mSaved = -1;
};

/// Everything readable from @p fd now (non-blocking).
std::string drain(int fd)
{
    std::string out;
    char buf[4096];
    for (;;) {
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, 50) <= 0 || !(p.revents & POLLIN)) break;
        const ssize_t n = ::read(fd, buf, sizeof buf);
        if (n <= 0) break;
        out.append(buf, std::size_t(n));
    }
    return out;
}

/// A pseudo-terminal: the master end to read, the slave end to stand in for stderr.
struct Pty
{
    int master = -1, slave = -1;
    Pty()
    {
        master = ::posix_openpt(O_RDWR | O_NOCTTY);
        if (master < 0 || ::grantpt(master) != 0 || ::unlockpt(master) != 0) return;
        const char* name = ::ptsname(master);
        if (name) slave = ::open(name, O_RDWR | O_NOCTTY);
    }
    ~Pty()
    {
        if (slave >= 0) ::close(slave);
        if (master >= 0) ::close(master);
    }
    bool ok() const { return master >= 0 && slave >= 0; }
};

TEST(Run, DefaultIsSilent)
{
    const nebula::Run run;
    EXPECT_EQ(run.tool(), "nebula");
    EXPECT_EQ(run.command(), "");
    EXPECT_TRUE(run.verbosity().quiet);
    EXPECT_FALSE(run.showProgress());
    CerrCapture cap;
    run.info("stage");
    run.warn("something odd");
    EXPECT_EQ(cap.text(), "");
}

TEST(Run, KeepsToolAndCommand)
{
    const nebula::Run run("nebgen", "nebgen -o x.vdb --seed 3", nebula::Verbosity{false, 2});
    EXPECT_EQ(run.tool(), "nebgen");
    EXPECT_EQ(run.command(), "nebgen -o x.vdb --seed 3");
    EXPECT_FALSE(run.verbosity().quiet);
    EXPECT_EQ(run.verbosity().verbose, 2);
}

TEST(Run, InfoOnlyUnderVerbose)
{
    {
        const nebula::Run run("nebillum", "cmd", nebula::Verbosity{false, 0});
        CerrCapture cap;
        run.info("reading");
        EXPECT_EQ(cap.text(), "");
    }
    {
        const nebula::Run run("nebillum", "cmd", nebula::Verbosity{false, 1});
        CerrCapture cap;
        run.info("reading");
        run.info("writing");
        EXPECT_EQ(cap.text(), "nebillum: reading\nnebillum: writing\n");
    }
}

TEST(Run, WarnUnlessQuiet)
{
    {
        const nebula::Run run("nebrender", "cmd", nebula::Verbosity{false, 0});
        CerrCapture cap;
        run.warn("no stars");
        EXPECT_EQ(cap.text(), "nebrender: warning: no stars\n");
    }
    {
        const nebula::Run run("nebrender", "cmd", nebula::Verbosity{true, 0});
        CerrCapture cap;
        run.warn("no stars");
        EXPECT_EQ(cap.text(), "");
    }
}

TEST(Run, NoProgressWhenQuietOrNotATerminal)
{
    EXPECT_FALSE(nebula::Run("t", "c", nebula::Verbosity{true, 0}).showProgress());
    // Not quiet: a bar exactly when stderr is a terminal.
    EXPECT_EQ(nebula::Run("t", "c", nebula::Verbosity{false, 0}).showProgress(),
              bool(::isatty(STDERR_FILENO)));
}

TEST(Run, ProgressOnATerminalDrawsAndFinishesWithANewline)
{
    Pty pty;
    if (!pty.ok()) GTEST_SKIP() << "no pseudo-terminal available";
    std::string drawn;
    {
        Fd2Redirect redirect(pty.slave);
        const nebula::Run run("t", "c", nebula::Verbosity{false, 0});
        ASSERT_TRUE(run.showProgress()); // stderr is a terminal now
        {
            nebula::Progress bar(run, "slices", 4);
            bar.add(1);
            bar.add(1);
        } // finished at 2 of 4: the final draw says 50%
        std::fflush(stderr);
        drawn = drain(pty.master);
    }
    EXPECT_EQ(drawn.rfind("\rslices [", 0), 0u) << drawn;
    EXPECT_NE(drawn.find(" 50%"), std::string::npos) << drawn;
    // 30 characters, half of them done.
    EXPECT_NE(drawn.find("[" + std::string(15, '#') + std::string(15, '.') + "]"),
              std::string::npos)
        << drawn;
    EXPECT_EQ(drawn.back(), '\n') << drawn;

    // A quiet run on the same terminal draws nothing.
    {
        Fd2Redirect redirect(pty.slave);
        const nebula::Run quiet("t", "c", nebula::Verbosity{true, 0});
        EXPECT_FALSE(quiet.showProgress());
        {
            nebula::Progress bar(quiet, "slices", 4);
            bar.add(4);
        }
        std::fflush(stderr);
        EXPECT_EQ(drain(pty.master), "");
    }
}

TEST(Run, ProgressOnANullRunDoesNothingAndCounts)
{
    // Even with stderr a terminal (where a real run would draw), a null run draws nothing;
    // add() from many threads is safe.
    Pty pty;
    const bool terminal = pty.ok();
    std::FILE* tmp = terminal ? nullptr : std::tmpfile();
    const int fd = terminal ? pty.slave : ::fileno(tmp);
    {
        Fd2Redirect redirect(fd);
        {
            nebula::Progress bar(nullptr, "nothing", 1000);
            std::vector<std::thread> threads;
            for (int t = 0; t < 4; ++t) {
                threads.emplace_back([&] {
                    for (int i = 0; i < 250; ++i)
                        bar.add(1);
                });
            }
            for (auto& th : threads)
                th.join();
        }
        // A zero total draws nothing either, whatever the run.
        const nebula::Run run("t", "c", nebula::Verbosity{false, 0});
        {
            nebula::Progress empty(run, "empty", 0);
            empty.add(3);
        }
        std::fflush(stderr);
    }
    if (terminal) {
        EXPECT_EQ(drain(pty.master), "");
    } else {
        std::fflush(tmp);
        EXPECT_EQ(std::ftell(tmp), 0L);
        std::fclose(tmp);
    }
}

} // namespace

// The time left a progress bar shows: the rate so far extrapolated, in the unit that reads
// best; nothing before 2 s of work (no rate yet) or when done.
TEST(Run, TimeLeftIsExtrapolatedFromTheRateSoFar)
{
    EXPECT_EQ(nebula::timeLeftText(1.0, 0.5), "");
    EXPECT_EQ(nebula::timeLeftText(10.0, 0.0), "");
    EXPECT_EQ(nebula::timeLeftText(10.0, 1.0), "");
    EXPECT_EQ(nebula::timeLeftText(10.0, 0.25), " 30 s left");
    EXPECT_EQ(nebula::timeLeftText(60.0, 0.2), " 4 min left");
    EXPECT_EQ(nebula::timeLeftText(3600.0, 0.25), " 3.0 h left");
    // 2^40 packets at a million per 15 s: what the bound on --packets prevents.
    EXPECT_EQ(nebula::timeLeftText(15.0, 1e6 / 1099511627776.0), " 191 days left");
}
