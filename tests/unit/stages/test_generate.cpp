// SPDX-License-Identifier: Apache-2.0
/// @file test_generate.cpp
/// nebgen's stage (stages/generate.h): the grids generateNebula() makes on a small lattice
/// (names, types, metadata, values finite and >= 0, zero voxels inactive), their
/// determinism, the shapes the header promises (envelope, emission ball or shell, cavities,
/// the [O III] zone), the spectral grids, parameter checks, and the dust temperature in the
/// stars' radiation field.

#include "nebula/stages/generate.h"

#include "nebula/core/error.h"
#include "nebula/core/memory.h"

#include "test_util.h"

#include <openvdb/openvdb.h>

#include <tbb/global_control.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <vector>

using nebula::GridSet;
using nebula::NebulaParams;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

using Coord = std::array<int, 3>;
using Pc = std::array<double, 3>;

NebulaParams small(int res = 24)
{
    NebulaParams p;
    p.res = res;
    return p;
}

openvdb::FloatGrid::Ptr floatGridOf(const GridSet& s, const std::string& name)
{
    return openvdb::gridPtrCast<openvdb::FloatGrid>(s.find(name));
}

/// The active values of @p grid by voxel.
std::map<Coord, float> activeValues(const openvdb::FloatGrid& grid)
{
    std::map<Coord, float> out;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        if (it.isVoxelValue()) {
            const auto c = it.getCoord();
            out[{c.x(), c.y(), c.z()}] = *it;
        } else {
            openvdb::CoordBBox box;
            it.getBoundingBox(box);
            for (auto c = box.begin(); c; ++c)
                out[{(*c).x(), (*c).y(), (*c).z()}] = *it;
        }
    }
    return out;
}

Pc worldOf(const openvdb::GridBase& grid, const Coord& c)
{
    const auto w = grid.transform().indexToWorld(openvdb::Coord(c[0], c[1], c[2]));
    return {w[0], w[1], w[2]};
}

double distance(const Pc& a, const Pc& b)
{
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                     (a[2] - b[2]) * (a[2] - b[2]));
}

double norm(const Pc& a)
{
    return distance(a, {0, 0, 0});
}

// ---- the grids ---------------------------------------------------------------------------------

TEST(GenerateNebula, GridNamesTypesAndMetadata)
{
    openvdb::initialize();
    NebulaParams p = small();
    p.stars = nebula::exampleStars();
    p.dust.albedo = 0.35;
    p.dust.g = 0.2;
    p.lines = nebula::parseLineList("H-alpha:1,[N II]6583:0.3", "t");
    const GridSet s = nebula::generateNebula(p);

    ASSERT_EQ(s.grids.size(), 2u);
    EXPECT_EQ(s.grids[0]->getName(), "density");
    EXPECT_EQ(s.grids[1]->getName(), "emission");
    const auto density = floatGridOf(s, "density");
    const auto emission = floatGridOf(s, "emission");
    ASSERT_TRUE(density);
    ASSERT_TRUE(emission);
    EXPECT_EQ(density->getGridClass(), openvdb::GRID_FOG_VOLUME);
    EXPECT_GT(density->activeVoxelCount(), 0u);
    EXPECT_GT(emission->activeVoxelCount(), 0u);
    // The emission grid says which lines it emits.
    const auto lines = emission->metaValue<std::string>(nebula::META_LINES);
    EXPECT_EQ(nebula::parseLineList(lines, "meta"), p.lines);

    // Stars and dust travel as file metadata.
    const auto stars = s.stars();
    ASSERT_EQ(stars.size(), p.stars.size());
    for (std::size_t i = 0; i < stars.size(); ++i) {
        EXPECT_EQ(stars[i].name, p.stars[i].name);
        EXPECT_EQ(stars[i].position, p.stars[i].position);
        EXPECT_EQ(stars[i].luminosity, p.stars[i].luminosity);
        EXPECT_EQ(stars[i].temperature, p.stars[i].temperature);
    }
    ASSERT_TRUE(s.hasDust());
    EXPECT_EQ(s.dust().albedo, 0.35);
    EXPECT_EQ(s.dust().g, 0.2);
    EXPECT_EQ(s.dust().kappa_V, p.dust.kappa_V);

    // No stars: an empty nebula:stars array, still present.
    NebulaParams none = small(8);
    const GridSet n = nebula::generateNebula(none);
    EXPECT_TRUE(n.stars().empty());
    EXPECT_FALSE(n.metaString(nebula::META_STARS).empty());
}

