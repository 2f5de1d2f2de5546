// SPDX-License-Identifier: Apache-2.0
// render/camera_path.h: keyframed camera paths: parsing (carry-over, errors), centripetal
// Catmull-Rom through the keyframes, constant speed, ease in and out.
#include "nebula/render/camera_path.h"

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

using namespace nebula;

namespace {

CameraPath parse(const std::string& text)
{
    Camera defaults;
    defaults.up = Vec3(0, 1, 0);
    defaults.fovDeg = 50;
    return parseCameraPath(text, "flight.json", defaults);
}

std::string errorOf(const std::string& text)
{
    try {
        parse(text);
    } catch (const Error& e) {
        return e.what();
    }
    return "(accepted)";
}

const std::string THREE_KEYS = R"({"fps": 24, "keyframes": [
    {"time": 0, "eye": [0, 0, -10], "look_at": [0, 0, 0]},
    {"time": 1, "eye": [5, 1, -5], "look_at": [0, 0, 1], "fov": 30, "roll": 10},
    {"time": 2.5, "eye": [6, 0, 3], "look_at": [1, 0, 0], "up": [0, 0, 1]}]})";

/// The uniform Catmull-Rom segment P1 -> P2 (the variant that forms loops and cusps).
Vec3 uniformCatmullRom(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, double u)
{
    const double u2 = u * u, u3 = u2 * u;
    return (p1 * 2.0 + (p2 - p0) * u + (p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3) * u2 +
            (-p0 + p1 * 3.0 - p2 * 3.0 + p3) * u3) *
           0.5;
}

/// Whether the 2D polyline (x, y of @p pts) crosses itself.
bool selfIntersects(const std::vector<Vec3>& pts)
{
    const auto cross = [](const Vec3& o, const Vec3& a, const Vec3& b) {
        return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    };
    for (std::size_t i = 0; i + 1 < pts.size(); ++i)
        for (std::size_t j = i + 2; j + 1 < pts.size(); ++j) {
            const double d1 = cross(pts[i], pts[i + 1], pts[j]);
            const double d2 = cross(pts[i], pts[i + 1], pts[j + 1]);
            const double d3 = cross(pts[j], pts[j + 1], pts[i]);
            const double d4 = cross(pts[j], pts[j + 1], pts[i + 1]);
            if (d1 * d2 < 0 && d3 * d4 < 0) return true;
        }
    return false;
}

} // namespace

// Missing up, fov and roll carry over from the previous keyframe (the first from the
// command line); the path has a frame per 1/fps up to its last keyframe.
TEST(CameraPath, KeyframesCarryOverAndCountFrames)
{
    const CameraPath p = parse(THREE_KEYS);
    ASSERT_EQ(p.keys.size(), 3u);
    EXPECT_EQ(p.keys[0].fovDeg, 50.0);
    EXPECT_EQ(p.keys[0].up.y, 1.0);
    EXPECT_EQ(p.keys[2].fovDeg, 30.0);
    EXPECT_EQ(p.keys[2].rollDeg, 10.0);
    EXPECT_EQ(p.keys[2].up.z, 1.0);
    EXPECT_EQ(p.frameCount(), 61); // 0 .. 2.5 s at 24 fps
    EXPECT_DOUBLE_EQ(p.frameTime(1), 0.0);
    EXPECT_DOUBLE_EQ(p.frameTime(25), 1.0);
}

// At each keyframe's time the camera is exactly that keyframe's; before the first and after
// the last it holds still.
TEST(CameraPath, PassesThroughItsKeyframes)
{
    const CameraPath p = parse(THREE_KEYS);
    const Camera base;
    for (const auto& k : p.keys) {
        const Camera c = p.at(k.time, base);
        EXPECT_NEAR((c.eye - k.eye).length(), 0.0, 1e-12) << k.time;
        EXPECT_NEAR((c.lookAt - k.lookAt).length(), 0.0, 1e-12) << k.time;
        EXPECT_NEAR(c.fovDeg, k.fovDeg, 1e-12) << k.time;
        EXPECT_NEAR(c.rollDeg, k.rollDeg, 1e-12) << k.time;
    }
    EXPECT_NEAR((p.at(-1, base).eye - p.keys[0].eye).length(), 0.0, 1e-12);
    EXPECT_NEAR((p.at(99, base).eye - p.keys[2].eye).length(), 0.0, 1e-12);
    // The model and resolution come from the base camera.
    Camera dome;
    dome.model = "fisheye";
    dome.width = dome.height = 64;
    EXPECT_EQ(p.at(0.5, dome).model, "fisheye");
    EXPECT_EQ(p.at(0.5, dome).width, 64);
}

