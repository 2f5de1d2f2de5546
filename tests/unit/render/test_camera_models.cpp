// SPDX-License-Identifier: Apache-2.0
/// @file test_camera_models.cpp
/// The camera registry (render/camera_model.h): lookup, the generic check of parameters a
/// model does not read, the one camera JSON, camera paths of both versions; and the stereo
/// fisheye, the camera added by one file: each eye maps as the fisheye does, each eye sees
/// the mono flux, a star's parallax is the IPD's, and parallax fades towards the pole.
#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/render/camera_model.h"
#include "nebula/render/camera_path.h"
#include "nebula/render/fast.h"
#include "render_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <set>
#include <string>

using namespace nebula;
using namespace nebula::test;

namespace {

std::string message(const std::function<void()>& f)
{
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

/// A valid camera of every registered model (the parameters the model needs).
Camera validCamera(const CameraModel& m)
{
    Camera c;
    c.model = m.name();
    c.fovDeg = m.defaultFov();
    c.width = c.height = 64;
    m.defaultSize(c.width, c.height);
    m.fitSize(c.width, c.height);
    if (m.name() == "ods" || m.stereoOf() == "fisheye") c.ipdPc = 0.1;
    return c;
}

Camera stereoDome(int side)
{
    Camera c;
    c.model = "fisheye-stereo";
    c.eye = Vec3(2.03, 1.98, 2.01);
    c.lookAt = Vec3(2.03, 1.98, 10);
    c.up = Vec3(0, 1, 0);
    c.width = side;
    c.height = 2 * side;
    c.fovDeg = 180;
    c.ipdPc = 0.2;
    return c;
}

} // namespace

// Every registered model has a unique name and help; a name not registered is refused with
// the list; --stereo finds the stereo forms (fisheye-stereo, ods) and refuses a model with
// none.
TEST(CameraModels, RegistryLooksUpEveryModelByName)
{
    std::set<std::string> names;
    for (const CameraModel* m : cameraModels()) {
        EXPECT_TRUE(names.insert(m->name()).second) << m->name();
        EXPECT_FALSE(m->help().empty()) << m->name();
        EXPECT_EQ(&cameraModel(m->name()), m);
        // Its default camera is valid: a Projection is made of it.
        EXPECT_NO_THROW(Projection(validCamera(*m))) << m->name();
    }
    EXPECT_GE(names.size(), 6u);
    const std::string bad = message([] { cameraModel("cube"); });
    EXPECT_NE(bad.find("--camera must be perspective, fisheye"), std::string::npos) << bad;
    EXPECT_NE(bad.find("fisheye-stereo"), std::string::npos) << bad;
    EXPECT_EQ(stereoCameraModel("fisheye").name(), "fisheye-stereo");
    EXPECT_EQ(stereoCameraModel("equirect").name(), "ods");
    const std::string none = message([] { stereoCameraModel("perspective"); });
    EXPECT_NE(none.find("--stereo: --camera perspective has no stereo form"), std::string::npos)
        << none;
}

// A parameter the model does not read is refused by the one generic check, naming the
// option and the models that read it, for every (model, parameter) pair the registry has.
TEST(CameraModels, ParameterTheModelDoesNotReadIsRefused)
{
    int refused = 0;
    for (const CameraModel* m : cameraModels()) {
        const auto reads = m->parameters();
        for (const CameraParameter& p : cameraParameters()) {
            if (std::find(reads.begin(), reads.end(), p.name) != reads.end()) continue;
            Camera c = validCamera(*m);
            p.set(c, p.name == "pole-merge" ? std::vector<double>{10, 20}
                                            : std::vector<double>(std::size_t(p.values), 1.0));
            ASSERT_TRUE(p.given(c)) << p.name;
            const std::string e = message([&] { validateCamera(c); });
            EXPECT_EQ(e.rfind("--" + p.name + " is for --camera " + cameraModelsReading(p.name) +
                                  " (--camera is " + m->name() + ")",
                              0),
                      0u)
                << e;
            ++refused;
        }
    }
    EXPECT_GT(refused, 15);
    EXPECT_EQ(cameraModelsReading("ipd"), "ods or fisheye-stereo");
}

// One camera JSON: every model's camera written and read back is the same camera (the same
// JSON), and an unknown key is refused naming it.
TEST(CameraModels, CameraJsonRoundTripsEveryModel)
{
    for (const CameraModel* m : cameraModels()) {
        Camera c = validCamera(*m);
        c.eye = Vec3(1, 2, 3);
        c.rollDeg = 12.5;
        const auto j = cameraToJson(c);
        EXPECT_EQ(j.at("projection"), m->name());
        const Camera back = cameraFromJson(j, Camera{}, "test");
        EXPECT_EQ(cameraToJson(back), j) << m->name();
        EXPECT_EQ(back.model, c.model);
    }
    const std::string e = message([] {
        cameraFromJson(nlohmann::json{{"zoom", 2}}, Camera{}, "cam.json");
    });
    EXPECT_EQ(e.rfind("cam.json: unknown camera key \"zoom\"", 0), 0u) << e;
}

// Camera paths: version 1 (no "version": fov, roll) still loads; version 2 reads the camera
// JSON's keys (fov_deg, roll_deg); a key of the other version is refused saying how to
// convert.
TEST(CameraModels, OldAndNewCameraPathsLoad)
{
    const std::string v1 = R"({"fps": 2, "keyframes": [
        {"time": 0, "eye": [0, 0, -10], "look_at": [0, 0, 0], "fov": 40, "roll": 5},
        {"time": 1, "eye": [1, 0, -10], "look_at": [0, 0, 0]}]})";
    const std::string v2 = R"({"version": 2, "fps": 2, "keyframes": [
        {"time": 0, "eye": [0, 0, -10], "look_at": [0, 0, 0], "fov_deg": 40, "roll_deg": 5},
        {"time": 1, "eye": [1, 0, -10], "look_at": [0, 0, 0]}]})";
    const CameraPath a = parseCameraPath(v1, "old.json", Camera{});
    const CameraPath b = parseCameraPath(v2, "new.json", Camera{});
    ASSERT_EQ(a.keys.size(), 2u);
    ASSERT_EQ(b.keys.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(a.keys[i].fovDeg, 40.0);
        EXPECT_EQ(b.keys[i].fovDeg, 40.0);
        EXPECT_EQ(a.keys[i].rollDeg, 5.0);
        EXPECT_EQ(b.keys[i].rollDeg, 5.0);
    }
    std::string mixed = v1;
    mixed.replace(mixed.find("\"fov\""), 5, "\"fov_deg\"");
    const std::string e = message([&] { parseCameraPath(mixed, "old.json", Camera{}); });
    EXPECT_NE(e.find("add \"version\": 2"), std::string::npos) << e;
    const std::string future = message([] {
        parseCameraPath(R"({"version": 3, "fps": 1, "keyframes": []})", "f.json", Camera{});
    });
    EXPECT_NE(future.find("version must be 1 or 2"), std::string::npos) << future;
}

