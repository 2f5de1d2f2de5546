// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file run.h
/// What a running tool knows about itself (its name, the command line for provenance, how
/// talkative to be) and progress: a bar on a terminal, lines in a log under -v. Knows nothing of
/// command-line parsing: cli/ builds a Run from the parsed options; the library only reports
/// through it.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace nebula {

/// How much a run says on stderr.
struct Verbosity
{
    bool quiet = false; ///< no progress bar, no warnings
    int verbose = 0;    ///< > 0: a line per stage (Run::info)
};

/// A tool's identity and its stderr reporting. A default-constructed Run is silent (library
/// callers such as tests and benchmarks that want no output).
class Run
{
public:
    Run() : Run("nebula", "", Verbosity{true, 0}) {}
    Run(std::string tool, std::string command, Verbosity verbosity = {});

    const std::string& tool() const { return mTool; }
    const std::string& command() const { return mCommand; }
    const Verbosity& verbosity() const { return mVerbosity; }

    /// A line on stderr under -v ("tool: message"); silent otherwise.
    void info(const std::string& message) const;
    /// A warning on stderr unless -q.
    void warn(const std::string& message) const;

    /// Whether progress bars are drawn (stderr is a TTY and not -q).
    bool showProgress() const { return mProgress; }
    /// Whether progress is written as lines instead (stderr is not a terminal: a log file, a
    /// Slurm job, CI; and -v is given, not -q).
    bool progressLines() const { return mProgressLines; }

    /// Work done under this run stops early, throwing Cancelled, once @p flag is true (null:
    /// never). The flag outlives the work; whoever sets it catches Cancelled.
    void setCancel(const std::atomic<bool>* flag) { mCancel = flag; }
    /// Whether a cancel flag is set (work then checks it often: at every row of a frame).
    bool cancellable() const { return mCancel != nullptr; }
    /// Whether the work should stop now (see setCancel()).
    bool cancelled() const { return mCancel && mCancel->load(std::memory_order_relaxed); }
    /// Throws Cancelled if cancelled().
    void checkCancel() const;

private:
    std::string mTool;
    std::string mCommand;
    Verbosity mVerbosity;
    bool mProgress = false;
    bool mProgressLines = false;
    const std::atomic<bool>* mCancel = nullptr;
};

/// " 12 s left", " 7 min left", " 3.2 h left", " 41 days left": the time a task that has run
/// @p elapsed seconds and done @p fraction of its work needs to finish at its rate so far;
/// "" until it has run 2 s (or when done). What a progress bar shows after its percentage.
std::string timeLeftText(double elapsed, double fraction);

/// A thread-safe progress bar on stderr, drawn only when the run shows progress; redrawn at
/// most 10 times a second with '\r' (with the time left, timeLeftText()), finished with a
/// newline. Where the run writes progress as lines (Run::progressLines()), a line each time
/// the work passes a multiple of 5 % or 30 s after the last line, whichever comes first
/// ("LABEL: 35 % after 12 s, 22 s left"), and one when done ("LABEL: done in 34 s"). A null
/// run draws nothing.

class Progress
{
public:
    Progress(const Run* run, std::string label, std::uint64_t total);
    Progress(const Run& run, std::string label, std::uint64_t total)
        : Progress(&run, std::move(label), total)
    {}
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;
    void add(std::uint64_t n);

private:
    void draw(bool final);
    void line(bool final);
    bool mEnabled;
    bool mLines = false;
    int mLastStep = 0; ///< lines: the last 5 % step written
    std::string mLabel;
    std::uint64_t mTotal;
    std::atomic<std::uint64_t> mDone{0};
    std::mutex mMutex;
    std::chrono::steady_clock::time_point mLast;
    std::chrono::steady_clock::time_point mStart;
};

} // namespace nebula
