// SPDX-License-Identifier: Apache-2.0
// The seam from files to scene (stages/scene_assembly.h): nebscatter's field read back from
// its grids into the scene, each typed source scaled to the scene's stars, and the fields a
// scene refuses.
#include "nebula/stages/scene_assembly.h"

#include "nebula/core/error.h"
#include "nebula/render/scatter_field.h"
#include "nebula/stages/scatter.h"
#include "test_util.h"
#include "view_scene.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nebula;
using nebula::test::errorMessage;
using nebula::test::litCube;

namespace {

/// The lit cube with nebscatter's field (order 1, cells of 2 voxels, few packets), one per
/// star with @p perStar; the in-memory field in @p field.
GridSet cubeWithField(bool perStar, ScatterField& field)
{
    GridSet grids = *litCube();
    ScatterStageOptions opts;
    opts.field.order = 1;
    opts.field.fieldLevel = 1;
    opts.field.packets = 4000;
    opts.field.perStar = perStar;
    opts.storedBits = FIELD_FLOAT_BITS; // the floats as computed: read back exactly
    field = scatter(grids, opts, nebula::Run());
    return grids;
}

/// @p grids with its star's luminosity times @p factor (its tau grids stay valid).
void scaleLuminosity(GridSet& grids, double factor)
{
    std::vector<Star> stars = grids.stars();
    for (auto& s : stars)
        s.luminosity *= factor;
    grids.setStars(stars);
}

/// The largest |a - f b| over the cells of @p a's lattice where a is not 0 (the cells the
/// field's grids hold), relative to the largest |a|; @p compared counts them.
double worstDifference(const SparseVolume& a, const SparseVolume& b, double f, int& compared)
{
    EXPECT_EQ(a.channels(), b.channels());
    double worst = 0.0, peak = 0.0;
    compared = 0;
    for (int k = a.lo()[2]; k < a.lo()[2] + a.dims()[2]; ++k)
        for (int j = a.lo()[1]; j < a.lo()[1] + a.dims()[1]; ++j)
            for (int i = a.lo()[0]; i < a.lo()[0] + a.dims()[0]; ++i) {
                const float* x = a.voxel(a.index(i, j, k));
                if (x[0] == 0.0f) continue;
                EXPECT_TRUE(b.contains(i, j, k)) << i << " " << j << " " << k;
                if (!b.contains(i, j, k)) return 1.0;
                const float* y = b.voxel(b.index(i, j, k));
                for (int c = 0; c < a.channels(); ++c) {
                    worst = std::max(worst, std::abs(double(x[c]) - f * y[c]));
                    peak = std::max(peak, std::abs(double(x[c])));
                }
                ++compared;
            }
    return peak > 0.0 ? worst / peak : 1.0;
}

} // namespace

// The field read from its grids is the field nebscatter computed (the sources summed as
// sceneScatterField() sums them in memory), and a per-star source follows its star's
// luminosity: twice as bright a star, twice the field.
TEST(SceneAssembly, PerStarFieldIsReadBackAndFollowsItsStar)
{
    const nebula::Run run;
    ScatterField field;
    GridSet grids = cubeWithField(true, field);
    ASSERT_EQ(field.sources.size(), 1u);
    EXPECT_EQ(field.sources[0].source, ScatterSource::oneStar(0));
    const RenderOptions opts;
    const RenderScene scene = buildScene(grids, opts, grids.dust(run));
    ASSERT_EQ(scene.scatter.order, 1);
    ASSERT_EQ(scene.scatter.level, 1);
    EXPECT_NE(scene.scatter.description.find("sources star_s"), std::string::npos)
        << scene.scatter.description;
    const SceneScatterField inMemory = sceneScatterField(field, opts);
    int compared = 0;
    EXPECT_LT(worstDifference(scene.scatter.moments, inMemory.moments, 1.0, compared), 1e-5);
    EXPECT_GT(compared, 64); // the cube's 8^3 cells and more

    scaleLuminosity(grids, 2.0);
    const RenderScene brighter = buildScene(grids, opts, grids.dust(run));
    EXPECT_LT(worstDifference(brighter.scatter.moments, inMemory.moments, 2.0, compared), 1e-5);
    EXPECT_GT(compared, 64);
}

// A field of all stars together was made for their luminosities: a scene whose star shines
// otherwise is refused, naming the star and the way out.
TEST(SceneAssembly, SummedFieldRefusesAnotherLuminosity)
{
    const nebula::Run run;
    ScatterField field;
    GridSet grids = cubeWithField(false, field);
    ASSERT_EQ(field.sources.size(), 1u);
    EXPECT_EQ(field.sources[0].source, ScatterSource::allStars());
    scaleLuminosity(grids, 2.0);
    const std::string e =
        errorMessage([&] { buildScene(grids, RenderOptions{}, grids.dust(run)); });
    EXPECT_NE(e.find("cube: the scattered-light field (nebscatter) was made for other stars: "
                     "star \"s\" of luminosity 100 L_sun, the scene's is 200"),
              std::string::npos)
        << e;
    RenderOptions without;
    without.scatterField = false;
    EXPECT_EQ(buildScene(grids, without, grids.dust(run)).scatter.order, -1);
}