// Each eye of the stereo fisheye maps directions and solid angles exactly as --camera
// fisheye does on its W x W square (the projection tests of test_camera.cpp hold for it),
// including the corners outside the circle.
TEST(CameraModels, StereoFisheyeEyesMapAsTheFisheye)
{
    for (const double tilt : {std::nan(""), 30.0}) {
        Camera st = stereoDome(48);
        st.domeTiltDeg = tilt;
        Camera mono = st;
        mono.model = "fisheye";
        mono.height = mono.width;
        mono.ipdPc = std::nan("");
        const Projection s(st), m(mono);
        EXPECT_EQ(s.views(), 2);
        EXPECT_FALSE(s.coversImage());
        for (int view = 0; view < 2; ++view) {
            int y0, y1;
            s.viewRows(view, y0, y1);
            EXPECT_EQ(y0, view * 48);
            EXPECT_EQ(y1, y0 + 48);
            for (double y = 0.5; y < 48; y += 3)
                for (double x = 0.5; x < 48; x += 3) {
                    Vec3 ds, dm;
                    const bool in = m.direction(x, y, dm);
                    ASSERT_EQ(s.direction(x, y + view * 48, ds), in);
                    EXPECT_EQ(s.pixelSolidAngle(x, y + view * 48), m.pixelSolidAngle(x, y));
                    EXPECT_EQ(s.pixelAngle(x, y + view * 48), m.pixelAngle(x, y));
                    if (!in) continue;
                    EXPECT_NEAR((ds - dm).length(), 0.0, 1e-15);
                    // A point far away (parallax below 1e-7 pixel) projects where the mono
                    // fisheye puts it, in this eye's square.
                    double px, py, qx, qy;
                    ASSERT_TRUE(m.project(mono.eye + dm * 1e8, qx, qy));
                    ASSERT_TRUE(s.project(st.eye + dm * 1e8, px, py, view));
                    EXPECT_NEAR(px, qx, 1e-5);
                    EXPECT_NEAR(py, qy + view * 48, 1e-5);
                }
        }
    }
}

