// SPDX-License-Identifier: Apache-2.0
// The multi-resolution levels (nebpyramid, DESIGN §5): box averages that conserve mass,
// the coarse transform, and the two ways of making tau.<star>.L<k>.
#include "nebula/stages/pyramid.h"

#include "nebula/stages/illuminate.h"
#include "test_util.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

using namespace nebula;

namespace {

constexpr double KAPPA = 1.5e-3;

struct PyramidTest : ::testing::Test
{
    void SetUp() override { openvdb::initialize(); }
};

/// A fine transform that is rotated, mirrored, anisotropic and translated.
openvdb::math::Transform::Ptr skewedTransform()
{
    auto xform = openvdb::math::Transform::createLinearTransform(1.0);
    xform->postScale(openvdb::Vec3d(0.2, 0.3, 0.5));
    xform->postRotate(0.7, openvdb::math::Y_AXIS);
    xform->postRotate(0.3, openvdb::math::X_AXIS);
    xform->postScale(openvdb::Vec3d(-1.0, 1.0, 1.0)); // mirror
    xform->postTranslate(openvdb::Vec3d(3.0, -2.0, 1.0));
    return xform;
}

/// Reference box sums: every active voxel (tiles voxelized) added to the coarse voxel
/// floor(i / 2^level), with std::floor on doubles.
std::map<openvdb::Coord, std::pair<double, int>> referenceSums(const openvdb::FloatGrid& grid,
                                                               int level)
{
    auto copy = grid.deepCopy();
    copy->tree().voxelizeActiveTiles();
    const double s = std::ldexp(1.0, level);
    std::map<openvdb::Coord, std::pair<double, int>> sums;
    for (auto it = copy->cbeginValueOn(); it; ++it) {
        const auto& c = it.getCoord();
        const openvdb::Coord I(int(std::floor(c.x() / s)), int(std::floor(c.y() / s)),
                               int(std::floor(c.z() / s)));
        sums[I].first += double(*it);
        sums[I].second += 1;
    }
    return sums;
}

/// A random sparse grid around the origin (negative and positive indices), an active tile,
/// and inactive voxels with values that must not count.
openvdb::FloatGrid::Ptr randomGrid(unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> coord(-21, 18);
    std::uniform_real_distribution<float> value(0.0f, 1000.0f);
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    g->setTransform(skewedTransform());
    auto acc = g->getAccessor();
    for (int n = 0; n < 3000; ++n) {
        acc.setValueOn(openvdb::Coord(coord(rng), coord(rng), coord(rng)), value(rng));
    }
    for (int n = 0; n < 200; ++n) {
        acc.setValueOff(openvdb::Coord(coord(rng), coord(rng), coord(rng)), 5000.0f);
    }
    // An 8^3 active tile (a leaf-sized block of constant value) at negative indices.
    g->tree().addTile(1, openvdb::Coord(-32, -24, 16), 250.0f, true);
    return g;
}

} // namespace

TEST_F(PyramidTest, CoarseIndexIsFloorDivision)
{
    for (int level = 0; level <= 4; ++level) {
        for (int i = -70; i <= 70; ++i) {
            EXPECT_EQ(coarseIndex(i, level), int(std::floor(i / std::ldexp(1.0, level))))
                << i << " level " << level;
        }
    }
    EXPECT_EQ(levelGridName("density", 2), "density.L2");
    EXPECT_EQ(levelGridName(tauGridName("alpha"), 3), "tau.alpha.L3");
    EXPECT_EQ(tauMethodFromString("average"), TauMethod::Average);
    EXPECT_EQ(toString(TauMethod::Recompute), "recompute");
    EXPECT_THROW(tauMethodFromString("mean"), UsageError);
}

