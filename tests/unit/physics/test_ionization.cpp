// SPDX-License-Identifier: Apache-2.0
// Photoionisation (nebionize, DESIGN §16) against closed forms, photon conservation and a
// brute-force reference.
#include "nebula/physics/ionization.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/physics/stars.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace nebula;

namespace {

/// A cube lattice of edge @p n (points 0 .. n-1) filled by f(i, j, k) [cm^-3].
template <typename F> SparseVolume makeVolume(int n, F f)
{
    SparseVolume v({0, 0, 0}, {n, n, n}, 1);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                v.writable(v.index(i, j, k))[0] = float(f(i, j, k));
    return v;
}

IonizingStar star(const Vec3& p, double q, double T = 40000.0)
{
    IonizingStar s;
    s.name = "s";
    s.position = p;
    s.rates = ionizingRates(1e5, T, q);
    s.temperature = T;
    return s;
}

/// Pure hydrogen at 10^4 K, no dust, voxels of @p voxelPc.
IonizationParams hydrogen(double voxelPc, double spacing = 1.0)
{
    IonizationParams p;
    p.electronTemperature = 1e4;
    p.abundances.he = 0.0;
    p.voxelSizeCm = voxelPc * PC_CM;
    p.raySpacing = spacing;
    return p;
}

/// Sum over the lattice of alpha_B n_e n_p x V [s^-1] and of x V [voxels].
struct Totals
{
    double recombinations = 0, volume = 0;
};
Totals totals(const IonizationSolver& solver, const SparseVolume& n, const IonizationParams& p)
{
    Totals t;
    const double alpha = caseBRecombinationH(p.electronTemperature);
    const auto d = n.dims();
    for (int k = 0; k < d[2]; ++k)
        for (int j = 0; j < d[1]; ++j)
            for (int i = 0; i < d[0]; ++i) {
                const auto v = solver.at(i, j, k);
                const double nH = n.voxel(n.index(i, j, k))[0];
                t.recombinations += alpha * v.ne * nH * v.hii * std::pow(p.voxelSizeCm, 3);
                t.volume += v.hii;
            }
    return t;
}

/// An fBm-like lognormal field: a sum of random plane waves, ln n with sigma ~ 1.
SparseVolume clumpy(int n, unsigned seed)
{
    std::mt19937 rng(seed);
    std::normal_distribution<double> g(0.0, 1.0);
    std::uniform_real_distribution<double> phase(0.0, 2 * PI);
    struct Wave
    {
        Vec3 k;
        double a, phi;
    };
    std::vector<Wave> waves;
    for (int w = 0; w < 60; ++w) {
        const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
        const double kk = 2 * PI / n * (1 + 7 * std::abs(g(rng)));
        waves.push_back({dir * kk, std::pow(kk * n / (2 * PI), -0.9), phase(rng)});
    }
    double norm = 0;
    for (const auto& w : waves)
        norm += w.a * w.a / 2;
    norm = std::sqrt(norm);
    return makeVolume(n, [&](int i, int j, int k) {
        double s = 0;
        for (const auto& w : waves)
            s += w.a * std::cos(w.k.dot(Vec3(i, j, k)) + w.phi);
        return 100.0 * std::exp(s / norm - 0.5);
    });
}

} // namespace

TEST(Photoionization, CaseBAndBalmerTables)
{
    EXPECT_NEAR(caseBRecombinationH(1e4), 2.59e-13, 1e-18);
    EXPECT_NEAR(caseBRecombinationH(5000), 4.54e-13, 1e-18);
    EXPECT_NEAR(caseBRecombinationH(20000), 1.43e-13, 1e-18);
    EXPECT_NEAR(balmerDecrement(1e4), 2.86, 1e-12);
    EXPECT_NEAR(hBetaEmissivity(1e4), 1.24e-25, 1e-30);
    // Monotonic between the tabulated points.
    EXPECT_GT(caseBRecombinationH(8000), caseBRecombinationH(1e4));
    EXPECT_LT(caseBRecombinationH(8000), caseBRecombinationH(5000));
    // alpha_eff(H-beta) / alpha_B = 0.117 at 10^4 K (AGN2: 3.03e-14 / 2.59e-13).
    EXPECT_NEAR(hBetaEffectiveRecombination(1e4) / caseBRecombinationH(1e4), 0.117, 0.002);
    EXPECT_THROW(caseBRecombinationH(-1.0), Error);
}