TEST(GenerateNebula, CubeCentredOnTheOriginWithVoxelsOfSizeOverRes)
{
    NebulaParams p = small(20);
    p.size = 8.0;
    const GridSet s = nebula::generateNebula(p);
    for (const auto& g : s.grids) {
        EXPECT_TRUE(g->transform().isLinear());
        EXPECT_NEAR(g->voxelSize()[0], 0.4, 1e-12);
        EXPECT_NEAR(g->voxelSize()[2], 0.4, 1e-12);
        // Lattice 0 .. res - 1, symmetric about the origin.
        const auto lo = worldOf(*g, {0, 0, 0}), hi = worldOf(*g, {19, 19, 19});
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(lo[a], -3.8, 1e-12);
            EXPECT_NEAR(hi[a], 3.8, 1e-12);
        }
        // Every active voxel is on the lattice.
        const auto box = g->evalActiveVoxelBoundingBox();
        if (!box.empty()) {
            EXPECT_GE(box.min().x(), 0);
            EXPECT_LE(box.max().z(), 19);
        }
    }
}

TEST(GenerateNebula, ValuesAreFiniteNonNegativeAndZeroVoxelsInactive)
{
    NebulaParams p = small(28);
    p.stars = nebula::exampleStars();
    for (const char* name : {"density", "emission"}) {
        const auto grid = floatGridOf(nebula::generateNebula(p), name);
        ASSERT_TRUE(grid);
        EXPECT_EQ(grid->background(), 0.0f);
        const auto values = activeValues(*grid);
        ASSERT_FALSE(values.empty()) << name;
        float peak = 0.0f;
        for (const auto& [c, v] : values) {
            ASSERT_TRUE(std::isfinite(v)) << name;
            ASSERT_GT(v, 0.0f) << name << " at " << c[0] << "," << c[1] << "," << c[2];
            peak = std::max(peak, v);
        }
        // The density is in cm^-3 around densityPeak, not in some other unit.
        if (std::string(name) == "density") {
            EXPECT_GT(peak, 0.01 * p.densityPeak);
            EXPECT_LT(peak, 100.0 * p.densityPeak);
        }
    }
}

TEST(GenerateNebula, SameSeedSameValuesOtherSeedOtherValues)
{
    NebulaParams p = small(20);
    p.seed = 42;
    const GridSet a = nebula::generateNebula(p);
    const GridSet b = nebula::generateNebula(p);
    for (const char* name : {"density", "emission"}) {
        EXPECT_EQ(activeValues(*floatGridOf(a, name)), activeValues(*floatGridOf(b, name))) << name;
    }
    p.seed = 43;
    const GridSet c = nebula::generateNebula(p);
    for (const char* name : {"density", "emission"}) {
        EXPECT_NE(activeValues(*floatGridOf(a, name)), activeValues(*floatGridOf(c, name))) << name;
    }
}

TEST(GenerateNebula, IndependentOfTheThreadCountAndReportsEverySlice)
{
    NebulaParams p = small(20);
    p.stars = nebula::exampleStars();
    p.spectral.enabled = true;
    p.spectral.oiii = 0.5;
    std::atomic<std::size_t> slices{0};
    const GridSet many = nebula::generateNebula(p, [&](std::size_t n) { slices += n; });
    EXPECT_EQ(slices.load(), std::size_t(p.res));
    GridSet one;
    {
        tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
        one = nebula::generateNebula(p);
    }
    ASSERT_EQ(many.grids.size(), one.grids.size());
    for (std::size_t i = 0; i < many.grids.size(); ++i) {
        const auto a = openvdb::gridPtrCast<openvdb::FloatGrid>(many.grids[i]);
        const auto b = openvdb::gridPtrCast<openvdb::FloatGrid>(one.grids[i]);
        if (a) {
            ASSERT_TRUE(b);
            EXPECT_EQ(activeValues(*a), activeValues(*b)) << a->getName();
        } else {
            const auto va = openvdb::gridPtrCast<openvdb::Vec3fGrid>(many.grids[i]);
            const auto vb = openvdb::gridPtrCast<openvdb::Vec3fGrid>(one.grids[i]);
            ASSERT_TRUE(va && vb);
            EXPECT_EQ(va->activeVoxelCount(), vb->activeVoxelCount());
            for (auto it = va->cbeginValueOn(); it; ++it) {
                ASSERT_EQ(vb->tree().getValue(it.getCoord()), *it);
            }
        }
    }
}

