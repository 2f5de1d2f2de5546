// SPDX-License-Identifier: Apache-2.0
// The frame loop's progress weights (src/render/frame.h rowCosts()): each row's expected
// cost against its closed form on a uniform cube seen by an orthographic camera (rows
// through the cube: the pixel's cost plus its steps through the lattice; rows beside it:
// the pixel's cost alone), rows outside a fisheye's circle weigh least, thick dust stops
// the count where the rays stop, and the weights are the same every time.
#include "nebula/render/options.h"
#include "nebula/render/scene.h"

#include "frame.h"
#include "render_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

using namespace nebula;

namespace {

/// 16 x 32 pixels of 0.2 pc looking along +z at the cube's centre: rows 0-5 pass above the
/// lattice (y > 4 pc), rows 6-25 through it.
RenderOptions orthographicView(double step)
{
    RenderOptions o;
    o.camera.model = "orthographic";
    o.camera.eye = Vec3(2, 2, -5);
    o.camera.lookAt = Vec3(2, 2, 2);
    o.camera.width = 16;
    o.camera.height = 32;
    o.camera.pixelSizePc = 0.2;
    o.step = step;
    return o;
}

} // namespace

TEST(FrameProgress, RowCostsFollowTheWorkOfEachRow)
{
    using namespace nebula::test;
    const RenderScene thin = cube(1e-3, 0.0, {});
    const RenderOptions o = orthographicView(1.0);
    const std::vector<std::uint64_t> w = detail::rowCosts(thin, o, nullptr);
    ASSERT_EQ(w.size(), 32u);
    const int columns = detail::ROW_COST_COLUMNS;
    // Beside the cube: the pixels alone.
    EXPECT_EQ(w[0], 1 + std::uint64_t(std::llround(16.0 * columns * detail::ROW_COST_PIXEL)));
    // Through it: each pixel steps through the lattice's 40 voxels along z (one step a voxel).
    EXPECT_EQ(w[16],
              1 + std::uint64_t(std::llround(16.0 * columns * (detail::ROW_COST_PIXEL + 40.0))));
    // Half the step: twice the steps.
    const std::vector<std::uint64_t> fine = detail::rowCosts(thin, orthographicView(0.5), nullptr);
    EXPECT_EQ(fine[16],
              1 + std::uint64_t(std::llround(16.0 * columns * (detail::ROW_COST_PIXEL + 80.0))));
    // The same every time, and never zero.
    EXPECT_EQ(detail::rowCosts(thin, o, nullptr), w);
    for (const auto x : w)
        EXPECT_GE(x, 1u);
    // Thick dust: the rays stop early, so do the weights.
    const RenderScene thick = cube(1e5, 0.0, {});
    EXPECT_LT(detail::rowCosts(thick, o, nullptr)[16], w[16]);
    EXPECT_EQ(detail::rowCosts(thick, o, nullptr)[0], w[0]);
}

TEST(FrameProgress, PixelsOutsideTheDomeWeighNothing)
{
    using namespace nebula::test;
    const RenderScene thin = cube(1e-3, 0.0, {});
    RenderOptions o;
    o.camera.model = "fisheye";
    o.camera.fovDeg = 180;
    o.camera.eye = Vec3(2, 2, -5);
    o.camera.lookAt = Vec3(2, 2, 2);
    o.camera.width = o.camera.height = 64;
    const std::vector<std::uint64_t> w = detail::rowCosts(thin, o, nullptr);
    // The top row's 16 sampled pixels are all outside the circle but the middle two.
    EXPECT_LT(w[0], w[32]);
    EXPECT_LE(w[0], 1 + std::uint64_t(std::llround(16.0 * 2 * detail::ROW_COST_PIXEL)));
}
