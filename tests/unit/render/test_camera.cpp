// SPDX-License-Identifier: Apache-2.0
// Cameras (render/camera.h): the perspective, fisheye and equirect projections' geometry
// (round trips, orientation, exact pixel solid angles), the Camera convenience functions
// against Projection, and validateCamera().
#include "nebula/render/camera.h"
#include "nebula/render/camera_model.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

using namespace nebula;

// Camera geometry: project() inverts direction(), and the pixel solid angles of a frame add
// up to the solid angle of its rectangular pyramid.
TEST(Render, CameraProjectionAndSolidAngle)
{
    Camera c;
    c.eye = Vec3(1, -2, 3);
    c.lookAt = Vec3(0, 0, 0);
    c.width = 80;
    c.height = 60;
    c.fovDeg = 50;
    double px, py;
    ASSERT_TRUE(c.project(c.eye + c.direction(17.5, 42.5) * 7.0, px, py));
    EXPECT_NEAR(px, 17.5, 1e-9);
    EXPECT_NEAR(py, 42.5, 1e-9);
    EXPECT_FALSE(c.project(c.eye - c.direction(40, 30), px, py));
    double omega = 0.0;
    for (int y = 0; y < 60; ++y)
        for (int x = 0; x < 80; ++x)
            omega += c.pixelSolidAngle(x + 0.5, y + 0.5);
    const double a = std::tan(25 * PI / 180), b = a * 60 / 80;
    const double pyramid = 4 * std::asin(a * b / std::sqrt((1 + a * a) * (1 + b * b)));
    EXPECT_NEAR(omega, pyramid, 1e-12 * pyramid); // each pixel's solid angle is exact
}

// The Camera's functions are Projection's; direction() is unit length, the centre
// of the frame looks at lookAt, the top row is up and the right column right, and the
// horizontal field of view spans fovDeg.
TEST(Camera, PinholeBasisAndFieldOfView)
{
    Camera c;
    c.eye = Vec3(0, 0, -10);
    c.lookAt = Vec3(0, 0, 0);
    c.up = Vec3(0, 1, 0);
    c.width = 100;
    c.height = 50;
    c.fovDeg = 60;
    const Projection p(c);
    EXPECT_EQ(p.eye().z, -10.0);
    for (const auto& [x, y] :
         {std::pair{0.5, 0.5}, std::pair{50.0, 25.0}, std::pair{99.5, 12.25}}) {
        const Vec3 a = c.direction(x, y), b = p.direction(x, y);
        EXPECT_NEAR((a - b).length(), 0.0, 1e-15);
        EXPECT_NEAR(a.length(), 1.0, 1e-12);
        EXPECT_DOUBLE_EQ(c.pixelSolidAngle(x, y), p.pixelSolidAngle(x, y));
    }
    // The frame's centre looks along +z at lookAt.
    const Vec3 centre = c.direction(50.0, 25.0);
    EXPECT_NEAR(centre.z, 1.0, 1e-12);
    // The left and right edges of the frame are fovDeg apart.
    const Vec3 left = c.direction(0.0, 25.0), right = c.direction(100.0, 25.0);
    EXPECT_NEAR(std::acos(left.dot(right)) * 180.0 / PI, 60.0, 1e-9);
    // py = 0 is the top row: it looks up (+y); larger px looks to the right. Looking along +z
    // with +y up, right-handed, "right" is -x.
    EXPECT_GT(c.direction(50.0, 0.0).y, 0.0);
    EXPECT_LT(c.direction(50.0, 50.0).y, 0.0);
    EXPECT_LT(c.direction(100.0, 25.0).x, 0.0);
    // The centre pixel's solid angle is about (angular pixel size)^2.
    const double pixel = 2.0 * std::tan(30.0 * PI / 180.0) / 100.0;
    EXPECT_NEAR(c.pixelSolidAngle(50.0, 25.0), pixel * pixel, 1e-3 * pixel * pixel);
    // Off-axis pixels subtend less.
    EXPECT_LT(c.pixelSolidAngle(0.5, 0.5), c.pixelSolidAngle(50.0, 25.0));
}

