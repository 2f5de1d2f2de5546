// SPDX-License-Identifier: Apache-2.0
/// @file test_stars.cpp
/// The stars JSON (parsing, every error, round trip) and spectral classes. (Planck's law is
/// in test_blackbody.cpp, black-body colours in test_colour.cpp.)

#include "nebula/physics/stars.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

namespace {

using nebula::test::contains;
using nebula::test::errorMessage;

// ---------------------------------------------------------------------------------------------
// parseStars / starsToJson

TEST(ParseStars, ReadsTemperatureAndClass)
{
    const auto stars = nebula::parseStars(R"([
        {"name": "alpha", "position": [1, 2.5, -3], "luminosity": 1000, "temperature": 30000},
        {"name": "beta_2-b", "position": [0, 0, 0], "luminosity": 0.5, "class": "G2V",
         "comment": "unknown fields are ignored"}
    ])",
                                          "stars.json");
    ASSERT_EQ(stars.size(), 2u);
    EXPECT_EQ(stars[0].name, "alpha");
    EXPECT_EQ(stars[0].position[0], 1.0);
    EXPECT_EQ(stars[0].position[1], 2.5);
    EXPECT_EQ(stars[0].position[2], -3.0);
    EXPECT_EQ(stars[0].luminosity, 1000.0);
    EXPECT_EQ(stars[0].temperature, 30000.0);
    EXPECT_EQ(stars[1].name, "beta_2-b");
    EXPECT_EQ(stars[1].luminosity, 0.5);
    EXPECT_EQ(stars[1].temperature, nebula::spectralClassTemperature("G2V"));
}

TEST(ParseStars, EmptyArrayIsNoStars)
{
    EXPECT_TRUE(nebula::parseStars("[]", "stars.json").empty());
}

TEST(ParseStars, RoundTrip)
{
    std::vector<nebula::Star> stars(3);
    stars[0] = {"a", {0.1, -2.0 / 3.0, 1e6}, 1.0 / 7.0, 5772.0};
    stars[1] = {"Star-2", {0, 0, 0}, 3e5, 41400.0};
    stars[2] = {"z_9", {-1e-3, 123.456, 7}, 1e-4, 3060.5};
    const auto back = nebula::parseStars(nebula::starsToJson(stars), "metadata");
    ASSERT_EQ(back.size(), stars.size());
    for (std::size_t i = 0; i < stars.size(); ++i) {
        EXPECT_EQ(back[i].name, stars[i].name);
        EXPECT_EQ(back[i].position, stars[i].position); // exact: shortest round-trip digits
        EXPECT_EQ(back[i].luminosity, stars[i].luminosity);
        EXPECT_EQ(back[i].temperature, stars[i].temperature);
    }
}

