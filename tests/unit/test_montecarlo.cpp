// The Monte Carlo core (montecarlo.h): exact bookkeeping, the two estimators against each
// other, determinism, the thin limit, and plane-parallel slabs against published results.
#include "nebula/error.h"
#include "nebula/montecarlo.h"

#include <tbb/task_arena.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace nebula;

namespace {

ScatteringMedium medium(double albedo, double g)
{
    ScatteringMedium m;
    m.albedo = albedo;
    m.g = g;
    return m;
}

McSettings settings(std::uint64_t photons, McEstimator est, int bins = 2)
{
    McSettings s;
    s.photons = photons;
    s.estimator = est;
    s.muBins = bins;
    return s;
}

/// |a - b| within k combined standard errors.
::testing::AssertionResult agree(const Estimate& a, const Estimate& b, double k = 3.0)
{
    const double tol = k * std::hypot(a.error, b.error);
    if (std::abs(a.mean - b.mean) <= tol) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << a.mean << " +- " << a.error << " vs " << b.mean
                                         << " +- " << b.error << " (" << k << " sigma = " << tol
                                         << ")";
}

::testing::AssertionResult agree(const Estimate& a, double published, double k = 3.0)
{
    return agree(a, Estimate{published, 0.0}, k);
}

} // namespace

TEST(MonteCarlo, AnalogBalancesEveryPhotonToRounding)
{
    // MCML bookkeeping: each photon's weight is exactly direct + reflected + transmitted +
    // absorbed - roulette, so the balance has no variance at all.
    for (double tau : {0.1, 2.0, 10.0}) {
        const auto r = runSlab(medium(0.9, 0.75), tau, 1.0, settings(20000, McEstimator::Analog));
        EXPECT_NEAR(r.balance.mean, 1.0, 1e-12) << "tau " << tau;
        EXPECT_LT(r.balance.error, 1e-12);
        // Roulette creates no weight on average.
        EXPECT_TRUE(agree(r.roulette, 0.0, 4.0));
    }
    const auto c = runCube(medium(0.6, 0.6), 3.0, settings(20000, McEstimator::Analog, 16));
    EXPECT_NEAR(c.balance.mean, 1.0, 1e-12);
}

TEST(MonteCarlo, NextEventBalancesInExpectation)
{
    for (double tau : {0.1, 2.0, 10.0}) {
        const auto r =
            runSlab(medium(0.9, 0.75), tau, 0.7, settings(40000, McEstimator::NextEvent, 8));
        EXPECT_TRUE(agree(r.balance, 1.0)) << "tau " << tau;
    }
}

TEST(MonteCarlo, DirectTransmissionIsExpMinusTauOverMu0)
{
    const double tau = 1.3, mu0 = 0.6;
    const auto ne = runSlab(medium(0.7, 0.3), tau, mu0, settings(5000, McEstimator::NextEvent));
    // Forced first interaction: the unscattered part is exact.
    EXPECT_NEAR(ne.direct.mean, std::exp(-tau / mu0), 1e-14);
    const auto an = runSlab(medium(0.7, 0.3), tau, mu0, settings(200000, McEstimator::Analog));
    EXPECT_TRUE(agree(an.direct, std::exp(-tau / mu0)));
    EXPECT_GT(an.direct.error, 0.0);
    // Cube: every photon crosses t along the entry direction.
    const auto c = runCube(medium(0.6, 0.6), 0.5, settings(5000, McEstimator::NextEvent));
    EXPECT_NEAR(c.direct.mean, std::exp(-0.5), 1e-14);
}

TEST(MonteCarlo, EstimatorsAgreeOnSlabsAndCubes)
{
    struct Case
    {
        double a, g, tau, mu0;
    };
    for (const Case& k : {Case{0.6, 0.6, 1.0, 1.0}, Case{0.95, -0.3, 4.0, 0.5},
                          Case{0.3, 0.9, 0.5, 0.8}}) {
        const auto m = medium(k.a, k.g);
        const auto an = runSlab(m, k.tau, k.mu0, settings(300000, McEstimator::Analog, 8));
        const auto ne = runSlab(m, k.tau, k.mu0, settings(30000, McEstimator::NextEvent, 8));
        EXPECT_TRUE(agree(an.reflected, ne.reflected)) << k.a << " " << k.g << " " << k.tau;
        EXPECT_TRUE(agree(an.transmitted, ne.transmitted)) << k.a << " " << k.g << " " << k.tau;
        EXPECT_TRUE(agree(an.absorbed, ne.absorbed)) << k.a << " " << k.g << " " << k.tau;
        for (int b = 0; b < 8; ++b) {
            EXPECT_TRUE(agree(an.perSteradian[b], ne.perSteradian[b])) << "bin " << b;
        }
    }
    const auto m = medium(0.6, 0.6);
    const auto an = runCube(m, 2.0, settings(300000, McEstimator::Analog, 8));
    const auto ne = runCube(m, 2.0, settings(30000, McEstimator::NextEvent, 8));
    for (int b = 0; b < 8; ++b) EXPECT_TRUE(agree(an.perSteradian[b], ne.perSteradian[b])) << b;
}

