/// @file test_lines.cpp
/// Spectral inputs: the emission-line catalogue, line lists and their metadata, the
/// temperature grid's check, and nebgen's dust temperature (radiative equilibrium).

#include "nebula/physics/lines.h"

#include "nebula/core/error.h"
#include "nebula/io/spectral_grids.h"
#include "nebula/stages/generate.h"

#include "test_util.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

// ---- catalogue -------------------------------------------------------------------------

TEST(LineCatalogue, AirWavelengthsOfNistAsd)
{
    // Air wavelengths [nm] (NIST ASD; Osterbrock & Ferland 2006), to 0.01 nm.
    const std::pair<const char*, double> expected[] = {
        {"H-alpha", 656.28},     {"H-beta", 486.13},      {"H-gamma", 434.05},
        {"H-delta", 410.17},     {"[O III]5007", 500.68}, {"[O III]4959", 495.89},
        {"[N II]6583", 658.35},  {"[N II]6548", 654.80},  {"[S II]6716", 671.64},
        {"[S II]6731", 673.08},  {"He I 5876", 587.56},
    };
    for (const auto& [name, nm] : expected) {
        EXPECT_DOUBLE_EQ(nebula::lineWavelength(name), nm) << name;
    }
    const auto names = nebula::knownLines();
    ASSERT_EQ(names.size(), std::size(expected));
    for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(names[i], expected[i].first);
}

TEST(LineCatalogue, UnknownNamesListTheKnownOnesWithHints)
{
    std::string msg = errorMessage([] { nebula::lineWavelength("H-epsilon"); });
    EXPECT_TRUE(contains(msg, "unknown emission line \"H-epsilon\"")) << msg;
    for (const auto& name : nebula::knownLines()) EXPECT_TRUE(contains(msg, name)) << msg;
    EXPECT_FALSE(contains(msg, "did you mean")) << msg;

    // Case-sensitive, but a case (or punctuation) slip gets a hint.
    msg = errorMessage([] { nebula::lineWavelength("h-alpha"); });
    EXPECT_TRUE(contains(msg, "did you mean \"H-alpha\"?")) << msg;
    msg = errorMessage([] { nebula::lineWavelength("Halpha"); });
    EXPECT_TRUE(contains(msg, "did you mean \"H-alpha\"?")) << msg;
    msg = errorMessage([] { nebula::lineWavelength("OIII"); });
    EXPECT_TRUE(contains(msg, "did you mean \"[O III]5007\" or \"[O III]4959\"?")) << msg;
    msg = errorMessage([] { nebula::lineWavelength("he i 5876"); });
    EXPECT_TRUE(contains(msg, "did you mean \"He I 5876\"?")) << msg;
}

// ---- line lists ------------------------------------------------------------------------

TEST(LineList, ParsesNamesStrengthsAndCustomWavelengths)
{
    auto lines = nebula::parseLineList(nebula::DEFAULT_EMISSION_LINES, "--lines");
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0], (nebula::SpectralLine{"H-alpha", 656.28, 1.0}));
    EXPECT_EQ(lines[1], (nebula::SpectralLine{"H-beta", 486.13, 0.35}));

    // Strength 1 when omitted, spaces around items ignored, names with spaces kept.
    lines = nebula::parseLineList(" [O III]5007 , He I 5876:0.2, 1000 ", "x");
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[0], (nebula::SpectralLine{"[O III]5007", 500.68, 1.0}));
    EXPECT_EQ(lines[1], (nebula::SpectralLine{"He I 5876", 587.56, 0.2}));
    EXPECT_EQ(lines[2], (nebula::SpectralLine{"1000", 1000.0, 1.0}));
}

