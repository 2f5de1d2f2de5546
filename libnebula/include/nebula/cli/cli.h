// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file cli.h
/// The command-line vocabulary every tool shares (docs/ARCHITECTURE.md): -i/-o with "-" for
/// stdin/stdout, --only-new, --density-grid, --threads, -q, -v, --version, --config, and
/// the run() wrapper that turns exceptions into exit codes (0 ok, 1 error, 2 usage).

#include "nebula/core/file_format.h"
#include "nebula/core/run.h"
#include "nebula/volume/volume.h"

#include <CLI/CLI.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace nebula {

/// Options every tool understands; each tool picks the ones it needs via CommonFlags.
struct CommonOptions
{
    std::string input;    ///< input VDB, "-" = stdin
    std::string output;   ///< output file, "-" = stdout
    bool onlyNew = false; ///< write only this tool's own grids
    std::string densityGrid = "density";
    int threads = 0;           ///< 0 = all cores
    bool writeThrough = false; ///< --write-through: write FIFOs, devices, symlinks in place
    bool inPlace = false;      ///< -i X -o X may name one file (tools that pass grids through)
    bool quiet = false;
    int verbose = 0;
};

namespace cli {

/// The most --threads a tool accepts.
inline constexpr int MAX_THREADS = 4096;

enum CommonFlags : unsigned {
    INPUT = 1u << 0,        ///< -i/--input (required)
    OUTPUT = 1u << 1,       ///< -o/--output (required)
    PASS_THROUGH = 1u << 2, ///< --only-new
    DENSITY_GRID = 1u << 3, ///< --density-grid
};

/// Adds the common options selected by @p flags, plus --threads, --write-through, -q, -v,
/// --version and --config, to @p app.
void addCommon(CLI::App& app, CommonOptions& opts, unsigned flags);

} // namespace cli

