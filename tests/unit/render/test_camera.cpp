// Cameras (render/camera.h): the pinhole projection's geometry, the Camera convenience
// functions against PinholeProjection, and validateCamera().
#include "nebula/render/camera.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <gtest/gtest.h>

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
    EXPECT_NEAR(omega, pyramid, 1e-3 * pyramid);
}

// The Camera's functions are PinholeProjection's; direction() is unit length, the centre
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
    const PinholeProjection p(c);
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