TEST(GenerateNebula, LeafByLeafGridsHoldEveryVoxelOfTheFields)
{
    // The generator skips leaves outside the fields' support; every voxel of the cube, skipped
    // or not, must hold exactly what the fields are there (active where non-zero). Cases: the
    // default ball, a shell off centre with [O III], a small dust envelope inside a large
    // emission ball, and lattices that are not whole leaves.
    std::vector<NebulaParams> cases;
    cases.push_back(small(40));
    NebulaParams shell = small(37);
    shell.stars = nebula::exampleStars();
    shell.emissionShape = nebula::EmissionShape::Shell;
    shell.emissionRadius = 0.2;
    shell.motionCentre = Pc{1.5, -1.0, 0.5};
    shell.spectral.enabled = true;
    shell.spectral.oiii = 0.7;
    cases.push_back(shell);
    NebulaParams wide = small(33);
    wide.envelope = 0.15;
    wide.emissionRadius = 0.8;
    cases.push_back(wide);
    for (const auto& p : cases) {
        const GridSet set = nebula::generateNebula(p);
        const auto d = activeValues(*floatGridOf(set, "density"));
        const auto e = activeValues(*floatGridOf(set, "emission"));
        const auto o = p.spectral.enabled ? activeValues(*floatGridOf(set, "emission.oiii"))
                                          : std::map<Coord, float>{};
        std::size_t dust = 0, corners = 0;
        for (int k = 0; k < p.res; ++k) {
            for (int j = 0; j < p.res; ++j) {
                for (int i = 0; i < p.res; ++i) {
                    const auto v = nebula::nebulaVoxel(p, i, j, k);
                    const auto at = [&](const std::map<Coord, float>& m) {
                        const auto it = m.find({i, j, k});
                        return it == m.end() ? 0.0f : it->second;
                    };
                    ASSERT_EQ(at(d), float(v.density)) << i << " " << j << " " << k;
                    ASSERT_EQ(at(e), float(v.emission)) << i << " " << j << " " << k;
                    if (p.spectral.enabled) {
                        ASSERT_EQ(at(o), float(v.oiii));
                    }
                    dust += v.density > 0.0;
                    const double x = (i + 0.5) / p.res - 0.5, y = (j + 0.5) / p.res - 0.5,
                                 z = (k + 0.5) / p.res - 0.5;
                    corners += x * x + y * y + z * z > 0.25;
                }
            }
        }
        EXPECT_EQ(d.count({0, 0, 0}), 0u) << "the corner is outside the dust";
        EXPECT_GT(dust, 0u);
        EXPECT_GT(corners, std::size_t(p.res * p.res * p.res / 3)); // the skipped region
    }
}

// ---- shapes ------------------------------------------------------------------------------------

TEST(GenerateNebula, DustInsideTheInscribedSphereAndOutsideTheCavities)
{
    NebulaParams p = small(32);
    p.stars = nebula::exampleStars();
    p.cavity = 2.0; // dust-free within 1 pc of each star
    const auto density = floatGridOf(nebula::generateNebula(p), "density");
    for (const auto& [c, v] : activeValues(*density)) {
        const Pc x = worldOf(*density, c);
        // The envelope is capped at the cube's inscribed sphere.
        EXPECT_LT(norm(x), 0.5 * p.size) << v;
        for (const auto& s : p.stars) {
            EXPECT_GE(distance(x, s.position), 0.5 * p.cavity) << s.name;
        }
    }
    // Without the cavity there is dust that close to the hot star (so the check above means
    // something).
    p.cavity = 0.0;
    const auto open = floatGridOf(nebula::generateNebula(p), "density");
    int near = 0;
    for (const auto& [c, v] : activeValues(*open)) {
        near += distance(worldOf(*open, c), p.stars[0].position) < 0.5 * 2.0;
    }
    EXPECT_GT(near, 0);
}

