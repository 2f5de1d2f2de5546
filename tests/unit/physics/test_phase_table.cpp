// SPDX-License-Identifier: Apache-2.0
// The effective phase-function table (physics/phase_table.h): building and lookup. (The
// grid form and its error messages are in io/test_phase_table_vdb.cpp.)
#include "nebula/physics/phase_table.h"

#include "phase_tables.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nebula;

using nebula::test::smallSpec;

TEST(PhaseTable, BuildIsDeterministicAndMeetsItsErrorTarget)
{
    const ScatteringMedium m;
    const auto spec = smallSpec();
    const PhaseTable a = buildPhaseTable(m, spec);
    const PhaseTable b = buildPhaseTable(m, spec);
    EXPECT_EQ(a.phi, b.phi);
    EXPECT_EQ(a.photons, b.photons);
    EXPECT_NEAR(a.t(0), 1e-3, 1e-15);
    EXPECT_NEAR(a.t(3), 1.0, 1e-12);
    EXPECT_EQ(a.t(4), 10.0);
    // Every row with t <= errorTMax reached the target (maxPhotons is ample here), and the
    // thick rows needed more photons than the thin ones.
    EXPECT_LE(a.worstRelativeError(spec.errorTMax), spec.targetError);
    EXPECT_GT(a.photons[4], a.photons[0]);
    auto other = spec;
    other.seed = 7;
    EXPECT_NE(buildPhaseTable(m, other).phi, a.phi);
}

TEST(PhaseTable, ThinRowIsAlbedoTimesPhaseFunction)
{
    ScatteringMedium m;
    m.g = 0.3;
    const PhaseTable t = buildPhaseTable(m, smallSpec());
    // Row 0 (t = 1e-3): a p(mu) averaged over each bin, to O(t) and statistics.
    for (int i = 0; i < t.muBins; ++i) {
        const double lo = -1.0 + 2.0 * i / t.muBins, hi = lo + 2.0 / t.muBins;
        double s = 0.0;
        for (int k = 0; k <= 64; ++k) {
            s += ((k == 0 || k == 64) ? 1 : (k % 2 ? 4 : 2)) *
                 m.phaseFunction(lo + (hi - lo) * k / 64.0);
        }
        const double expected = m.albedo * s / (3.0 * 64.0);
        EXPECT_NEAR(t.value(0, i), expected, 3.0 * t.error[i] + 2e-3 * expected) << "bin " << i;
    }
}

TEST(PhaseTable, LookupIsBilinearInLogTAndMu)
{
    PhaseTable t;
    t.tMin = 1e-2;
    t.tMax = 1e2;
    t.tCount = 3; // 0.01, 1, 100
    t.muBins = 4; // centres -0.75, -0.25, 0.25, 0.75
    t.photons = {1, 1, 1};
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 4; ++i)
            t.phi.push_back(float(10 * j + i));
    t.error.assign(12, 0.0f);
    EXPECT_DOUBLE_EQ(t.eval(1.0, 0.25), 12.0); // a node
    EXPECT_DOUBLE_EQ(t.eval(0.1, 0.25), 7.0);  // half way in log t
    EXPECT_NEAR(t.eval(1.0, 0.0), 11.5, 1e-6); // half way between centres
    EXPECT_DOUBLE_EQ(t.eval(1.0, 1.0), 13.0);  // clamped to the last centre
    EXPECT_DOUBLE_EQ(t.eval(1.0, -1.0), 10.0);
    EXPECT_DOUBLE_EQ(t.eval(1e-6, 0.75), 3.0); // below t_min: row 0
    EXPECT_DOUBLE_EQ(t.eval(1e6, 0.75), 23.0); // above t_max: last row
}
