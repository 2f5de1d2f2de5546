// SPDX-License-Identifier: Apache-2.0
/// @file test_dust.cpp
/// Phase functions (normalisation, asymmetry), the CCM89 extinction curve against published
/// values, the dust parameters' validation and JSON form, and the phase-function samplers
/// (DESIGN §3-4) against their densities: chi-squared goodness of fit in the style of
/// Mitsuba's chi2 tests, mean cosines, exact inverse CDFs, and the scattering frame.

#include "nebula/physics/dust.h"

#include "nebula/core/error.h"
#include "nebula/core/rng.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace {

using nebula::Pcg32;
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
                simpson([&](double mu) { return nebula::phaseFunction(model, mu, g); }, -1.0, 1.0,
                        200000);
            EXPECT_NEAR(integral, 1.0, 1e-6) << nebula::toString(model) << ", g = " << g;
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
    // DESIGN §3.1: sigma_c / sigma_G at 700 / 546.1 / 435.8 nm.
    struct Case
    {
        double R_V, redOverGreen, blueOverGreen;
    };
    for (const Case& c :
         {Case{3.1, 0.745, 1.331}, Case{4.0, 0.772, 1.256}, Case{5.0, 0.791, 1.204}}) {
        const double green = nebula::ccmExtinction(546.1, c.R_V);
        EXPECT_NEAR(nebula::ccmExtinction(700.0, c.R_V) / green, c.redOverGreen, 0.003) << c.R_V;
        EXPECT_NEAR(nebula::ccmExtinction(435.8, c.R_V) / green, c.blueOverGreen, 0.003) << c.R_V;
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
    EXPECT_NO_THROW(nebula::ccmExtinction(125.0, 3.1));  // x = 8
    EXPECT_NO_THROW(nebula::ccmExtinction(3333.0, 3.1)); // x ~ 0.3
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

    // Wrong type.
    std::string message = fromJson("{" + complete + R"(, "R_V": "3.1"})");
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

// ---------------------------------------------------------------------------------------------
// Chi-squared machinery

/// Regularized upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a): the series
/// for P = 1 - Q when x < a + 1, else the continued fraction for Q by the modified Lentz
/// method (Numerical Recipes, 3rd ed., section 6.2). Relative accuracy ~1e-14.
double gammaQ(double a, double x)
{
    if (x <= 0.0) {
        return 1.0;
    }
    const double logPrefactor = -x + a * std::log(x) - std::lgamma(a);
    if (x < a + 1.0) {
        double term = 1.0 / a;
        double sum = term;
        for (int n = 1; n < 10000 && std::fabs(term) > 1e-16 * std::fabs(sum); ++n) {
            term *= x / (a + n);
            sum += term;
        }
        return 1.0 - sum * std::exp(logPrefactor);
    }
    constexpr double TINY = 1e-300;
    double b = x + 1.0 - a;
    double c = 1.0 / TINY;
    double d = 1.0 / b;
    double h = d;
    for (int i = 1; i < 10000; ++i) {
        const double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        d = std::fabs(d) < TINY ? TINY : d;
        c = b + an / c;
        c = std::fabs(c) < TINY ? TINY : c;
        d = 1.0 / d;
        const double delta = d * c;
        h *= delta;
        if (std::fabs(delta - 1.0) < 1e-16) {
            break;
        }
    }
    return std::exp(logPrefactor) * h;
}

/// P(X >= chi2) for X chi-squared distributed with @p dof degrees of freedom.
double chiSquaredPValue(double chi2, int dof)
{
    return gammaQ(0.5 * dof, 0.5 * chi2);
}

struct ChiSquaredResult
{
    double statistic = 0.0; ///< sum (O - E)^2 / E over the merged cells
    int dof = 0;            ///< merged cells - 1
    double pValue = 0.0;
};

/// Pearson's chi-squared test of @p observed counts against @p expected counts. Adjacent
/// cells are pooled until each pooled cell expects at least @p minExpected; a remainder at the
/// end joins the last pooled cell.
ChiSquaredResult chiSquaredTest(const std::vector<double>& observed,
                                const std::vector<double>& expected, double minExpected = 5.0)
{
    std::vector<double> obs;
    std::vector<double> exp;
    double poolObs = 0.0;
    double poolExp = 0.0;
    for (size_t i = 0; i < observed.size(); ++i) {
        poolObs += observed[i];
        poolExp += expected[i];
        if (poolExp >= minExpected) {
            obs.push_back(poolObs);
            exp.push_back(poolExp);
            poolObs = poolExp = 0.0;
        }
    }
    if (poolExp > 0.0 || poolObs > 0.0) {
        if (exp.empty()) {
            obs.push_back(poolObs);
            exp.push_back(poolExp);
        } else {
            obs.back() += poolObs;
            exp.back() += poolExp;
        }
    }

    ChiSquaredResult result;
    for (size_t i = 0; i < obs.size(); ++i) {
        const double diff = obs[i] - exp[i];
        result.statistic += diff * diff / exp[i];
    }
    result.dof = static_cast<int>(obs.size()) - 1;
    result.pValue = chiSquaredPValue(result.statistic, result.dof);
    return result;
}

constexpr int CHI2_SAMPLES = 1000000;
constexpr int CHI2_BINS = 100;     // equal width in mu over [-1, 1]
constexpr int SIMPSON_STEPS = 200; // per bin
constexpr double CHI2_MIN_P = 0.01;
constexpr uint64_t SEED = 20240611;

/// Draws CHI2_SAMPLES cosines from (@p sampleModel, @p sampleG) on stream @p stream and tests
/// them against the density 2 pi p(mu) of (@p densityModel, @p densityG).
ChiSquaredResult chiSquaredOfSampler(PhaseModel sampleModel, double sampleG,
                                     PhaseModel densityModel, double densityG, uint64_t stream)
{
    std::vector<double> observed(CHI2_BINS, 0.0);
    Pcg32 rng(stream, SEED);
    for (int i = 0; i < CHI2_SAMPLES; ++i) {
        const double mu = nebula::samplePhaseCosine(sampleModel, sampleG, rng.uniformDouble());
        const int bin = std::min(CHI2_BINS - 1, static_cast<int>(0.5 * (mu + 1.0) * CHI2_BINS));
        observed[bin] += 1.0;
    }

    // Expected counts: N * integral of 2 pi p(mu) over each bin.
    std::vector<double> expected(CHI2_BINS);
    double total = 0.0;
    for (int k = 0; k < CHI2_BINS; ++k) {
        const double lo = -1.0 + 2.0 * k / CHI2_BINS;
        const double hi = -1.0 + 2.0 * (k + 1) / CHI2_BINS;
        const double probability = simpson(
            [&](double mu) {
                return 2.0 * nebula::PI * nebula::phaseFunction(densityModel, mu, densityG);
            },
            lo, hi, SIMPSON_STEPS);
        expected[k] = CHI2_SAMPLES * probability;
        total += probability;
    }
    // Simpson leaves ~4e-9 of the total at g = 0.9 (its peak at mu = 1): 0.004 counts.
    EXPECT_NEAR(total, 1.0, 1e-6) << "density not normalised: " << nebula::toString(densityModel);
    return chiSquaredTest(observed, expected);
}

struct SamplerCase
{
    PhaseModel model;
    double g;
};

constexpr SamplerCase SAMPLER_CASES[] = {
    {PhaseModel::HenyeyGreenstein, -0.3}, {PhaseModel::HenyeyGreenstein, 0.0},
    {PhaseModel::HenyeyGreenstein, 0.6},  {PhaseModel::HenyeyGreenstein, 0.9},
    {PhaseModel::Rayleigh, 0.0},          {PhaseModel::MieHazy, 0.0},
    {PhaseModel::MieMurky, 0.0},
};

double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/// Uniformly distributed unit vector (Archimedes: z uniform in [-1, 1], azimuth uniform).
void uniformSphere(Pcg32& rng, double out[3])
{
    const double z = 2.0 * rng.uniformDouble() - 1.0;
    const double r = std::sqrt(std::fmax(0.0, 1.0 - z * z));
    const double phi = 2.0 * nebula::PI * rng.uniformDouble();
    out[0] = r * std::cos(phi);
    out[1] = r * std::sin(phi);
    out[2] = z;
}

// ---------------------------------------------------------------------------------------------
// Phase-function sampling

TEST(PhaseSampling, ChiSquaredPValueMatchesClosedFormsAndTables)
{
    // dof 1: Q(1/2, x/2) = erfc(sqrt(x/2)); dof 2: Q(1, x/2) = exp(-x/2). Both branches
    // (series below a + 1, continued fraction above) are exercised.
    for (double chi2 : {0.1, 0.5, 1.0, 3.841, 10.0, 30.0}) {
        EXPECT_NEAR(chiSquaredPValue(chi2, 1), std::erfc(std::sqrt(0.5 * chi2)),
                    1e-12 * std::erfc(std::sqrt(0.5 * chi2)) + 1e-15)
            << chi2;
        EXPECT_NEAR(chiSquaredPValue(chi2, 2), std::exp(-0.5 * chi2),
                    1e-12 * std::exp(-0.5 * chi2) + 1e-15)
            << chi2;
    }
    // Tabulated critical values (NIST/SEMATECH e-Handbook, table 1.3.6.7.4), 3-4 digits.
    EXPECT_NEAR(chiSquaredPValue(134.642, 99), 0.01, 2e-5);
    EXPECT_NEAR(chiSquaredPValue(123.225, 99), 0.05, 2e-5);
    EXPECT_NEAR(chiSquaredPValue(18.307, 10), 0.05, 2e-5);
}

TEST(PhaseSampling, EverySamplerPassesChiSquaredAgainstItsDensity)
{
    // 1e6 samples in 100 equal-width mu bins, expected counts by Simpson (200 steps per bin),
    // cells pooled to >= 5 expected, p > 0.01. Fixed seed and one stream per case, so the
    // test is deterministic.
    uint64_t stream = 100;
    for (const SamplerCase& c : SAMPLER_CASES) {
        const ChiSquaredResult r = chiSquaredOfSampler(c.model, c.g, c.model, c.g, stream++);
        EXPECT_GT(r.pValue, CHI2_MIN_P)
            << nebula::toString(c.model) << ", g = " << c.g << ": chi2 = " << r.statistic
            << " with " << r.dof << " dof";
    }
}

TEST(PhaseSampling, ChiSquaredDetectsAWrongAsymmetry)
{
    // The test's power: HG samples for g = 0.6 against the density for g = 0.55 must fail.
    const ChiSquaredResult r = chiSquaredOfSampler(PhaseModel::HenyeyGreenstein, 0.6,
                                                   PhaseModel::HenyeyGreenstein, 0.55, 200);
    EXPECT_LT(r.pValue, 1e-6) << "chi2 = " << r.statistic << " with " << r.dof << " dof";
}

TEST(PhaseSampling, HenyeyGreensteinMeanCosineIsG)
{
    // Mean of the sampled mu equals g (forward for g > 0) within 4 standard errors.
    constexpr int N = 400000;
    uint64_t stream = 300;
    for (double g : {-0.3, 0.0, 0.3, 0.6, 0.9}) {
        Pcg32 rng(stream++, SEED);
        double sum = 0.0;
        double sumSq = 0.0;
        for (int i = 0; i < N; ++i) {
            const double mu =
                nebula::samplePhaseCosine(PhaseModel::HenyeyGreenstein, g, rng.uniformDouble());
            sum += mu;
            sumSq += mu * mu;
        }
        const double mean = sum / N;
        const double variance = (sumSq - N * mean * mean) / (N - 1);
        EXPECT_NEAR(mean, g, 4.0 * std::sqrt(variance / N)) << g;
    }
}

TEST(PhaseSampling, HenyeyGreensteinMatchesTextbookInverseCdf)
{
    // The rearranged sampler against the textbook inverse CDF evaluated in long double (which
    // keeps ~15 digits even at g = 1e-4, where the 1/(2g) costs 4 of its 19). Exact at g = 0.
    for (double g : {-0.9, -0.3, -1e-4, 1e-4, 0.3, 0.6, 0.9}) {
        for (int i = 0; i <= 64; ++i) {
            const double u = std::min(i / 64.0, 1.0 - 0x1p-53);
            const long double gl = g;
            const long double s = (1.0L - gl * gl) / (1.0L - gl + 2.0L * gl * u);
            const long double textbook = (1.0L + gl * gl - s * s) / (2.0L * gl);
            EXPECT_NEAR(nebula::samplePhaseCosine(PhaseModel::HenyeyGreenstein, g, u),
                        static_cast<double>(textbook), 1e-12)
                << "g = " << g << ", u = " << u;
        }
    }
    for (double u : {0.0, 0.25, 0.5, 0.7, 0.999}) {
        EXPECT_EQ(nebula::samplePhaseCosine(PhaseModel::HenyeyGreenstein, 0.0, u), 2.0 * u - 1.0);
    }
}

TEST(PhaseSampling, RayleighInvertsItsCdfAndEndsAreExact)
{
    // CDF (mu^3 + 3 mu + 4)/8 of the sampled mu returns u.
    for (int i = 0; i <= 64; ++i) {
        const double u = std::min(i / 64.0, 1.0 - 0x1p-53);
        const double mu = nebula::samplePhaseCosine(PhaseModel::Rayleigh, 0.0, u);
        EXPECT_NEAR((mu * mu * mu + 3.0 * mu + 4.0) / 8.0, u, 1e-15) << u;
    }
    // Every sampler maps [0, 1) into [-1, 1], starting at -1.
    for (const SamplerCase& c : SAMPLER_CASES) {
        EXPECT_NEAR(nebula::samplePhaseCosine(c.model, c.g, 0.0), -1.0, 1e-14)
            << nebula::toString(c.model);
        const double top = nebula::samplePhaseCosine(c.model, c.g, 1.0 - 0x1p-53);
        EXPECT_TRUE(top <= 1.0 && top > 0.999) << nebula::toString(c.model) << ": " << top;
    }
}

TEST(PhaseSampling, SampleDirectionIsUnitAtCosineMu)
{
    // Unit length and dot(in, out) = mu to 1e-12, for random directions and the frame's
    // awkward cases (poles, -z where Duff et al.'s sign flips, just off -z, the equator).
    std::vector<std::array<double, 3>> ins = {
        {0.0, 0.0, 1.0}, {0.0, 0.0, -1.0}, {1.0, 0.0, 0.0}, {0.0, -1.0, 0.0}};
    const double eps = 1e-9;
    ins.push_back({eps, 0.0, -std::sqrt(1.0 - eps * eps)});
    ins.push_back({0.0, eps, std::sqrt(1.0 - eps * eps)});
    Pcg32 rng(400, SEED);
    for (int i = 0; i < 200; ++i) {
        std::array<double, 3> v;
        uniformSphere(rng, v.data());
        ins.push_back(v);
    }
    for (const auto& in : ins) {
        for (int j = 0; j < 20; ++j) {
            const double mu = j < 5 ? -1.0 + 0.5 * j : 2.0 * rng.uniformDouble() - 1.0;
            const double phi = 2.0 * nebula::PI * rng.uniformDouble();
            double out[3];
            nebula::sampleDirection(mu, phi, in.data(), out);
            EXPECT_NEAR(std::sqrt(dot(out, out)), 1.0, 1e-12);
            EXPECT_NEAR(dot(out, in.data()), mu, 1e-12)
                << "in = (" << in[0] << ", " << in[1] << ", " << in[2] << ")";
        }
    }
}

TEST(PhaseSampling, UniformAzimuthGivesZeroMeanTransverseComponent)
{
    // out - mu in averages to zero over phi uniform in [0, 2 pi): each component within 4
    // standard errors, for HG-distributed mu about a few incoming directions.
    constexpr int N = 100000;
    const double ins[][3] = {{0.0, 0.0, 1.0}, {0.0, 0.0, -1.0}, {0.48, -0.6, 0.64}};
    Pcg32 rng(500, SEED);
    for (const auto& in : ins) {
        double sum[3] = {0.0, 0.0, 0.0};
        double sumSq[3] = {0.0, 0.0, 0.0};
        for (int i = 0; i < N; ++i) {
            const double mu =
                nebula::samplePhaseCosine(PhaseModel::HenyeyGreenstein, 0.6, rng.uniformDouble());
            const double phi = 2.0 * nebula::PI * rng.uniformDouble();
            double out[3];
            nebula::sampleDirection(mu, phi, in, out);
            for (int k = 0; k < 3; ++k) {
                const double t = out[k] - mu * in[k];
                sum[k] += t;
                sumSq[k] += t * t;
            }
        }
        for (int k = 0; k < 3; ++k) {
            const double mean = sum[k] / N;
            const double variance = (sumSq[k] - N * mean * mean) / (N - 1);
            EXPECT_NEAR(mean, 0.0, 4.0 * std::sqrt(variance / N) + 1e-15)
                << "component " << k << ", in = (" << in[0] << ", " << in[1] << ", " << in[2]
                << ")";
        }
    }
}

} // namespace