TEST(GenerateNebula, SphereEmissionWithinItsRadius)
{
    NebulaParams p = small(32);
    p.emissionRadius = 0.25; // 2.5 pc
    const auto emission = floatGridOf(nebula::generateNebula(p), "emission");
    const auto values = activeValues(*emission);
    ASSERT_FALSE(values.empty());
    double farthest = 0.0;
    for (const auto& [c, v] : values)
        farthest = std::max(farthest, norm(worldOf(*emission, c)));
    EXPECT_LE(farthest, p.emissionRadius * p.size + 1e-9);
    EXPECT_GT(farthest, 0.4 * p.emissionRadius * p.size); // fills the ball, not a dot
}

TEST(GenerateNebula, ShellEmissionWithinItsWidth)
{
    NebulaParams p = small(32);
    p.emissionShape = nebula::EmissionShape::Shell;
    p.emissionRadius = 0.3; // R = 3 pc
    p.shellWidth = 0.2;     // |d - R| < 0.6 pc
    p.motionCentre = Pc{0.5, -0.5, 0.25};
    const auto emission = floatGridOf(nebula::generateNebula(p), "emission");
    const auto values = activeValues(*emission);
    ASSERT_FALSE(values.empty());
    const double R = p.emissionRadius * p.size, w = p.shellWidth * R;
    double inner = R, outer = R;
    for (const auto& [c, v] : values) {
        const double d = distance(worldOf(*emission, c), *p.motionCentre);
        EXPECT_LT(std::abs(d - R), w + 1e-9) << d;
        inner = std::min(inner, d);
        outer = std::max(outer, d);
    }
    EXPECT_LT(inner, R); // a shell, both sides of its radius
    EXPECT_GT(outer, R);
}

// ---- spectral grids ----------------------------------------------------------------------------

TEST(GenerateNebula, SpectralGridsOnlyWithSpectralParameters)
{
    NebulaParams p = small(16);
    p.spectral.oiii = 0.5; // ignored unless spectral.enabled
    GridSet s = nebula::generateNebula(p);
    EXPECT_FALSE(s.find("temperature"));
    EXPECT_FALSE(s.find("velocity"));
    EXPECT_FALSE(s.find("emission.oiii"));

    p.spectral.enabled = true;
    p.spectral.oiii = 0.0;
    s = nebula::generateNebula(p);
    EXPECT_TRUE(floatGridOf(s, "temperature"));
    EXPECT_TRUE(openvdb::gridPtrCast<openvdb::Vec3fGrid>(s.find("velocity")));
    EXPECT_FALSE(s.find("emission.oiii"));

    p.spectral.oiii = 0.5;
    s = nebula::generateNebula(p);
    EXPECT_TRUE(floatGridOf(s, "emission.oiii"));
    EXPECT_EQ(s.grids.size(), 5u);
}

