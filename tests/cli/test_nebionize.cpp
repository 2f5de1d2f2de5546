// SPDX-License-Identifier: Apache-2.0
// nebionize end to end: the grids it writes, their lines and units, -v's photon budget, a
// spectral render of its lines, and its refusals.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/physics/lines.h"
#include "nebula/physics/photoionization.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

using namespace nebula::clitest;

namespace {

constexpr const char* O_STAR =
    R"([{"name":"o","position":[0,2,2],"luminosity":2e5,"temperature":40000}])";

} // namespace

TEST_F(Cli, NebionizeWritesFrontsAndLines)
{
    ASSERT_EQ(run("nebgen --res 24 --density 300 -o p.vdb").code, 0);
    {
        std::ofstream(path("o.json")) << O_STAR;
    }
    const Result r = run("nebionize -i p.vdb --stars o.json -v -o ion.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("star o: Q(H0) 1.05"), std::string::npos) << r.err; // 40 kK, 2e5 L_sun
    EXPECT_NE(r.err.find("recombinations in the grid / photons"), std::string::npos) << r.err;
    const auto g = read(path("ion.vdb"));
    for (const char* name : {"density", "ionization.hii", "ionization.oiii", "emission",
                             "emission.oiii", "emission.nii", "emission.sii", "emission.oi"}) {
        EXPECT_TRUE(g.find(name)) << name;
    }
    // The fractions lie in [0, 1]: the thin gas is ionised, the fronts partly, the dense
    // clumps' shadows not.
    const auto hii = g.floatGrid("ionization.hii", "");
    int partial = 0, mostly = 0;
    for (auto it = hii->cbeginValueOn(); it; ++it) {
        ASSERT_GE(*it, 0.0f);
        ASSERT_LE(*it, 1.0f);
        partial += (*it > 0.0f && *it < 1.0f) ? 1 : 0;
        mostly += (*it >= 0.9f) ? 1 : 0;
    }
    EXPECT_GT(partial, 10);
    EXPECT_GT(mostly, 10);
    EXPECT_LT(hii->activeVoxelCount(), g.floatGrid("density", "")->activeVoxelCount());
    // Each emission grid names its lines, which the catalogue knows, and its unit.
    for (const char* name : {"emission", "emission.oiii", "emission.nii", "emission.sii"}) {
        const auto e = g.floatGrid(name, "");
        const auto lines = e->template metaValue<std::string>(nebula::META_LINES);
        EXPECT_FALSE(nebula::parseLineList(lines, name).empty()) << name;
        EXPECT_EQ(e->template metaValue<std::string>("units"), "L_sun pc^-3 sr^-1");
        EXPECT_GT(maxValue(*e), 0.0) << name;
    }
    // T_e from the thermal balance (no --electron-temperature): a nebular temperature, and
    // the Balmer decrement is Case B's at its mean.
    const auto h = g.floatGrid("emission", "");
    const double te = h->template metaValue<double>("electron_temperature");
    EXPECT_GT(te, 6000.0);
    EXPECT_LT(te, 10000.0);
    char decrement[64];
    std::snprintf(decrement, sizeof decrement, "H-alpha:%.4g,H-beta:1",
                  nebula::balmerDecrement(te));
    EXPECT_EQ(h->template metaValue<std::string>(nebula::META_LINES), decrement);
    EXPECT_NE(r.err.find("electron temperature: mean"), std::string::npos) << r.err;
    // The lines render, at their wavelengths.
    ASSERT_EQ(run("nebillum -i ion.vdb -o lit.vdb").code, 0);
    const Result s = run("nebrender -i lit.vdb --spectral --res 32x32 -o s.exr");
    EXPECT_EQ(s.code, 0) << s.err;
}

TEST_F(Cli, NebionizeRefusesBadInput)
{
    ASSERT_EQ(run("nebgen --res 16 -o n.vdb").code, 0);
    {
        std::ofstream(path("q.json"))
            << R"([{"name":"o","position":[0,0,0],"luminosity":1,"Q":1e49}])";
    }
    expectFailure("nebionize -i n.vdb --stars q.json -o x.vdb", 1,
                  "q.json: star 1 (\"o\"): \"Q\" needs the star's \"temperature\"");
    expectFailure("nebionize -i n.vdb --abundances o=2 -o x.vdb", 2,
                  "--abundances: \"o=2\": the abundance must be a number from 0 to 1");
    expectFailure("nebionize -i n.vdb --density-grid nothing -o x.vdb", 1, "nothing");
    expectFailure("nebionize -i n.vdb --electron-temperature 10 -o x.vdb", 2,
                  "--electron-temperature");
    EXPECT_FALSE(fs::exists(path("x.vdb")));
}

TEST_F(Cli, NebionizeSaysWhenPhotonsEscape)
{
    ASSERT_EQ(run("nebgen --res 16 --density 10 -o thin.vdb").code, 0);
    const Result r = run("nebionize -i thin.vdb --star o:0,0,0:1e6:50000 -v -o t.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("ionises the gas out to the grid's edge"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(not an error)"), std::string::npos) << r.err;
}
