// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/run.h"

#include "nebula/core/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <iostream>

#include <unistd.h>

namespace nebula {

Run::Run(std::string tool, std::string command, Verbosity verbosity)
    : mTool(std::move(tool)), mCommand(std::move(command)), mVerbosity(verbosity)
{
    mProgress = !verbosity.quiet && ::isatty(STDERR_FILENO);
    mProgressLines = !verbosity.quiet && !mProgress && verbosity.verbose > 0;
}

void Run::info(const std::string& message) const
{
    if (mVerbosity.verbose > 0 && !mVerbosity.quiet) std::cerr << mTool << ": " << message << "\n";
}

void Run::warn(const std::string& message) const
{
    if (!mVerbosity.quiet) std::cerr << mTool << ": warning: " << message << "\n";
}

void Run::checkCancel() const
{
    if (cancelled()) throw Cancelled();
}

Progress::Progress(const Run* run, std::string label, std::uint64_t total)
    : mEnabled(run && (run->showProgress() || run->progressLines()) && total > 0),
      mLines(run && !run->showProgress()), mLabel(std::move(label)), mTotal(total),
      mLast(std::chrono::steady_clock::now()), mStart(mLast)
{}

Progress::~Progress()
{
    if (!mEnabled) return;
    if (mLines) {
        line(true);
    } else {
        draw(true);
    }
}

void Progress::add(std::uint64_t n)
{
    mDone += n;
    if (!mEnabled) return;
    // Only one thread draws, and at most every 100 ms; the others just count.
    std::unique_lock<std::mutex> lock(mMutex, std::try_to_lock);
    if (!lock.owns_lock()) return;
    if (mLines) {
        line(false);
        return;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - mLast < std::chrono::milliseconds(100)) return;
    mLast = now;
    draw(false);
}

std::string timeLeftText(double elapsed, double fraction)
{
    if (!(fraction > 0.0 && fraction < 1.0) || !(elapsed > 2.0)) return "";
    const double left = elapsed * (1.0 - fraction) / fraction;
    return left < 120.0      ? fmt::format(" {:.0f} s left", left)
           : left < 7200.0   ? fmt::format(" {:.0f} min left", left / 60.0)
           : left < 172800.0 ? fmt::format(" {:.1f} h left", left / 3600.0)
                             : fmt::format(" {:.0f} days left", left / 86400.0);
}

void Progress::line(bool final)
{
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - mStart).count();
    if (final) {
        std::fprintf(stderr, "%s: done in %.0f s\n", mLabel.c_str(), elapsed);
        std::fflush(stderr);
        return;
    }
    const double f = std::min(1.0, double(mDone.load()) / double(mTotal));
    const int step = int(f * 20.0); // 5 % steps
    if (step <= mLastStep && now - mLast < std::chrono::seconds(30)) return;
    if (step >= 20) return; // the final line says it
    mLastStep = std::max(mLastStep, step);
    mLast = now;
    std::string left = timeLeftText(elapsed, f);
    if (!left.empty()) left = "," + left;
    std::fprintf(stderr, "%s: %.0f %% after %.0f s%s\n", mLabel.c_str(), 100.0 * f, elapsed,
                 left.c_str());
    std::fflush(stderr);
}

void Progress::draw(bool final)
{
    const double f = std::min(1.0, double(mDone.load()) / double(mTotal));
    const int width = 30;
    const int filled = int(f * width + 0.5);
    std::string bar(std::size_t(filled), '#');
    bar.resize(std::size_t(width), '.');
    // The time left, once there is enough of a rate to tell it.
    std::string eta =
        final
            ? std::string()
            : timeLeftText(
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - mStart).count(),
                  f);
    eta.resize(std::max<std::size_t>(eta.size(), 16), ' ');
    std::fprintf(stderr, "\r%s [%s] %3d%%%s%s", mLabel.c_str(), bar.c_str(), int(f * 100 + 0.5),
                 final ? "" : eta.c_str(), final ? "                \n" : "");
    std::fflush(stderr);
}

} // namespace nebula
