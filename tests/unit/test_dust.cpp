/// @file test_dust.cpp
/// Phase functions (normalisation, asymmetry), the CCM89 extinction curve against published
/// values, and the dust parameters' validation and JSON form.

#include "nebula/physics/dust.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <functional>
#include <string>

namespace {

using nebula::PhaseModel;

using nebula::test::simpson;

using nebula::test::contains;
using nebula::test::errorMessage;

constexpr PhaseModel ALL_MODELS[] = {PhaseModel::HenyeyGreenstein, PhaseModel::Rayleigh,
                                     PhaseModel::MieHazy, PhaseModel::MieMurky};
constexpr double ASYMMETRIES[] = {-0.3, 0.0, 0.3, 0.6, 0.9};

// ---------------------------------------------------------------------------------------------
// Phase functions

TEST(PhaseFunction, NormalisedOverTheSphere)
{
    // 2 pi * int_{-1}^{1} p(mu) dmu = 1 (azimuthal symmetry), within 1e-6.
    for (PhaseModel model : ALL_MODELS) {
        for (double g : ASYMMETRIES) {
            const double integral =
                2.0 * nebula::PI *
                simpson([&](double mu) { return nebula::phaseFunction(model, mu, g); }, -1.0,
                        1.0, 200000);
            EXPECT_NEAR(integral, 1.0, 1e-6)
                << nebula::toString(model) << ", g = " << g;
        }
    }
}

TEST(PhaseFunction, HenyeyGreensteinScattersForwardForPositiveG)
{
    for (double g : {0.1, 0.3, 0.6, 0.9}) {
        EXPECT_GT(nebula::henyeyGreenstein(1.0, g), nebula::henyeyGreenstein(-1.0, g)) << g;
        EXPECT_LT(nebula::henyeyGreenstein(1.0, -g), nebula::henyeyGreenstein(-1.0, -g)) << g;
    }
    // g = 0 is isotropic.
    EXPECT_NEAR(nebula::henyeyGreenstein(0.3, 0.0), nebula::INV_FOUR_PI, 1e-15);
}

TEST(PhaseFunction, HenyeyGreensteinMeanCosineIsG)
{
    for (double g : ASYMMETRIES) {
        const double meanCosine =
            2.0 * nebula::PI *
            simpson([&](double mu) { return mu * nebula::henyeyGreenstein(mu, g); }, -1.0, 1.0,
                    200000);
        EXPECT_NEAR(meanCosine, g, 1e-6) << g;
    }
}

TEST(PhaseFunction, MieApproximationsScatterForward)
{
    for (PhaseModel model : {PhaseModel::MieHazy, PhaseModel::MieMurky}) {
        EXPECT_GT(nebula::phaseFunction(model, 1.0, 0.0), nebula::phaseFunction(model, -1.0, 0.0));
    }
    // Rayleigh is symmetric.
    EXPECT_DOUBLE_EQ(nebula::phaseFunction(PhaseModel::Rayleigh, 0.7, 0.0),
                     nebula::phaseFunction(PhaseModel::Rayleigh, -0.7, 0.0));
}

TEST(PhaseFunction, PhaseFunctionMatchesInlineHenyeyGreenstein)
{
    EXPECT_EQ(nebula::phaseFunction(PhaseModel::HenyeyGreenstein, 0.25, 0.6),
              nebula::henyeyGreenstein(0.25, 0.6));
}

TEST(PhaseModelNames, RoundTripAndReject)
{
    for (PhaseModel model : ALL_MODELS) {
        EXPECT_EQ(nebula::phaseModelFromString(nebula::toString(model)), model);
    }
    EXPECT_EQ(nebula::toString(PhaseModel::HenyeyGreenstein), "hg");
    const std::string message = errorMessage([] { nebula::phaseModelFromString("mie"); });
    EXPECT_TRUE(contains(message, "\"mie\"")) << message;
    EXPECT_TRUE(contains(message, "hg, rayleigh, hazy, murky")) << message;
}

// ---------------------------------------------------------------------------------------------
// CCM89 extinction curve

TEST(CcmExtinction, PublishedValues)
{
    // DustExtinction.jl documentation, CCM89 with R_V = 3.1: 1.46456 at 4000 A and 1.12225
    // at 5000 A.
    EXPECT_NEAR(nebula::ccmExtinction(400.0, 3.1), 1.46456, 1e-4);
    EXPECT_NEAR(nebula::ccmExtinction(500.0, 3.1), 1.12225, 1e-4);
}

TEST(CcmExtinction, UnityAtV)
{
    // x = 1.82 um^-1 (549.45 nm) is the expansion point: a = 1, b = 0.
    for (double R_V : {2.5, 3.1, 5.0}) {
        EXPECT_NEAR(nebula::ccmExtinction(549.0, R_V), 1.0, 0.01) << R_V;
        EXPECT_NEAR(nebula::ccmExtinction(1000.0 / 1.82, R_V), 1.0, 1e-12) << R_V;
    }
}

TEST(CcmExtinction, BBandIsOnePlusInverseRV)
{
    // A_B / A_V = (A_V + E(B-V)) / A_V = 1 + 1/R_V, with B at 440 nm.
    for (double R_V : {3.1, 5.0}) {
        const double expected = 1.0 + 1.0 / R_V;
        EXPECT_NEAR(nebula::ccmExtinction(440.0, R_V) / expected, 1.0, 0.02) << R_V;
    }
}

TEST(CcmExtinction, ChannelRatios)
{
    // shared/notes/physics-sources.md 4.2: sigma_c / sigma_G at 700 / 546.1 / 435.8 nm.
    struct Case
    {
        double R_V, redOverGreen, blueOverGreen;
    };
    for (const Case& c : {Case{3.1, 0.745, 1.331}, Case{4.0, 0.772, 1.256},
                          Case{5.0, 0.791, 1.204}}) {
        const double green = nebula::ccmExtinction(546.1, c.R_V);
        EXPECT_NEAR(nebula::ccmExtinction(700.0, c.R_V) / green, c.redOverGreen, 0.003) << c.R_V;
        EXPECT_NEAR(nebula::ccmExtinction(435.8, c.R_V) / green, c.blueOverGreen, 0.003)
            << c.R_V;
    }
}

TEST(CcmExtinction, PiecesJoinContinuously)
{
    // The curve's pieces meet at x = 1.1 and 3.3 um^-1 to within the fit's accuracy, and
    // the far-UV term Fa, Fb vanishes at x = 5.9.
    for (double x : {1.1, 3.3, 5.9}) {
        const double below = nebula::ccmExtinction(1000.0 / (x - 1e-9), 3.1);
        const double above = nebula::ccmExtinction(1000.0 / (x + 1e-9), 3.1);
        EXPECT_NEAR(below, above, 0.02) << "x = " << x;
    }
}

TEST(CcmExtinction, UltravioletBump)
{
    // The 2175 A bump (x = 4.6 um^-1) stands above both of its sides (x = 4.0 and 5.5),
    // and the far-UV rise makes 125 nm (x = 8) more opaque than 160 nm (x = 6.25).
    EXPECT_GT(nebula::ccmExtinction(217.5, 3.1), nebula::ccmExtinction(250.0, 3.1));
    EXPECT_GT(nebula::ccmExtinction(217.5, 3.1), nebula::ccmExtinction(180.0, 3.1));
    EXPECT_GT(nebula::ccmExtinction(125.0, 3.1), nebula::ccmExtinction(160.0, 3.1));
}

TEST(CcmExtinction, RejectsOutOfRange)
{
    EXPECT_NO_THROW(nebula::ccmExtinction(125.0, 3.1));   // x = 8
    EXPECT_NO_THROW(nebula::ccmExtinction(3333.0, 3.1));  // x ~ 0.3
    const std::string message = errorMessage([] { nebula::ccmExtinction(100.0, 3.1); });
    EXPECT_TRUE(contains(message, "100 nm")) << message;
    EXPECT_THROW(nebula::ccmExtinction(5000.0, 3.1), nebula::Error);
    EXPECT_THROW(nebula::ccmExtinction(-500.0, 3.1), nebula::Error);
    EXPECT_THROW(nebula::ccmExtinction(550.0, 0.0), nebula::Error);
}

// ---------------------------------------------------------------------------------------------
// DustParams

TEST(DustParams, DefaultsAreValid)
{
    EXPECT_NO_THROW(nebula::DustParams{}.validate());
}

TEST(DustParams, ValidateNamesTheParameter)
{
    struct Case
    {
        std::function<void(nebula::DustParams&)> spoil;
        const char* name;
    };
    const Case cases[] = {
        {[](auto& p) { p.kappa_V = 0.0; }, "kappa_V"},
        {[](auto& p) { p.kappa_V = INFINITY; }, "kappa_V"},
        {[](auto& p) { p.albedo = 1.2; }, "albedo"},
        {[](auto& p) { p.albedo = -0.1; }, "albedo"},
        {[](auto& p) { p.albedo = NAN; }, "albedo"},
        {[](auto& p) { p.g = 1.0; }, "g"},
        {[](auto& p) { p.g = -1.5; }, "g"},
        {[](auto& p) { p.R_V = -3.1; }, "R_V"},
        {[](auto& p) { p.curve = "F99"; }, "curve"},
    };
    for (const Case& c : cases) {
        nebula::DustParams params;
        c.spoil(params);
        try {
            params.validate();
            ADD_FAILURE() << "no UsageError for " << c.name;
        } catch (const nebula::UsageError& e) {
            EXPECT_TRUE(contains(e.what(), std::string(" ") + c.name + " ")) << e.what();
        }
    }
    // The boundaries that are allowed.
    nebula::DustParams params;
    params.albedo = 0.0;
    EXPECT_NO_THROW(params.validate());
    params.albedo = 1.0;
    params.g = -0.99;
    EXPECT_NO_THROW(params.validate());
}

TEST(DustParams, JsonRoundTrip)
{
    nebula::DustParams params;
    params.kappa_V = 1.234567890123e-3;
    params.albedo = 0.3;
    params.g = -0.45;
    params.phase = PhaseModel::MieMurky;
    params.R_V = 5.0;
    const nebula::DustParams back = nebula::DustParams::fromJson(params.toJson(), "test");
    EXPECT_EQ(back.kappa_V, params.kappa_V);
    EXPECT_EQ(back.albedo, params.albedo);
    EXPECT_EQ(back.g, params.g);
    EXPECT_EQ(back.phase, params.phase);
    EXPECT_EQ(back.curve, params.curve);
    EXPECT_EQ(back.R_V, params.R_V);

    for (PhaseModel model : ALL_MODELS) {
        nebula::DustParams p;
        p.phase = model;
        EXPECT_EQ(nebula::DustParams::fromJson(p.toJson(), "test").phase, model);
    }
}

TEST(DustParams, JsonHasTheDocumentedFields)
{
    const std::string json = nebula::DustParams{}.toJson();
    for (const char* key : {"\"kappa_V\"", "\"albedo\"", "\"g\"", "\"phase\":\"hg\"",
                            "\"curve\":\"CCM89\"", "\"R_V\""}) {
        EXPECT_TRUE(contains(json, key)) << json;
    }
}

TEST(DustParams, JsonErrors)
{
    const auto fromJson = [](const std::string& text) {
        return errorMessage([&] { nebula::DustParams::fromJson(text, "cloud.vdb"); });
    };
    const std::string complete =
        R"("kappa_V": 0.0015, "albedo": 0.6, "g": 0.6, "phase": "hg", "curve": "CCM89")";

    // Missing field: names the source and the field.
    std::string message = fromJson("{" + complete + "}");
    EXPECT_EQ(message, "cloud.vdb: dust parameters: missing field \"R_V\"");
    message = fromJson(R"({"kappa_V": 0.0015, "g": 0.6, "phase": "hg", "curve": "CCM89",
                           "R_V": 3.1})");
    EXPECT_EQ(message, "cloud.vdb: dust parameters: missing field \"albedo\"");