// A hand-made grid: the blocks by floor division (negative indices included), values
// sum / 8^k with inactive voxels as 0, and the metadata.
TEST_F(PyramidTest, BoxAverageOfHandMadeGrid)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("smoke");
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
    auto acc = g->getAccessor();
    acc.setValueOn(openvdb::Coord(-1, -1, -1), 8.0f);  // level 1: block (-1,-1,-1)
    acc.setValueOn(openvdb::Coord(-2, -2, -2), 16.0f); //          same block
    acc.setValueOn(openvdb::Coord(-3, 0, 1), 4.0f);    //          block (-2, 0, 0)
    acc.setValueOn(openvdb::Coord(0, 0, 0), 80.0f);    //          block (0, 0, 0)
    acc.setValueOff(openvdb::Coord(1, 1, 1), 1000.0f); // inactive: counts as 0

    const auto l1 = boxAverage(*g, 1);
    EXPECT_EQ(l1->getName(), "smoke.L1");
    EXPECT_EQ(l1->getGridClass(), openvdb::GRID_FOG_VOLUME);
    EXPECT_EQ(l1->activeVoxelCount(), 3u);
    const auto a1 = l1->getConstAccessor();
    EXPECT_FLOAT_EQ(a1.getValue(openvdb::Coord(-1, -1, -1)), 24.0f / 8.0f);
    EXPECT_FLOAT_EQ(a1.getValue(openvdb::Coord(-2, 0, 0)), 4.0f / 8.0f);
    EXPECT_FLOAT_EQ(a1.getValue(openvdb::Coord(0, 0, 0)), 80.0f / 8.0f);
    EXPECT_EQ(l1->metaValue<openvdb::Int32>("level"), 1);
    EXPECT_EQ(l1->metaValue<openvdb::Int32>("scale"), 2);
    EXPECT_EQ(l1->metaValue<std::string>("source_grid"), "smoke");

    // Level 2: (-1..-4) -> -1, (0..3) -> 0.
    const auto l2 = boxAverage(*g, 2);
    EXPECT_EQ(l2->activeVoxelCount(), 3u);
    const auto a2 = l2->getConstAccessor();
    EXPECT_FLOAT_EQ(a2.getValue(openvdb::Coord(-1, -1, -1)), 24.0f / 64.0f);
    EXPECT_FLOAT_EQ(a2.getValue(openvdb::Coord(-1, 0, 0)), 4.0f / 64.0f);
    EXPECT_FLOAT_EQ(a2.getValue(openvdb::Coord(0, 0, 0)), 80.0f / 64.0f);
    EXPECT_NEAR(l2->voxelSize()[0], 1.0, 1e-12);

    // The mean of the active values only (for tau).
    const auto m1 = activeMean(*g, 1);
    EXPECT_FLOAT_EQ(m1->getConstAccessor().getValue(openvdb::Coord(-1, -1, -1)), 12.0f);
    EXPECT_FLOAT_EQ(m1->getConstAccessor().getValue(openvdb::Coord(0, 0, 0)), 80.0f);
}

// A random sparse grid with a tile, on a skewed transform: every coarse voxel against a
// brute-force reference, and mass (sum n x voxel volume) conserved to 1e-6 relative.
TEST_F(PyramidTest, BoxAverageMatchesReferenceAndConservesMass)
{
    const auto g = randomGrid(7);
    ASSERT_GT(g->tree().activeTileCount(), 0u);
    const double mass0 = gridMass(*g);
    ASSERT_GT(mass0, 0.0);
    for (int level = 0; level <= 5; ++level) {
        const auto coarse = boxAverage(*g, level);
        const auto mean = activeMean(*g, level);
        const auto ref = referenceSums(*g, level);
        const double volume = std::ldexp(1.0, 3 * level);
        ASSERT_EQ(coarse->activeVoxelCount(), ref.size()) << "level " << level;
        ASSERT_EQ(mean->activeVoxelCount(), ref.size()) << "level " << level;
        const auto acc = coarse->getConstAccessor();
        const auto meanAcc = mean->getConstAccessor();
        for (const auto& [I, sum] : ref) {
            ASSERT_TRUE(acc.isValueOn(I)) << "level " << level << " " << I;
            EXPECT_NEAR(acc.getValue(I), sum.first / volume, 1e-6 * sum.first / volume)
                << "level " << level << " " << I;
            EXPECT_NEAR(meanAcc.getValue(I), sum.first / sum.second, 1e-6 * sum.first / sum.second);
        }
        EXPECT_NEAR(gridMass(*coarse), mass0, 1e-6 * mass0) << "level " << level;
        EXPECT_NEAR(coarse->transform().voxelVolume(), volume * g->transform().voxelVolume(),
                    1e-9 * volume);
    }
}

