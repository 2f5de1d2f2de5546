// SPDX-License-Identifier: Apache-2.0
/// @file test_cli.cpp
/// cli/cli.h: the options every tool shares (addCommon), cli::run's exit codes (0 ok, 1 an
/// error, 2 a usage error) and its "tool: error: " messages, the version line, and the
/// option parsers parseVec3, parseResolution and requireMode.

#include "nebula/cli/cli.h"

#include "nebula/core/error.h"
#include "nebula/core/version.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <iostream>
#include <new>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

/// Captures std::cout and std::cerr (rdbuf swap) for its lifetime.
class Capture
{
public:
    Capture() : mOut(std::cout.rdbuf(mOutBuf.rdbuf())), mErr(std::cerr.rdbuf(mErrBuf.rdbuf())) {}
    ~Capture()
    {
        std::cout.rdbuf(mOut);
        std::cerr.rdbuf(mErr);
    }
    Capture(const Capture&) = delete;
    Capture& operator=(const Capture&) = delete;
    std::string out() const { return mOutBuf.str(); }
    std::string err() const { return mErrBuf.str(); }

private:
    std::ostringstream mOutBuf, mErrBuf;
    std::streambuf* mOut;
    std::streambuf* mErr;
};

/// What one cli::run() call did.
struct Outcome
{
    int code = -1;
    bool bodyRan = false;
    std::string out, err;
    std::string tool, command;
    nebula::Verbosity verbosity;
    nebula::CommonOptions opts;
};

/// Runs cli::run() for tool "nebtest" with common options @p flags (and whatever @p setup
/// adds) on the arguments @p args (argv[0] is "nebtest"), calling @p body inside.
Outcome runTool(unsigned flags, std::initializer_list<std::string> args,
                const std::function<void(nebula::Run&)>& body = {},
                const std::function<void(CLI::App&)>& setup = {})
{
    CLI::App app("test tool", "nebtest");
    Outcome o;
    nebula::cli::addCommon(app, o.opts, flags);
    if (setup) setup(app);
    std::vector<std::string> storage = {"nebtest"};
    storage.insert(storage.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& s : storage)
        argv.push_back(s.data());
    argv.push_back(nullptr);
    Capture cap;
    o.code = nebula::cli::run(app, "nebtest", o.opts, int(storage.size()), argv.data(),
                              [&](nebula::Run& run) {
                                  o.bodyRan = true;
                                  o.tool = run.tool();
                                  o.command = run.command();
                                  o.verbosity = run.verbosity();
                                  if (body) body(run);
                              });
    o.out = cap.out();
    o.err = cap.err();
    return o;
}

constexpr unsigned ALL = nebula::cli::INPUT | nebula::cli::OUTPUT | nebula::cli::PASS_THROUGH |
                         nebula::cli::DENSITY_GRID;

// ---- cli::run --------------------------------------------------------------------------------

TEST(CliRun, SuccessIsZeroAndTheBodySeesTheRun)
{
    const Outcome o = runTool(ALL, {"-i", "in.vdb", "-o", "out.vdb", "--only-new", "--density-grid",
                                    "dust", "--threads", "2", "-v", "-v"});
    EXPECT_EQ(o.code, 0) << o.err;
    EXPECT_TRUE(o.bodyRan);
    EXPECT_EQ(o.err, "");
    EXPECT_EQ(o.opts.input, "in.vdb");
    EXPECT_EQ(o.opts.output, "out.vdb");
    EXPECT_TRUE(o.opts.onlyNew);
    EXPECT_EQ(o.opts.densityGrid, "dust");
    EXPECT_EQ(o.opts.threads, 2);
    EXPECT_EQ(o.tool, "nebtest");
    EXPECT_FALSE(o.verbosity.quiet);
    EXPECT_EQ(o.verbosity.verbose, 2); // -v counts
    // The command line, for provenance: every argument, in order.
    EXPECT_EQ(o.command,
              "nebtest -i in.vdb -o out.vdb --only-new --density-grid dust --threads 2 -v -v");
}

TEST(CliRun, DefaultsAndQuiet)
{
    const Outcome o = runTool(ALL, {"-i", "a", "-o", "b.vdb", "-q"});
    EXPECT_EQ(o.code, 0) << o.err;
    EXPECT_EQ(o.opts.densityGrid, "density");
    EXPECT_EQ(o.opts.threads, 0);
    EXPECT_FALSE(o.opts.onlyNew);
    EXPECT_TRUE(o.verbosity.quiet);
    EXPECT_EQ(o.verbosity.verbose, 0);
}