TEST(ParseStars, ErrorMessages)
{
    const auto parse = [](const std::string& json) {
        return errorMessage([&] { nebula::parseStars(json, "stars.json"); });
    };
    const std::string alpha =
        R"({"name": "alpha", "position": [0, 0, 0], "luminosity": 1, "temperature": 5000})";

    // The message starts with the source, names the star (from 1) and the field, and says
    // what was expected and what was found.
    EXPECT_EQ(parse("[" + alpha +
                    R"(, {"name": "beta", "position": [1, 2, 3], "luminosity": -1,
                          "temperature": 5000}])"),
              R"(stars.json: star 2 ("beta"): "luminosity" must be > 0 [L_sun], got -1)");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 0,
                         "temperature": 5000}])"),
              R"(stars.json: star 1 ("a"): "luminosity" must be > 0 [L_sun], got 0)");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": "bright",
                         "temperature": 5000}])"),
              R"(stars.json: star 1 ("a"): "luminosity" must be > 0 [L_sun], got "bright")");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1,
                         "temperature": -300}])"),
              R"(stars.json: star 1 ("a"): "temperature" must be > 0 [K], got -300)");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, 2], "luminosity": 1,
                         "temperature": 300}])"),
              R"(stars.json: star 1 ("a"): "position" must be an array of 3 finite numbers )"
              R"([pc], got [1,2])");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, "2", 3], "luminosity": 1,
                         "temperature": 300}])"),
              R"(stars.json: star 1 ("a"): "position" must be an array of 3 finite numbers )"
              R"([pc], got [1,"2",3])");

    // Missing fields.
    EXPECT_EQ(parse(R"([{"position": [1, 2, 3], "luminosity": 1, "temperature": 300}])"),
              R"(stars.json: star 1: missing "name")");
    EXPECT_EQ(parse(R"([{"name": "a", "luminosity": 1, "temperature": 300}])"),
              R"(stars.json: star 1 ("a"): missing "position")");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, 2, 3], "temperature": 300}])"),
              R"(stars.json: star 1 ("a"): missing "luminosity")");
    EXPECT_EQ(parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1}])"),
              R"(stars.json: star 1 ("a"): missing "temperature" (or a spectral "class"))");

    // Names: the grid-name alphabet, unique.
    std::string message = parse(R"([{"name": "a b", "position": [1, 2, 3], "luminosity": 1,
                                     "temperature": 300}])");
    EXPECT_EQ(message.rfind(R"(stars.json: star 1: "name" must be)", 0), 0u) << message;
    EXPECT_TRUE(contains(message, R"(got "a b")")) << message;
    message = parse(R"([{"name": "", "position": [1, 2, 3], "luminosity": 1,
                         "temperature": 300}])");
    EXPECT_TRUE(contains(message, R"(star 1: "name" must be)")) << message;
    message = parse(R"([{"name": 7, "position": [1, 2, 3], "luminosity": 1,
                         "temperature": 300}])");
    EXPECT_TRUE(contains(message, R"(star 1: "name" must be)")) << message;
    message = parse("[" + alpha + ", " + alpha + "]");
    EXPECT_EQ(message,
              R"(stars.json: star 2 ("alpha"): "name" must be unique, but star 1 has the same )"
              R"(name)");

    // Spectral class.
    message = parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1,
                         "class": "X5"}])");
    EXPECT_EQ(message.rfind(R"(stars.json: star 1 ("a"): "class": spectral class "X5")", 0), 0u)
        << message;
    message = parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1, "class": 5}])");
    EXPECT_TRUE(contains(message, R"(star 1 ("a"): "class" must be a spectral class)")) << message;
    message = parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1, "class": "B3V",
                         "temperature": 300}])");
    EXPECT_EQ(message,
              R"(stars.json: star 1 ("a"): give either "temperature" or "class", not both)");

    // Structure.
    message = parse("[" + alpha + ", 3]");
    EXPECT_EQ(message.rfind("stars.json: star 2: expected an object", 0), 0u) << message;
    message = parse(alpha);
    EXPECT_EQ(message.rfind("stars.json: expected a JSON array of stars, got ", 0), 0u) << message;
    message = parse(R"([{"name": "a",)");
    EXPECT_EQ(message.rfind("stars.json: not valid JSON: ", 0), 0u) << message;
    EXPECT_FALSE(contains(message, "[json.exception")) << message;
    message = parse("");
    EXPECT_EQ(message.rfind("stars.json: not valid JSON: ", 0), 0u) << message;
    // A number beyond double's range is a JSON error too (nlohmann's out_of_range).
    message = parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1e999,
                         "temperature": 5000}])");
    EXPECT_EQ(message.rfind("stars.json: not valid JSON: ", 0), 0u) << message;
    EXPECT_TRUE(contains(message, "1e999")) << message;
}

// ---------------------------------------------------------------------------------------------
// Spectral classes

TEST(SpectralClass, StandardTemperatures)
{
    // Mamajek's mean dwarf sequence (Pecaut & Mamajek 2013), see stars.cpp.
    EXPECT_NEAR(nebula::spectralClassTemperature("G2V"), 5770.0, 30.0);
    EXPECT_NEAR(nebula::spectralClassTemperature("A0V"), 9700.0, 100.0);
    EXPECT_NEAR(nebula::spectralClassTemperature("B0V"), 31500.0, 200.0);
    EXPECT_NEAR(nebula::spectralClassTemperature("M0V"), 3850.0, 50.0);
    EXPECT_NEAR(nebula::spectralClassTemperature("O5V"), 41400.0, 1000.0);
    EXPECT_NEAR(nebula::spectralClassTemperature("M5V"), 3060.0, 50.0);
}

TEST(SpectralClass, DwarfLuminosityClassIsTheTable)
{
    const double b3 = nebula::spectralClassTemperature("B3");
    for (const char* suffix : {"V", " V"}) {
        EXPECT_EQ(nebula::spectralClassTemperature(std::string("B3") + suffix), b3) << suffix;
    }
}