TEST(LineList, CustomWavelengthsAndRoundTrip)
{
    const auto lines = nebula::parseLineList("H-alpha:2.5,372.71:0.125,[S II]6731:1e-3", "t");
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[1], (nebula::SpectralLine{"372.71", 372.71, 0.125}));
    const std::string text = nebula::lineListToString(lines);
    EXPECT_EQ(text, "H-alpha:2.5,372.71:0.125,[S II]6731:0.001");
    EXPECT_EQ(nebula::parseLineList(text, "t"), lines);

    // Awkward doubles survive the round trip exactly (shortest round-trip decimals).
    const std::vector<nebula::SpectralLine> odd = {{"H-beta", 486.13, 1.0 / 3.0},
                                                   {"0.1", 0.1, 2.0 / 7.0}};
    EXPECT_EQ(nebula::parseLineList(nebula::lineListToString(odd), "t"), odd);
    // A custom line written under another name is written as its wavelength.
    EXPECT_EQ(nebula::lineListToString({{"mine", 501.5, 1.0}}), "501.5:1");
    EXPECT_EQ(nebula::lineListToString(
                  nebula::parseLineList(nebula::OIII_EMISSION_LINES, "t")),
              nebula::OIII_EMISSION_LINES);
}

TEST(LineList, EachErrorNamesSourceAndItem)
{
    struct Case
    {
        const char* text;
        const char* mention;
    };
    const Case cases[] = {
        {"", "empty line list"},
        {"   ", "empty line list"},
        {"H-alpha,", "item 2 is empty"},
        {",H-alpha", "item 1 is empty"},
        {"H-alpha,,H-beta", "item 2 is empty"},
        {"H-alfa:1", "item 1 (\"H-alfa:1\"): unknown emission line \"H-alfa\""},
        {"H-beta,h-alpha", "did you mean \"H-alpha\"?"},
        {"H-alpha:", "no strength after ':'"},
        {":0.5", "no line name before ':'"},
        {"H-alpha:abc", "strength \"abc\" is not a number"},
        {"H-alpha:1x", "strength \"1x\" is not a number"},
        {"H-alpha:0", "strength must be a finite number > 0, got 0"},
        {"H-alpha:-1", "strength must be a finite number > 0, got -1"},
        {"H-alpha:1e999", "strength must be a finite number > 0, got 1e999"},
        {"H-alpha:nan", "strength \"nan\" is not a number"},
        {"H-alpha:inf", "strength \"inf\" is not a number"},
        {"0:1", "custom wavelength must be a finite number > 0 [nm], got 0"},
        {"-500:1", "custom wavelength must be a finite number > 0 [nm], got -500"},
        {"1e999", "custom wavelength must be a finite number > 0 [nm], got 1e999"},
        {"H-alpha,H-beta,H-alpha:2", "item 3 (\"H-alpha:2\"): \"H-alpha\" (656.28 nm) is listed "
                                     "twice, also as item 1"},
        {"H-alpha,656.28:0.1", "listed twice, also as item 1"},
        {"500.5,500.50", "listed twice, also as item 1"},
    };
    for (const auto& c : cases) {
        const std::string msg = errorMessage([&] { nebula::parseLineList(c.text, "--lines"); });
        EXPECT_EQ(msg.rfind("--lines \"" + std::string(c.text) + "\": ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, c.mention)) << "for \"" << c.text << "\": " << msg;
    }
    // An unknown name lists the catalogue and the custom-wavelength form.
    const std::string msg = errorMessage([] { nebula::parseLineList("Lyman-alpha", "cfg"); });
    EXPECT_TRUE(contains(msg, "\"[S II]6716\"")) << msg;
    EXPECT_TRUE(contains(msg, "rest wavelength in nm")) << msg;
}

// ---- grid metadata ---------------------------------------------------------------------

TEST(GridLines, MetadataOrFallback)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("emission");
    const std::vector<nebula::SpectralLine> fallback = {{"H-alpha", 656.28, 1.0}};
    EXPECT_EQ(nebula::gridLines(*grid, "a.vdb", fallback), fallback);

    grid->insertMeta(nebula::META_LINES, openvdb::StringMetadata("[N II]6583:0.3,H-alpha"));
    const auto lines = nebula::gridLines(*grid, "a.vdb", fallback);
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0].name, "[N II]6583");
    EXPECT_DOUBLE_EQ(lines[0].strength, 0.3);

    grid->removeMeta(nebula::META_LINES);
    grid->insertMeta(nebula::META_LINES, openvdb::StringMetadata("H-alpha:-2"));
    std::string msg = errorMessage([&] { nebula::gridLines(*grid, "a.vdb", fallback); });
    EXPECT_EQ(msg.rfind("a.vdb: grid \"emission\" metadata nebula:lines \"H-alpha:-2\": ", 0), 0u)
        << msg;
    EXPECT_TRUE(contains(msg, "strength must be a finite number > 0")) << msg;

    grid->removeMeta(nebula::META_LINES);
    grid->insertMeta(nebula::META_LINES, openvdb::FloatMetadata(1.0f));
    msg = errorMessage([&] { nebula::gridLines(*grid, "a.vdb", fallback); });
    EXPECT_TRUE(contains(msg, "a.vdb: grid \"emission\" metadata nebula:lines is a float, "
                              "expected a string"))
        << msg;
}