TEST(CliRun, CommandQuotesArgumentsAShellWouldSplit)
{
    const Outcome o = runTool(ALL, {"-i", "my cloud.vdb", "-o", "it's.vdb"});
    EXPECT_EQ(o.code, 0) << o.err;
    EXPECT_EQ(o.opts.input, "my cloud.vdb");
    EXPECT_TRUE(contains(o.command, "'my cloud.vdb'")) << o.command;
    EXPECT_TRUE(contains(o.command, "'it'\\''s.vdb'")) << o.command;
}

TEST(CliRun, UsageErrorsAreTwo)
{
    const auto check = [](const Outcome& o, const std::string& what) {
        EXPECT_EQ(o.code, 2) << what << ": " << o.err;
        EXPECT_FALSE(o.bodyRan) << what;
        EXPECT_EQ(o.err.rfind("nebtest: error: ", 0), 0u) << what << ": " << o.err;
        EXPECT_TRUE(contains(o.err, "nebtest --help")) << what << ": " << o.err;
    };
    check(runTool(ALL, {"-i", "a", "-o", "b.vdb", "--no-such-option"}), "unknown option");
    check(runTool(ALL, {"-o", "b.vdb"}), "missing required -i");
    check(runTool(ALL, {"-i", "a"}), "missing required -o");
    check(runTool(ALL, {"-i", "a", "-o", "b.vdb", "--threads", "-1"}), "negative --threads");
    check(runTool(ALL, {"-i", "a", "-o", "b.vdb", "--threads", "many"}), "non-numeric --threads");
    check(runTool(ALL, {"-i", "a", "-o", "b.vdb", "stray"}), "positional argument");
    // Options a tool did not ask for do not exist.
    check(runTool(0, {"-i", "a"}), "-i without INPUT");
    check(runTool(nebula::cli::INPUT, {"-i", "a", "--density-grid", "d"}),
          "--density-grid without DENSITY_GRID");
    check(runTool(nebula::cli::INPUT, {"-i", "a", "--only-new"}),
          "--only-new without PASS_THROUGH");
    // The message names the offending option.
    const Outcome o = runTool(ALL, {"-i", "a", "-o", "b.vdb", "--frobnicate"});
    EXPECT_TRUE(contains(o.err, "--frobnicate")) << o.err;
}

TEST(CliRun, FlagValuesCli11CannotCountAreUsageErrors)
{
    // CLI11 reads a flag's value with std::stoll, which threw past its parser (an abort) on
    // "abc" and past 19 digits, from the command line or a config file (found by fuzz_config).
    for (const std::string bad : {"--verbose=88888888888888888888888", "--verbose=abc",
                                  "--quiet=1234567890", "--write-through=888\xb9"}) {
        const Outcome o = runTool(ALL, {"-i", "a", "-o", "b.vdb", bad});
        EXPECT_EQ(o.code, 2) << bad << ": " << o.err;
        EXPECT_FALSE(o.bodyRan) << bad;
        EXPECT_TRUE(contains(o.err, "expected true, false or a count of at most 9 digits"))
            << bad << ": " << o.err;
    }
    for (const std::string good :
         {"--verbose=2", "-vv", "--quiet=true", "--write-through=off", "--verbose=123456789"}) {
        const Outcome o = runTool(ALL, {"-i", "a", "-o", "b.vdb", good});
        EXPECT_EQ(o.code, 0) << good << ": " << o.err;
        EXPECT_TRUE(o.bodyRan) << good;
    }
}

TEST(CliRun, ErrorsThrownByTheBody)
{
    // nebula::Error: 1, "tool: error: message".
    Outcome o = runTool(ALL, {"-i", "a", "-o", "b.vdb"},
                        [](nebula::Run&) { throw nebula::Error("cloud.vdb: no grid \"x\""); });
    EXPECT_TRUE(o.bodyRan);
    EXPECT_EQ(o.code, 1);
    EXPECT_EQ(o.err, "nebtest: error: cloud.vdb: no grid \"x\"\n");

    // nebula::UsageError: 2.
    o = runTool(ALL, {"-i", "a", "-o", "b.vdb"},
                [](nebula::Run&) { throw nebula::UsageError("--res must be in [2, 2048]"); });
    EXPECT_EQ(o.code, 2);
    EXPECT_EQ(o.err, "nebtest: error: --res must be in [2, 2048]\n");

    // Any other exception: 1.
    o = runTool(ALL, {"-i", "a", "-o", "b.vdb"},
                [](nebula::Run&) { throw std::runtime_error("out of luck"); });
    EXPECT_EQ(o.code, 1);
    EXPECT_EQ(o.err, "nebtest: error: out of luck\n");
}