// The coarse voxel centre is the mean of its block's fine voxel centres in world space, for
// a rotated, mirrored, anisotropic, translated level-0 transform.
TEST_F(PyramidTest, CoarseCentresAreBlockCentres)
{
    const auto fine = skewedTransform();
    ASSERT_LT(fine->voxelVolume(), 0.0) << "the test transform should mirror";
    for (int level = 1; level <= 3; ++level) {
        const auto coarse = levelTransform(*fine, level);
        EXPECT_TRUE(coarse->isLinear());
        const int s = 1 << level;
        for (const openvdb::Coord I : {openvdb::Coord(0, 0, 0), openvdb::Coord(-1, -1, -1),
                                       openvdb::Coord(3, -2, 5), openvdb::Coord(-7, 4, -1)}) {
            openvdb::Vec3d mean(0.0);
            for (int z = 0; z < s; ++z)
                for (int y = 0; y < s; ++y)
                    for (int x = 0; x < s; ++x) {
                        mean += fine->indexToWorld(
                            openvdb::Coord(s * I.x() + x, s * I.y() + y, s * I.z() + z));
                    }
            mean /= double(s * s * s);
            const auto centre = coarse->indexToWorld(I);
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(centre[c], mean[c], 1e-9) << "level " << level << " " << I;
            }
        }
        // The coarse axes are the fine ones times 2^k.
        for (int c = 0; c < 3; ++c) {
            openvdb::Vec3d e(0.0);
            e[c] = 1.0;
            const auto dc = coarse->indexToWorld(e) - coarse->indexToWorld(openvdb::Vec3d(0.0));
            const auto df = fine->indexToWorld(e) - fine->indexToWorld(openvdb::Vec3d(0.0));
            EXPECT_NEAR((dc - df * double(s)).length(), 0.0, 1e-9);
        }
    }
    // boxAverage uses it.
    const auto g = randomGrid(3);
    EXPECT_EQ(boxAverage(*g, 2)->transform(), *levelTransform(g->transform(), 2));
}

TEST_F(PyramidTest, MaxLevelKeepsTwoVoxelsAcross)
{
    using openvdb::Coord;
    using openvdb::CoordBBox;
    EXPECT_EQ(maxPyramidLevel(CoordBBox()), -1);
    EXPECT_EQ(maxPyramidLevel(CoordBBox(Coord(0), Coord(0))), -1);
    EXPECT_EQ(maxPyramidLevel(CoordBBox(Coord(0), Coord(2, 0, 0))), 0);  // 3 across
    EXPECT_EQ(maxPyramidLevel(CoordBBox(Coord(-2), Coord(1, 0, 0))), 1); // 4 across
    EXPECT_EQ(maxPyramidLevel(CoordBBox(Coord(0), Coord(0, 22, 3))), 3); // 23: 16 <= 23 < 32
    EXPECT_EQ(maxPyramidLevel(CoordBBox(Coord(0), Coord(31, 0, 0))), 4); // 32
}

