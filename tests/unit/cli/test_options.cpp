// SPDX-License-Identifier: Apache-2.0
/// @file test_options.cpp
/// cli/options.h: --star values (parseStarOption), the stars of --stars and --star together
/// (loadStars), the dust options (addDust, DustOptions::apply: only what was given, then
/// validated).

#include "nebula/cli/options.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

/// The UsageError message of @p f, or a note that it threw something else or nothing.
std::string usageMessage(const std::function<void()>& f)
{
    try {
        f();
    } catch (const nebula::UsageError& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("not a UsageError: ") + e.what();
    }
    return "no error";
}

/// Parses @p args (without the program name) into @p app.
void parse(CLI::App& app, std::vector<std::string> args)
{
    std::reverse(args.begin(), args.end()); // CLI11 takes a reversed vector
    app.parse(args);
}

// ---- --star --------------------------------------------------------------------------------

TEST(StarOption, ParsesNamePositionLuminosityAndClassOrKelvin)
{
    const nebula::Star a = nebula::cli::parseStarOption("alpha:0.5,-1,2e-1:1000:B2V");
    EXPECT_EQ(a.name, "alpha");
    EXPECT_EQ(a.position, (std::array<double, 3>{0.5, -1.0, 0.2}));
    EXPECT_EQ(a.luminosity, 1000.0);
    EXPECT_EQ(a.temperature, nebula::spectralClassTemperature("B2V"));

    const nebula::Star b = nebula::cli::parseStarOption("b_2-x:0,0,0:0.25:6000");
    EXPECT_EQ(b.name, "b_2-x");
    EXPECT_EQ(b.luminosity, 0.25);
    EXPECT_EQ(b.temperature, 6000.0);

    // A class without luminosity class, with decimals.
    EXPECT_EQ(nebula::cli::parseStarOption("c:1,2,3:5:B0.5").temperature,
              nebula::spectralClassTemperature("B0.5"));
    EXPECT_EQ(nebula::cli::parseStarOption("d:1,2,3:5:5772.5").temperature, 5772.5);
}

TEST(StarOption, BadValuesAreUsageErrorsNamingTheOption)
{
    const char* syntax[] = {
        "",                       // nothing
        "alpha",                  // one part
        "alpha:0,0,0:1000",       // no class
        "alpha:0,0,0:1000:B2V:x", // five parts
        "alpha:0,0:1000:B2V",     // two coordinates
        "alpha:0,0,0,0:1000:B2V", // four coordinates
        "alpha:0,x,0:1000:B2V",   // not a number
        "alpha:0,,0:1000:B2V",    // empty coordinate
        "alpha:0,0,0:bright:B2V", // luminosity not a number
        "alpha:0,0,0:10x:B2V",    // trailing characters
        "alpha:0,0,0:1e999:B2V",  // luminosity out of range
    };
    for (const char* text : syntax) {
        const std::string msg = usageMessage([&] { nebula::cli::parseStarOption(text); });
        EXPECT_EQ(
            msg.rfind("--star \"" + std::string(text) + "\": expected NAME:X,Y,Z:LUMINOSITY:CLASS",
                      0),
            0u)
            << text << ": " << msg;
    }
    // Values parseStars() refuses: still usage errors, starting with --star and saying what.
    const std::pair<const char*, const char*> values[] = {
        {"alpha:0,0,0:-5:B2V", "\"luminosity\" must be > 0"},
        {"alpha:0,0,0:0:B2V", "\"luminosity\" must be > 0"},
        {"alpha:0,0,0:10:-300", "temperature"},
        {"alpha:0,0,0:10:0", "temperature"},
        {"alpha:0,0,0:10:Q9", "spectral class \"Q9\""},
        {"alpha:0,0,0:10:K0III", "K0III"}, // a giant: give the temperature
        {"bad name:0,0,0:10:B2V", "\"name\""},
        {"a.b:0,0,0:10:B2V", "\"name\""},
        {":0,0,0:10:B2V", "\"name\""},
        {"alpha:nan,0,0:10:B2V", "\"position\""},
        {"alpha:0,0,0,:10:B2V", "\"position\""},        // a trailing comma
        {"alpha:0,0,0:10:B2V:", "expected NAME:X,Y,Z"}, // a trailing colon
        {"alpha:0,0,0:inf:B2V", "\"luminosity\""},
        {"alpha:0,0,0:10:1e999", "temperature [K] must be a finite number"}, // out of range
    };
    for (const auto& [text, mention] : values) {
        const std::string& value = text; // (a structured binding cannot be captured in C++17)
        const std::string msg = usageMessage([&] { nebula::cli::parseStarOption(value); });
        EXPECT_EQ(msg.rfind("--star", 0), 0u) << text << ": " << msg;
        EXPECT_TRUE(contains(msg, mention)) << text << ": " << msg;
    }
}

