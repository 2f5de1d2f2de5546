// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: config files (--config, TOML in CLI11's dialect) on arbitrary text, the way
// cli::run() takes them: checkConfigText() line by line, then, for text it accepts, CLI11
// parses the same text from a memory file into a tool's options (numbers with ranges, a vector,
// flags, an X,Y,Z option). Anything but a clean nebula::Error or CLI::ParseError is a finding.
#include "nebula/cli/cli.h"
#include "nebula/core/error.h"

#include <CLI/CLI.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <sys/mman.h>
#include <unistd.h>
#include <vector>

namespace {

/// A tool's options, built once (CLI11 apps are slow to build): every input clears the
/// parse results and parses again.
struct Tool
{
    CLI::App app{"nebfuzz", "nebfuzz"};
    nebula::CommonOptions common;
    int res = 16;
    double scale = 1.0;
    std::vector<std::string> lines;
    bool flag = false;
    std::array<double, 3> eye{0, 0, -5};
    int fd = -1; ///< the memory file CLI11 reads the config from, rewritten for every input

    Tool()
    {
        nebula::cli::addCommon(app, common, nebula::cli::DENSITY_GRID);
        app.add_option("--res", res)->check(nebula::cli::integerIn(8, 4096));
        app.add_option("--scale", scale)->check(nebula::cli::positive());
        app.add_option("--lines", lines);
        app.add_flag("--flag", flag);
        nebula::cli::addVec3(app, "--eye", eye, "Eye [pc]");
        nebula::cli::checkNumbers(app);
        fd = int(::memfd_create("fuzz-config", MFD_CLOEXEC));
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static Tool tool;
    const std::string text(reinterpret_cast<const char*>(data), size);
    tool.app.clear();
    try {
        nebula::cli::checkConfigText(tool.app, text, "fuzz.toml", "nebfuzz");
    } catch (const nebula::Error&) {
        return 0;
    }
    if (tool.fd < 0 || ::ftruncate(tool.fd, 0) != 0) return 0;
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::pwrite(tool.fd, text.data() + done, text.size() - done, off_t(done));
        if (n <= 0) return 0;
        done += std::size_t(n);
    }
    std::string arg0 = "nebfuzz", arg1 = "--config",
                arg2 = "/proc/self/fd/" + std::to_string(tool.fd);
    char* argv[] = {arg0.data(), arg1.data(), arg2.data()};
    tool.app.clear();
    try {
        tool.app.parse(3, argv);
    } catch (const CLI::ParseError&) {
    } catch (const nebula::Error&) {
    }
    return 0;
}