TEST(CliRun, HelpAndVersionAreZeroOnStdout)
{
    Outcome o = runTool(ALL, {"--version"});
    EXPECT_EQ(o.code, 0);
    EXPECT_FALSE(o.bodyRan);
    EXPECT_TRUE(contains(o.out, nebula::cli::versionString("nebtest"))) << o.out;
    EXPECT_EQ(o.err, "");

    o = runTool(ALL, {"--help"});
    EXPECT_EQ(o.code, 0);
    EXPECT_FALSE(o.bodyRan);
    for (const char* option : {"--input", "--output", "--only-new", "--density-grid", "--threads",
                               "--quiet", "--verbose", "--version", "--config"}) {
        EXPECT_TRUE(contains(o.out, option)) << option << "\n" << o.out;
    }
}

TEST(CliRun, ConfigFile)
{
    std::random_device rd;
    const fs::path dir = fs::temp_directory_path() /
                         ("nebula_cli_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    fs::create_directories(dir);
    const std::string good = (dir / "good.toml").string(), bad = (dir / "bad.toml").string();
    std::ofstream(good) << "threads = 3\ndensity-grid = \"n_H\"\n";
    std::ofstream(bad) << "threads = 3\nthreadz = 4\n";

    Outcome o = runTool(ALL, {"-i", "a", "-o", "b.vdb", "--config", good});
    EXPECT_EQ(o.code, 0) << o.err;
    EXPECT_EQ(o.opts.threads, 3);
    EXPECT_EQ(o.opts.densityGrid, "n_H");

    // A misspelt key is an error, as a misspelt option is, and says where it came from.
    o = runTool(ALL, {"-i", "a", "-o", "b.vdb", "--config", bad});
    EXPECT_EQ(o.code, 2) << o.err;
    EXPECT_FALSE(o.bodyRan);
    EXPECT_EQ(o.err.rfind("nebtest: error: --config: ", 0), 0u) << o.err;
    EXPECT_TRUE(contains(o.err, "threadz")) << o.err;

    std::error_code ec;
    fs::remove_all(dir, ec);
}

TEST(Cli, VersionString)
{
    const std::string v = nebula::cli::versionString("nebrender");
    EXPECT_EQ(v.rfind(std::string("nebrender ") + NEBULA_VERSION_STRING + " (OpenVDB ", 0), 0u)
        << v;
    EXPECT_EQ(v.back(), ')');
}

// ---- option parsers --------------------------------------------------------------------------

TEST(Cli, ParseVec3)
{
    EXPECT_EQ(nebula::cli::parseVec3("1,2,3", "--eye"), (std::array<double, 3>{1, 2, 3}));
    EXPECT_EQ(nebula::cli::parseVec3("-0.5,1e3,+2.25", "--eye"),
              (std::array<double, 3>{-0.5, 1000.0, 2.25}));
    for (const char* bad : {"", "1,2", "1,2,3,4", "1,2,", ",1,2", "1,,3", "a,b,c", "1,2,3x",
                            "1;2;3", "1,2,nan", "1,2,inf", "1,2,1e999", "1 2 3"}) {
        const std::string msg = errorMessage([&] { nebula::cli::parseVec3(bad, "--look-at"); });
        EXPECT_EQ(msg, "--look-at \"" + std::string(bad) + "\": expected X,Y,Z (three numbers)")
            << bad;
        EXPECT_THROW(nebula::cli::parseVec3(bad, "--look-at"), nebula::UsageError) << bad;
    }
}

TEST(Cli, ParseResolution)
{
    int w = 0, h = 0;
    nebula::cli::parseResolution("640x480", w, h);
    EXPECT_EQ(w, 640);
    EXPECT_EQ(h, 480);
    nebula::cli::parseResolution("1x1", w, h);
    EXPECT_EQ(w, 1);
    EXPECT_EQ(h, 1);
    for (const char* bad : {"", "640", "640x", "x480", "0x10", "10x0", "-5x5", "5x-5", "1.5x2",
                            "10x10x", "10X10", "axb", "99999999999x1"}) {
        w = h = 7;
        const std::string msg = errorMessage([&] { nebula::cli::parseResolution(bad, w, h); });
        EXPECT_EQ(msg.rfind("--res \"" + std::string(bad) + "\": ", 0), 0u) << bad << ": " << msg;
        EXPECT_THROW(nebula::cli::parseResolution(bad, w, h), nebula::UsageError) << bad;
        EXPECT_EQ(w, 7) << bad; // untouched on error
        EXPECT_EQ(h, 7) << bad;
    }
}

TEST(Cli, RequireMode)
{
    CLI::App app("t", "t");
    int bands = 0;
    double step = 0;
    bool spectral = false;
    auto* b = app.add_option("--bands", bands);
    auto* s = app.add_option("--continuum-step", step);
    app.add_flag("--spectral", spectral);
    const auto parse = [&](std::vector<std::string> args) {
        spectral = false; // CLI11 writes only the options given
        app.clear();
        std::reverse(args.begin(), args.end()); // CLI11 takes a reversed vector
        app.parse(args);
    };

    // Neither given: fine in either mode.
    parse({});
    EXPECT_NO_THROW(nebula::cli::requireMode({b, s}, false, "--spectral"));
    // Given in the mode: fine.
    parse({"--spectral", "--bands", "8"});
    EXPECT_NO_THROW(nebula::cli::requireMode({b, s}, spectral, "--spectral"));
    // Given without the mode: a usage error naming the first such option and the mode.
    parse({"--continuum-step", "5", "--bands", "8"});
    EXPECT_FALSE(spectral);
    EXPECT_EQ(errorMessage([&] {
                  nebula::cli::requireMode({b, s}, spectral, "--spectral");
              }),
              "--bands needs --spectral");
    EXPECT_THROW(nebula::cli::requireMode({b, s}, spectral, "--spectral"), nebula::UsageError);
    parse({"--continuum-step", "5"});
    EXPECT_EQ(errorMessage([&] {
                  nebula::cli::requireMode({b, s}, false, "--spectral");
              }),
              "--continuum-step needs --spectral");
}

} // namespace