TEST(Camera, ValidateRefusesDegenerateViews)
{
    Camera c;
    EXPECT_NO_THROW(validateCamera(c));
    Camera same = c;
    same.lookAt = same.eye;
    EXPECT_THROW(validateCamera(same), UsageError);
    Camera parallel = c;
    parallel.eye = Vec3(0, 5, 0);
    parallel.lookAt = Vec3(0, 0, 0);
    parallel.up = Vec3(0, 1, 0);
    EXPECT_THROW(validateCamera(parallel), UsageError);
    parallel.up = Vec3(0, -3, 0);
    EXPECT_THROW(validateCamera(parallel), UsageError);
    parallel.up = Vec3(0, 0, 1);
    EXPECT_NO_THROW(validateCamera(parallel));
}

// Coordinates whose squares overflow, and non-finite ones, are blamed on their own option
// (an eye at 1e300 used to be blamed on --up).
TEST(Camera, ValidateNamesTheOptionOfAHugeOrNonFiniteVector)
{
    Camera far;
    far.eye = Vec3(1e300, 0, 0);
    try {
        validateCamera(far);
        ADD_FAILURE() << "no UsageError";
    } catch (const UsageError& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind("--eye 1e+300,0,0: each number must be at most 1e+150 in magnitude", 0),
                  0u)
            << msg;
        EXPECT_EQ(msg.find("--up"), std::string::npos) << msg;
    }
    Camera nanLook;
    nanLook.lookAt = Vec3(0, std::nan(""), 0);
    try {
        validateCamera(nanLook);
        ADD_FAILURE() << "no UsageError";
    } catch (const UsageError& e) {
        EXPECT_EQ(std::string(e.what()).rfind("--look-at must be three finite numbers", 0), 0u)
            << e.what();
    }
    Camera infUp;
    infUp.up = Vec3(0, INFINITY, 0);
    EXPECT_THROW(validateCamera(infUp), UsageError);
    // At the limit: valid.
    Camera edge;
    edge.eye = Vec3(MAX_CAMERA_COORDINATE, 0, -MAX_CAMERA_COORDINATE);
    EXPECT_NO_THROW(validateCamera(edge));
}

namespace {

Camera model(const std::string& m, int w, int h, double fov)
{
    Camera c;
    c.eye = Vec3(1, -2, 3);
    c.lookAt = Vec3(4, 0, -1);
    c.up = Vec3(0, 0, 1);
    c.model = m;
    c.width = w;
    c.height = h;
    c.fovDeg = fov;
    return c;
}

double totalSolidAngle(const Camera& c)
{
    const Projection p(c);
    double omega = 0.0;
    for (int y = 0; y < c.height; ++y)
        for (int x = 0; x < c.width; ++x)
            omega += p.pixelSolidAngle(x + 0.5, y + 0.5);
    return omega;
}

double angle(const Vec3& a, const Vec3& b)
{
    return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
}

} // namespace

// The pixels' solid angles add up to the whole view: a fisheye's circle of full angle F
// covers 2 pi (1 - cos(F/2)) (the whole sphere at 360), an equirect panorama 4 pi. Equirect
// is exact; the fisheye's rim pixels are integrated on 16 x 16 midpoints (error ~ 1e-4).
TEST(Camera, SolidAnglesAddUpToTheView)
{
    EXPECT_NEAR(totalSolidAngle(model("equirect", 64, 32, 0)), 4 * PI, 1e-12);
    for (const double fov : {60.0, 180.0, 250.0, 360.0}) {
        const double cap = 2 * PI * (1 - std::cos(fov * PI / 360));
        EXPECT_NEAR(totalSolidAngle(model("fisheye", 96, 96, fov)), cap, 2e-4 * cap)
            << "fov " << fov;
    }
}