// A nebula:dust that lacks fields takes the defaults for them and lists them (in toJson()'s
// order) for the caller's warning; unknown fields are ignored.
TEST(DustParams, PartialJsonTakesTheDefaultsAndListsThem)
{
    const nebula::DustParams defaults;
    std::vector<std::string> missing{"stale"};
    const auto d = nebula::DustParams::fromJson(
        R"({"R_V": 5.0, "albedo": 0.3, "future_field": [1, 2]})", "cloud.vdb", &missing);
    EXPECT_EQ(d.albedo, 0.3);
    EXPECT_EQ(d.R_V, 5.0);
    EXPECT_EQ(d.kappa_V, defaults.kappa_V);
    EXPECT_EQ(d.g, defaults.g);
    EXPECT_EQ(d.phase, defaults.phase);
    EXPECT_EQ(d.curve, defaults.curve);
    EXPECT_EQ(missing, (std::vector<std::string>{"kappa_V", "g", "phase", "curve"}));
    EXPECT_EQ(d.missingFieldsText(missing), "kappa_V = 0.0015, g = 0.6, phase = hg, curve = CCM89");

    // Complete: nothing missing. Empty object: everything, all defaults.
    const auto full = nebula::DustParams::fromJson(defaults.toJson(), "a", &missing);
    EXPECT_TRUE(missing.empty());
    EXPECT_EQ(full.toJson(), defaults.toJson());
    const auto none = nebula::DustParams::fromJson("{}", "a", &missing);
    EXPECT_EQ(missing.size(), 6u);
    EXPECT_EQ(none.toJson(), defaults.toJson());
    // Without a list to fill, a partial object is read all the same.
    EXPECT_EQ(nebula::DustParams::fromJson(R"({"g": -0.2})", "a").g, -0.2);
}