// addVec3: "X,Y,Z" straight into the target at parse time, its value the default --help
// shows; a bad value is a usage error (exit 2) naming the option, and the body never runs.
TEST(Cli, AddVec3ParsesIntoTheTargetOrRefuses)
{
    const auto runWith = [](std::initializer_list<std::string> args, std::array<double, 3>& a,
                            nebula::Vec3& v, std::string* help = nullptr) {
        const Outcome o = runTool(0, args, {}, [&](CLI::App& app) {
            nebula::cli::addVec3(app, "--axis", a, "An axis");
            nebula::cli::addVec3(app, "--eye", v, "An eye [pc]");
            if (help) *help = app.help();
        });
        return std::make_tuple(o.code, o.bodyRan, o.err);
    };
    std::array<double, 3> a{0, 1, 0};
    nebula::Vec3 v(4, 3, -19);
    std::string help;
    auto [code, ran, err] = runWith({}, a, v, &help);
    EXPECT_EQ(code, 0);
    EXPECT_NE(help.find("--axis X,Y,Z=0,1,0"), std::string::npos) << help;
    EXPECT_NE(help.find("--eye X,Y,Z=4,3,-19"), std::string::npos) << help;
    std::tie(code, ran, err) = runWith({"--axis", "1,-2.5,1e3", "--eye", "0,0,-25"}, a, v);
    EXPECT_EQ(code, 0) << err;
    EXPECT_EQ(a, (std::array<double, 3>{1, -2.5, 1000}));
    EXPECT_EQ(v.z, -25.0);
    for (const char* bad : {"1,2", "1,2,nan", "a,b,c", "1,2,3,4"}) {
        std::tie(code, ran, err) = runWith({"--eye", bad}, a, v);
        EXPECT_EQ(code, 2) << bad;
        EXPECT_FALSE(ran) << bad;
        EXPECT_EQ(err.rfind("nebtest: error: --eye \"" + std::string(bad) +
                                "\": expected X,Y,Z (three numbers)",
                            0),
                  0u)
            << err;
    }
}

// ---- number checks, shared streams, config files ----------------------------------------------

