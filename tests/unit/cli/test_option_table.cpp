// SPDX-License-Identifier: Apache-2.0
/// @file test_option_table.cpp
/// cli/option_table.h: options declared as rows (addOptions: the target's type, the default
/// shown, the check, the group, the mode list) and argumentOf (an option's value before
/// parsing).

#include "nebula/cli/cli.h"
#include "nebula/cli/option_table.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace {

/// Parses @p args (without the program name) into @p app.
void parse(CLI::App& app, std::vector<std::string> args)
{
    std::reverse(args.begin(), args.end()); // CLI11 takes a reversed vector
    app.parse(args);
}

struct Values
{
    int count = 3;
    std::uint64_t seed = 7;
    double size = 2.5;
    std::optional<double> radius;
    std::string shape = "sphere";
    bool flag = false;
    std::array<double, 3> axis{0, 1, 0};
};

} // namespace

TEST(OptionTable, DeclaresRowsInOrderIntoTheirTargets)
{
    Values v;
    CLI::App app{"test"};
    std::vector<CLI::Option*> special;
    const auto options = nebula::cli::addOptions(
        app, {
                 {"--count", &v.count, "How many", nebula::cli::integerIn(1, 10)},
                 {"--seed", &v.seed, "Seed"},
                 {"--size", &v.size, "Size", {}, "Special", &special},
                 {"--radius", &v.radius, "Radius", nebula::cli::positive(), "Special", &special},
                 {"--shape", &v.shape, "Shape", CLI::IsMember({"sphere", "shell"})},
                 {"--flag", &v.flag, "A flag", {}, "Special", &special},
                 {"--axis", &v.axis, "Axis"},
             });
    ASSERT_EQ(options.size(), 7u);
    EXPECT_EQ(options[0]->get_name(), "--count");
    EXPECT_EQ(options[6]->get_name(), "--axis");
    ASSERT_EQ(special.size(), 3u);
    EXPECT_EQ(special[0], options[2]);
    EXPECT_EQ(special[2], options[5]);
    EXPECT_EQ(options[2]->get_group(), "Special");
    EXPECT_EQ(options[0]->get_group(), "Options");

    parse(app, {"--count", "4", "--seed", "9", "--size", "1.5", "--radius", "0.5", "--shape",
                "shell", "--flag", "--axis", "1,2,3"});
    EXPECT_EQ(v.count, 4);
    EXPECT_EQ(v.seed, 9u);
    EXPECT_EQ(v.size, 1.5);
    EXPECT_EQ(v.radius, 0.5);
    EXPECT_EQ(v.shape, "shell");
    EXPECT_TRUE(v.flag);
    EXPECT_EQ(v.axis, (std::array<double, 3>{1, 2, 3}));
}

TEST(OptionTable, ShowsDefaultsAndChecksAsTheRowsSay)
{
    Values v;
    CLI::App app{"test"};
    nebula::cli::addOptions(app,
                            {
                                {"--count", &v.count, "How many", nebula::cli::integerIn(1, 10)},
                                {"--shape", &v.shape, "Shape", {}, "", nullptr, false},
                                {"--radius", &v.radius, "Radius"},
                                {"--axis", &v.axis, "Axis"},
                            });
    const std::string help = app.help();
    EXPECT_NE(help.find("--count INT:[1, 10]=3"), std::string::npos) << help;
    EXPECT_NE(help.find("--shape TEXT "), std::string::npos) << help;
    EXPECT_EQ(help.find("=sphere"), std::string::npos) << help;
    EXPECT_NE(help.find("--axis X,Y,Z=0,1,0"), std::string::npos) << help;
    EXPECT_THROW(parse(app, {"--count", "11"}), CLI::ValidationError);
}

TEST(OptionTable, ArgumentOfReadsTheLastValueBeforeDoubleDash)
{
    const char* argv[] = {"tool", "--preset", "box",   "--res", "8", "--preset=pillars",
                          "--",   "--preset", "bubble"};
    EXPECT_EQ(nebula::cli::argumentOf(9, argv, "--preset"), "pillars");
    EXPECT_EQ(nebula::cli::argumentOf(3, argv, "--preset"), "box");
    EXPECT_EQ(nebula::cli::argumentOf(2, argv, "--preset"), ""); // no value follows
    EXPECT_EQ(nebula::cli::argumentOf(9, argv, "--seed"), "");
}