// ---- --stars and --star together --------------------------------------------------------------

class StarsFileTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        std::random_device rd;
        dir = fs::temp_directory_path() /
              ("nebula_options_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
        fs::create_directories(dir);
    }
    void TearDown() override
    {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    fs::path dir;
};

TEST_F(StarsFileTest, FileThenEachStarOption)
{
    nebula::StarOptions opts;
    EXPECT_TRUE(nebula::cli::loadStars(opts).empty()); // neither given

    const std::string file = (dir / "stars.json").string();
    std::ofstream(file) << R"([{"name": "f1", "position": [1, 2, 3], "luminosity": 10,
                               "temperature": 9000}])";
    opts.starsFile = file;
    opts.star = {"s1:0,0,0:5:6000", "s2:1,1,1:7:B2V"};
    const auto stars = nebula::cli::loadStars(opts);
    ASSERT_EQ(stars.size(), 3u);
    EXPECT_EQ(stars[0].name, "f1");
    EXPECT_EQ(stars[0].temperature, 9000.0);
    EXPECT_EQ(stars[1].name, "s1");
    EXPECT_EQ(stars[2].name, "s2");
    EXPECT_EQ(stars[2].luminosity, 7.0);

    // A --star with a name already taken (by the file or another --star).
    opts.star = {"f1:0,0,0:5:6000"};
    std::string msg = usageMessage([&] { nebula::cli::loadStars(opts); });
    EXPECT_EQ(msg.rfind("--star", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "duplicate star name \"f1\"")) << msg;
    opts.starsFile.clear();
    opts.star = {"x:0,0,0:5:6000", "x:1,0,0:5:6000"};
    EXPECT_THROW(nebula::cli::loadStars(opts), nebula::UsageError);

    // A missing or broken file: an Error naming it.
    opts.star.clear();
    opts.starsFile = (dir / "missing.json").string();
    msg = errorMessage([&] { nebula::cli::loadStars(opts); });
    EXPECT_EQ(msg.rfind(opts.starsFile + " (--stars): cannot open file", 0), 0u) << msg;
    const std::string broken = (dir / "broken.json").string();
    std::ofstream(broken) << "[{\"name\": ";
    opts.starsFile = broken;
    msg = errorMessage([&] { nebula::cli::loadStars(opts); });
    EXPECT_EQ(msg.rfind(broken + ": ", 0), 0u) << msg;
}

TEST_F(StarsFileTest, AddStarsOptions)
{
    CLI::App app("t", "t");
    nebula::StarOptions opts;
    nebula::cli::addStars(app, opts);
    const std::string file = (dir / "s.json").string();
    std::ofstream(file)
        << R"([{"name": "c", "position": [0, 1, 0], "luminosity": 3, "temperature": 7000}])";
    parse(app, {"--star", "a:0,0,0:1:A0V", "--star", "b:1,0,0:2:6000", "--stars", file});
    EXPECT_EQ(opts.star, (std::vector<std::string>{"a:0,0,0:1:A0V", "b:1,0,0:2:6000"}));
    EXPECT_EQ(opts.starsFile, file);
    EXPECT_EQ(nebula::cli::loadStars(opts).size(), 3u);

    // A file that holds no stars is an error naming it (it was silently no stars), also
    // with --star.
    std::ofstream(file, std::ios::trunc) << "[]";
    const std::string msg = errorMessage([&] { nebula::cli::loadStars(opts); });
    EXPECT_EQ(msg, file + " (--stars) holds no stars: an empty list; give at least one star, or "
                          "leave out --stars");

    // --stars must name an existing file.
    CLI::App app2("t", "t");
    nebula::StarOptions opts2;
    nebula::cli::addStars(app2, opts2);
    EXPECT_THROW(parse(app2, {"--stars", (dir / "none.json").string()}), CLI::ValidationError);
}

// ---- dust ----------------------------------------------------------------------------------

nebula::DustParams customBase()
{
    nebula::DustParams d;
    d.kappa_V = 2.5e-3;
    d.albedo = 0.4;
    d.g = 0.3;
    d.phase = nebula::PhaseModel::MieHazy;
    d.curve = "grey";
    d.R_V = 5.0;
    return d;
}

void expectSame(const nebula::DustParams& a, const nebula::DustParams& b)
{
    EXPECT_EQ(a.kappa_V, b.kappa_V);
    EXPECT_EQ(a.albedo, b.albedo);
    EXPECT_EQ(a.g, b.g);
    EXPECT_EQ(a.phase, b.phase);
    EXPECT_EQ(a.curve, b.curve);
    EXPECT_EQ(a.R_V, b.R_V);
}