// Equally spaced collinear keyframes at equal time steps: the centripetal curve is the
// straight line at uniform speed (knot intervals all equal, so it is the uniform spline,
// which reproduces linear motion).
TEST(CameraPath, CollinearEvenKeyframesGiveUniformStraightMotion)
{
    const CameraPath p = parse(R"({"fps": 10, "keyframes": [
        {"time": 0, "eye": [0, 0, 0], "look_at": [0, 0, 10]},
        {"time": 1, "eye": [1, 2, 3], "look_at": [0, 0, 10]},
        {"time": 2, "eye": [2, 4, 6], "look_at": [0, 0, 10]},
        {"time": 3, "eye": [3, 6, 9], "look_at": [0, 0, 10]}]})");
    for (double t = 0; t <= 3.0; t += 0.05) {
        const Vec3 e = p.at(t, Camera()).eye;
        EXPECT_NEAR((e - Vec3(t, 2 * t, 3 * t)).length(), 0.0, 1e-12) << t;
    }
}

// The centripetal parametrisation never loops within a segment (Yuksel, Schaefer and Keyser
// 2011): uneven keyframes for which the uniform Catmull-Rom segment crosses itself.
TEST(CameraPath, CentripetalSegmentsDoNotLoop)
{
    const Vec3 p0(3, -6, 0), p1(0, 0, 0), p2(1, 0, 0), p3(-6, 4, 0);
    std::vector<Vec3> uniform;
    for (int i = 0; i <= 400; ++i)
        uniform.push_back(uniformCatmullRom(p0, p1, p2, p3, i / 400.0));
    ASSERT_TRUE(selfIntersects(uniform)); // the test's case is a hard one
    const CameraPath p = parse(R"({"fps": 24, "keyframes": [
        {"time": 0, "eye": [3, -6, 0], "look_at": [0, 0, 50]},
        {"time": 1, "eye": [0, 0, 0], "look_at": [0, 0, 50]},
        {"time": 2, "eye": [1, 0, 0], "look_at": [0, 0, 50]},
        {"time": 3, "eye": [-6, 4, 0], "look_at": [0, 0, 50]}]})");
    std::vector<Vec3> centripetal;
    for (int i = 0; i <= 400; ++i)
        centripetal.push_back(p.at(1.0 + i / 400.0, Camera()).eye);
    EXPECT_FALSE(selfIntersects(centripetal));
}

