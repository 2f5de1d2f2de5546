/// @file test_stars.cpp
/// The stars JSON (parsing, every error, round trip), spectral classes, Planck's law against
/// Wien's and Stefan-Boltzmann's laws, and black-body colours.

#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
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
        EXPECT_EQ(back[i].position, stars[i].position);  // exact: shortest round-trip digits
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
    EXPECT_EQ(message.rfind(R"(stars.json: star 1 ("a"): "class": spectral class "X5")", 0),
              0u)
        << message;
    message = parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1, "class": 5}])");
    EXPECT_TRUE(contains(message, R"(star 1 ("a"): "class" must be a spectral class)"))
        << message;
    message = parse(R"([{"name": "a", "position": [1, 2, 3], "luminosity": 1, "class": "B3V",
                         "temperature": 300}])");
    EXPECT_EQ(message,
              R"(stars.json: star 1 ("a"): give either "temperature" or "class", not both)");

    // Structure.
    message = parse("[" + alpha + ", 3]");
    EXPECT_EQ(message.rfind("stars.json: star 2: expected an object", 0), 0u) << message;
    message = parse(alpha);
    EXPECT_EQ(message.rfind("stars.json: expected a JSON array of stars, got ", 0), 0u)
        << message;
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
        EXPECT_EQ(message.rfind(std::string("spectral class \"") + name + "\"", 0), 0u)
            << message;
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
                                 std::to_string(subtype % 10) + "." +
                                 std::to_string(tenth % 10);
        const double T = nebula::spectralClassTemperature(name);
        EXPECT_LT(T, previous) << name;
        previous = T;
    }
}

TEST(SpectralClass, RejectsAnythingElse)
{
    for (const char* bad : {"X5", "", "B12", "O3", "O4V", "M6", "M5.5", "g2v", "G2VV", "G2 ",
                            "G2  V", "B.5", "B1.", "B3VI", "5", " G2", "G2-V"}) {
        const std::string message =
            errorMessage([&] { nebula::spectralClassTemperature(bad); });
        EXPECT_EQ(message.rfind(std::string("spectral class \"") + bad + "\"", 0), 0u)
            << bad << ": " << message;
    }
}

// ---------------------------------------------------------------------------------------------
// Planck's law

/// Maximiser of f on [a, b] by golden-section search.
double argMax(const std::function<double(double)>& f, double a, double b)
{
    const double r = 0.5 * (std::sqrt(5.0) - 1.0);
    double c = b - r * (b - a);
    double d = a + r * (b - a);
    for (int i = 0; i < 200; ++i) {
        if (f(c) > f(d)) {
            b = d;
        } else {
            a = c;
        }
        c = b - r * (b - a);
        d = a + r * (b - a);
    }
    return 0.5 * (a + b);
}

TEST(Planck, WienDisplacement)
{
    // Wien's displacement constant b = 2.897771955e-3 m K (CODATA 2018).
    for (double T : {3000.0, 5772.0, 30000.0}) {
        const double peak = argMax([&](double l) { return nebula::planck(l, T); }, 1e-8, 1e-5);
        EXPECT_NEAR(peak / (2.897771955e-3 / T), 1.0, 1e-4) << T;
    }
}

TEST(Planck, StefanBoltzmann)
{
    // int_0^inf B_lambda dlambda = sigma T^4 / pi, sigma = 5.670374419e-8 W m^-2 K^-4
    // (CODATA 2018). Simpson's rule in ln(lambda) over 1e-2 ... 1e3 times the peak; the
    // tails beyond hold less than 1e-8 of the total.
    for (double T : {3000.0, 5772.0, 30000.0}) {
        const double peak = 2.897771955e-3 / T;
        const double a = std::log(1e-2 * peak);
        const double b = std::log(1e3 * peak);
        const int n = 20000;
        const double h = (b - a) / n;
        double sum = 0.0;
        for (int i = 0; i <= n; ++i) {
            const double lambda = std::exp(a + i * h);
            const double w = (i == 0 || i == n) ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0);
            sum += w * nebula::planck(lambda, T) * lambda;
        }
        const double integral = sum * h / 3.0;
        const double expected = 5.670374419e-8 * std::pow(T, 4) / 3.14159265358979323846;
        EXPECT_NEAR(integral / expected, 1.0, 1e-4) << T;
    }
}

TEST(Planck, RejectsNonPositiveInput)
{
    EXPECT_THROW(nebula::planck(0.0, 5000.0), nebula::Error);
    EXPECT_THROW(nebula::planck(5e-7, 0.0), nebula::Error);
    EXPECT_THROW(nebula::planck(5e-7, NAN), nebula::Error);
    EXPECT_THROW(nebula::blackbodyLinearSRGB(-1.0), nebula::Error);
}

// ---------------------------------------------------------------------------------------------
// Black-body colours

double luminance(const std::array<double, 3>& rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

TEST(BlackbodyColour, UnitLuminance)
{
    // Y = 1 up to the rounding of the 4-digit IEC 61966-2-1 matrix.
    for (double T : {1000.0, 1500.0, 3000.0, 5772.0, 10000.0, 42000.0, 1e6}) {
        const auto rgb = nebula::blackbodyLinearSRGB(T);
        EXPECT_NEAR(luminance(rgb), 1.0, 1e-4) << T;
        for (double c : rgb) {
            EXPECT_GE(c, 0.0) << T;
        }
    }
}

TEST(BlackbodyColour, HotIsBlueCoolIsRed)
{
    const auto hot = nebula::blackbodyLinearSRGB(30000.0);
    EXPECT_GT(hot[2], hot[0]);
    const auto cool = nebula::blackbodyLinearSRGB(3000.0);
    EXPECT_GT(cool[0], cool[2]);
}

TEST(BlackbodyColour, NearWhiteAt6500K)
{
    const auto rgb = nebula::blackbodyLinearSRGB(6500.0);
    const double hi = std::max({rgb[0], rgb[1], rgb[2]});
    const double lo = std::min({rgb[0], rgb[1], rgb[2]});
    EXPECT_LT(hi / lo, 1.10);
}

TEST(BlackbodyColour, MatchesCieIntegratedRatios)
{
    // shared/notes/physics-sources.md 4.1, "CIE-1931-integrated linear sRGB", normalised so
    // that the largest channel is 1.
    struct Case
    {
        double T;
        std::array<double, 3> rgb;
    };
    for (const Case& c : {Case{42000, {0.34, 0.48, 1.00}}, Case{30000, {0.36, 0.50, 1.00}},
                          Case{9600, {0.63, 0.71, 1.00}}, Case{7300, {0.86, 0.86, 1.00}},
                          Case{5778, {1.00, 0.88, 0.82}}, Case{5200, {1.00, 0.82, 0.68}},
                          Case{3800, {1.00, 0.63, 0.33}}}) {
        const auto rgb = nebula::blackbodyLinearSRGB(c.T);
        const double max = std::max({rgb[0], rgb[1], rgb[2]});
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(rgb[k] / max, c.rgb[k], 0.03) << "T = " << c.T << ", channel " << k;
        }
    }
}

} // namespace