namespace {

/// A GridSet holding @p density and one star "c" at world @p star, default dust.
GridSet sceneWith(openvdb::FloatGrid::Ptr density, const openvdb::Vec3d& star)
{
    GridSet set;
    set.source = "test";
    set.grids.push_back(density);
    Star s;
    s.name = "c";
    s.position = {star[0], star[1], star[2]};
    s.luminosity = 10.0;
    s.temperature = 20000.0;
    set.setStars({s});
    DustParams dust;
    dust.kappa_V = KAPPA;
    set.setDust(dust);
    return set;
}

/// A 64^3 density over index -32 .. 31 filled by f(i, j, k) (zero stays inactive).
template <typename F> openvdb::FloatGrid::Ptr sphereGrid(double h, F f)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    auto xform = openvdb::math::Transform::createLinearTransform(h);
    xform->postTranslate(openvdb::Vec3d(1.0, -0.5, 2.0));
    g->setTransform(xform);
    auto acc = g->getAccessor();
    for (int k = -32; k < 32; ++k)
        for (int j = -32; j < 32; ++j)
            for (int i = -32; i < 32; ++i) {
                const double v = f(i, j, k);
                if (v > 0.0) acc.setValueOn(openvdb::Coord(i, j, k), float(v));
            }
    return g;
}

} // namespace

// Uniform sphere, star at its centre: where every coarse cell along the ray is made of full
// blocks, the coarse density is exactly n0 and tau = kappa_V n0 r exactly (to rounding), as
// in OpticalDepth.UniformSphereStarAtCentre. A coarse cell's corners' blocks reach
// sqrt(3) (1.5 * 2^k - 0.5) fine voxels beyond a point in the cell, so that is how far inside
// the sphere a voxel must be. Beyond the sphere tau is kappa_V n0 R up to the blurred edge
// (within one coarse voxel of optical depth).
TEST_F(PyramidTest, RecomputedTauOfUniformSphereMatchesClosedForm)
{
    const double h = 0.1, R = 28.0, n0 = 1000.0; // R in fine voxels
    const auto density = sphereGrid(
        h, [&](int i, int j, int k) { return i * i + j * j + k * k <= R * R ? n0 : 0.0; });
    const auto star = density->indexToWorld(openvdb::Vec3d(0.0));
    auto grids = sceneWith(density, star);
    const nebula::Run run;
    PyramidOptions opts;
    opts.levels = 2;
    buildPyramid(grids, opts, run);
    for (int level = 1; level <= 2; ++level) {
        const auto tau = grids.floatGrid(levelGridName("tau.c", level), "");
        EXPECT_EQ(tau->metaValue<std::string>("method"), "recompute");
        EXPECT_EQ(tau->metaValue<openvdb::Int32>("level"), level);
        EXPECT_EQ(tau->metaValue<std::string>("star"), "c");
        EXPECT_EQ(tau->metaValue<double>("kappa_V"), KAPPA);
        EXPECT_EQ(tau->transform(), grids.find(levelGridName("density", level))->transform());
        const double inside = R - std::sqrt(3.0) * (1.5 * (1 << level) - 0.5);
        int nInside = 0, nOutside = 0;
        for (auto it = tau->cbeginValueOn(); it; ++it) {
            const double r = (tau->indexToWorld(it.getCoord()) - star).length(); // [pc]
            if (r <= inside * h) {
                EXPECT_NEAR(*it, KAPPA * n0 * r, 1e-5 * KAPPA * n0 * R * h)
                    << "level " << level << " " << it.getCoord();
                ++nInside;
            } else if (r >= (R + 2 * (1 << level)) * h) {
                EXPECT_NEAR(*it, KAPPA * n0 * R * h, KAPPA * n0 * (1 << level) * h)
                    << "level " << level << " " << it.getCoord();
                ++nOutside;
            }
        }
        EXPECT_GT(nInside, level == 1 ? 4000 : 300) << "level " << level;
        EXPECT_GT(nOutside, 50) << "level " << level;
    }
}