namespace {

/// The message of @p check on @p text ("" if it passes), and the text as it leaves the check.
std::pair<std::string, std::string> checked(const CLI::Validator& check, std::string text)
{
    const std::string error = check(text);
    return {error, text};
}

} // namespace

// integerIn: decimal integers in a range, named in the message; no sign for an unsigned
// range, no overflow, no "0x" or "1e3", and "010" is ten (CLI11 alone would read eight).
TEST(CliChecks, IntegerIn)
{
    const auto seed = nebula::cli::integerIn(0, UINT64_MAX);
    EXPECT_EQ(seed.get_description(), "[0, 18446744073709551615]");
    EXPECT_EQ(checked(seed, "18446744073709551615"),
              std::make_pair(std::string(), std::string("18446744073709551615")));
    EXPECT_EQ(checked(seed, "010").second, "10");
    EXPECT_EQ(checked(seed, "+7").second, "7");
    for (const char* bad : {"-1", "18446744073709551616", "99999999999999999999", "0x10", "1e3",
                            "1.0", "", "-", "+", " 1", "1 ", "one"}) {
        EXPECT_EQ(checked(seed, bad).first,
                  "expected an integer in [0, 18446744073709551615], got " + std::string(bad))
            << bad;
    }
    const auto levels = nebula::cli::integerIn(-3, 16);
    EXPECT_EQ(checked(levels, "-3").first, "");
    EXPECT_EQ(checked(levels, "-0").second, "0");
    EXPECT_EQ(checked(levels, "-4").first, "expected an integer in [-3, 16], got -4");
    EXPECT_EQ(checked(levels, "17").first, "expected an integer in [-3, 16], got 17");
    const auto res = nebula::cli::integerIn(2, 2048);
    EXPECT_EQ(checked(res, "1").first, "expected an integer in [2, 2048], got 1");
    EXPECT_EQ(checked(res, "-0").first, "expected an integer in [2, 2048], got -0");
    const auto wide = nebula::cli::integerIn(INT64_MIN, INT64_MAX);
    EXPECT_EQ(checked(wide, "-9223372036854775808").first, "");
    EXPECT_NE(checked(wide, "-9223372036854775809").first, "");
    // Bytes that are not text are shown escaped.
    EXPECT_EQ(checked(res, std::string("1\x01\xff", 3)).first,
              "expected an integer in [2, 2048], got 1\\x01\\xFF");
}

// numberIn and friends: finite numbers in a range written as people write it.
TEST(CliChecks, NumberIn)
{
    EXPECT_EQ(nebula::cli::positive().get_description(), "POSITIVE");
    EXPECT_EQ(nebula::cli::nonNegative().get_description(), "NONNEGATIVE");
    EXPECT_EQ(nebula::cli::numberIn(1, INFINITY, true).get_description(), "> 1");
    EXPECT_EQ(nebula::cli::finite().get_description(), "");
    EXPECT_EQ(nebula::cli::numberIn(0.01, 179).get_description(), "[0.01, 179]");
    EXPECT_EQ(nebula::cli::numberIn(-1, 1, true, true).get_description(), "(-1, 1)");
    EXPECT_EQ(nebula::cli::numberIn(0, 1, true).get_description(), "(0, 1]");

    EXPECT_EQ(checked(nebula::cli::positive(), "0").first, "expected a finite number > 0, got 0");
    EXPECT_EQ(checked(nebula::cli::positive(), "1e-300").first, "");
    EXPECT_EQ(checked(nebula::cli::nonNegative(), "-1").first,
              "expected a finite number >= 0, got -1");
    EXPECT_EQ(checked(nebula::cli::numberIn(0.01, 179), "180").first,
              "expected a number in [0.01, 179], got 180");
    EXPECT_EQ(checked(nebula::cli::numberIn(-1, 1, true, true), "1").first,
              "expected a number in (-1, 1), got 1");
    EXPECT_EQ(checked(nebula::cli::numberIn(-1, 1, true, true), "-0.999").first, "");
    for (const char* bad :
         {"nan", "NaN", "inf", "-inf", "infinity", "1e999", "-1e999", "", "1x", "one"}) {
        EXPECT_EQ(checked(nebula::cli::finite(), bad).first,
                  "expected a finite number, got " + std::string(bad))
            << bad;
        EXPECT_NE(checked(nebula::cli::positive(), bad).first, "") << bad;
        EXPECT_NE(checked(nebula::cli::numberIn(0, 1), bad).first, "") << bad;
    }
    EXPECT_EQ(checked(nebula::cli::finite(), "-1e308").first, "");
}