TEST(GenerateNebula, TemperatureIsTheDustEquilibriumOnDensityAndEmission)
{
    NebulaParams p = small(20);
    p.stars = nebula::exampleStars();
    p.spectral.enabled = true;
    const GridSet s = nebula::generateNebula(p);
    const auto t = floatGridOf(s, "temperature");
    ASSERT_TRUE(t);
    EXPECT_EQ(t->metaValue<std::string>("units"), "K");
    EXPECT_EQ(t->getGridClass(), openvdb::GRID_UNKNOWN);
    const auto temps = activeValues(*t);
    // Active exactly on the voxels of density or emission.
    auto uni = activeValues(*floatGridOf(s, "density"));
    for (const auto& [c, v] : activeValues(*floatGridOf(s, "emission")))
        uni[c] = v;
    ASSERT_EQ(temps.size(), uni.size());
    const double rMin = 0.5 * p.size / p.res;
    for (const auto& [c, T] : temps) {
        ASSERT_TRUE(uni.count(c));
        const double U = nebula::radiationFieldU(worldOf(*t, c), p.stars, rMin);
        EXPECT_NEAR(T, nebula::dustTemperature(U), 1e-5 * T);
        EXPECT_GE(T, 16.4f); // never below the interstellar field's 16.4 K
    }

    // With a gas temperature: that, wherever there is emission; the dust's elsewhere.
    p.spectral.gasTemperature = 8000.0;
    const GridSet g = nebula::generateNebula(p);
    const auto gt = activeValues(*floatGridOf(g, "temperature"));
    const auto em = activeValues(*floatGridOf(g, "emission"));
    int gas = 0;
    for (const auto& [c, T] : gt) {
        if (em.count(c)) {
            EXPECT_EQ(T, 8000.0f);
            ++gas;
        } else {
            EXPECT_EQ(T, temps.at(c));
        }
    }
    EXPECT_GT(gas, 0);
}

TEST(GenerateNebula, VelocityIsTheMotionFieldInWorldAxes)
{
    NebulaParams p = small(16);
    p.stars = nebula::exampleStars();
    p.spectral.enabled = true;
    p.spectral.motion.expansion = 25.0;
    p.spectral.motion.rotation = -8.0;
    p.spectral.motion.turbulence = 3.0;
    const GridSet s = nebula::generateNebula(p);
    const auto v = openvdb::gridPtrCast<openvdb::Vec3fGrid>(s.find("velocity"));
    ASSERT_TRUE(v);
    EXPECT_EQ(v->metaValue<std::string>("units"), "km/s");
    EXPECT_TRUE(v->isInWorldSpace());
    EXPECT_EQ(v->getVectorType(), openvdb::VEC_CONTRAVARIANT_RELATIVE);
    EXPECT_EQ(v->activeVoxelCount(), floatGridOf(s, "temperature")->activeVoxelCount());
    const nebula::MotionField field(nebula::motionParams(p), p.size);
    int n = 0;
    for (auto it = v->cbeginValueOn(); it; ++it, ++n) {
        const auto c = it.getCoord();
        const auto expected = field(worldOf(*v, {c.x(), c.y(), c.z()}));
        for (int a = 0; a < 3; ++a) {
            ASSERT_NEAR((*it)[a], expected[std::size_t(a)],
                        1e-5 * (1.0 + std::abs(expected[std::size_t(a)])));
        }
    }
    EXPECT_GT(n, 0);
}

TEST(GenerateNebula, OxygenZoneInsideTheIonisedRegion)
{
    NebulaParams p = small(32);
    p.spectral.enabled = true;
    p.spectral.oiii = 0.7;
    p.emissionRadius = 0.3;
    const GridSet s = nebula::generateNebula(p);
    const auto oiiiGrid = floatGridOf(s, "emission.oiii");
    ASSERT_TRUE(oiiiGrid);
    EXPECT_EQ(oiiiGrid->metaValue<std::string>(nebula::META_LINES),
              nebula::lineListToString(nebula::parseLineList(nebula::OIII_EMISSION_LINES, "t")));
    const auto oiii = activeValues(*oiiiGrid);
    const auto em = activeValues(*floatGridOf(s, "emission"));
    ASSERT_FALSE(oiii.empty());
    const double R = p.emissionRadius * p.size;
    const Pc centre = nebula::motionCentre(p); // the origin: no stars
    int full = 0;
    for (const auto& [c, o] : oiii) {
        ASSERT_TRUE(em.count(c)); // only where there is emission
        const double e = em.at(c);
        const double d = distance(worldOf(*oiiiGrid, c), centre);
        // oiii * emission * s, s falling from 1 at 0.5 R to 0 at 0.8 R.
        EXPECT_LE(o, p.spectral.oiii * e * (1 + 1e-6));
        EXPECT_LT(d, 0.8 * R);
        if (d <= 0.5 * R) {
            EXPECT_NEAR(o, p.spectral.oiii * e, 1e-6 * o);
            ++full;
        }
    }
    EXPECT_GT(full, 0);
}

