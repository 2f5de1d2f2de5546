// The effective phase-function table (phase_table.h, phase_table_vdb.h): building, lookup,
// and the grid form with its error messages.
#include "nebula/core/error.h"
#include "nebula/io/phase_table_vdb.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace nebula;

namespace {

PhaseTableSpec smallSpec()
{
    PhaseTableSpec s;
    s.tMin = 1e-3;
    s.tMax = 10.0;
    s.tCount = 5;  // 1e-3, 1e-2, 0.1, 1, 10
    s.muBins = 16;
    s.minPhotons = 2048;
    s.maxPhotons = 65536;
    s.targetError = 0.02;
    return s;
}

std::string errorOf(const std::function<void()>& f)
{
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

} // namespace

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
    t.tCount = 3;  // 0.01, 1, 100
    t.muBins = 4;  // centres -0.75, -0.25, 0.25, 0.75
    t.photons = {1, 1, 1};
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 4; ++i) t.phi.push_back(float(10 * j + i));
    t.error.assign(12, 0.0f);
    EXPECT_DOUBLE_EQ(t.eval(1.0, 0.25), 12.0);             // a node
    EXPECT_DOUBLE_EQ(t.eval(0.1, 0.25), 7.0);              // half way in log t
    EXPECT_NEAR(t.eval(1.0, 0.0), 11.5, 1e-6);              // half way between centres
    EXPECT_DOUBLE_EQ(t.eval(1.0, 1.0), 13.0);              // clamped to the last centre
    EXPECT_DOUBLE_EQ(t.eval(1.0, -1.0), 10.0);
    EXPECT_DOUBLE_EQ(t.eval(1e-6, 0.75), 3.0);             // below t_min: row 0
    EXPECT_DOUBLE_EQ(t.eval(1e6, 0.75), 23.0);             // above t_max: last row
}

TEST(PhaseTable, GridRoundTrip)
{
    openvdb::initialize();
    const PhaseTable t = buildPhaseTable(ScatteringMedium{}, smallSpec());
    GridSet grids;
    grids.source = "phase.vdb";
    addPhaseTable(grids, t);
    const auto phi = openvdb::gridPtrCast<openvdb::FloatGrid>(grids.find("phase"));
    ASSERT_TRUE(phi);
    EXPECT_EQ(phi->activeVoxelCount(), openvdb::Index64(t.tCount * t.muBins));
    EXPECT_TRUE(phi->transform().isIdentity());  // index space
    EXPECT_EQ(phi->tree().getValue(openvdb::Coord(3, 2, 0)), t.value(2, 3));
    const PhaseTable back = readPhaseTable(grids);
    EXPECT_EQ(back.phi, t.phi);
    EXPECT_EQ(back.error, t.error);
    EXPECT_EQ(back.photons, t.photons);
    EXPECT_EQ(back.tMin, t.tMin);
    EXPECT_EQ(back.tMax, t.tMax);
    EXPECT_EQ(back.medium.albedo, t.medium.albedo);
    EXPECT_EQ(back.medium.g, t.medium.g);
    EXPECT_EQ(back.seed, t.seed);
}

TEST(PhaseTable, ReadRejectsWhatIsNotAConsistentTable)
{
    openvdb::initialize();
    PhaseTableSpec spec = smallSpec();
    spec.maxPhotons = spec.minPhotons;
    const PhaseTable t = buildPhaseTable(ScatteringMedium{}, spec);
    const auto fresh = [&] {
        GridSet g;
        g.source = "phase.vdb";
        addPhaseTable(g, t);
        return g;
    };
    const auto edit = [&](const std::function<void(openvdb::GridBase&)>& change) {
        GridSet g = fresh();
        change(*g.find("phase"));
        return errorOf([&] { readPhaseTable(g); });
    };
    EXPECT_NE(errorOf([] {
                  GridSet g;
                  g.source = "empty.vdb";
                  readPhaseTable(g);
              }).find("empty.vdb: no grid \"phase\""),
              std::string::npos);
    EXPECT_NE(edit([](openvdb::GridBase& g) { g.removeMeta("table"); }).find("not a phase table"),
              std::string::npos);
    EXPECT_NE(edit([](openvdb::GridBase& g) { g.removeMeta("t_max"); }).find("\"t_max\""),
              std::string::npos);
    EXPECT_NE(edit([](openvdb::GridBase& g) { g.removeMeta("mu_bins"); }).find("\"mu_bins\""),
              std::string::npos);
    const std::string reversed = edit([](openvdb::GridBase& g) {
        g.removeMeta("t_max");
        g.insertMeta("t_max", openvdb::DoubleMetadata(1e-4));
    });
    EXPECT_NE(reversed.find("t_min < t_max"), std::string::npos) << reversed;
    const std::string albedo = edit([](openvdb::GridBase& g) {
        g.removeMeta("albedo");
        g.insertMeta("albedo", openvdb::DoubleMetadata(1.5));
    });
    EXPECT_NE(albedo.find("albedo"), std::string::npos) << albedo;
    const std::string g1 = edit([](openvdb::GridBase& g) {
        g.removeMeta("g");
        g.insertMeta("g", openvdb::DoubleMetadata(1.0));
    });
    EXPECT_NE(g1.find("|g| < 1"), std::string::npos) << g1;
    const std::string photons = edit([](openvdb::GridBase& g) {
        g.removeMeta("photons_min");
        g.insertMeta("photons_min", openvdb::Int64Metadata(0));
    });
    EXPECT_NE(photons.find("photons"), std::string::npos) << photons;
    const std::string axes = edit([](openvdb::GridBase& g) {
        g.removeMeta("t_count");
        g.insertMeta("t_count", openvdb::Int32Metadata(4));
    });
    EXPECT_NE(axes.find("t_count"), std::string::npos) << axes;
    const std::string wrongType = [&] {
        GridSet g = fresh();
        auto v = openvdb::Vec3fGrid::create();
        v->setName("phase");
        g.replace(v);
        return errorOf([&] { readPhaseTable(g); });
    }();
    EXPECT_NE(wrongType.find("not a phase table"), std::string::npos) << wrongType;
}