TEST(Photoionization, BlackbodyPhotonRatesAgainstQuadrature)
{
    // The fraction of photons above x0 against Simpson's rule of x^2 / (e^x - 1).
    for (double T : {20000.0, 40000.0, 60000.0}) {
        const double x0 = H_IONIZATION_EV / (8.617333262e-5 * T);
        double num = 0, den = 0;
        const int n = 200000;
        const double h = 80.0 / n;
        for (int i = 1; i <= n; ++i) {
            const double x = h * i;
            const double w = (i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
            const double f = x * x / std::expm1(x);
            den += w * f;
            if (x >= x0) num += w * f;
        }
        EXPECT_NEAR(blackbodyPhotonFraction(T, H_IONIZATION_EV), num / den, 2e-4) << T;
    }
    // Q(H0) of a 40 kK, 2e5 L_sun black body: L / kT * 15 / pi^4 * tail(3.945) = 1.05e49.
    EXPECT_NEAR(blackbodyPhotonRate(2e5, 40000, H_IONIZATION_EV) / 1.05e49, 1.0, 0.01);
    // A given Q keeps the black body's hardness.
    const auto r = ionizingRates(2e5, 40000, 1e49);
    EXPECT_DOUBLE_EQ(r.h, 1e49);
    EXPECT_NEAR(r.he / r.h,
                blackbodyPhotonFraction(40000, HE_IONIZATION_EV) /
                    blackbodyPhotonFraction(40000, H_IONIZATION_EV),
                1e-12);
    EXPECT_DOUBLE_EQ(ionizingRates(2e5, 40000, 1e49, 3e47).oiii, 3e47);
}

TEST(Photoionization, ForbiddenLinesFollowTheirAtomicData)
{
    // [O III] 5007 / 4959 = 2.98 (Storey & Zeippen 2000), independent of T and n_e.
    const auto& o3 = oiiiLevels();
    EXPECT_NEAR(forbiddenEmissivity(o3[0], 1e4, 100) / forbiddenEmissivity(o3[1], 1e4, 100), 2.98,
                0.02);
    // The low-density [S II] 6716/6731 ratio is ~1.45-1.5; it falls towards 0.44 at high n_e.
    const auto& s2 = siiLevels();
    const double low = forbiddenEmissivity(s2[0], 1e4, 1) / forbiddenEmissivity(s2[1], 1e4, 1);
    const double high = forbiddenEmissivity(s2[0], 1e4, 1e6) / forbiddenEmissivity(s2[1], 1e4, 1e6);
    EXPECT_NEAR(low, 1.5, 0.06);
    EXPECT_NEAR(high, 0.44, 0.03);
    // Collisional excitation: exp(-E/kT) makes [O III] much weaker at 8000 K than at 10^4 K.
    const double ratio =
        forbiddenEmissivitySum(o3, 8000, 100) / forbiddenEmissivitySum(o3, 1e4, 100);
    EXPECT_NEAR(
        ratio, std::sqrt(1e4 / 8000) * std::exp(-o3[0].energyK / 8000 + o3[0].energyK / 1e4), 1e-3);
    EXPECT_EQ(forbiddenLineList(o3, 1e4, 100), "[O III]5007:1,[O III]4959:0.3359");
}

TEST(Photoionization, AbundancesParse)
{
    const auto a = parseAbundances("he=0,o=5e-4", "--abundances");
    EXPECT_EQ(a.he, 0.0);
    EXPECT_EQ(a.o, 5e-4);
    EXPECT_EQ(a.n, Abundances{}.n);
    for (const char* bad : {"he", "x=1", "o=-1", "o=2", "o=abc", ""}) {
        EXPECT_THROW(parseAbundances(bad, "--abundances"), Error) << bad;
    }
}

// Stromgren sphere (DESIGN §16; Iliev et al. 2006, test 1): uniform n_H = 100 cm^-3, Q =
// 1e49 s^-1, T = 10^4 K: R_S = (3 Q / (4 pi n^2 alpha_B))^(1/3) = 3.154 pc, at 20 voxels a
// radius. The ionised volume's radius and the front along the axes within 1 %.
TEST(Ionization, StromgrenSphere)
{
    const double RS = std::cbrt(3 * 1e49 / (4 * PI * 1e4 * 2.59e-13)) / PC_CM;
    EXPECT_NEAR(RS, 3.154, 0.001);
    const int N = 48;
    const double h = RS / 20.0;
    const auto n = makeVolume(N, [](int, int, int) { return 100.0; });
    const auto p = hydrogen(h);
    IonizationSolver solver(n, {star(Vec3(23.5, 23.5, 23.5), 1e49)}, p);
    solver.solve();
    const Totals t = totals(solver, n, p);
    const double R = std::cbrt(3 * t.volume / (4 * PI)) * h;
    EXPECT_NEAR(R / RS, 1.0, 0.01);
    for (const Vec3& d : {Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(1, 1, 1), Vec3(-1, 2, 0.5)})
        EXPECT_NEAR(solver.frontDistance(0, d) * h / RS, 1.0, 0.01);
    // A front voxel is partly ionised; none deep inside or far outside is.
    int partial = 0;
    for (int i = 24; i < N; ++i) {
        const double x = solver.at(i, 23, 23).hii;
        const double r = (i - 23.5) * h;
        if (r < RS - 2 * h) {
            EXPECT_EQ(x, 1.0);
        }
        if (r > RS + 2 * h) {
            EXPECT_EQ(x, 0.0);
        }
        if (x > 0 && x < 1) ++partial;
    }
    EXPECT_GE(partial, 1);
    EXPECT_NEAR(solver.photons()[0].recombined / 1e49, 1.0, 1e-9);
}

// An electron temperature per voxel (channel 1) replaces the parameter: at 20000 K alpha_B is
// 1.43e-13, and the Strömgren sphere is (2.59 / 1.43)^(1/3) = 1.22 times larger.
TEST(Ionization, TemperatureChannelSetsRecombination)
{
    const int N = 48;
    SparseVolume n({0, 0, 0}, {N, N, N}, 2);
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                float* v = n.writable(n.index(i, j, k));
                v[0] = 100.0f;
                v[1] = 20000.0f;
            }
    const double RS = std::cbrt(3 * 1e49 / (4 * PI * 1e4 * 1.43e-13)) / PC_CM;
    const double h = RS / 20.0;
    const auto p = hydrogen(h);
    IonizationSolver solver(n, {star(Vec3(23.5, 23.5, 23.5), 1e49)}, p);
    solver.solve();
    double volume = 0;
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i)
                volume += solver.at(i, j, k).hii;
    EXPECT_NEAR(std::cbrt(3 * volume / (4 * PI)) * h / RS, 1.0, 0.01);
    EXPECT_EQ(solver.at(23, 23, 23).te, 20000.0);
}