    // Wrong type.
    message = fromJson("{" + complete + R"(, "R_V": "3.1"})");
    EXPECT_TRUE(contains(message, "cloud.vdb: ")) << message;
    EXPECT_TRUE(contains(message, "\"R_V\" must be a number, got a string")) << message;

    // Unknown phase model.
    message = fromJson(R"({"kappa_V": 0.0015, "albedo": 0.6, "g": 0.6, "phase": "mie",
                           "curve": "CCM89", "R_V": 3.1})");
    EXPECT_TRUE(contains(message, "cloud.vdb: ")) << message;
    EXPECT_TRUE(contains(message, "\"mie\"")) << message;

    // Out of range: a data error (Error, not UsageError) that names the parameter.
    try {
        nebula::DustParams::fromJson(R"({"kappa_V": 0.0015, "albedo": 1.5, "g": 0.6,
                                         "phase": "hg", "curve": "CCM89", "R_V": 3.1})",
                                     "cloud.vdb");
        ADD_FAILURE() << "no Error";
    } catch (const nebula::UsageError& e) {
        ADD_FAILURE() << "UsageError for a file's value: " << e.what();
    } catch (const nebula::Error& e) {
        EXPECT_TRUE(contains(e.what(), "cloud.vdb: ")) << e.what();
        EXPECT_TRUE(contains(e.what(), "albedo")) << e.what();
    }

    // Not JSON, not an object.
    message = fromJson("{kappa_V: 1}");
    EXPECT_EQ(message.rfind("cloud.vdb: dust parameters: not valid JSON: ", 0), 0u) << message;
    message = fromJson("[1, 2]");
    EXPECT_TRUE(contains(message, "expected a JSON object")) << message;
}

} // namespace