// ---- temperature -----------------------------------------------------------------------

TEST(TemperatureGrid, RejectsNegativeNanAndInfinite)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("temperature");
    grid->tree().setValue(openvdb::Coord(1, 2, 3), 20.0f);
    grid->tree().setValue(openvdb::Coord(0, 0, 0), 0.0f);  // active 0 K is allowed
    EXPECT_NO_THROW(nebula::requireValidTemperature(*grid, "t.vdb"));

    const std::pair<float, const char*> bad[] = {
        {-1.0f, "a negative temperature -1"},
        {std::numeric_limits<float>::quiet_NaN(), "a NaN temperature"},
        {std::numeric_limits<float>::infinity(), "an infinite temperature"},
    };
    for (const auto& [value, mention] : bad) {
        auto g = grid->deepCopy();
        g->tree().setValue(openvdb::Coord(4, 5, 6), value);
        const std::string msg = errorMessage([&] { nebula::requireValidTemperature(*g, "t.vdb"); });
        EXPECT_EQ(msg.rfind("t.vdb: grid \"temperature\" has ", 0), 0u) << msg;
        EXPECT_TRUE(contains(msg, mention)) << msg;
        EXPECT_TRUE(contains(msg, "at voxel (4, 5, 6)")) << msg;
        EXPECT_TRUE(contains(msg, "expected finite temperatures >= 0 [K]")) << msg;
    }
}

TEST(DustTemperature, RadiativeEquilibriumWithTheStars)
{
    // U of a 1 L_sun star at 1 pc, by hand: L_sun / (4 pi pc^2 c u_ISRF) =
    // 3.828e33 / (4 pi (3.0857e18)^2 * 2.9979e10 * 8.64e-13) = 1.2351e-3.
    nebula::Star sun;
    sun.position = {1.0, 2.0, 3.0};
    sun.luminosity = 1.0;
    EXPECT_NEAR(nebula::radiationFieldU({2.0, 2.0, 3.0}, {sun}, 0.01), 1.2351e-3, 1e-6);
    // Inverse square, linear in L, summed over stars, clamped at rMin.
    nebula::Star big = sun;
    big.luminosity = 8000.0;
    const double U1 = nebula::radiationFieldU({1.0, 2.0, 5.0}, {big}, 0.01);
    EXPECT_NEAR(U1, 8000.0 * 1.2351e-3 / 4.0, 1e-3 * U1);
    EXPECT_NEAR(nebula::radiationFieldU({1.0, 2.0, 5.0}, {big, sun}, 0.01),
                U1 + nebula::radiationFieldU({1.0, 2.0, 5.0}, {sun}, 0.01), 1e-12 * U1);
    EXPECT_DOUBLE_EQ(nebula::radiationFieldU(sun.position, {sun}, 0.5),
                     nebula::radiationFieldU({1.5, 2.0, 3.0}, {sun}, 0.5));
    EXPECT_EQ(nebula::radiationFieldU({0, 0, 0}, {}, 0.5), 0.0);

    // T = 16.4 K (1 + U)^(1/6): the interstellar field alone gives 16.4 K * 2^(1/6).
    EXPECT_DOUBLE_EQ(nebula::dustTemperature(0.0), 16.4);
    EXPECT_NEAR(nebula::dustTemperature(1.0), 18.408, 1e-3);
    EXPECT_NEAR(nebula::dustTemperature(63.0), 32.8, 1e-9);      // 64^(1/6) = 2
    EXPECT_NEAR(nebula::dustTemperature(4095.0), 65.6, 1e-9);    // 4096^(1/6) = 4
}

} // namespace
