// SPDX-License-Identifier: Apache-2.0
// End-to-end tests of nebgen's spectral grids (--spectral): temperature, velocity, the
// emission grids' line metadata, [O III] and shells, their options and their errors.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/spectral_grids.h"
#include "nebula/physics/lines.h"
#include "nebula/physics/motion.h"
#include "nebula/stages/generate.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

using namespace nebula::clitest;

namespace {

std::vector<std::string> gridNames(const nebula::GridSet& set)
{
    std::vector<std::string> names;
    for (const auto& g : set.grids)
        names.push_back(g->getName());
    return names;
}

using CoordSet = std::set<std::tuple<int, int, int>>;

/// The active voxels of @p grid (expecting no active tiles).
template <typename GridT> CoordSet activeVoxels(const GridT& grid)
{
    CoordSet out;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        EXPECT_TRUE(it.isVoxelValue()) << grid.getName() << ": active tile";
        const auto c = it.getCoord();
        out.emplace(c.x(), c.y(), c.z());
    }
    return out;
}

/// The active coordinates of @p grid (tiles count by their origin only: none in nebgen's).
template <typename GridT> CoordSet voxelsOf(const GridT& grid)
{
    CoordSet out;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        const auto c = it.getCoord();
        out.emplace(c.x(), c.y(), c.z());
    }
    return out;
}

std::string gridMeta(const openvdb::GridBase& grid, const std::string& key)
{
    const auto m = grid[key];
    return m ? m->str() : std::string("<none>");
}

std::array<double, 3> worldOf(const openvdb::GridBase& grid, const openvdb::Coord& c)
{
    const auto x = grid.indexToWorld(c);
    return {x[0], x[1], x[2]};
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b)
{
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                     (a[2] - b[2]) * (a[2] - b[2]));
}

/// Every grid of @p a equals the one of the same name in @p b, voxel for voxel.
void expectSameGrids(const nebula::GridSet& a, const nebula::GridSet& b)
{
    ASSERT_EQ(gridNames(a), gridNames(b));
    for (const auto& ga : a.grids) {
        const auto gb = b.find(ga->getName());
        ASSERT_EQ(ga->activeVoxelCount(), gb->activeVoxelCount()) << ga->getName();
        if (auto fa = openvdb::gridPtrCast<openvdb::FloatGrid>(ga)) {
            auto acc = openvdb::gridPtrCast<openvdb::FloatGrid>(gb)->getConstAccessor();
            for (auto it = fa->cbeginValueOn(); it; ++it) {
                ASSERT_TRUE(acc.isValueOn(it.getCoord())) << ga->getName();
                ASSERT_EQ(*it, acc.getValue(it.getCoord())) << ga->getName();
            }
        } else {
            auto va = openvdb::gridPtrCast<openvdb::Vec3fGrid>(ga);
            ASSERT_TRUE(va) << ga->getName();
            auto acc = openvdb::gridPtrCast<openvdb::Vec3fGrid>(gb)->getConstAccessor();
            for (auto it = va->cbeginValueOn(); it; ++it) {
                ASSERT_TRUE(acc.isValueOn(it.getCoord())) << ga->getName();
                ASSERT_EQ(*it, acc.getValue(it.getCoord())) << ga->getName();
            }
        }
    }
}

} // namespace

