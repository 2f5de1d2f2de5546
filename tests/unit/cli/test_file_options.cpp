// SPDX-License-Identifier: Apache-2.0
// cli::inputFile(), cli::outputFile() and checkFileOptions(): every file option of a tool,
// in option groups too, compared with every other before any work.
#include "nebula/cli/cli.h"
#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace nebula;
namespace fs = std::filesystem;

namespace {

struct Tool
{
    CLI::App app{"test"};
    CommonOptions common;
    std::string fits, sed, table, json;

    Tool()
    {
        cli::addCommon(app, common, cli::INPUT | cli::OUTPUT);
        cli::outputFile(app.add_option("--fits", fits), FileFormat::Fits);
        auto* group = app.add_option_group("Table");
        cli::outputFile(group->add_option("--json", json), FileFormat::Json);
        cli::inputFile(group->add_option("--table", table));
        // Marked twice: the last mark holds (-o of nebrender is EXR, not addCommon's VDB).
        cli::outputFile(cli::outputFile(app.add_option("--sed", sed), FileFormat::Vdb),
                        FileFormat::Csv);
    }

    /// The UsageError of checkFileOptions() after parsing @p args, or "".
    std::string check(std::vector<std::string> args, const std::vector<cli::ExtraFile>& extra = {})
    {
        args.insert(args.begin(), "test");
        std::vector<char*> argv;
        for (auto& a : args)
            argv.push_back(a.data());
        app.parse(int(argv.size()), argv.data());
        try {
            cli::checkFileOptions(app, common, extra);
            return "";
        } catch (const UsageError& e) {
            return e.what();
        }
    }
};

} // namespace

TEST(FileOptions, EveryOutputAgainstEveryFile)
{
    const fs::path dir = fs::path(::testing::TempDir()) / "nebula_file_options";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string in = (dir / "in.vdb").string(), t = (dir / "t.vdb").string();
    std::ofstream(in) << "x";
    std::ofstream(t) << "x";

    EXPECT_EQ(Tool().check({"-i", in, "-o", "out.vdb", "--fits", "a.fits", "--sed", "s.csv"}), "");
    EXPECT_EQ(Tool().check({"-i", in, "-o", "out.vdb", "--sed", in}),
              "--sed " + in + " is the input -i " + in +
                  "; writing it would destroy the input: give the output another name");
    // An option group's input and output.
    EXPECT_NE(Tool().check({"-i", in, "-o", t, "--table", t}).find("is the input --table"),
              std::string::npos);
    EXPECT_NE(Tool().check({"-i", in, "-o", "x.vdb", "--json", "./x.vdb"}).find("same file"),
              std::string::npos);
    // The last mark holds: --sed is CSV.
    EXPECT_NE(Tool().check({"-i", in, "-o", "x.vdb", "--sed", "s.vdb"}).find("this output is CSV"),
              std::string::npos);
    // Extra files: a derived output, an input inside an option's value.
    EXPECT_NE(Tool()
                  .check({"-i", in, "-o", "x.vdb", "--fits", "f.fits"},
                         {{"the PNG", "./f.fits", true, FileFormat::Fits}})
                  .find("--fits f.fits and the PNG ./f.fits are the same file"),
              std::string::npos);
    EXPECT_NE(Tool()
                  .check({"-i", in, "-o", t}, {{"--emission", t, false, std::nullopt}})
                  .find("is the input --emission"),
              std::string::npos);
    fs::remove_all(dir);
}