// checkNumbers (run by cli::run): every floating-point option refuses nan and inf, every
// unsigned one a sign and overflow, every int one values beyond an int, unless the option has
// its own range; a usage error (2) naming the option, and the body never runs.
TEST(CliChecks, EveryNumberOptionIsChecked)
{
    double scale = 1.0, ranged = 0.5;
    std::uint64_t seed = 0;
    int count = 0;
    const auto setup = [&](CLI::App& app) {
        app.add_option("--scale", scale);
        app.add_option("--ranged", ranged)->check(nebula::cli::numberIn(0, 1));
        app.add_option("--seed", seed);
        app.add_option_group("Group")->add_option("--count", count);
    };
    const auto expectUsage = [&](std::initializer_list<std::string> args,
                                 const std::string& mention) {
        const Outcome o = runTool(0, args, {}, setup);
        EXPECT_EQ(o.code, 2) << o.err;
        EXPECT_FALSE(o.bodyRan);
        EXPECT_TRUE(contains(o.err, mention)) << mention << " in:\n" << o.err;
    };
    expectUsage({"--scale", "nan"}, "--scale: expected a finite number, got nan");
    expectUsage({"--scale", "-inf"}, "--scale: expected a finite number, got -inf");
    expectUsage({"--ranged", "inf"}, "--ranged: expected a number in [0, 1], got inf");
    expectUsage({"--seed", "-1"}, "--seed: expected an integer in [0, 18446744073709551615]");
    expectUsage({"--count", "4294967296"},
                "--count: expected an integer in [-2147483648, 2147483647], got 4294967296");
    const Outcome o = runTool(
        0, {"--scale", "-2.5", "--seed", "18446744073709551615", "--count", "-7", "--ranged", "1"},
        {}, setup);
    EXPECT_EQ(o.code, 0) << o.err;
    EXPECT_EQ(scale, -2.5);
    EXPECT_EQ(seed, UINT64_MAX);
    EXPECT_EQ(count, -7);
    EXPECT_EQ(ranged, 1.0);
    // --threads has its range in words.
    expectUsage({"--threads", "-1"}, "--threads: expected an integer in [0, 4096], got -1");
}

// A std::bad_alloc that escapes the body is "out of memory" with the tool's name, exit 1.
TEST(CliRun, BadAllocIsOutOfMemory)
{
    const Outcome o = runTool(0, {}, [](nebula::Run&) { throw std::bad_alloc(); });
    EXPECT_EQ(o.code, 1);
    EXPECT_EQ(o.err.rfind("nebtest: error: out of memory", 0), 0u) << o.err;
    EXPECT_FALSE(contains(o.err, "std::bad_alloc")) << o.err;
}

TEST(Cli, RefuseSharedStream)
{
    using nebula::cli::refuseSharedStream;
    EXPECT_NO_THROW(refuseSharedStream({{"-i", "-"}, {"--phase", "p.vdb"}}, "stdin"));
    EXPECT_NO_THROW(refuseSharedStream({{"-i", "a"}, {"--phase", ""}}, "stdin"));
    EXPECT_EQ(errorMessage([] {
                  refuseSharedStream({{"-i", "-"}, {"--phase", "-"}}, "stdin");
              }),
              "-i - and --phase - both read stdin, which can carry only one of them; give one a "
              "file name");
    EXPECT_THROW(refuseSharedStream({{"-o", "-"}, {"--json", "-"}}, "stdout"), nebula::UsageError);
    EXPECT_TRUE(contains(errorMessage([] {
                             refuseSharedStream({{"-o", "-"}, {"--json", "-"}}, "stdout");
                         }),
                         "-o - and --json - both write stdout"));
}

// Huge coordinates are refused by the X,Y,Z parser: their squares would overflow.
TEST(Cli, ParseVec3RefusesMagnitudesWhoseSquaresOverflow)
{
    EXPECT_NO_THROW(nebula::cli::parseVec3("1e150,-1e150,0", "--eye"));
    const std::string msg = errorMessage([] { nebula::cli::parseVec3("1e300,0,0", "--eye"); });
    EXPECT_EQ(msg.rfind("--eye \"1e300,0,0\": each number must be at most 1e+150 in magnitude", 0),
              0u)
        << msg;
    EXPECT_THROW(nebula::cli::parseVec3("0,-1e151,0", "--up"), nebula::UsageError);
}