// Photon conservation in a clumpy lognormal field whose front stays inside the grid: the
// grid's recombinations equal Q within 1 %.
TEST(Ionization, PhotonConservationClumpy)
{
    const int N = 48;
    const auto n = clumpy(N, 7);
    const auto p = hydrogen(0.15);
    const double Q = 1e47;
    IonizationSolver solver(n, {star(Vec3(20.2, 25.7, 23.1), Q)}, p);
    solver.solve();
    EXPECT_EQ(solver.photons()[0].escaped, 0.0);
    EXPECT_NEAR(totals(solver, n, p).recombinations / Q, 1.0, 0.01);
}

// Two stars whose H II regions overlap: the recombinations of the grid equal Q1 + Q2 within
// 1 %, and the union is larger than each alone (they share the overlap's recombinations).
TEST(Ionization, TwoOverlappingStarsConservePhotons)
{
    const int N = 56;
    const auto n = makeVolume(N, [](int, int, int) { return 100.0; });
    const auto p = hydrogen(0.12);
    IonizationSolver both(n, {star(Vec3(20, 27.5, 27.5), 1.5e48), star(Vec3(35, 27.5, 27.5), 1e48)},
                          p);
    both.solve();
    EXPECT_GT(both.iterations(), 1);
    const Totals t = totals(both, n, p);
    EXPECT_NEAR(t.recombinations / 2.5e48, 1.0, 0.01);
    EXPECT_EQ(both.photons()[0].escaped + both.photons()[1].escaped, 0.0);
    // Uniform gas: the joint region holds as much as one sphere of 2.5e48 photons would.
    const double single = 2.5e48 / (1e4 * 2.59e-13 * std::pow(0.12 * PC_CM, 3));
    EXPECT_NEAR(t.volume / single, 1.0, 0.01);
}

