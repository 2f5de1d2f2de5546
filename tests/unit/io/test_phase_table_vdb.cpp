// SPDX-License-Identifier: Apache-2.0
// The effective phase-function table as grids (io/phase_table_vdb.h): the round trip and
// the error messages of readPhaseTable().
#include "nebula/io/phase_table_vdb.h"

#include "nebula/core/error.h"

#include <openvdb/openvdb.h>

#include "phase_tables.h"

#include <gtest/gtest.h>

#include <functional>
#include <string>

using namespace nebula;

namespace {

using nebula::test::smallSpec;

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
    EXPECT_TRUE(phi->transform().isIdentity()); // index space
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