// project() inverts direction() in every model, and every direction is unit length.
TEST(Camera, ProjectInvertsDirectionInEveryModel)
{
    for (const auto& c : {model("perspective", 80, 60, 70), model("fisheye", 90, 90, 180),
                          model("fisheye", 90, 90, 330), model("equirect", 120, 60, 0)}) {
        const Projection p(c);
        int checked = 0;
        for (double y = 0.75; y < c.height; y += 3.1)
            for (double x = 0.25; x < c.width; x += 2.7) {
                Vec3 d;
                if (!p.direction(x, y, d)) continue;
                EXPECT_NEAR(d.length(), 1.0, 1e-12);
                double px, py;
                ASSERT_TRUE(p.project(c.eye + d * 3.5, px, py)) << c.model;
                EXPECT_NEAR(px, x, 1e-6) << c.model << " at " << x << "," << y;
                EXPECT_NEAR(py, y, 1e-6) << c.model << " at " << x << "," << y;
                ++checked;
            }
        EXPECT_GT(checked, 300) << c.model;
    }
}

// Fisheye: the centre looks at lookAt; the angle from the axis is proportional to the
// distance from the centre (azimuthal equidistant): the circle's edge is fov/2 away; up is
// at the top and right at the right, as in the perspective image; the corners are out of
// view and have no solid angle.
TEST(Camera, FisheyeIsAzimuthalEquidistant)
{
    Camera c = model("fisheye", 100, 100, 200);
    c.eye = Vec3(0, 0, 0);
    c.lookAt = Vec3(0, 0, 5);
    c.up = Vec3(0, 1, 0);
    const Projection p(c);
    const Vec3 forward(0, 0, 1);
    EXPECT_NEAR(angle(p.direction(50, 50), forward), 0.0, 1e-12);
    for (const double r : {0.1, 0.4, 0.75, 1.0}) {
        EXPECT_NEAR(angle(p.direction(50 + 50 * r, 50), forward), r * 100 * PI / 180, 1e-12);
        EXPECT_NEAR(angle(p.direction(50, 50 - 50 * r), forward), r * 100 * PI / 180, 1e-12);
    }
    EXPECT_GT(p.direction(50, 10).y, 0.0); // top: up
    Camera persp = c;
    persp.model = "perspective";
    persp.fovDeg = 90;
    EXPECT_GT(p.direction(90, 50).x * persp.direction(90, 50).x, 0.0); // right: right
    Vec3 d;
    EXPECT_FALSE(p.direction(2, 2, d));
    EXPECT_FALSE(p.inView(0.5, 0.5));
    EXPECT_TRUE(p.inView(50, 50));
    EXPECT_EQ(p.pixelSolidAngle(0.5, 0.5), 0.0);
    // Beyond half the full angle: not in view; behind the eye but within 100 degrees: in view.
    double px, py;
    EXPECT_FALSE(p.project(Vec3(0, 0, -5), px, py));
    EXPECT_TRUE(p.project(Vec3(5, 0, -0.5), px, py));
    // The centre pixel subtends (angular pixel size)^2.
    const double pixel = 200.0 * PI / 180.0 / 100.0;
    EXPECT_NEAR(p.pixelSolidAngle(50.5, 50.5), pixel * pixel, 1e-3 * pixel * pixel);
}

// Dome tilt: T = 0 is a horizontal planetarium dome, its centre straight up, the look-at
// point on the bottom edge of the circle (the front of a dome master); T = 90 is the
// untilted fisheye; in between, the look-at point is 90 - T degrees below the centre.
TEST(Camera, DomeTiltTurnsTheAxisFromUpTowardsTheView)
{
    Camera c = model("fisheye", 100, 100, 180);
    c.eye = Vec3(0, 0, 0);
    c.lookAt = Vec3(0, 0, 5);
    c.up = Vec3(0, 1, 0);
    double px, py;
    c.domeTiltDeg = 0;
    EXPECT_NEAR(angle(Projection(c).direction(50, 50), Vec3(0, 1, 0)), 0.0, 1e-12);
    ASSERT_TRUE(Projection(c).project(Vec3(0, 0, 5), px, py));
    EXPECT_NEAR(px, 50.0, 1e-9);
    EXPECT_NEAR(py, 100.0, 1e-9);
    c.domeTiltDeg = 30;
    ASSERT_TRUE(Projection(c).project(Vec3(0, 0, 5), px, py));
    EXPECT_NEAR(px, 50.0, 1e-9);
    EXPECT_NEAR(py, 50.0 + 50.0 * 60.0 / 90.0, 1e-9); // 60 degrees below the centre
    EXPECT_GT(Projection(c).direction(90, 50).x * Projection(c).direction(90, 60).x, 0.0);
    c.domeTiltDeg = 90;
    Camera untilted = c;
    untilted.domeTiltDeg = std::nan("");
    for (const auto& [x, y] : {std::pair{10.5, 40.5}, std::pair{77.0, 23.0}})
        EXPECT_NEAR((Projection(c).direction(x, y) - Projection(untilted).direction(x, y)).length(),
                    0.0, 1e-12);
}