TEST(MonteCarlo, SameSeedSameResultWhateverTheThreadCount)
{
    const auto m = medium(0.6, 0.6);
    auto s = settings(5000, McEstimator::NextEvent, 16);
    McResult one, two;
    tbb::task_arena(1).execute([&] { one = runCube(m, 1.0, s); });
    tbb::task_arena(2).execute([&] { two = runCube(m, 1.0, s); });
    for (int b = 0; b < 16; ++b) EXPECT_EQ(one.perSteradian[b].mean, two.perSteradian[b].mean);
    EXPECT_EQ(one.absorbed.mean, two.absorbed.mean);
    s.seed = 2;
    const auto other = runCube(m, 1.0, s);
    EXPECT_NE(other.perSteradian[15].mean, one.perSteradian[15].mean);
}

TEST(MonteCarlo, ThinCubeScattersLikeOneEvent)
{
    // t -> 0: one interaction, so the scattered power per sr per unit t is a p(mu), averaged
    // over each bin (DESIGN §4's thin limit). At t = 1e-4 second-order terms are ~1e-4.
    const double t = 1e-4;
    for (double g : {0.6, -0.3, 0.0}) {
        const auto m = medium(0.6, g);
        const int bins = 16;
        const auto r = runCube(m, t, settings(20000, McEstimator::NextEvent, bins));
        const double scattered = -std::expm1(-t);  // fraction that interacts
        for (int b = 0; b < bins; ++b) {
            // Bin average of a p(mu), by Simpson with 64 panels.
            const double lo = r.muEdges[b], hi = r.muEdges[b + 1];
            double s = 0.0;
            for (int i = 0; i <= 64; ++i) {
                const double w = (i == 0 || i == 64) ? 1 : (i % 2 ? 4 : 2);
                s += w * m.phaseFunction(lo + (hi - lo) * i / 64.0);
            }
            const double expected = m.albedo * s / (3.0 * 64.0) * scattered;
            const Estimate& got = r.perSteradian[b];
            EXPECT_NEAR(got.mean, expected, 3.0 * got.error + 2e-4 * expected)
                << "g " << g << " bin " << b;
        }
    }
}

TEST(MonteCarlo, CubeMatchesIndependentVariantBNumbers)
{
    // notes/physics-sources.md §2.3 "variant B" (beam through the voxel), computed with an
    // independent pure-Python Monte Carlo, a = 0.6, g = 0.6, 40,000 photons: scattered
    // escape, its mean cosine, and the unscattered fraction. Tolerances: 3 of that run's
    // standard errors (binomial, ~0.0023 for escape and unscattered; ~0.005 for a mean cosine
    // of ~10^4 escaping photons) plus its rounding to the printed digits.
    struct Row
    {
        double t, escape, meanCos, unscattered;
    };
    const auto m = medium(0.6, 0.6);
    for (const Row& row : {Row{0.1, 0.056, 0.60, 0.905}, Row{1.0, 0.312, 0.54, 0.370},
                           Row{2.0, 0.346, 0.46, 0.135}, Row{5.0, 0.229, 0.25, 0.007},
                           Row{10.0, 0.143, 0.06, 0.000}}) {
        const auto r = runCube(m, row.t, settings(20000, McEstimator::NextEvent, 64));
        const double escape = r.reflected.mean + r.transmitted.mean;
        double first = 0.0;
        for (int b = 0; b < 64; ++b) {
            const double dOmega = 2.0 * 3.14159265358979323846 * (2.0 / 64);
            first += 0.5 * (r.muEdges[b] + r.muEdges[b + 1]) * r.perSteradian[b].mean * dOmega;
        }
        EXPECT_NEAR(escape, row.escape, 0.0075) << "t " << row.t;
        EXPECT_NEAR(first / escape, row.meanCos, 0.02) << "t " << row.t;
        EXPECT_NEAR(r.direct.mean, row.unscattered, 0.0075) << "t " << row.t;
    }
}

TEST(MonteCarlo, RejectsBadParameters)
{
    const auto ok = medium(0.6, 0.6);
    const auto s = settings(100, McEstimator::NextEvent);
    EXPECT_THROW(runSlab(medium(1.2, 0.6), 1.0, 1.0, s), UsageError);
    EXPECT_THROW(runSlab(medium(0.6, 1.0), 1.0, 1.0, s), UsageError);
    EXPECT_THROW(runSlab(ok, 0.0, 1.0, s), UsageError);
    EXPECT_THROW(runSlab(ok, 1.0, 0.0, s), UsageError);
    EXPECT_THROW(runCube(ok, -1.0, s), UsageError);
    auto zero = s;
    zero.photons = 0;
    EXPECT_THROW(runCube(ok, 1.0, zero), UsageError);
    auto odd = s;
    odd.muBins = 3;
    EXPECT_THROW(runCube(ok, 1.0, odd), UsageError);
    auto points = settings(100, McEstimator::Analog);
    points.muPoints = {0.5};
    EXPECT_THROW(runCube(ok, 1.0, points), UsageError);
}