TEST(DustOptions, NothingGivenKeepsTheBase)
{
    const nebula::DustOptions none;
    EXPECT_FALSE(none.any());
    expectSame(none.apply(customBase()), customBase());
    expectSame(none.apply(nebula::DustParams{}), nebula::DustParams{});
}

TEST(DustOptions, OnlyWhatWasGivenChanges)
{
    const auto one = [](const std::function<void(nebula::DustOptions&)>& set,
                        const std::function<void(nebula::DustParams&)>& expect) {
        nebula::DustOptions o;
        set(o);
        EXPECT_TRUE(o.any());
        nebula::DustParams want = customBase();
        expect(want);
        expectSame(o.apply(customBase()), want);
    };
    one([](auto& o) { o.kappa_V = 1e-3; }, [](auto& d) { d.kappa_V = 1e-3; });
    one([](auto& o) { o.albedo = 0.9; }, [](auto& d) { d.albedo = 0.9; });
    one([](auto& o) { o.g = -0.5; }, [](auto& d) { d.g = -0.5; });
    one([](auto& o) { o.R_V = 3.1; }, [](auto& d) { d.R_V = 3.1; });
    one([](auto& o) { o.phase = "rayleigh"; },
        [](auto& d) { d.phase = nebula::PhaseModel::Rayleigh; });
    one([](auto& o) { o.phase = "murky"; },
        [](auto& d) { d.phase = nebula::PhaseModel::MieMurky; });
    one([](auto& o) { o.curve = "CCM89"; }, [](auto& d) { d.curve = "CCM89"; });
    // Several at once.
    one(
        [](auto& o) {
            o.albedo = 0.0;
            o.g = 0.0;
            o.phase = "hg";
        },
        [](auto& d) {
            d.albedo = 0.0;
            d.g = 0.0;
            d.phase = nebula::PhaseModel::HenyeyGreenstein;
        });
}

TEST(DustOptions, ResultIsValidated)
{
    const auto bad = [](const std::function<void(nebula::DustOptions&)>& set) {
        nebula::DustOptions o;
        set(o);
        return usageMessage([&] { o.apply(customBase()); });
    };
    EXPECT_TRUE(contains(bad([](auto& o) { o.albedo = 1.5; }), "albedo"));
    EXPECT_TRUE(contains(bad([](auto& o) { o.albedo = -0.1; }), "albedo"));
    EXPECT_TRUE(contains(bad([](auto& o) { o.g = 1.0; }), "g must be in (-1, 1)"));
    EXPECT_TRUE(contains(bad([](auto& o) { o.kappa_V = 0.0; }), "kappa_V"));
    EXPECT_TRUE(contains(bad([](auto& o) { o.R_V = -2.0; }), "R_V"));
    EXPECT_TRUE(contains(bad([](auto& o) { o.curve = "MW"; }), "curve"));
    // An invalid base is refused too, even if no option touches the bad field.
    nebula::DustParams broken = customBase();
    broken.albedo = 7.0;
    nebula::DustOptions g;
    g.g = 0.1;
    EXPECT_THROW(g.apply(broken), nebula::UsageError);
    // An unknown phase function name is an error naming it.
    nebula::DustOptions p;
    p.phase = "lambertian";
    const std::string msg = errorMessage([&] { p.apply(customBase()); });
    EXPECT_TRUE(contains(msg, "lambertian")) << msg;
}

TEST(DustOptions, AddDustOptions)
{
    CLI::App app("t", "t");
    nebula::DustOptions o;
    nebula::cli::addDust(app, o);
    parse(app, {"--albedo", "0.3", "--phase-function", "hazy", "--rv", "4", "--kappa-v", "0.002"});
    EXPECT_EQ(o.albedo, 0.3);
    EXPECT_EQ(o.phase, std::string("hazy"));
    EXPECT_EQ(o.R_V, 4.0);
    EXPECT_EQ(o.kappa_V, 0.002);
    EXPECT_FALSE(o.g);
    EXPECT_FALSE(o.curve);
    const nebula::DustParams d = o.apply(customBase());
    EXPECT_EQ(d.albedo, 0.3);
    EXPECT_EQ(d.phase, nebula::PhaseModel::MieHazy);
    EXPECT_EQ(d.g, customBase().g);
    EXPECT_EQ(d.curve, customBase().curve);

    // Without kappa: --kappa-v is no option of the tool.
    CLI::App noKappa("t", "t");
    nebula::DustOptions k;
    nebula::cli::addDust(noKappa, k, false);
    EXPECT_THROW(parse(noKappa, {"--kappa-v", "0.002"}), CLI::ParseError);
    parse(noKappa, {"--g=-0.25", "--extinction-curve", "grey"});
    EXPECT_EQ(k.g, -0.25);
    EXPECT_EQ(k.curve, std::string("grey"));
    EXPECT_FALSE(k.kappa_V);
}

} // namespace
