// SPDX-License-Identifier: Apache-2.0
// LognormalField (physics/turbulence.h): the statistics it promises, checked on the lattice.
#include "nebula/physics/cloud_statistics.h"
#include "nebula/physics/turbulence.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using nebula::LognormalField;
using nebula::TurbulenceParams;

namespace {

/// The lattice's values summed along z: a map whose power spectrum is the field's at k_z = 0
/// (the projection-slice theorem), so its slope is the 3-D spectrum's.
nebula::ColumnMap projectS(const LognormalField& f)
{
    const int n = f.lattice();
    nebula::ColumnMap map;
    map.nu = map.nv = n;
    map.values.assign(std::size_t(n) * n, 0.0);
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            double s = 0.0;
            for (int k = 0; k < n; ++k)
                s += f.at(i, j, k);
            map.values[std::size_t(j) * n + i] = s;
        }
    }
    return map;
}

struct Moments
{
    double mean = 0.0, sd = 0.0, meanExp = 0.0;
};

Moments moments(const LognormalField& f)
{
    const int n = f.lattice();
    double s = 0.0, q = 0.0, e = 0.0;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            for (int k = 0; k < n; ++k) {
                const double v = f.at(i, j, k);
                s += v;
                q += v * v;
                e += std::exp(v);
            }
        }
    }
    const double c = double(n) * n * n;
    return {s / c, std::sqrt(q / c - (s / c) * (s / c)), e / c};
}

} // namespace

TEST(Turbulence, SigmaFollowsMachAndForcing)
{
    // sigma_s^2 = ln(1 + b^2 M^2) (Federrath et al. 2008): e.g. M = 5, b = 0.4 gives
    // sqrt(ln 5) = 1.2686.
    TurbulenceParams p;
    p.mach = 5.0;
    p.forcingB = 0.4;
    EXPECT_NEAR(p.sigmaS(), 1.2686, 1e-4);
    for (double b : {1.0 / 3.0, 1.0}) {
        for (double mach : {2.0, 5.0, 10.0}) {
            p.mach = mach;
            p.forcingB = b;
            const LognormalField f(p, 32, 7);
            const Moments m = moments(f);
            const double sigma = std::sqrt(std::log(1.0 + b * b * mach * mach));
            EXPECT_NEAR(m.sd, sigma, 1e-4 * sigma) << "M " << mach << " b " << b;
            EXPECT_NEAR(m.mean, -0.5 * sigma * sigma, 1e-4) << "M " << mach << " b " << b;
        }
    }
}

TEST(Turbulence, MassIsConservedForModerateMach)
{
    // <exp(s)> = 1 for a Gaussian s of mean -sigma^2 / 2: the lattice's sample mean, over 64^3
    // points of a field whose outer scale is an eighth of the cube (512 independent cells),
    // within 5 % for sigma_s up to 1.1 (M = 4, b = 0.4).
    TurbulenceParams p;
    p.outerScale = 0.125;
    for (double mach : {2.0, 4.0}) {
        p.mach = mach;
        const LognormalField f(p, 64, 3);
        EXPECT_NEAR(moments(f).meanExp, 1.0, 0.05) << "M " << mach;
    }
}

TEST(Turbulence, PowerSpectrumHasTheIndex)
{
    // P_s(k) ~ (k^2 + k0^2)^(-index/2): well above k0 = 1 the slope is -index. The projected
    // lattice's ring spectrum over k = 4-16 (64^3) within 0.2 of it.
    for (double index : {2.5, 3.6}) {
        TurbulenceParams p;
        p.index = index;
        p.outerScale = 1.0;
        const LognormalField f(p, 64, 11);
        const auto fit = nebula::powerSpectrum(projectS(f), 4.0, 16.0);
        ASSERT_TRUE(fit.fitted);
        EXPECT_NEAR(fit.slope, -index, 0.2) << "index " << index;
    }
}