// Dust absorbs ionising photons: with it the H II region is smaller and the photons the dust
// took plus the recombinations are Q.
TEST(Ionization, DustTakesItsShare)
{
    const int N = 48;
    const auto n = makeVolume(N, [](int, int, int) { return 100.0; });
    auto p = hydrogen(0.1575);
    p.dustCrossSection = 1e-21;
    IonizationSolver solver(n, {star(Vec3(23.5, 23.5, 23.5), 1e49)}, p);
    solver.solve();
    const auto& ph = solver.photons()[0];
    EXPECT_GT(ph.dust, 0.05 * 1e49);
    EXPECT_NEAR((ph.dust + ph.recombined) / 1e49, 1.0, 1e-9);
    EXPECT_NEAR(totals(solver, n, p).recombinations / ph.recombined, 1.0, 0.01);
}

// A Q that ionises more than the grid holds is not an error: the rest escapes.
TEST(Ionization, EscapingPhotonsAreCounted)
{
    const auto n = makeVolume(16, [](int, int, int) { return 10.0; });
    const auto p = hydrogen(0.1);
    IonizationSolver solver(n, {star(Vec3(7.5, 7.5, 7.5), 1e49)}, p);
    solver.solve();
    const auto& ph = solver.photons()[0];
    EXPECT_NEAR(ph.openSolidAngle / (4 * PI), 1.0, 1e-9);
    EXPECT_NEAR((ph.escaped + ph.recombined) / 1e49, 1.0, 1e-9);
    EXPECT_GT(ph.escaped, 0.99e49);
    EXPECT_EQ(solver.at(0, 0, 0).hii, 1.0);
}

// Shadow: an opaque sphere of radius a at distance D from the star leaves a neutral cone of
// half-angle asin(a / D) behind it; outside the cone the gas is ionised.
TEST(Ionization, OpaqueSphereCastsAConeShadow)
{
    const int N = 64;
    const Vec3 s(8, 31.5, 31.5), c(22, 31.5, 31.5);
    const double a = 4.0;
    const auto n = makeVolume(
        N, [&](int i, int j, int k) { return (Vec3(i, j, k) - c).length() < a ? 1e7 : 1.0; });
    const auto p = hydrogen(0.1);
    IonizationSolver solver(n, {star(s, 1e49)}, p);
    solver.solve();
    const double half = std::asin(a / (c - s).length());
    int inCone = 0, outCone = 0;
    for (int k = 0; k < N; k += 3)
        for (int j = 0; j < N; j += 3)
            for (int i = 34; i < N; i += 3) { // well behind the sphere
                const Vec3 d = Vec3(i, j, k) - s;
                const double angle = std::acos(d.dot(Vec3(1, 0, 0)) / d.length());
                const double x = solver.at(i, j, k).hii;
                if (angle < half - 0.06) {
                    EXPECT_EQ(x, 0.0) << i << " " << j << " " << k;
                    ++inCone;
                } else if (angle > half + 0.06) {
                    EXPECT_EQ(x, 1.0) << i << " " << j << " " << k;
                    ++outCone;
                }
            }
    EXPECT_GT(inCone, 20);
    EXPECT_GT(outCone, 100);
}

// Against the brute-force reference (a long characteristic per sample point; 16^2 lines
// through a front voxel, each cut where it leaves the H II region): the H+ fraction of every voxel
// within 1 % (fine rays, so each voxel sees many).
TEST(Ionization, AgreesWithBruteForceReference)
{
    const int N = 18;
    const auto n = makeVolume(N, [](int i, int j, int k) {
        return 100.0 * (1.0 + 0.3 * std::sin(0.5 * i) * std::cos(0.4 * j + 0.3 * k));
    });
    const auto p = hydrogen(0.25, 0.1);
    const IonizingStar s = star(Vec3(8.3, 8.9, 8.1), 2e47);
    IonizationSolver solver(n, {s}, p);
    solver.solve();
    const auto ref = ionizationReference(n, s, p, 16);
    int fronts = 0;
    double worst = 0;
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                const double x = solver.at(i, j, k).hii, r = ref[n.index(i, j, k)];
                worst = std::max(worst, std::fabs(x - r));
                if (r > 0 && r < 1) ++fronts;
            }
    EXPECT_GT(fronts, 100); // the front crosses many voxels: the test sees it
    EXPECT_LT(worst, 0.01);
}