// Parallax fades by the pole-merge rule: the ray's origin is IPD/2 from the eye below 60
// degrees of latitude (up is the pole), a quarter of the IPD at 67.5, the eye itself above
// 75; and a star on the horizon at distance r is seen by the left and right eyes at azimuths
// -/+ asin(IPD / 2r) about its own (project() solves it), a star at latitude 80 at one place.
TEST(CameraModels, StereoFisheyeParallaxFadesTowardsThePole)
{
    Camera c = stereoDome(96);
    c.domeTiltDeg = 0.0; // a horizontal dome: its centre is the zenith (up)
    const Projection p(c);
    for (const double lat : {80.0, 67.5, 30.0}) {
        const double want = lat > 75 ? 0.0 : lat > 60 ? 0.05 : 0.1;
        const double la = lat * PI / 180.0;
        const Vec3 d = c.up * std::sin(la) + Vec3(0, 0, 1) * std::cos(la);
        for (int view = 0; view < 2; ++view) {
            double px, py;
            ASSERT_TRUE(p.project(c.eye + d * 1e9, px, py, view)) << lat;
            const Vec3 origin = p.origin(px, py);
            EXPECT_NEAR((origin - c.eye).length(), want, 1e-6) << lat << " view " << view;
            // The origin is to the left (view 0) or right of the ray's horizontal direction.
            const Vec3 right = Vec3(0, 0, 1).cross(c.up);
            if (want > 0) {
                EXPECT_GT((origin - c.eye).dot(right) * (view == 0 ? -1 : 1), 0.0);
            }
        }
    }
    // A star on the horizon, 35 degrees round from the view direction, 1.5 pc away.
    const double lon0 = 35.0 * PI / 180.0, r = 1.5;
    const Vec3 fwd(0, 0, 1), right = fwd.cross(c.up);
    // (0.05 pc above the horizon: inside the 180-degree dome's circle, not on its rim)
    const Vec3 star = c.eye + (fwd * std::cos(lon0) + right * std::sin(lon0)) * r + c.up * 0.05;
    const double delta = std::asin(0.1 / r);
    for (int view = 0; view < 2; ++view) {
        double px, py;
        ASSERT_TRUE(p.project(star, px, py, view));
        // The ray from this eye's origin through the pixel passes through the star.
        const Vec3 o = p.origin(px, py), d = p.direction(px, py);
        const Vec3 to = star - o;
        EXPECT_NEAR((to - d * to.dot(d)).length(), 0.0, 1e-6) << "view " << view;
        const double lon = std::atan2(d.dot(right), d.dot(fwd));
        EXPECT_NEAR(lon, view == 0 ? lon0 + delta : lon0 - delta, 1e-6) << "view " << view;
    }
}

// Each eye of the stereo fisheye sees the flux the mono fisheye sees, from inside a uniformly
// glowing cube (no dust): radiance times pixel solid angle summed over each eye's square,
// within 2 % (the target; the eyes stand 0.1 pc off the centre of a 3.9 pc cube). A star's
// sprite carries its flux in each eye.
TEST(CameraModels, StereoFisheyeEachEyeSeesTheMonoFlux)
{
    const auto scene = cube(0.0, 1.0, {});
    RenderOptions o = axisCamera(Vec3(2.03, 1.98, 2.01), 0.25);
    o.emissionColor = {1, 1, 1};
    o.camera = stereoDome(96);
    RenderOptions mono = o;
    mono.camera.model = "fisheye";
    mono.camera.height = 96;
    mono.camera.ipdPc = std::nan("");
    const auto flux = [](const Image& img, const Camera& cam, int y0, int y1) {
        const Projection p(cam);
        double f = 0.0;
        for (int y = y0; y < y1; ++y)
            for (int x = 0; x < img.width; ++x)
                f += img.rgba[(std::size_t(y) * img.width + x) * 4 + 1] *
                     p.pixelSolidAngle(x + 0.5, y + 0.5);
        return f;
    };
    const double m = flux(renderFrame(scene, mono), mono.camera, 0, 96);
    const Image img = renderFrame(scene, o);
    ASSERT_EQ(img.inView.size(), std::size_t(96 * 192));
    EXPECT_EQ(img.inView[0], 0);
    EXPECT_EQ(img.inView[48 * 96 + 48], 1);
    EXPECT_EQ(img.inView[(96 + 48) * 96 + 48], 1);
    for (int view = 0; view < 2; ++view) {
        const double f = flux(img, o.camera, view * 96, view * 96 + 96);
        std::cout << "[ flux ] stereo fisheye view " << view << " / fisheye - 1 = " << f / m - 1
                  << "\n";
        EXPECT_NEAR(f, m, 2e-2 * m) << "view " << view;
    }
    Star s;
    s.name = "s";
    s.position = {2.03 + 0.5, 1.98 + 0.2, 2.01 + 1.0};
    s.luminosity = 100.0;
    RenderOptions lit = o;
    lit.drawStars = true;
    const Image starImg = renderFrame(cube(0.0, 0.0, {s}), lit);
    const Vec3 d = Vec3(0.5, 0.2, 1.0);
    const double expected = 100.0 / (4 * PI * d.dot(d));
    for (int view = 0; view < 2; ++view) {
        const double f = flux(starImg, o.camera, view * 96, view * 96 + 96);
        EXPECT_NEAR(f, expected, 1e-2 * expected) << "view " << view;
    }
}
