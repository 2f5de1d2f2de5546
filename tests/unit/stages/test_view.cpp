// SPDX-License-Identifier: Apache-2.0
// nebview's stage: frames equal to nebrender's, components that add up to the beauty,
// cancellation, the voxel probe against the cube's closed form, camera paths that read back.
#include "nebula/core/error.h"
#include "nebula/render/fast.h"
#include "nebula/render/sprites.h"
#include "nebula/stages/scene_assembly.h"
#include "nebula/stages/view.h"
#include "test_util.h"
#include "view_scene.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>

using namespace nebula;
using nebula::test::cubeSettings;
using nebula::test::litCube;

namespace {

const std::shared_ptr<const GridSet>& cube()
{
    static const auto grids = litCube();
    return grids;
}

} // namespace

TEST(ViewSession, FinalFrameIsNebrendersImage)
{
    const nebula::Run run;
    const ViewSettings settings = cubeSettings();
    const ViewSession session(cube(), settings, cube()->dust(run), run);
    Camera cam = settings.render.camera;
    cam.eye = {0.7, 0.4, -4.0};
    const ViewFrame frame = session.render(cam, ViewStage::Final, false, run);
    const Image shown = session.compose(frame, ViewShow{});

    RenderOptions opts = settings.render; // what nebrender renders
    opts.camera = cam;
    const RenderScene scene = buildScene(*cube(), opts, cube()->dust(run));
    const Image reference = renderFrame(scene, opts);
    ASSERT_EQ(shown.width, reference.width);
    ASSERT_EQ(shown.height, reference.height);
    ASSERT_EQ(shown.rgba.size(), reference.rgba.size());
    double lit = 0.0;
    for (std::size_t i = 0; i < shown.rgba.size(); ++i) {
        ASSERT_EQ(shown.rgba[i], reference.rgba[i]) << "sample " << i;
        lit += reference.rgba[i];
    }
    EXPECT_GT(lit, 0.0);
    // The tone and the PNG are then the same too.
    const ToneCurve curve = computeToneCurve(reference, ToneParams{});
    EXPECT_EQ(pngBytes(shown, curve), pngBytes(reference, curve));
}

TEST(ViewSession, StagesHaveTheirSizeAndSettings)
{
    const nebula::Run run;
    ViewSettings settings = cubeSettings(64, 48);
    const ViewSession session(cube(), settings, cube()->dust(run), run);
    EXPECT_EQ(session.resolution(ViewStage::Interactive), (std::array<int, 2>{32, 24}));
    EXPECT_EQ(session.resolution(ViewStage::Preview), (std::array<int, 2>{64, 48}));
    const Camera& cam = settings.render.camera;
    const RenderOptions fast = session.stageOptions(cam, ViewStage::Interactive, false);
    EXPECT_FALSE(fast.exactStarDepth);
    EXPECT_EQ(fast.step, settings.fastStep);
    const RenderOptions final = session.stageOptions(cam, ViewStage::Final, false);
    EXPECT_TRUE(final.exactStarDepth);
    EXPECT_EQ(final.step, settings.render.step);
    const ViewFrame f = session.render(cam, ViewStage::Interactive, false, run);
    EXPECT_EQ(f.image.width, 32);
    EXPECT_EQ(f.image.height, 24);
}

TEST(ViewSession, ComponentsAddUpToTheBeauty)
{
    const nebula::Run run;
    const ViewSettings settings = cubeSettings();
    const ViewSession session(cube(), settings, cube()->dust(run), run);
    const ViewFrame frame = session.render(settings.render.camera, ViewStage::Final, false, run);
    const Image all = session.compose(frame, ViewShow{});
    ViewShow single, sprites, none;
    single.field = single.emission = single.sprites = false;
    sprites.single = sprites.field = sprites.emission = false;
    none.stars = {false}; // the one star off: its light, scattered and direct, goes
    const Image a = session.compose(frame, single);
    const Image b = session.compose(frame, sprites);
    const Image c = session.compose(frame, none);
    double sumAll = 0.0, sumParts = 0.0, sumNone = 0.0, sumSprites = 0.0;
    for (std::size_t i = 0; i < all.rgba.size(); ++i) {
        if (i % 4 == 3) continue;
        sumAll += all.rgba[i];
        sumParts += a.rgba[i] + b.rgba[i];
        sumNone += c.rgba[i];
        sumSprites += b.rgba[i];
        EXPECT_NEAR(a.rgba[i] + b.rgba[i], all.rgba[i], 1e-5 * (1.0 + all.rgba[i]));
    }
    EXPECT_GT(sumSprites, 0.0);          // the star is in view
    EXPECT_GT(sumAll - sumSprites, 0.0); // and its light is scattered
    EXPECT_NEAR(sumParts, sumAll, 1e-5 * sumAll);
    EXPECT_EQ(sumNone, 0.0); // no field, no emission: nothing without the star
}

TEST(ViewSession, CancelledFrameThrows)
{
    nebula::Run run;
    const ViewSettings settings = cubeSettings();
    const ViewSession session(cube(), settings, cube()->dust(run), run);
    std::atomic<bool> cancel{true};
    run.setCancel(&cancel);
    EXPECT_THROW(session.render(settings.render.camera, ViewStage::Final, false, run), Cancelled);
    cancel = false;
    EXPECT_NO_THROW(session.render(settings.render.camera, ViewStage::Final, false, run));
}