// Equirect: the view direction at the centre, longitude growing to the right (camera right
// at 3/4 of the width, behind at the left and right edges), the camera's up at the top row;
// each pixel subtends (2 pi / W)(sin lat_top - sin lat_bottom).
TEST(Camera, EquirectOrientationAndSolidAngle)
{
    Camera c = model("equirect", 200, 100, 0);
    c.eye = Vec3(0, 0, 0);
    c.lookAt = Vec3(0, 0, 5);
    c.up = Vec3(0, 1, 0);
    const Projection p(c);
    EXPECT_NEAR(angle(p.direction(100, 50), Vec3(0, 0, 1)), 0.0, 1e-12);
    EXPECT_NEAR(angle(p.direction(150, 50), p.right()), 0.0, 1e-12);
    EXPECT_NEAR(p.right().x, -1.0, 1e-12); // as the perspective camera's right
    EXPECT_NEAR(angle(p.direction(0, 50), Vec3(0, 0, -1)), 0.0, 1e-12);
    EXPECT_NEAR(angle(p.direction(200, 50), Vec3(0, 0, -1)), 0.0, 1e-12);
    EXPECT_NEAR(angle(p.direction(100, 0), Vec3(0, 1, 0)), 0.0, 1e-12);
    EXPECT_NEAR(angle(p.direction(37, 100), Vec3(0, -1, 0)), 0.0, 1e-12);
    EXPECT_TRUE(p.wrapsHorizontally());
    const double lat0 = PI / 2 - 10 * PI / 100, lat1 = lat0 - PI / 100;
    EXPECT_NEAR(p.pixelSolidAngle(3.5, 10.5), 2 * PI / 200 * (std::sin(lat0) - std::sin(lat1)),
                1e-15);
}

// Roll turns the camera clockwise about its view direction: at +90 the top of the picture
// looks towards what was the right.
TEST(Camera, RollTurnsTheCamera)
{
    Camera c;
    c.eye = Vec3(0, 0, 0);
    c.lookAt = Vec3(0, 0, 5);
    c.up = Vec3(0, 1, 0);
    c.width = c.height = 100;
    c.fovDeg = 60;
    const Vec3 right = Projection(c).right();
    c.rollDeg = 90;
    const Projection p(c);
    EXPECT_NEAR((p.upward() - right).length(), 0.0, 1e-12);
    EXPECT_NEAR(angle(p.direction(50, 50), Vec3(0, 0, 1)), 0.0, 1e-12);
}

// Each model's image shape and field of view, and --dome-tilt only for the fisheye.
TEST(Camera, ValidateChecksTheModelsShapeAndAngles)
{
    Camera c;
    c.fovDeg = 200;
    EXPECT_THROW(validateCamera(c), UsageError); // perspective: at most 179
    c.model = "fisheye";
    EXPECT_NO_THROW(validateCamera(c));
    c.fovDeg = 361;
    EXPECT_THROW(validateCamera(c), UsageError);
    c.fovDeg = 180;
    c.width = 600;
    try {
        validateCamera(c);
        ADD_FAILURE() << "no UsageError";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("--res 600x512 must be square"), std::string::npos)
            << e.what();
    }
    c.width = 512;
    c.domeTiltDeg = 95;
    EXPECT_THROW(validateCamera(c), UsageError);
    c.domeTiltDeg = 20;
    EXPECT_NO_THROW(validateCamera(c));
    c.model = "equirect";
    EXPECT_THROW(validateCamera(c), UsageError); // --dome-tilt is for the fisheye
    c.domeTiltDeg = std::nan("");
    EXPECT_THROW(validateCamera(c), UsageError); // 512x512 is not 2:1
    c.width = 1024;
    EXPECT_NO_THROW(validateCamera(c));
    EXPECT_EQ(cameraModel("equirect").name(), "equirect");
    EXPECT_THROW(cameraModel("cube").name(), UsageError);
}