TEST(Stars, IonizingRatesParse)
{
    const auto s = parseStars(R"([{"name":"a","position":[0,0,0],"luminosity":1e5,
        "temperature":40000,"Q":1e49,"Q_OIII":1e47}])",
                              "x");
    EXPECT_EQ(s[0].ionizingRate, 1e49);
    EXPECT_EQ(s[0].oiiiRate, 1e47);
    EXPECT_EQ(parseStars(starsToJson(s), "y")[0].ionizingRate, 1e49);
    // Q without a temperature: refused, named.
    try {
        parseStars(R"([{"name":"a","position":[0,0,0],"luminosity":1,"Q":1e49}])", "x.json");
        FAIL();
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("x.json: star 1 (\"a\"): \"Q\" needs the star's "
                                             "\"temperature\""),
                  std::string::npos)
            << e.what();
    }
    EXPECT_THROW(parseStars(R"([{"name":"a","position":[0,0,0],"luminosity":1,
        "temperature":4e4,"Q":-1}])",
                            "x"),
                 Error);
    EXPECT_THROW(parseStars(R"([{"name":"a","position":[0,0,0],"luminosity":1,
        "temperature":4e4,"Q":1e47,"Q_OIII":1e48}])",
                            "x"),
                 Error);
}

// One collisionally excited line at low density cools by n_e n_ion q_12 k E, q_12 = 8.629e-6
// Omega / (g_1 sqrt(T)) exp(-E / kT) (AGN2 eq. 3.20); at the critical density n_c = A / q_21
// half of that.
TEST(Photoionization, LineCoolingAgainstTheTwoLevelClosedForm)
{
    const auto& lines = coolingTransitions();
    ASSERT_GE(lines.size(), 10u);
    const double k = 1.380649e-16;
    for (const auto& t : lines) {
        for (double T : {6000.0, 8000.0, 12000.0}) {
            const double q12 =
                8.629e-6 * t.omega / (t.gLower * std::sqrt(T)) * std::exp(-t.energyK / T);
            EXPECT_NEAR(transitionCooling(t, T, 1e-6) / (q12 * k * t.energyK), 1.0, 1e-6) << t.name;
            const double nc = t.einsteinA / (8.629e-6 * t.omega / (t.gUpper * std::sqrt(T)));
            EXPECT_NEAR(transitionCooling(t, T, nc) / (q12 * k * t.energyK), 0.5, 1e-9) << t.name;
        }
    }
    // [O III] 88 um: E / k = 163 K, so q_12 k E barely depends on T (1 / sqrt(T)), while the
    // optical 5007 (E / k = 29170 K) grows as exp(-E / kT) / sqrt(T).
    const auto find = [&](const std::string& name) {
        for (const auto& t : lines)
            if (name == t.name) return t;
        ADD_FAILURE() << name;
        return lines[0];
    };
    const auto ir = find("[O III] 88 um"), optical = find("[O III] 4959/5007");
    EXPECT_NEAR(transitionCooling(ir, 16000, 1) / transitionCooling(ir, 8000, 1),
                std::sqrt(0.5) * std::exp(-163.0 / 16000 + 163.0 / 8000), 1e-3);
    EXPECT_NEAR(transitionCooling(optical, 10000, 1) / transitionCooling(optical, 8000, 1),
                std::sqrt(0.8) * std::exp(optical.energyK / 8000 - optical.energyK / 10000), 1e-4);
}