TEST_F(Cli, SpectralWritesTemperatureAndVelocity)
{
    const Result r = run("nebgen --res 16 --spectral --expansion 30 -o x.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto set = read(path("x.vdb"));
    EXPECT_EQ(gridNames(set),
              (std::vector<std::string>{"density", "emission", "temperature", "velocity"}));
    const auto density = set.floatGrid("density", "");
    const auto emission = set.floatGrid("emission", "");
    EXPECT_EQ(gridMeta(*emission, nebula::META_LINES), "H-alpha:1,H-beta:0.35");

    // Topology: density union emission, as voxels, in temperature and velocity alike.
    CoordSet expected = voxelsOf(*density);
    const CoordSet em = voxelsOf(*emission);
    expected.insert(em.begin(), em.end());
    ASSERT_GT(em.size(), 0u);

    const auto T = set.floatGrid("temperature", "");
    EXPECT_EQ(T->getGridClass(), openvdb::GRID_UNKNOWN);
    EXPECT_EQ(gridMeta(*T, "units"), "K");
    EXPECT_EQ(T->transform(), density->transform());
    EXPECT_EQ(activeVoxels(*T), expected);
    EXPECT_NO_THROW(nebula::requireValidTemperature(*T, set.source));
    // Dust heated by the example's stars (8000 and 60 L_sun): between the bare interstellar
    // field's 16.4 K and a few 100 K, and at every voxel the documented formula.
    const auto stars = set.stars();
    ASSERT_EQ(stars.size(), 2u);
    const double rMin = 0.5 * 10.0 / 16;
    for (auto it = T->cbeginValueOn(); it; ++it) {
        ASSERT_TRUE(std::isfinite(*it));
        ASSERT_GE(*it, 16.4f);
        ASSERT_LE(*it, 300.0f);
        const double U = nebula::radiationFieldU(worldOf(*T, it.getCoord()), stars, rMin);
        ASSERT_NEAR(*it, 16.4 * std::pow(1.0 + U, 1.0 / 6.0), 1e-5 * *it);
    }
    EXPECT_GT(maxValue(*T), 25.0); // next to the B star: U ~ 100 at half a voxel

    const auto v = nebula::velocityGrid(set, "velocity", "");
    EXPECT_EQ(v->getVectorType(), openvdb::VEC_CONTRAVARIANT_RELATIVE);
    EXPECT_TRUE(v->isInWorldSpace());
    EXPECT_EQ(gridMeta(*v, "units"), "km/s");
    EXPECT_EQ(v->transform(), density->transform());
    EXPECT_EQ(activeVoxels(*v), expected);
    // Expansion about the first star, 30 km/s at --emission-radius * --size = 3 pc.
    const auto c = stars[0].position;
    for (auto it = v->cbeginValueOn(); it; ++it) {
        const auto x = worldOf(*v, it.getCoord());
        for (int a = 0; a < 3; ++a) {
            ASSERT_NEAR((*it)[a], 30.0 * (x[a] - c[a]) / 3.0, 1e-5 * (1.0 + std::fabs((*it)[a])));
        }
    }
}

TEST_F(Cli, SpectralOiiiGridInTheInnerIonisedRegion)
{
    const Result r = run("nebgen --res 24 --spectral --oiii 0.5 -o o.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto set = read(path("o.vdb"));
    EXPECT_EQ(gridNames(set), (std::vector<std::string>{"density", "emission", "emission.oiii",
                                                        "temperature", "velocity"}));
    const auto emission = set.floatGrid("emission", "");
    const auto oiii = set.floatGrid("emission.oiii", "");
    EXPECT_EQ(gridMeta(*oiii, nebula::META_LINES), "[O III]5007:1,[O III]4959:0.336");
    const auto lines = nebula::gridLines(*oiii, set.source, {});
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_NEAR(lines[0].strength / lines[1].strength, 2.98, 0.01);
    EXPECT_EQ(oiii->transform(), emission->transform());

    // 0.5 x emission within 0.5 R = 1.5 pc of the motion centre (the first star), nothing
    // beyond 0.8 R = 2.4 pc, in between at most 0.5 x emission.
    const auto c = set.stars()[0].position;
    auto eAcc = emission->getConstAccessor();
    auto oAcc = oiii->getConstAccessor();
    int inner = 0;
    for (auto it = emission->cbeginValueOn(); it; ++it) {
        const double d = distance(worldOf(*emission, it.getCoord()), c);
        const float o = oAcc.getValue(it.getCoord());
        if (d <= 1.5) {
            ++inner;
            ASSERT_NEAR(o, 0.5 * *it, 1e-6 * *it);
            ASSERT_TRUE(oAcc.isValueOn(it.getCoord()));
        } else if (d >= 2.4) {
            ASSERT_FALSE(oAcc.isValueOn(it.getCoord()));
        } else {
            ASSERT_LE(o, 0.5f * *it * (1 + 1e-6f));
        }
    }
    EXPECT_GT(inner, 10);
    for (auto it = oiii->cbeginValueOn(); it; ++it) {
        ASSERT_TRUE(eAcc.isValueOn(it.getCoord()));
        ASSERT_GT(*it, 0.0f);
    }
}

TEST_F(Cli, SpectralGasTemperatureWhereThereIsEmission)
{
    ASSERT_EQ(run("nebgen --res 16 --spectral --gas-temperature 8000 -o g.vdb").code, 0);
    const auto set = read(path("g.vdb"));
    const auto T = set.floatGrid("temperature", "");
    auto eAcc = set.floatGrid("emission", "")->getConstAccessor();
    int gas = 0, dust = 0;
    for (auto it = T->cbeginValueOn(); it; ++it) {
        if (eAcc.getValue(it.getCoord()) > 0.0f) {
            ASSERT_EQ(*it, 8000.0f);
            ++gas;
        } else {
            ASSERT_GE(*it, 16.4f);
            ASSERT_LE(*it, 300.0f);
            ++dust;
        }
    }
    EXPECT_GT(gas, 0);
    EXPECT_GT(dust, 0);
}

TEST_F(Cli, SpectralGridsLeaveDensityAndEmissionUnchanged)
{
    ASSERT_EQ(run("nebgen --res 20 --seed 4 -o plain.vdb").code, 0);
    ASSERT_EQ(run("nebgen --res 20 --seed 4 --spectral --turbulence 3 --rotation 5 --oiii 1 "
                  "--gas-temperature 9000 -o spec.vdb")
                  .code,
              0);
    const auto plain = read(path("plain.vdb")), spec = read(path("spec.vdb"));
    EXPECT_EQ(gridNames(plain), (std::vector<std::string>{"density", "emission"}));
    nebula::GridSet sub;
    for (const std::string name : {"density", "emission"})
        sub.grids.push_back(spec.find(name));
    expectSameGrids(plain, sub);
    EXPECT_EQ(gridMeta(*plain.find("emission"), nebula::META_LINES), "H-alpha:1,H-beta:0.35");
}

TEST_F(Cli, SpectralSameGridsWhateverTheThreadCount)
{
    const std::string opts = "--res 20 --seed 5 --spectral --turbulence 4 --rotation 10 "
                             "--rotation-axis 1,1,0 --expansion -5 --oiii 0.4 ";
    ASSERT_EQ(run("nebgen " + opts + "--threads 1 -o one.vdb").code, 0);
    ASSERT_EQ(run("nebgen " + opts + "--threads 2 -o two.vdb").code, 0);
    expectSameGrids(read(path("one.vdb")), read(path("two.vdb")));
}

TEST_F(Cli, ShellEmissionAboutTheMotionCentre)
{
    // A shell of radius 0.3 x 10 pc and FWHM 0.15 x 3 pc about (1, 0, 0): its envelope
    // vanishes beyond 3 +- 0.45 pc. Allowed without --spectral (it shapes the emission).
    Result r = run("nebgen --res 32 --emission-shape shell --motion-centre 1,0,0 -o s.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    ASSERT_EQ(run("nebgen --res 32 -o sphere.vdb").code, 0);
    const auto shell = read(path("s.vdb")), sphere = read(path("sphere.vdb"));
    const auto e = shell.floatGrid("emission", "");
    ASSERT_GT(e->activeVoxelCount(), 100);
    for (auto it = e->cbeginValueOn(); it; ++it) {
        const double d = distance(worldOf(*e, it.getCoord()), {1.0, 0.0, 0.0});
        ASSERT_LE(std::fabs(d - 3.0), 0.45 + 1e-9) << d;
    }
    // Only the emission's envelope changes.
    nebula::GridSet a, b;
    a.grids = {shell.find("density")};
    b.grids = {sphere.find("density")};
    expectSameGrids(a, b);

    // The Doppler example: an expanding shell (default centre: the first star).
    r = run("nebgen --res 24 --spectral --expansion 40 --emission-shape shell --shell-width 0.3 "
            "-o shell.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto set = read(path("shell.vdb"));
    const auto c = set.stars()[0].position;
    const auto v = nebula::velocityGrid(set, "velocity", "");
    auto vAcc = v->getConstAccessor();
    const auto em = set.floatGrid("emission", "");
    ASSERT_GT(em->activeVoxelCount(), 0);
    for (auto it = em->cbeginValueOn(); it; ++it) {
        const auto x = worldOf(*em, it.getCoord());
        const double d = distance(x, c);
        ASSERT_LE(std::fabs(d - 3.0), 0.9 + 1e-9);
        // Radial speed 40 km/s x d / 3 pc: about 40 km/s on the shell.
        const auto vel = vAcc.getValue(it.getCoord());
        const double vr =
            (vel[0] * (x[0] - c[0]) + vel[1] * (x[1] - c[1]) + vel[2] * (x[2] - c[2])) / d;
        ASSERT_NEAR(vr, 40.0 * d / 3.0, 1e-4 * vr);
    }
}

TEST_F(Cli, LinesOptionSetsTheEmissionMetadata)
{
    const Result r = run("nebgen --res 8 --lines 'H-alpha:1, [N II]6583:0.3,501.5:0.1' -o l.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto set = read(path("l.vdb"));
    const auto e = set.find("emission");
    EXPECT_EQ(gridMeta(*e, nebula::META_LINES), "H-alpha:1,[N II]6583:0.3,501.5:0.1");
    const auto lines = nebula::gridLines(*e, set.source, {});
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_DOUBLE_EQ(lines[1].wavelength, 658.35);
    EXPECT_DOUBLE_EQ(lines[2].wavelength, 501.5);
}

TEST_F(Cli, SpectralGridsPassThroughNebillum)
{
    const Result r = run("nebgen --res 16 --spectral --rotation 10 --oiii 0.5 -o - | "
                         "nebillum -i - -o lit.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto lit = read(path("lit.vdb"));
    auto names = gridNames(lit);
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"density", "emission", "emission.oiii", "tau.alpha",
                                               "tau.beta", "temperature", "velocity"}));
    const auto v = nebula::velocityGrid(lit, "velocity", "");
    EXPECT_EQ(v->getVectorType(), openvdb::VEC_CONTRAVARIANT_RELATIVE);
    EXPECT_TRUE(v->isInWorldSpace());
    EXPECT_EQ(gridMeta(*lit.find("emission.oiii"), nebula::META_LINES),
              "[O III]5007:1,[O III]4959:0.336");
}

TEST_F(Cli, SpectralOptionErrors)
{
    expectFailure("nebgen --res 8 --lines H-alfa -o x.vdb", 2, "unknown emission line \"H-alfa\"");
    expectFailure("nebgen --res 8 --lines H-alfa -o x.vdb", 2, "\"[O III]5007\"");
    expectFailure("nebgen --res 8 --spectral --lines h-alpha:1 -o x.vdb", 2,
                  "did you mean \"H-alpha\"?");
    expectFailure("nebgen --res 8 --lines 'H-alpha,H-alpha' -o x.vdb", 2, "listed twice");
    expectFailure("nebgen --res 8 --lines H-alpha:0 -o x.vdb", 2, "--lines \"H-alpha:0\": item 1");
    expectFailure("nebgen --res 8 --expansion 30 -o x.vdb", 2, "--expansion needs --spectral");
    expectFailure("nebgen --res 8 --rotation 3 -o x.vdb", 2, "--rotation needs --spectral");
    expectFailure("nebgen --res 8 --turbulence 3 -o x.vdb", 2, "--turbulence needs --spectral");
    expectFailure("nebgen --res 8 --oiii 0.5 -o x.vdb", 2, "--oiii needs --spectral");
    expectFailure("nebgen --res 8 --gas-temperature 8000 -o x.vdb", 2,
                  "--gas-temperature needs --spectral");
    expectFailure("nebgen --res 8 --motion-radius 2 -o x.vdb", 2,
                  "--motion-radius needs --spectral");
    expectFailure("nebgen --res 8 --motion-centre 1,2,3 -o x.vdb", 2,
                  "--motion-centre needs --spectral or --emission-shape shell");
    expectFailure("nebgen --res 8 --shell-width 0.2 -o x.vdb", 2,
                  "--shell-width needs --emission-shape shell");
    expectFailure("nebgen --res 8 --emission-shape shell --shell-width 0 -o x.vdb", 2,
                  "--shell-width: expected a number in (0, 1], got 0");
    expectFailure("nebgen --res 8 --emission-shape cube -o x.vdb", 2, "--emission-shape");
    expectFailure("nebgen --res 8 --spectral --rotation-axis 0,0,0 -o x.vdb", 2,
                  "--rotation-axis must not be the zero vector");
    expectFailure("nebgen --res 8 --spectral --rotation-axis 1,2 -o x.vdb", 2,
                  "--rotation-axis \"1,2\": expected X,Y,Z");
    expectFailure("nebgen --res 8 --spectral --motion-centre a,b,c -o x.vdb", 2,
                  "--motion-centre \"a,b,c\": expected X,Y,Z");
    expectFailure("nebgen --res 8 --spectral --motion-radius 0 -o x.vdb", 2,
                  "--motion-radius: expected a finite number > 0, got 0");
    expectFailure("nebgen --res 8 --spectral --turbulence -1 -o x.vdb", 2,
                  "--turbulence: expected a finite number >= 0, got -1");
    expectFailure("nebgen --res 8 --spectral --oiii -1 -o x.vdb", 2,
                  "--oiii: expected a finite number >= 0, got -1");
    expectFailure("nebgen --res 8 --spectral --gas-temperature -5 -o x.vdb", 2,
                  "--gas-temperature: expected a finite number >= 0, got -5");
}

TEST_F(Cli, SpectralHelp)
{
    ASSERT_EQ(run("nebgen --help > help.txt").code, 0);
    std::ifstream in(path("help.txt"));
    std::stringstream s;
    s << in.rdbuf();
    const std::string help = s.str();
    const auto options = help.find("Options:");
    ASSERT_NE(options, std::string::npos);
    // The method and the line catalogue are in the man page (nebgen --man), with every example.
    ASSERT_EQ(run("nebgen --man > man.txt").code, 0);
    std::ifstream min(path("man.txt"));
    std::stringstream m;
    m << min.rdbuf();
    const std::string man = m.str();
    EXPECT_NE(man.find("nebgen \\-\\-spectral \\-\\-expansion 40 \\-\\-emission\\-shape shell"),
              std::string::npos);
    EXPECT_NE(man.find("T = 16.4 K (1 + U)^(1/6)"), std::string::npos);
    EXPECT_NE(man.find("[O III]5007 500.68"), std::string::npos);
    for (const std::string opt :
         {"--spectral", "--lines", "--gas-temperature", "--expansion", "--rotation ",
          "--rotation-axis", "--turbulence ", "--turbulence-frequency", "--motion-centre",
          "--motion-radius", "--oiii", "--emission-shape", "--shell-width"}) {
        EXPECT_NE(help.find(opt, options), std::string::npos) << opt;
    }
}