// ---- parameters --------------------------------------------------------------------------------

TEST(GenerateNebula, BadParametersAreUsageErrorsNamingTheOption)
{
    const auto message = [](const std::function<void(NebulaParams&)>& set) {
        NebulaParams p = small(8);
        set(p);
        try {
            nebula::generateNebula(p);
        } catch (const nebula::UsageError& e) {
            return std::string(e.what());
        } catch (const std::exception& e) {
            return std::string("not a UsageError: ") + e.what();
        }
        return std::string("no error");
    };
    EXPECT_TRUE(contains(message([](auto& p) { p.res = 1; }), "--res"));
    EXPECT_TRUE(contains(message([](auto& p) { p.res = 4096; }), "--res"));
    EXPECT_TRUE(contains(message([](auto& p) { p.size = 0; }), "--size"));
    EXPECT_TRUE(contains(message([](auto& p) { p.size = NAN; }), "--size"));
    EXPECT_TRUE(contains(message([](auto& p) { p.densityPeak = -1; }), "--density"));
    EXPECT_TRUE(contains(message([](auto& p) { p.emissionPeak = -1; }), "--emission"));
    EXPECT_TRUE(contains(message([](auto& p) { p.fbm.octaves = 0; }), "--octaves"));
    EXPECT_TRUE(contains(message([](auto& p) { p.fbm.octaves = 17; }), "--octaves"));
    EXPECT_TRUE(contains(message([](auto& p) { p.cavity = -0.1; }), "--cavity"));
    EXPECT_TRUE(contains(message([](auto& p) { p.contrast = 0; }), "--contrast"));
    EXPECT_TRUE(contains(message([](auto& p) { p.exponent = 0; }), "--exponent"));
    EXPECT_TRUE(contains(message([](auto& p) { p.shellWidth = 0; }), "--shell-width"));
    EXPECT_TRUE(contains(message([](auto& p) { p.shellWidth = 1.5; }), "--shell-width"));
    EXPECT_TRUE(contains(message([](auto& p) {
                             p.emissionShape = nebula::EmissionShape::Shell;
                             p.emissionRadius = 0;
                         }),
                         "--emission-radius"));
    EXPECT_TRUE(contains(message([](auto& p) {
                             p.motionCentre = Pc{0, INFINITY, 0};
                         }),
                         "--motion-centre"));
    EXPECT_TRUE(contains(message([](auto& p) { p.lines.clear(); }), "--lines"));
    EXPECT_TRUE(contains(message([](auto& p) {
                             p.spectral.enabled = true;
                             p.spectral.gasTemperature = -5;
                         }),
                         "--gas-temperature"));
    EXPECT_TRUE(contains(message([](auto& p) {
                             p.spectral.enabled = true;
                             p.spectral.oiii = NAN;
                         }),
                         "--oiii"));
    EXPECT_TRUE(contains(message([](auto& p) {
                             p.spectral.enabled = true;
                             p.motionRadius = 0.0;
                         }),
                         "--motion-radius"));
    // Bad dust is a usage error too.
    const std::string dust = message([](auto& p) { p.dust.albedo = 2; });
    EXPECT_EQ(dust.rfind("not a UsageError", 0), std::string::npos) << dust;
    EXPECT_NE(dust, "no error");
    // The smallest lattice is fine.
    EXPECT_EQ(message([](auto& p) { p.res = 2; }), "no error");
}

TEST(GenerateNebula, MotionCentreAndParams)
{
    NebulaParams p;
    EXPECT_EQ(nebula::motionCentre(p), (Pc{0, 0, 0}));
    p.stars = nebula::exampleStars();
    EXPECT_EQ(nebula::motionCentre(p), p.stars[0].position);
    p.motionCentre = Pc{1, 2, 3};
    EXPECT_EQ(nebula::motionCentre(p), (Pc{1, 2, 3}));

    p.seed = 99;
    p.spectral.motion.expansion = 12.0;
    p.spectral.motion.seed = 5;   // replaced by the nebula's
    p.spectral.motion.radius = 7; // replaced
    auto m = nebula::motionParams(p);
    EXPECT_EQ(m.centre, (Pc{1, 2, 3}));
    EXPECT_DOUBLE_EQ(m.radius, p.emissionRadius * p.size);
    EXPECT_EQ(m.seed, 99u);
    EXPECT_EQ(m.expansion, 12.0);
    p.motionRadius = 2.5;
    m = nebula::motionParams(p);
    EXPECT_EQ(m.radius, 2.5);
}