// constant_speed: equal times, equal distances along the eye's curve, whatever the keyframe
// times say; with ease_in/ease_out the speed rises from and falls to zero and the path still
// ends at the last keyframe.
TEST(CameraPath, ConstantSpeedAndEasing)
{
    const std::string keys = R"("keyframes": [
        {"time": 0, "eye": [0, 0, 0], "look_at": [0, 0, 50]},
        {"time": 0.2, "eye": [1, 0, 0], "look_at": [0, 0, 50]},
        {"time": 3, "eye": [4, 3, 0], "look_at": [0, 0, 50]},
        {"time": 4, "eye": [9, 3, 1], "look_at": [0, 0, 50]}]})";
    const CameraPath p = parse(R"({"fps": 25, "constant_speed": true, )" + keys);
    std::vector<double> steps;
    Vec3 prev = p.at(0, Camera()).eye;
    for (int f = 1; f <= 100; ++f) {
        const Vec3 e = p.at(f * 0.04, Camera()).eye;
        steps.push_back((e - prev).length());
        prev = e;
    }
    const double mean = (steps.front() + steps.back()) / 2;
    for (const double s : steps)
        EXPECT_NEAR(s, mean, 1e-2 * mean);
    EXPECT_NEAR((p.at(4, Camera()).eye - Vec3(9, 3, 1)).length(), 0.0, 1e-9);

    const CameraPath eased =
        parse(R"({"fps": 25, "constant_speed": true, "ease_in": 1, "ease_out": 0.5, )" + keys);
    const auto speed = [&](double t) {
        return (eased.at(t + 1e-4, Camera()).eye - eased.at(t, Camera()).eye).length() / 1e-4;
    };
    const double cruise = speed(2.0);
    EXPECT_LT(speed(0.0), 1e-3 * cruise);                 // starts at rest
    EXPECT_NEAR(speed(0.5), 0.5 * cruise, 1e-2 * cruise); // linear ramp over 1 s
    EXPECT_LT(speed(4.0 - 1e-4), 1e-2 * cruise);          // stops at the end
    EXPECT_NEAR((eased.at(4, Camera()).eye - Vec3(9, 3, 1)).length(), 0.0, 1e-9);
    // A camera that stays put (no arc length) follows the keyframe times.
    const CameraPath still = parse(R"({"fps": 25, "constant_speed": true, "keyframes": [
        {"time": 0, "eye": [1, 1, 1], "look_at": [0, 0, 0], "fov": 20},
        {"time": 2, "eye": [1, 1, 1], "look_at": [0, 0, 0], "fov": 60}]})");
    EXPECT_NEAR(still.at(1, Camera()).fovDeg, 40.0, 1e-9);
}

// Every mistake names the file and, where it applies, the keyframe.
TEST(CameraPath, MistakesAreNamed)
{
    EXPECT_NE(errorOf("{").find("flight.json: the camera path is not valid JSON"),
              std::string::npos)
        << errorOf("{");
    EXPECT_NE(errorOf(R"({"keyframes": []})").find("\"fps\" is missing"), std::string::npos);
    EXPECT_NE(errorOf(R"({"fps": 24, "keyframes": []})").find("non-empty"), std::string::npos);
    const std::string k0 = R"({"time": 0, "eye": [0, 0, -5], "look_at": [0, 0, 0]})";
    EXPECT_NE(errorOf(R"({"fps": 24, "speed": 1, "keyframes": [)" + k0 + "]}")
                  .find("unknown key \"speed\""),
              std::string::npos);
    EXPECT_NE(errorOf(R"({"fps": 24, "keyframes": [)" + k0 + "," + k0 + "]}")
                  .find("flight.json: keyframe 2: time 0 must be after the previous"),
              std::string::npos)
        << errorOf(R"({"fps": 24, "keyframes": [)" + k0 + "," + k0 + "]}");
    EXPECT_NE(
        errorOf(R"({"fps": 24, "keyframes": [{"time": 0, "eye": [0, 0], "look_at": [0, 0, 1]}]})")
            .find("keyframe 1: eye must be an array of 3 numbers"),
        std::string::npos);
    EXPECT_NE(
        errorOf(
            R"({"fps": 24, "keyframes": [{"time": 0, "eye": [0, 0, 1], "look_at": [0, 0, 1]}]})")
            .find("keyframe 1: --eye and --look-at must differ"),
        std::string::npos);
    EXPECT_NE(errorOf(R"({"fps": 24, "keyframes": [{"time": 0, "look_at": [0, 0, 1]}]})")
                  .find("keyframe 1: \"eye\" is missing"),
              std::string::npos);
    EXPECT_NE(errorOf(R"({"fps": 24, "ease_in": 2, "keyframes": [)" + k0 +
                      R"(, {"time": 1, "eye": [0, 0, -4], "look_at": [0, 0, 0]}]})")
                  .find("must not exceed the path's duration"),
              std::string::npos);
    EXPECT_NE(errorOf(R"({"fps": -1, "keyframes": [)" + k0 + "]}").find("fps must be in"),
              std::string::npos);
}
