// SPDX-License-Identifier: Apache-2.0
// --frame-nebula's geometry (render/camera_framing.h): for every camera model, with the eye
// free and given, the target's centre lands on the framing point (the centre of the view, a
// tilted dome's sweet spot), the user's choices are kept, and the size follows the rule.
#include "nebula/render/camera_framing.h"
#include "nebula/render/camera_model.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace nebula;

namespace {

FramingTarget offCentreTarget()
{
    FramingTarget t;
    t.centre = Vec3(3.0, -2.0, 5.0);
    t.radius = 1.5;
    t.extent = 3.0;
    return t;
}

Camera model(const std::string& name)
{
    Camera c;
    c.model = name;
    c.fovDeg = cameraModel(name).defaultFov();
    c.width = 64;
    c.height = 64;
    cameraModel(name).defaultSize(c.width, c.height);
    if (name == "equirect") c.width = 2 * c.height;
    if (name == "ods") c.height = c.width;
    if (name == "fisheye-stereo") c.height = 2 * c.width;
    if (cameraModel(name).reads("ipd")) c.ipdPc = 0.05;
    return c;
}

/// Where @p p falls in view @p view, as fractions of the view's width and height from its
/// centre.
bool offset(const Camera& c, const Vec3& p, int view, double& dx, double& dy)
{
    const Projection proj(c);
    int y0 = 0, y1 = 0;
    proj.viewRows(view, y0, y1);
    double px = 0, py = 0;
    if (!proj.project(p, px, py, view)) return false;
    dx = px / c.width - 0.5;
    dy = (py - y0) / double(y1 - y0) - 0.5;
    return true;
}

} // namespace

// Every model, eye free or given: the target's centre in the central 10 % of each view (in
// fact on its centre), --up, --fov, --roll kept, the eye kept when given.
TEST(CameraFraming, EveryModelPutsTheCentroidInTheMiddle)
{
    const FramingTarget t = offCentreTarget();
    for (const CameraModel* m : cameraModels()) {
        for (const bool keepEye : {false, true}) {
            for (const double roll : {0.0, 25.0}) {
                Camera c = model(m->name());
                c.rollDeg = roll;
                if (keepEye) c.eye = Vec3(-6.0, 4.0, -9.0);
                const Camera f = frameCamera(c, t, {keepEye, false});
                const std::string what =
                    m->name() + (keepEye ? " (eye given)" : "") + " roll " + std::to_string(roll);
                const Projection proj(f);
                for (int v = 0; v < proj.views(); ++v) {
                    double dx = 1, dy = 1;
                    ASSERT_TRUE(offset(f, t.centre, v, dx, dy)) << what;
                    EXPECT_LT(std::abs(dx), 0.05) << what << " view " << v;
                    EXPECT_LT(std::abs(dy), 0.05) << what << " view " << v;
                    if (proj.views() == 1) { // mono: exactly on the centre
                        EXPECT_NEAR(dx, 0.0, 1e-6) << what;
                        EXPECT_NEAR(dy, 0.0, 1e-6) << what;
                    }
                }
                EXPECT_EQ(f.up.x, c.up.x);
                EXPECT_EQ(f.up.y, c.up.y);
                EXPECT_EQ(f.fovDeg, c.fovDeg);
                EXPECT_EQ(f.rollDeg, c.rollDeg);
                if (keepEye) {
                    EXPECT_EQ((f.eye - c.eye).length(), 0.0) << what;
                } else { // the orientation kept: only moved
                    const Vec3 a = (f.lookAt - f.eye).normalized();
                    const Vec3 b = (c.lookAt - c.eye).normalized();
                    EXPECT_NEAR((a - b).length(), 0.0, 1e-12) << what;
                }
            }
        }
    }
}

// The size: a perspective camera's eye goes to where the radius spans 80 % of the half
// field (the nearest edge of a square frame is half the fov away); the orthographic pixel
// makes the radius 80 % of half the frame, and its eye plane is outside all the dust; a
// given --pixel-size is kept.
TEST(CameraFraming, SizesTheRadiusToTheView)
{
    const FramingTarget t = offCentreTarget();
    Camera c = model("perspective");
    c.fovDeg = 40.0;
    const Camera f = frameCamera(c, t, {});
    const double angle = std::asin(t.radius / (t.centre - f.eye).length());
    EXPECT_NEAR(angle / DEG_RAD, FRAMING_FILL * 20.0, 0.2);
    EXPECT_NEAR((f.lookAt - t.centre).length(), 0.0, 1e-9);

    Camera o = model("orthographic");
    const Camera fo = frameCamera(o, t, {});
    EXPECT_NEAR(fo.pixelSizePc, t.radius / (FRAMING_FILL * 32.0), 1e-12);
    EXPECT_GT((fo.eye - t.centre).length(), t.extent);
    o.pixelSizePc = 0.01;
    EXPECT_EQ(frameCamera(o, t, {false, true}).pixelSizePc, 0.01);

    // A dome: the radius spans at most FRAMING_MAX_ANGLE_DEG.
    const Camera d = frameCamera(model("fisheye"), t, {});
    EXPECT_NEAR(std::asin(t.radius / (t.centre - d.eye).length()) / DEG_RAD, FRAMING_MAX_ANGLE_DEG,
                1e-9);
}

// A tilted dome (a planetarium's 30 degrees): the centroid lands on the sweet spot, on the
// front meridian 40 degrees above the dome's front edge (50 of the 90 degrees from the
// centre: 5/9 of the radius below the centre of the dome master), not on the bottom edge
// and not at the centre; the dome's orientation kept: a level view direction sees the
// centroid 40 - 30 = 10 degrees above the horizon.
TEST(CameraFraming, TiltedDomePutsTheNebulaInTheSweetSpot)
{
    const FramingTarget t = offCentreTarget();
    for (const bool keepEye : {false, true}) {
        Camera c = model("fisheye");
        c.width = c.height = 90;
        c.domeTiltDeg = 30.0;
        c.eye = Vec3(0, 0, -10);
        c.lookAt = Vec3(0, 0, 0); // level
        const Camera f = frameCamera(c, t, {keepEye, false});
        EXPECT_EQ(f.domeTiltDeg, 30.0);
        double px = 0, py = 0;
        ASSERT_TRUE(Projection(f).project(t.centre, px, py));
        EXPECT_NEAR(px, 45.0, 1e-6);
        EXPECT_NEAR(py, 45.0 + 45.0 * 50.0 / 90.0, 1e-6) << (keepEye ? "eye given" : "");
        if (!keepEye) {
            const Vec3 d = (t.centre - f.eye).normalized();
            EXPECT_NEAR(std::asin(d.y) / DEG_RAD, 10.0, 1e-9);
        }
    }
    // No tilt (a fisheye lens): the centre.
    Camera lens = model("fisheye");
    const Camera f = frameCamera(lens, t, {});
    double px = 0, py = 0;
    ASSERT_TRUE(Projection(f).project(t.centre, px, py));
    EXPECT_NEAR(px, 32.0, 1e-6);
    EXPECT_NEAR(py, 32.0, 1e-6);
}

// A given eye at the centroid has nothing to aim at: refused, naming the option.
TEST(CameraFraming, EyeAtTheCentroidIsRefused)
{
    const FramingTarget t = offCentreTarget();
    Camera c = model("perspective");
    c.eye = t.centre;
    try {
        (void)frameCamera(c, t, {true, false});
        FAIL() << "no refusal";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("--frame-nebula"), std::string::npos) << e.what();
    }
}