namespace cli {

/// The GLIBC_TUNABLES a tool runs again with (see run()), or nullopt to run as it is: where
/// the kernel gives transparent huge pages only on request (@p thpMode, the first line of
/// /sys/kernel/mm/transparent_hugepage/enabled, selects "[madvise]") and @p tunables (the
/// variable, or null) does not name glibc.malloc.hugetlb already (the user's choice, e.g. 0),
/// @p tunables with glibc.malloc.hugetlb=1 added.
std::optional<std::string> hugePageTunables(const char* tunables, const std::string& thpMode);

/// `TOOL --man` and `TOOL --bash-completion` (alone) print the tool's man page and bash
/// completion (cli/manual.h) and return 0: the build installs them.
/// First, where hugePageTunables() says so (glibc 2.35 and later; not for --help and
/// --version, nor under AddressSanitizer), runs the program again, before reading anything,
/// with that GLIBC_TUNABLES, so that OpenVDB's trees sit on transparent huge pages (README,
/// "Rendering a fly-through on a Slurm cluster"). Then parses @p argv into @p app, checks the
/// file options (checkFileOptions()), sets up threads and the Run, calls @p body, and maps the
/// outcome to an exit code: 0 ok (also --help, --version), 2 usage error (CLI11 errors,
/// UsageError), 1 any other error, printed as "tool: error: message" on stderr.
int run(CLI::App& app, const std::string& tool, CommonOptions& opts, int argc, char** argv,
        const std::function<void(Run&)>& body);

/// Marks @p option as naming input files (-i, --stars, --phase, --camera-path, --emission,
/// --filter-file, ...): checkFileOptions() compares them with every output. Returns @p option.
CLI::Option* inputFile(CLI::Option* option);

/// Marks @p option as naming an output file of @p format (-o, --png, --fits, --sed, --json,
/// --path-out, ...): checkFileOptions() compares it with every other output and every input,
/// and checks its name's ending (checkOutputName(), core/file_format.h). nullopt: a format
/// that depends on other options (nebexport's -o), whose writer checks the name. Replaces an
/// earlier mark (addCommon() marks -o as a VDB output). Returns @p option.
CLI::Option* outputFile(CLI::Option* option, std::optional<FileFormat> format);

/// A file a tool derives from its options rather than one an option names whole: nebrender's
/// PNG next to its EXR (an output), nebimport's FILE of --emission FILE:HDU (an input).
struct ExtraFile
{
    std::string label; ///< how a message names it: "the PNG (-o's name with .png)"
    std::string path;
    bool output = false;
    std::optional<FileFormat> format; ///< an output's format (its name is checked)
};

/// One check of every file a command names, before any work (run() calls it after parsing;
/// a tool with ExtraFiles calls it again with them): the outputs (options marked with
/// outputFile(), and @p extra outputs) must be different files, none may be an input
/// (options marked with inputFile(), --config, and @p extra inputs), except -i X -o X in a tool
/// that passes its input grids through (@p opts.inPlace: the input is read completely before the
/// output replaces it), and each output's name must end as its format's names do. Same file means
/// the same existing inode (a hard or symbolic link, "./x" for "x", a folder reached two ways) or,
/// for names that do not exist yet, the same absolute, normalised name. Throws UsageError
/// naming both options.
void checkFileOptions(const CLI::App& app, const CommonOptions& opts,
                      const std::vector<ExtraFile>& extra = {});

/// Every option of @p app (and its option groups) but those named in @p skip, as (name, its
/// values as given, or "" when not given), in the order they were defined: what ranks of one
/// MPI job compare (cli/process_ranks.h).
std::vector<std::pair<std::string, std::string>> optionValues(const CLI::App& app,
                                                              const std::vector<std::string>& skip);

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

/// Parses --listen ADDR:PORT ([V6]:PORT too) into @p address and @p port; throws UsageError
/// naming the option otherwise.
void parseListen(const std::string& text, std::string& address, std::uint16_t& port);

/// Parses "WxH" (positive integers) for @p option "--res"; throws UsageError otherwise.
void parseResolution(const std::string& text, int& width, int& height);

/// The largest magnitude of a coordinate of an X,Y,Z option (addVec3, parseVec3): squares of
/// three such numbers, and of differences of two points, stay finite.
inline constexpr double MAX_VEC3_COMPONENT = 1e150;

// CLI11 checks with limits in words: a failure reads "--seed: expected an integer in [0,
// 18446744073709551615], got -1", never CLI11's 300-digit rendering of the largest double.
// The description (shown after the type in --help) is the limit, e.g. "INT:[0, 4096]".

/// A whole number written in decimal (optional sign, digits only: no "0x", no "1e3") in
/// [@p lo, @p hi]. A negative value for an unsigned option, or one that overflows, is refused
/// before CLI11 converts it (CLI11 would wrap "-1" round to the largest unsigned value).
CLI::Validator integerIn(std::int64_t lo, std::uint64_t hi);
/// "auto" or a whole number in [@p lo, @p hi] (integerIn(); the text is left as given);
/// --help shows "auto|LO..HI" (nebscatter's --field-level).
CLI::Validator autoOrIntegerIn(int lo, int hi);

/// A finite number in [@p lo, @p hi]; @p loOpen / @p hiOpen make that end open. An infinite
/// @p hi (or -infinite @p lo) is no limit: the message then says "> 0", ">= 0", ... (and
/// --help POSITIVE, NONNEGATIVE for 0, as CLI11's own checks did).
CLI::Validator numberIn(double lo, double hi, bool loOpen = false, bool hiOpen = false);
/// A finite number > 0.
CLI::Validator positive();
/// A finite number >= 0.
CLI::Validator nonNegative();
/// A finite number (not nan, inf, or out of the range of a double such as 1e999).
CLI::Validator finite();

/// What cli::run() does to every option of @p app (and its option groups) before parsing:
/// a floating-point option without a numberIn() check gets finite(); an integer option
/// without an integerIn() check gets the range of int (INT) or of std::uint64_t (UINT). So no
/// option of any tool takes nan, inf, a negative unsigned or an overflowing value.
void checkNumbers(CLI::App& app);

/// Throws UsageError if two of @p paths (option name, value) are "-": both would read stdin
/// (@p stream "stdin") or write stdout ("stdout"). Names both options.
void refuseSharedStream(const std::vector<std::pair<std::string, std::string>>& paths,
                        const std::string& stream);

/// Checks the text of config file @p path (read once by run(), readInput(): a pipe or
/// /dev/stdin as the stream it is, at most MAX_TEXT_INPUT_BYTES) for @p app before CLI11 reads
/// the same text: every line must be blank, a comment (# or ;), [default], "key = value" with
/// a key that is an option of @p app (a bare flag name also), set once, or the continuation
/// of a [multi-line, array]; a single value must pass the option's number check (integerIn(),
/// numberIn()). Throws UsageError naming the file and line ("--config: cfg.toml, line 3:
/// unknown option \"rez\" ..."); binary content is named by its first non-text byte, never
/// echoed.
void checkConfigText(CLI::App& app, const std::string& text, const std::string& path,
                     const std::string& tool);

/// Throws UsageError("<option> needs <mode>") for the first of @p options that was given
/// while @p enabled is false (options that only mean something in a mode, e.g. --spectral).
void requireMode(const std::vector<CLI::Option*>& options, bool enabled, const std::string& mode);

} // namespace cli
} // namespace nebula