TEST(ViewSession, ProbeFindsTheCubesFaceInClosedForm)
{
    const nebula::Run run;
    const ViewSettings settings = cubeSettings(64, 48);
    const ViewSession session(cube(), settings, cube()->dust(run), run);
    const Camera& cam = settings.render.camera; // on the -z axis, looking at the centre
    const ProbeResult p = session.probe(cam, 32.0, 24.0);
    ASSERT_TRUE(p.hit);
    // The density is N0 on index [-8, 7]; trilinear, it ramps from 0 over the voxel before
    // the face when the lattice has a zero border there. Optical depth kappa n z.
    const double slope = test::VIEW_KAPPA * test::VIEW_N0; // [pc^-1]
    const bool border = session.scene().fields.lo()[2] < -8;
    const double face = -0.8, ramp = border ? 0.5 * slope * test::VIEW_H : 0.0;
    EXPECT_NEAR(p.position.z, face + (PROBE_TAU - ramp) / slope, 1e-3);
    EXPECT_NEAR(p.position.x, 0.0, 1e-9);
    EXPECT_NEAR(p.position.y, 0.0, 1e-9);
    EXPECT_NEAR(p.density, test::VIEW_N0, 1e-3);
    EXPECT_NEAR(p.tauRay, 1.5 * slope + (border ? 2 : 0) * ramp, 1e-3);
    ASSERT_EQ(p.tau.size(), 1u);
    // The star is 1.5 pc above the axis: its light enters the top face (y = 0.7) and crosses
    // 0.7 pc of dust to the probe point (x = 0, y = 0).
    const double top = 0.7,
                 topRamp = session.scene().fields.lo()[1] + session.scene().fields.dims()[1] - 1 > 7
                               ? 0.5 * slope * test::VIEW_H
                               : 0.0;
    const double dz = p.position.z - (-0.3), dy = 1.5;
    const double through = top / dy * std::sqrt(dy * dy + dz * dz); // the path inside y <= 0.7
    EXPECT_NEAR(p.tau[0], slope * through + topRamp * std::sqrt(dy * dy + dz * dz) / dy, 0.01);
    EXPECT_TRUE(p.J.empty()); // no field in this input
    // A ray that misses the cube.
    const ProbeResult miss = session.probe(cam, 1.0, 1.0);
    EXPECT_FALSE(miss.hit);
    EXPECT_EQ(miss.tauRay, 0.0);
}

TEST(ViewSession, CameraPathReadsBackAndWritesAtomically)
{
    CameraPath path;
    path.fps = 30;
    path.constantSpeed = true;
    path.easeIn = 0.5;
    for (int i = 0; i < 3; ++i) {
        CameraKeyframe k;
        k.time = 1.5 * i;
        k.eye = {0.1 * i, 1.0 / 3.0, -5.0 + i};
        k.lookAt = {0, 0.2, 0};
        k.up = {0, 1, 0};
        k.fovDeg = 30 + i;
        k.rollDeg = i;
        path.keys.push_back(k);
    }
    const CameraPath back = parseCameraPath(cameraPathJson(path), "p.json", Camera{});
    ASSERT_EQ(back.keys.size(), 3u);
    EXPECT_EQ(back.fps, 30);
    EXPECT_TRUE(back.constantSpeed);
    EXPECT_EQ(back.easeIn, 0.5);
    for (std::size_t i = 0; i < 3; ++i) { // doubles in their shortest exact text
        EXPECT_EQ(back.keys[i].eye.y, 1.0 / 3.0);
        EXPECT_EQ(back.keys[i].time, path.keys[i].time);
        EXPECT_EQ(back.keys[i].rollDeg, path.keys[i].rollDeg);
    }
    const Camera a = path.at(2.0, Camera{}), b = back.at(2.0, Camera{});
    EXPECT_EQ(a.eye.x, b.eye.x);
    EXPECT_EQ(a.eye.z, b.eye.z);
    const std::string dir = ::testing::TempDir() + "view_path";
    std::filesystem::create_directories(dir);
    writeCameraPath(dir + "/p.json", path);
    EXPECT_TRUE(std::filesystem::exists(dir + "/p.json"));
    EXPECT_THROW(writeCameraPath(dir + "/missing/p.json", path), Error);
}

TEST(ViewSession, EveryCameraModelAndTheSpectralMode)
{
    const nebula::Run run;
    const ViewSettings settings = cubeSettings(64, 48);
    const ViewSession session(cube(), settings, cube()->dust(run), run);
    Camera cam = settings.render.camera;
    cam.model = "equirect";
    const ViewFrame e = session.render(cam, ViewStage::Preview, false, run);
    EXPECT_EQ(e.image.width, 64);
    EXPECT_EQ(e.image.height, 32);
    cam.model = "fisheye";
    cam.fovDeg = 180;
    cam.domeTiltDeg = 30;
    const ViewFrame f = session.render(cam, ViewStage::Interactive, false, run);
    EXPECT_EQ(f.image.width, 24);
    EXPECT_EQ(f.image.height, 24);
    EXPECT_FALSE(f.image.inView.empty()); // the dome's corners
    // Spectral: the spectral scene is built on first use; the frame is shown whole.
    const ViewFrame s = session.render(settings.render.camera, ViewStage::Interactive, true, run);
    double sum = 0.0;
    for (std::size_t i = 0; i < s.image.rgba.size(); ++i)
        if (i % 4 != 3) sum += s.image.rgba[i];
    EXPECT_GT(sum, 0.0);
    ViewShow none;
    none.single = none.sprites = false;
    EXPECT_EQ(session.compose(s, none).rgba, s.image.rgba);
}