// ---- radiation field and dust temperature ------------------------------------------------------

TEST(DustTemperature, RadiativeEquilibriumWithTheStars)
{
    // U of a 1 L_sun star at 1 pc, by hand: L_sun / (4 pi pc^2 c u_ISRF) =
    // 3.828e33 / (4 pi (3.0857e18)^2 * 2.9979e10 * 8.64e-13) = 1.2351e-3.
    nebula::Star sun;
    sun.position = {1.0, 2.0, 3.0};
    sun.luminosity = 1.0;
    EXPECT_NEAR(nebula::radiationFieldU({2.0, 2.0, 3.0}, {sun}, 0.01), 1.2351e-3, 1e-6);
    // Inverse square, linear in L, summed over stars, clamped at rMin.
    nebula::Star big = sun;
    big.luminosity = 8000.0;
    const double U1 = nebula::radiationFieldU({1.0, 2.0, 5.0}, {big}, 0.01);
    EXPECT_NEAR(U1, 8000.0 * 1.2351e-3 / 4.0, 1e-3 * U1);
    EXPECT_NEAR(nebula::radiationFieldU({1.0, 2.0, 5.0}, {big, sun}, 0.01),
                U1 + nebula::radiationFieldU({1.0, 2.0, 5.0}, {sun}, 0.01), 1e-12 * U1);
    EXPECT_DOUBLE_EQ(nebula::radiationFieldU(sun.position, {sun}, 0.5),
                     nebula::radiationFieldU({1.5, 2.0, 3.0}, {sun}, 0.5));
    EXPECT_EQ(nebula::radiationFieldU({0, 0, 0}, {}, 0.5), 0.0);

    // T = 16.4 K (1 + U)^(1/6): the interstellar field alone gives 16.4 K * 2^(1/6).
    EXPECT_DOUBLE_EQ(nebula::dustTemperature(0.0), 16.4);
    EXPECT_NEAR(nebula::dustTemperature(1.0), 18.408, 1e-3);
    EXPECT_NEAR(nebula::dustTemperature(63.0), 32.8, 1e-9);   // 64^(1/6) = 2
    EXPECT_NEAR(nebula::dustTemperature(4095.0), 65.6, 1e-9); // 4096^(1/6) = 4
}

TEST(DustTemperature, SixthRootScaling)
{
    // (T / 16.4 K)^6 = 1 + U for any U >= 0 ...
    for (double U : {0.0, 1e-6, 0.3, 1.0, 17.0, 1e3, 1e8}) {
        EXPECT_NEAR(std::pow(nebula::dustTemperature(U) / 16.4, 6.0), 1.0 + U, 1e-12 * (1.0 + U))
            << U;
    }
    // ... so far above the interstellar field T ~ U^(1/6): 64 times the field, twice as hot.
    for (double U : {1e6, 1e9, 1e12}) {
        // (Relative deviations 0.33/U and 1/(6U) from the 1 + U.)
        EXPECT_NEAR(nebula::dustTemperature(64.0 * U) / nebula::dustTemperature(U), 2.0, 1.0 / U)
            << U;
        EXPECT_NEAR(nebula::dustTemperature(U), 16.4 * std::pow(U, 1.0 / 6.0),
                    16.4 * std::pow(U, 1.0 / 6.0) / U)
            << U;
    }
    // Monotonic: more light, warmer dust.
    double previous = 0.0;
    for (double U = 0.0; U < 1e4; U = U * 3.0 + 0.1) {
        const double T = nebula::dustTemperature(U);
        EXPECT_GT(T, previous) << U;
        previous = T;
    }
}