// checkConfigText: each line a comment, [default], key = value with a known key and a value
// the option's number check accepts, or an array's continuation; messages name file and line.
TEST(CliChecks, ConfigFileLines)
{
    std::random_device rd;
    const fs::path dir = fs::temp_directory_path() /
                         ("nebula_cfg_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    fs::create_directories(dir);
    const std::string file = (dir / "c.toml").string();
    CLI::App app("t", "nebtest");
    nebula::CommonOptions opts;
    std::vector<std::string> list;
    double scale = 1;
    nebula::cli::addCommon(app, opts, nebula::cli::DENSITY_GRID);
    app.add_option("--list", list);
    app.add_option("--scale", scale)->check(nebula::cli::positive());
    nebula::cli::checkNumbers(app);
    const auto check = [&](const std::string& text) {
        try {
            nebula::cli::checkConfigText(app, text, file, "nebtest");
        } catch (const nebula::UsageError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_EQ(check("# c\n; c\n\n[default]\nthreads = 2\ndensity-grid = \"n H\"\nquiet\n"
                    "verbose = true\nlist = [\"a\",\n  \"b\"]\nscale = '2.5'\n"),
              "");
    const std::string at = "--config: " + file + ", line ";
    EXPECT_EQ(check("threads = 2\nthreadz = 3\n"),
              at + "2: unknown option \"threadz\" in the config file (not an option of nebtest)");
    EXPECT_EQ(check("just words\n"),
              at + "1: expected \"key = value\", a [section] or a # comment, got \"just words\"");
    EXPECT_EQ(check("[nebtest]\n"), at + "1: section [nebtest]: nebtest has no sections (only "
                                         "[default]); give its options as \"key = value\" lines "
                                         "at the top of the file");
    EXPECT_EQ(check("threads =\n"), at + "1: \"threads\" has no value after '='");
    EXPECT_EQ(check("threads = -1\n"),
              at + "1: --threads: expected an integer in [0, 4096], got -1");
    EXPECT_EQ(check("scale = \"nan\"\n"), at + "1: --scale: expected a finite number > 0, got nan");
    EXPECT_EQ(check("list = [\"a\",\n\"b\",\n"), at + "2: the array opened with '[' is not closed");
    EXPECT_EQ(check("threads = 2\nquiet\nthreads = 3\n"),
              at + "3: --threads is set again (line 1 set it first); give each option once");
    EXPECT_EQ(check("config = other.toml\n"),
              at + "1: a config file cannot name another config file");
    EXPECT_EQ(check(std::string("threads = 2\nab\0cd\n", 18)),
              at + "2: byte 0x00 at column 3 is not text; a config file holds lines \"key = "
                   "value\"");
    EXPECT_EQ(check("a\x1b[31m = 1\n"),
              at + "1: byte 0x1B at column 2 is not text; a config file holds lines \"key = "
                   "value\"");
    EXPECT_EQ(check("caf\xc3\xa9 = 1\n"),
              at + "1: unknown option \"caf\\xC3\\xA9\" in the config file (not an option of "
                   "nebtest)");
    std::error_code ec;
    fs::remove_all(dir, ec);
}

TEST(CliRun, HugePageMallocOnlyWhereTheKernelWaitsToBeAsked)
{
    using nebula::cli::hugePageTunables;
    const std::string madvise = "always [madvise] never", always = "[always] madvise never",
                      never = "always madvise [never]";
    EXPECT_EQ(hugePageTunables(nullptr, madvise), "glibc.malloc.hugetlb=1");
    EXPECT_EQ(hugePageTunables("", madvise), "glibc.malloc.hugetlb=1");
    // Other tunables are kept; the user's own choice of this one is left alone.
    EXPECT_EQ(hugePageTunables("glibc.malloc.arena_max=2", madvise),
              "glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1");
    EXPECT_EQ(hugePageTunables("glibc.malloc.hugetlb=0", madvise), std::nullopt);
    EXPECT_EQ(hugePageTunables("glibc.malloc.hugetlb=1", madvise), std::nullopt);
    // THP for every mapping already, or none at all, or no THP in this kernel: nothing to gain.
    EXPECT_EQ(hugePageTunables(nullptr, always), std::nullopt);
    EXPECT_EQ(hugePageTunables(nullptr, never), std::nullopt);
    EXPECT_EQ(hugePageTunables(nullptr, ""), std::nullopt);
}