// A pure hydrogen gas heated by eps per recombination balances where eps alpha_B = alpha_B k T
// (0.684 - 0.0416 ln(T / 10^4 K)) + 1.42e-27 g_ff sqrt(T): with eps chosen for 7000 K, the
// balance is 7000 K. Metals cool: the same heating gives a cooler gas, O++ (its 88/52 um and
// optical lines) cooler still than O+.
TEST(Photoionization, ThermalBalanceOfAKnownHeating)
{
    const double k = 1.380649e-16, T0 = 7000.0;
    const double eps = k * T0 * (0.684 - 0.0416 * std::log(T0 / 1e4)) +
                       1.42e-27 * 1.3 * std::sqrt(T0) / caseBRecombinationH(T0);
    Abundances none;
    none.he = none.n = none.o = none.s = none.ne = 0.0;
    const PhotoHeating heat{eps, 0.0};
    const IonisedGas gas{100.0, 0.0, 0.0};
    EXPECT_NEAR(thermalBalanceTemperature(gas, none, heat) / T0, 1.0, 1e-6);
    const double pure = heatingRate(T0, gas, none, heat) / coolingRate(T0, gas, none);
    EXPECT_NEAR(pure, 1.0, 1e-9);

    const Abundances lexington; // the defaults
    const PhotoHeating star = blackbodyHeating(40000.0);
    EXPECT_NEAR(star.h / 1.602176634e-12, 3.78, 0.02); // mean excess of 13.6-24.6 eV photons
    const double oii = thermalBalanceTemperature({100.0, 1.0, 0.0}, lexington, star);
    const double oiii = thermalBalanceTemperature({100.0, 1.0, 1.0}, lexington, star);
    EXPECT_LT(oiii, oii);
    EXPECT_GT(oiii, 5000.0);
    EXPECT_LT(oii, 11000.0);
    // Dense gas: the IR lines are collisionally de-excited (n_c of [O III] 88 um ~ 500 cm^-3),
    // so it cools less and is warmer.
    EXPECT_GT(thermalBalanceTemperature({1e5, 1.0, 1.0}, lexington, star), oiii + 500.0);
}

// Cross-sections in AGN2's power-law form: a_T at the threshold, none below; a black body's
// photons above 35.1 eV meet a smaller He0 cross-section than those from 24.6 to 35.1 eV.
TEST(Photoionization, BandCrossSectionsAndChargeExchange)
{
    EXPECT_DOUBLE_EQ(HE0_CROSS_SECTION.at(HE_IONIZATION_EV), 7.83e-18);
    EXPECT_EQ(HE0_CROSS_SECTION.at(24.0), 0.0);
    EXPECT_DOUBLE_EQ(OII_CROSS_SECTION.at(OII_IONIZATION_EV), 7.32e-18);
    const auto b = bandCrossSections(40000.0);
    EXPECT_LT(b.heHard, b.heSoft);
    EXPECT_GT(b.heSoft, 5e-18);
    EXPECT_LT(b.heSoft, 7.83e-18);
    // H0 above 35.1 eV: 6.3e-18 (13.6 / E)^3 is below its value at 35.1 eV.
    EXPECT_LT(b.hHard, 6.30e-18 * std::pow(H_IONIZATION_EV / OII_IONIZATION_EV, 3));
    EXPECT_NEAR(b.hAll, meanHydrogenCrossSection(40000.0), 1e-30);
    // Kingdon & Ferland 1996 at 10^4 K: 1.04e-9 (1 - 0.61 e^-9.73).
    EXPECT_NEAR(chargeExchangeOIII(1e4), 1.04e-9 * (1 - 0.61 * std::exp(-9.73)), 1e-15);
}