TEST(Turbulence, AnisotropyPutsPowerAcrossTheAxis)
{
    // A = 2 along x: wavevectors along x count 3 times, so at a given |k| the power is lower
    // along x than across it. The model's ratio over the same modes, summed directly, is the
    // reference; the lattice's within 25 % of it (one realisation, 64^2 modes), and above 2.
    TurbulenceParams p;
    p.anisotropy = 2.0;
    p.axis = {1.0, 0.0, 0.0};
    p.outerScale = 1.0;
    const LognormalField f(p, 64, 5);
    const auto fit = nebula::powerSpectrum(projectS(f), 4.0, 16.0);
    double across = 0.0, along = 0.0, nAcross = 0.0, nAlong = 0.0;
    for (int kv = -32; kv < 32; ++kv) {
        for (int ku = -32; ku < 32; ++ku) {
            const double k = std::hypot(double(ku), double(kv));
            if (k < 4.0 || k > 16.0) continue;
            const double keff2 = 9.0 * ku * ku + double(kv) * kv;
            const double power = std::pow(keff2 + 1.0, -0.5 * p.index);
            if (std::abs(kv) > std::abs(ku)) {
                across += power;
                nAcross += 1.0;
            } else if (std::abs(ku) > std::abs(kv)) {
                along += power;
                nAlong += 1.0;
            }
        }
    }
    const double expected = (across / nAcross) / (along / nAlong);
    EXPECT_GT(expected, 2.0);
    EXPECT_NEAR(fit.anisotropy / expected, 1.0, 0.25) << "expected " << expected;
    // Isotropic: the ratio near 1.
    p.anisotropy = 0.0;
    const LognormalField iso(p, 64, 5);
    const auto isoFit = nebula::powerSpectrum(projectS(iso), 4.0, 16.0);
    EXPECT_NEAR(isoFit.anisotropy, 1.0, 0.25);
}

TEST(Turbulence, DeterministicAndTheSameCloudAtEveryResolution)
{
    TurbulenceParams p;
    const LognormalField a(p, 32, 9), b(p, 32, 9), c(p, 32, 10);
    int same = 0, differ = 0;
    for (int i = 0; i < 32; ++i) {
        same += a.at(i, 3, 5) == b.at(i, 3, 5);
        differ += a.at(i, 3, 5) != c.at(i, 3, 5);
    }
    EXPECT_EQ(same, 32);
    EXPECT_EQ(differ, 32);
    // A 64^3 lattice of the same seed holds the 32^3 one's modes and finer ones: sampled at
    // the same points, the two correlate (the power is mostly in the common modes).
    const LognormalField fine(p, 64, 9);
    double sab = 0.0, saa = 0.0, sbb = 0.0;
    for (int i = 0; i < 32; ++i) {
        for (int j = 0; j < 32; ++j) {
            for (int k = 0; k < 32; k += 4) {
                const double x = (i + 0.5) / 32 - 0.5, y = (j + 0.5) / 32 - 0.5,
                             z = (k + 0.5) / 32 - 0.5;
                const double u = a(x, y, z) + 0.5 * a.sigma() * a.sigma();
                const double v = fine(x, y, z) + 0.5 * fine.sigma() * fine.sigma();
                sab += u * v;
                saa += u * u;
                sbb += v * v;
            }
        }
    }
    EXPECT_GT(sab / std::sqrt(saa * sbb), 0.9);
}

TEST(Turbulence, TrilinearBetweenLatticePointsAndPeriodic)
{
    TurbulenceParams p;
    const LognormalField f(p, 16, 2);
    // At a lattice point, its value; half way, the mean of the two; one cube edge on, the same.
    const auto x = [](int i) { return (i + 0.5) / 16 - 0.5; };
    EXPECT_FLOAT_EQ(f(x(3), x(4), x(5)), f.at(3, 4, 5));
    EXPECT_NEAR(f(0.5 * (x(3) + x(4)), x(4), x(5)), 0.5 * (f.at(3, 4, 5) + f.at(4, 4, 5)), 1e-5);
    EXPECT_NEAR(f(x(3) + 1.0, x(4) - 2.0, x(5)), f.at(3, 4, 5), 1e-5);
    EXPECT_NEAR(f(x(15) + 0.5 / 16, x(0), x(0)), 0.5 * (f.at(15, 0, 0) + f.at(0, 0, 0)), 1e-5);
}

TEST(Turbulence, RefusesParametersOutOfRange)
{
    const auto message = [](TurbulenceParams p) {
        return nebula::test::errorMessage([&] { p.validate(); });
    };
    TurbulenceParams p;
    p.mach = 0.0;
    EXPECT_NE(message(p).find("--mach must be a finite number > 0"), std::string::npos);
    p = {};
    p.forcingB = 0.0;
    EXPECT_NE(message(p).find("--forcing-b must be in (0, 1]"), std::string::npos);
    p.forcingB = 1.5;
    EXPECT_NE(message(p).find("--forcing-b must be in (0, 1]"), std::string::npos);
    p = {};
    p.anisotropy = -0.5;
    EXPECT_NE(message(p).find("--anisotropy must be in [0, 100]"), std::string::npos);
    p = {};
    p.axis = {0.0, 0.0, 0.0};
    EXPECT_NE(message(p).find("--anisotropy-axis"), std::string::npos);
    EXPECT_THROW(LognormalField(TurbulenceParams{}, 1, 1), nebula::UsageError);
}
