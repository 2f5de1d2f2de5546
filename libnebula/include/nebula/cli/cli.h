#pragma once
/// @file cli.h
/// The command-line vocabulary every tool shares (docs/ARCHITECTURE.md): -i/-o with "-" for
/// stdin/stdout, --only-new, --density-grid, --threads, -q, -v, --version, --config, and
/// the run() wrapper that turns exceptions into exit codes (0 ok, 1 error, 2 usage).

#include "nebula/core/run.h"
#include "nebula/volume/volume.h"

#include <CLI/CLI.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

namespace nebula {

/// Options every tool understands; each tool picks the ones it needs via CommonFlags.
struct CommonOptions
{
    std::string input;    ///< input VDB, "-" = stdin
    std::string output;   ///< output file, "-" = stdout
    bool onlyNew = false; ///< write only this tool's own grids
    std::string densityGrid = "density";
    int threads = 0; ///< 0 = all cores
    bool quiet = false;
    int verbose = 0;
};

namespace cli {

enum CommonFlags : unsigned {
    INPUT = 1u << 0,        ///< -i/--input (required)
    OUTPUT = 1u << 1,       ///< -o/--output (required)
    PASS_THROUGH = 1u << 2, ///< --only-new
    DENSITY_GRID = 1u << 3, ///< --density-grid
};

/// Adds the common options selected by @p flags, plus --threads, -q, -v, --version and
/// --config, to @p app.
void addCommon(CLI::App& app, CommonOptions& opts, unsigned flags);

} // namespace cli

namespace cli {

/// Parses @p argv into @p app, sets up threads and the Run, calls @p body, and maps the
/// outcome to an exit code: 0 ok (also --help, --version), 2 usage error (CLI11 errors,
/// UsageError), 1 any other error, printed as "tool: error: message" on stderr.
int run(CLI::App& app, const std::string& tool, CommonOptions& opts, int argc, char** argv,
        const std::function<void(Run&)>& body);

/// The version line: "tool 0.1.0 (OpenVDB x.y.z)".
std::string versionString(const std::string& tool);

/// Parses "X,Y,Z" into three doubles; throws UsageError naming @p option otherwise.
std::array<double, 3> parseVec3(const std::string& text, const std::string& option);

/// Adds option @p name taking "X,Y,Z" (three finite numbers, parseVec3()) straight into
/// @p target, whose value is the default --help shows. A bad value is a usage error (exit 2)
/// naming the option.
CLI::Option* addVec3(CLI::App& app, const std::string& name, std::array<double, 3>& target,
                     const std::string& description);
CLI::Option* addVec3(CLI::App& app, const std::string& name, Vec3& target,
                     const std::string& description);

/// Parses "WxH" (positive integers) for @p option "--res"; throws UsageError otherwise.
void parseResolution(const std::string& text, int& width, int& height);

/// Throws UsageError("<option> needs <mode>") for the first of @p options that was given
/// while @p enabled is false (options that only mean something in a mode, e.g. --spectral).
void requireMode(const std::vector<CLI::Option*>& options, bool enabled, const std::string& mode);

} // namespace cli
} // namespace nebula