TEST(RadiationField, FallsAsInverseSquareFromOneStar)
{
    nebula::Star s;
    s.name = "s";
    s.position = {-1.0, 0.5, 2.0};
    s.luminosity = 500.0;
    const double rMin = 0.05;
    // U r^2 is the same at every distance beyond rMin, in every direction.
    const double k = nebula::radiationFieldU({-1.0 + 1.0, 0.5, 2.0}, {s}, rMin); // r = 1 pc
    EXPECT_GT(k, 0.0);
    // L / (4 pi r^2 c u_ISRF), all in cgs: 500 L_sun at 1 pc.
    const double expected = 500.0 * nebula::L_SUN_CGS /
                            (4.0 * nebula::PI * nebula::PC_CM * nebula::PC_CM *
                             nebula::SPEED_OF_LIGHT_CGS * nebula::U_ISRF);
    EXPECT_NEAR(k, expected, 1e-12 * expected);
    const Pc dirs[] = {{1, 0, 0}, {0, -1, 0}, {0.6, 0, 0.8}, {-0.48, 0.6, -0.64}};
    for (double r : {0.06, 0.1, 0.5, 2.0, 7.0, 100.0}) {
        for (const Pc& d : dirs) {
            const Pc x = {s.position[0] + r * d[0], s.position[1] + r * d[1],
                          s.position[2] + r * d[2]};
            EXPECT_NEAR(nebula::radiationFieldU(x, {s}, rMin) * r * r, k, 1e-9 * k) << r;
        }
    }
    // Inside rMin the field is that at rMin.
    for (double r : {0.0, 0.01, 0.049}) {
        const Pc x = {s.position[0] + r, s.position[1], s.position[2]};
        EXPECT_NEAR(nebula::radiationFieldU(x, {s}, rMin), k / (rMin * rMin),
                    1e-9 * k / (rMin * rMin))
            << r;
    }
}

} // namespace

// The memory generateNebula() may need: dense arrays of the emitting fields plus, at worst,
// sparse grids of every voxel; a resolution that would not fit is refused before anything
// is allocated, naming --res and both sizes.
TEST(GenerateNebula, MemoryNeedsAreCheckedBeforeAllocating)
{
    NebulaParams p = small(100);
    const double voxels = 1e6;
    // The grids with every voxel of the support's leaves active (no dense arrays: they are
    // built leaf by leaf): at most the whole cube, at least the ball the dust may fill (r < 0.5
    // cube edges, 52 % of the cube), and the same voxels for every variant.
    const double perVoxel = 2 * 4.125;
    const double base = nebula::generateBytes(p);
    EXPECT_LE(base, voxels * perVoxel);
    EXPECT_GE(base, 0.52 * voxels * perVoxel);
    p.spectral.enabled = true;
    EXPECT_DOUBLE_EQ(nebula::generateBytes(p), base / perVoxel * (2 * 4.125 + 4.125 + 12.125));
    p.spectral.oiii = 0.5;
    EXPECT_DOUBLE_EQ(nebula::generateBytes(p), base / perVoxel * (3 * 4.125 + 4.125 + 12.125));
    // Memory follows the nebula: a small envelope and no emission need a small part of the cube.
    NebulaParams compact = small(100);
    compact.envelope = 0.1;
    compact.emissionPeak = 0.0;
    EXPECT_LT(nebula::generateBytes(compact), 0.1 * voxels * perVoxel);
    EXPECT_GE(nebula::generateBytes(compact), 4.0 / 3.0 * 3.14159 * 50 * 50 * 50 * 0.1 * 0.1 * 0.1 *
                                                  perVoxel); // r < 0.1: always dust room

    // 2048^3 with every grid: about 100 GiB. Refused unless this machine has that much (then the
    // check is only that it does not throw before generating, which would take too long).
    p = small(2048);
    p.spectral.enabled = true;
    p.spectral.oiii = 0.5;
    const double need = nebula::generateBytes(p);
    EXPECT_GT(need, 1e11);
    if (double(nebula::physicalMemory()) < need) {
        EXPECT_EQ(errorMessage([&] { nebula::generateNebula(p); }),
                  "--res 2048: generating the grids needs " + nebula::bytesText(need) +
                      " of memory; this machine has " +
                      nebula::bytesText(double(nebula::physicalMemory())));
    }
}