// The orthographic camera: parallel rays along the view, each from its pixel on the plane
// through the eye (the eye itself at the image centre), pixels of --pixel-size pc (or the
// width --fov spans at the look-at point), solid angle (pixel / D)^2; project() inverts
// origin(); stars behind the eye's plane are not in view; the optical depth to a star starts
// at its foot on that plane; validateCamera() names --pixel-size and --distance.
TEST(Camera, OrthographicRaysAreParallelFromTheEyesPlane)
{
    Camera c;
    c.model = "orthographic";
    c.eye = Vec3(1, 2, -20);
    c.lookAt = Vec3(1, 2, 0);
    c.width = 40;
    c.height = 30;
    c.pixelSizePc = 0.25;
    c.distancePc = 1000.0;
    validateCamera(c);
    const Projection p(c);
    EXPECT_TRUE(p.parallel());
    for (double y = 0.5; y < 30; y += 3.7)
        for (double x = 0.5; x < 40; x += 4.1) {
            Vec3 d;
            ASSERT_TRUE(p.direction(x, y, d));
            EXPECT_NEAR(d.z, 1.0, 1e-15);
            const Vec3 o = p.origin(x, y);
            EXPECT_NEAR(o.z, -20.0, 1e-12);
            // Right is -x looking along +z with y up.
            EXPECT_NEAR(o.x, 1.0 - (x - 20.0) * 0.25, 1e-12);
            EXPECT_NEAR(o.y, 2.0 + (15.0 - y) * 0.25, 1e-12);
            double px, py;
            ASSERT_TRUE(p.project(o + d * 7.0, px, py));
            EXPECT_NEAR(px, x, 1e-9);
            EXPECT_NEAR(py, y, 1e-9);
            EXPECT_NEAR(p.pixelSolidAngle(x, y), 0.25 * 0.25 / 1e6, 1e-20);
        }
    EXPECT_NEAR((p.origin(20, 15) - c.eye).length(), 0.0, 1e-12);
    double px, py;
    EXPECT_FALSE(p.project(Vec3(1, 2, -21), px, py)); // behind the eye's plane
    const Vec3 foot = p.originTowards(Vec3(3, -1, 5));
    EXPECT_NEAR((foot - Vec3(3, -1, -20)).length(), 0.0, 1e-12);
    EXPECT_NEAR(p.distanceSquared(Vec3(3, -1, 5)), 1e6, 1e-6);
    // Defaults: the pixel the perspective --fov spans at the look-at point; D = |eye - look-at|.
    Camera d = c;
    d.pixelSizePc = std::nan("");
    d.distancePc = std::nan("");
    d.fovDeg = 36.0;
    EXPECT_NEAR(d.orthographicPixel(), 2 * 20 * std::tan(18 * PI / 180) / 40, 1e-12);
    EXPECT_NEAR(d.observerDistance(), 20.0, 1e-12);
    const auto refused = [](const Camera& cam, const std::string& option) {
        try {
            validateCamera(cam);
            ADD_FAILURE() << "not refused: " << option;
        } catch (const UsageError& e) {
            EXPECT_NE(std::string(e.what()).find(option), std::string::npos) << e.what();
        }
    };
    Camera bad = c;
    bad.distancePc = 0.0;
    refused(bad, "--distance");
    bad = c;
    bad.pixelSizePc = -1.0;
    refused(bad, "--pixel-size");
    bad = c;
    bad.model = "perspective";
    refused(bad, "--pixel-size is for --camera orthographic (--camera is perspective)");
    EXPECT_EQ(cameraModel("orthographic").name(), "orthographic");
}