// A star whose He-ionising photons all lie above 35.1 eV (Q_OIII = Q_He): they pay all the
// He0 photoionisations, so O++ ends where He+ does, well inside the H front. The He+ front
// lies between (3 Q_He / (4 pi n_e n_He alpha))^(1/3) (n_e = n_H (1 + y)) with alpha = alpha_B
// (the He ground recombinations' photons all reabsorbed by He0, deep inside) and alpha_B +
// alpha_1 (all taken by H0, at the front). Inside, O+ is photoionised (O++ > 0.5 near the
// star), beyond it O++ is 0. Half the hard photons: the O++ zone still ends at the He+ front
// (they outlast the softer ones), but O++/O is lower.
TEST(Ionization, OiiiZoneEndsWhereHardPhotonsRunOut)
{
    const int N = 48;
    const auto n = makeVolume(N, [](int, int, int) { return 100.0; });
    IonizationParams p;
    p.electronTemperature = 1e4;
    p.abundances.he = 0.1;
    p.abundances.o = 1e-12; // no O++ recombinations to pay
    p.voxelSizeCm = 0.15 * PC_CM;
    p.raySpacing = 0.5;
    const double Q = 1e49;
    IonizingStar s = star(Vec3(23.5, 23.5, 23.5), Q);
    s.rates.he = 0.03 * Q;
    s.rates.oiii = s.rates.he;
    const double ne = 100.0 * 1.1, nHe = 10.0;
    const double RHe =
        std::cbrt(3 * s.rates.he / (4 * PI * ne * nHe * caseBRecombinationHe(1e4))) / p.voxelSizeCm;
    const double RH =
        std::cbrt(3 * Q / (4 * PI * 100.0 * 100.0 * caseBRecombinationH(1e4))) / p.voxelSizeCm;
    const double RHeA =
        RHe * std::cbrt(caseBRecombinationHe(1e4) / (caseBRecombinationHe(1e4) + 1.59e-13));
    ASSERT_LT(RHe, 0.8 * RH);
    ASSERT_LT(RH, 23.0);
    const auto profile = [&](double hard, double r) {
        IonizingStar t = s;
        t.rates.oiii = hard * s.rates.he;
        IonizationSolver solver(n, {t}, p);
        solver.solve();
        const int i = int(std::lround(23.5 + r));
        return solver.at(i, 23, 23);
    };
    for (double hard : {1.0, 0.5}) {
        EXPECT_GT(profile(hard, 0.3 * RHe).oiii, hard * 0.5) << hard;
        EXPECT_EQ(profile(hard, RHe + 1.5).oiii, 0.0) << hard;
        EXPECT_GT(profile(hard, RHe + 1.5).hii, 0.99) << hard; // inside the H front
        EXPECT_GT(profile(hard, RHeA - 1.5).heii, 0.99) << hard;
        EXPECT_GT(profile(hard, RHeA - 1.5).oiii, 0.0) << hard;
    }
    EXPECT_LT(profile(0.5, 0.6 * RHe).oiii, profile(1.0, 0.6 * RHe).oiii);
}

// With the thermal balance the rays pay recombinations at each voxel's own T_e; the grid's
// recombinations at the voxels' T_e still equal the photons, for one star in clumpy gas and
// for two overlapping H II regions (T_e there the mean of the stars', as they share).
TEST(Ionization, ThermalBalanceConservesPhotons)
{
    const auto check = [](const SparseVolume& n, std::vector<IonizingStar> stars, double voxelPc) {
        IonizationParams p;
        p.thermalBalance = true;
        p.voxelSizeCm = voxelPc * PC_CM;
        p.raySpacing = 0.5;
        double Q = 0;
        for (const auto& s : stars)
            Q += s.rates.h;
        IonizationSolver solver(n, std::move(stars), p);
        solver.solve();
        const auto d = n.dims();
        double rec = 0, tMin = 1e9, tMax = 0;
        for (int k = 0; k < d[2]; ++k)
            for (int j = 0; j < d[1]; ++j)
                for (int i = 0; i < d[0]; ++i) {
                    const auto v = solver.at(i, j, k);
                    if (v.hii <= 0) continue;
                    rec += caseBRecombinationH(v.te) * v.ne * n.voxel(n.index(i, j, k))[0] * v.hii *
                           std::pow(p.voxelSizeCm, 3);
                    tMin = std::min(tMin, v.te);
                    tMax = std::max(tMax, v.te);
                }
        EXPECT_NEAR(rec / Q, 1.0, 0.01);
        EXPECT_GT(tMin, 5000.0);
        EXPECT_LT(tMax, 12000.0);
        EXPECT_GT(tMax, tMin); // the O++ zone is cooler than the O+ zone
    };
    check(clumpy(48, 7), {star(Vec3(20.2, 25.7, 23.1), 1e47)}, 0.15);
    const auto flat = makeVolume(56, [](int, int, int) { return 100.0; });
    check(flat, {star(Vec3(20, 27.5, 27.5), 1.5e48), star(Vec3(35, 27.5, 27.5), 1e48)}, 0.12);
}
