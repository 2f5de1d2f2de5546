// SPDX-License-Identifier: Apache-2.0
// --frame-nebula's target (stages/framing.h): the dust's centroid and radius against closed
// forms; an off-centre cloud framed by every camera has its column-density image's centroid
// (each voxel's mass projected through the camera, brute force) in the central 10 % of each
// view; a grid without dust is refused naming the grid.
#include "nebula/stages/framing.h"

#include "nebula/core/error.h"
#include "nebula/render/camera_model.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <string>
#include <vector>

using namespace nebula;

namespace {

GridSet withDensity(openvdb::FloatGrid::Ptr g)
{
    openvdb::initialize();
    GridSet set;
    set.source = "cloud.vdb";
    g->setName("density");
    set.grids.push_back(g);
    return set;
}

/// An off-centre, lopsided cloud: a Gaussian blob about index (40, -12, 7), voxel 0.1 pc,
/// plus a faint wisp on one side.
GridSet offCentreCloud()
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    for (int k = -10; k <= 10; ++k)
        for (int j = -10; j <= 10; ++j)
            for (int i = -14; i <= 14; ++i) {
                const double r2 = i * i / 49.0 + j * j / 16.0 + k * k / 25.0;
                const float v = float(std::exp(-0.5 * r2));
                if (v > 1e-3f) g->tree().setValueOn(openvdb::Coord(40 + i, -12 + j, 7 + k), v);
            }
    for (int i = 0; i < 10; ++i)
        g->tree().setValueOn(openvdb::Coord(60 + i, -12, 7), 0.05f);
    return withDensity(g);
}

} // namespace

// Two voxels of mass 1 and 3 on the x axis: the centroid a quarter of the way, the 90 %
// radius the distance to the heavier one (it holds 75 %: the radius must reach the other).
TEST(Framing, TargetIsTheMassCentroidAndRadius)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
    g->tree().setValueOn(openvdb::Coord(0, 0, 0), 1.0f);
    g->tree().setValueOn(openvdb::Coord(8, 0, 0), 3.0f);
    g->tree().setValueOn(openvdb::Coord(2, 2, 2), 0.0f); // active, no dust
    const GridSet set = withDensity(g);
    const FramingTarget t = dustFramingTarget(set, "density");
    EXPECT_NEAR(t.centre.x, 3.0, 1e-12); // (0 * 1 + 4 * 3) / 4 pc
    EXPECT_NEAR(t.centre.y, 0.0, 1e-12);
    EXPECT_NEAR(t.extent, 3.0, 1e-12);
    EXPECT_NEAR(t.radius, 3.0, 3.0 / 8192 + 1e-12);
}

TEST(Framing, OffCentreCloudLandsInTheMiddleOfEveryCamera)
{
    const GridSet set = offCentreCloud();
    const auto grid = set.floatGrid("density", "--density-grid");
    const nebula::Run quiet;
    for (const CameraModel* m : cameraModels()) {
        for (const bool keepEye : {false, true}) {
            Camera c;
            c.model = m->name();
            c.fovDeg = m->defaultFov();
            c.width = c.height = 48;
            if (m->name() == "equirect") c.width = 96;
            if (m->name() == "fisheye-stereo") c.height = 96;
            if (m->reads("ipd")) c.ipdPc = 0.01;
            if (keepEye) c.eye = Vec3(-3, 2, -8);
            const Camera f = frameNebula(set, "density", c, {keepEye, false}, quiet);
            const Projection proj(f);
            for (int v = 0; v < proj.views(); ++v) {
                int y0 = 0, y1 = 0;
                proj.viewRows(v, y0, y1);
                double sum = 0, sx = 0, sy = 0;
                for (auto it = grid->cbeginValueOn(); it; ++it) {
                    const openvdb::Vec3d w = grid->transform().indexToWorld(it.getCoord());
                    double px = 0, py = 0;
                    if (!proj.project(Vec3(w.x(), w.y(), w.z()), px, py, v)) continue;
                    sum += *it;
                    sx += *it * px;
                    sy += *it * (py - y0);
                }
                ASSERT_GT(sum, 0.0);
                const double dx = sx / sum / f.width - 0.5, dy = sy / sum / (y1 - y0) - 0.5;
                const std::string what =
                    m->name() + (keepEye ? " eye given" : "") + " view " + std::to_string(v);
                EXPECT_LT(std::abs(dx), 0.05) << what;
                EXPECT_LT(std::abs(dy), 0.05) << what;
            }
        }
    }
}

TEST(Framing, NoDustIsRefusedNamingTheGrid)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->tree().setValueOn(openvdb::Coord(1, 2, 3), 0.0f);
    const GridSet set = withDensity(g);
    try {
        (void)dustFramingTarget(set, "density");
        FAIL() << "no refusal";
    } catch (const UsageError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("--frame-nebula"), std::string::npos) << msg;
        EXPECT_NE(msg.find("\"density\""), std::string::npos) << msg;
        EXPECT_NE(msg.find("cloud.vdb"), std::string::npos) << msg;
    }
}