// A smooth field, n = n0 (1 - r^2/R^2), star off-centre: averaging the level-0 tau over
// each block and recomputing it through the coarse density agree away from the star and
// the sphere's edge, where both are smooth. The block mean of a smooth tau differs from its
// centre value by O(H^2 tau''), and the coarse trilinear density from the fine one by
// O(H^2 n''); measured here: |dT| <= 0.32 % (level 1) and 0.86 % (level 2); the bounds
// below leave about a factor 2.
TEST_F(PyramidTest, AverageAgreesWithRecomputeForSmoothField)
{
    const double h = 0.05, R = 30.0, n0 = 800.0;
    const auto density = sphereGrid(h, [&](int i, int j, int k) {
        return std::max(0.0, n0 * (1.0 - (i * i + j * j + k * k) / (R * R)));
    });
    const openvdb::Vec3d starIndex(6.3, -4.1, 2.7);
    const auto star = density->indexToWorld(starIndex);
    const nebula::Run run;
    auto lit = sceneWith(density, star);
    IllumOptions illum;
    illum.dust = lit.dust();
    illuminate(lit, illum, run);

    auto averaged = lit;
    auto recomputed = lit;
    PyramidOptions opts;
    opts.levels = 2;
    opts.tau = TauMethod::Average;
    buildPyramid(averaged, opts, run);
    opts.tau = TauMethod::Recompute;
    buildPyramid(recomputed, opts, run);

    const double bound[] = {0.0, 0.006, 0.015};
    for (int level = 1; level <= 2; ++level) {
        const std::string name = levelGridName("tau.c", level);
        const auto avg = averaged.floatGrid(name, ""), rec = recomputed.floatGrid(name, "");
        EXPECT_EQ(avg->metaValue<std::string>("method"), "average");
        EXPECT_EQ(avg->metaValue<std::string>("source_grid"), "tau.c");
        // Both are active on the coarse density's voxels and their 26 neighbours.
        EXPECT_EQ(avg->activeVoxelCount(), rec->activeVoxelCount());
        const auto avgAcc = avg->getConstAccessor();
        const double H = (1 << level);
        double worst = 0.0;
        int compared = 0;
        for (auto it = rec->cbeginValueOn(); it; ++it) {
            ASSERT_TRUE(avgAcc.isValueOn(it.getCoord())) << it.getCoord();
            const auto fineIndex = it.getCoord().asVec3d() * H + openvdb::Vec3d(0.5 * (H - 1));
            if ((fineIndex - starIndex).length() < 2 * H) continue;
            if (fineIndex.length() > R - 2 * H) continue;
            const double dT =
                std::exp(-double(avgAcc.getValue(it.getCoord()))) - std::exp(-double(*it));
            worst = std::max(worst, std::fabs(dT));
            ++compared;
        }
        EXPECT_GT(compared, level == 1 ? 8000 : 500);
        EXPECT_LT(worst, bound[level]) << "level " << level;
    }
}

TEST_F(PyramidTest, BadInput)
{
    const nebula::Run run;
    const auto cube = [] {
        auto g = openvdb::FloatGrid::create(0.0f);
        g->setName("density");
        g->fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(7)), 100.0f, true);
        return g;
    };
    PyramidOptions opts;
    auto grids = sceneWith(cube(), openvdb::Vec3d(0.0));
    opts.levels = 0;
    EXPECT_THROW(buildPyramid(grids, opts, run), UsageError);
    opts.levels = 3; // 8 voxels across: at most 2 levels
    EXPECT_TRUE(test::contains(test::errorMessage([&] { buildPyramid(grids, opts, run); }),
                               "at most --levels 2"));
    EXPECT_THROW(buildPyramid(grids, opts, run), UsageError);
    opts.levels = 2;
    opts.tau = TauMethod::Average;
    EXPECT_TRUE(test::contains(test::errorMessage([&] { buildPyramid(grids, opts, run); }),
                               "test: no grid \"tau.c\" for star \"c\""));
    GridSet noStars;
    noStars.source = "nostars.vdb";
    noStars.grids.push_back(cube());
    opts.tau = TauMethod::Recompute;
    EXPECT_TRUE(test::contains(test::errorMessage([&] { buildPyramid(noStars, opts, run); }),
                               "nostars.vdb: no stars"));
    // Nothing was added by the failures.
    EXPECT_EQ(grids.grids.size(), 1u);
    EXPECT_EQ(noStars.grids.size(), 1u);
}