// The table is the main sequence's: a giant or supergiant is refused, never given a dwarf's
// temperature (K0III is about 4800 K, K0V about 5300 K).
TEST(SpectralClass, RefusesGiantsAndSupergiants)
{
    for (const char* name : {"K0III", "K0 III", "B3IV", "B3II", "B3I", "B3Ia", "B3Ib", "B3Iab"}) {
        const std::string message = errorMessage([&] { nebula::spectralClassTemperature(name); });
        EXPECT_EQ(message.rfind(std::string("spectral class \"") + name + "\"", 0), 0u) << message;
        EXPECT_NE(message.find("is not supported"), std::string::npos) << message;
        EXPECT_NE(message.find("kelvin"), std::string::npos) << message;
    }
}

TEST(SpectralClass, InterpolatesSubclasses)
{
    // Half a subclass lies between its neighbours; a bare letter means subclass 5.
    const double b4 = nebula::spectralClassTemperature("B4");
    const double b5 = nebula::spectralClassTemperature("B5");
    EXPECT_DOUBLE_EQ(nebula::spectralClassTemperature("B4.5V"), 0.5 * (b4 + b5));
    EXPECT_EQ(nebula::spectralClassTemperature("G"), nebula::spectralClassTemperature("G5"));
    // O9.5 lies between O9 and B0.
    const double o95 = nebula::spectralClassTemperature("O9.5V");
    EXPECT_LT(o95, nebula::spectralClassTemperature("O9"));
    EXPECT_GT(o95, nebula::spectralClassTemperature("B0"));
}

TEST(SpectralClass, HotterToCooler)
{
    // The temperature falls monotonically from O5 to M5, in steps of a tenth of a subclass.
    const std::string letters = "OBAFGKM";
    double previous = INFINITY;
    for (int tenth = 50; tenth <= 650; ++tenth) {
        const int subtype = tenth / 10;
        const std::string name = std::string(1, letters[subtype / 10]) +
                                 std::to_string(subtype % 10) + "." + std::to_string(tenth % 10);
        const double T = nebula::spectralClassTemperature(name);
        EXPECT_LT(T, previous) << name;
        previous = T;
    }
}

TEST(SpectralClass, RejectsAnythingElse)
{
    for (const char* bad : {"X5", "", "B12", "O3", "O4V", "M6", "M5.5", "g2v", "G2VV", "G2 ",
                            "G2  V", "B.5", "B1.", "B3VI", "5", " G2", "G2-V"}) {
        const std::string message = errorMessage([&] { nebula::spectralClassTemperature(bad); });
        EXPECT_EQ(message.rfind(std::string("spectral class \"") + bad + "\"", 0), 0u)
            << bad << ": " << message;
    }
}

} // namespace

// Limits that keep everything derived from a star finite: coordinates (squared distances),
// luminosity (radiance in a float) and temperature (Planck's law); each says its limit.
TEST(ParseStars, ValuesThatWouldOverflowAreRefusedSayingTheLimit)
{
    const auto parse = [](const std::string& position, const std::string& luminosity,
                          const std::string& temperature) {
        return errorMessage([&] {
            nebula::parseStars(R"([{"name": "a", "position": )" + position + R"(, "luminosity": )" +
                                   luminosity + R"(, "temperature": )" + temperature + "}]",
                               "stars.json");
        });
    };
    EXPECT_EQ(parse("[0, 0, 0]", "1e308", "5000"),
              R"(stars.json: star 1 ("a"): "luminosity" 1e+308 is above the limit of 1e+30 L_sun )"
              R"((larger values overflow the rendered radiance))");
    EXPECT_EQ(parse("[0, 1e151, 0]", "1", "5000"),
              R"(stars.json: star 1 ("a"): "position" [0,1e+151,0]: each coordinate must be at )"
              R"(most 1e+150 pc in magnitude (distances are computed from squares, which would )"
              R"(overflow))");
    EXPECT_EQ(parse("[0, 0, 0]", "1", "1e10"),
              R"(stars.json: star 1 ("a"): "temperature" 1e+10 is above the limit of 1e+09 K )"
              R"((the hottest stars are about 2e5 K))");
    // At the limits: fine.
    const auto stars = nebula::parseStars(
        R"([{"name": "a", "position": [1e150, -1e150, 0], "luminosity": 1e30,
             "temperature": 1e9}])",
        "stars.json");
    ASSERT_EQ(stars.size(), 1u);
    EXPECT_EQ(stars[0].luminosity, nebula::MAX_STAR_LUMINOSITY);
}
