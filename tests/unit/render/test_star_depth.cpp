// SPDX-License-Identifier: Apache-2.0
// StarDepth (render/star_depth.h, DESIGN §3.3): each star's optical depth exact through
// optically rough cells, against nebillum's exact integral (columnDensityReference) and a
// brute-force single-scattering integral at the lit face of optically thick voxels.
#include "nebula/render/star_depth.h"

#include "render_scenes.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nebula;
using namespace nebula::test;

namespace {

/// The cube with voxels of V optical depth @p voxelTau, lit along +x by a far star (its
/// tau grid exact at the lattice points, as nebillum writes it).
RenderScene thickCube(double voxelTau)
{
    RenderScene scene = cube(voxelTau / (KAPPA * H), 0.0, {farStar(Vec3(-1, 0, 0))});
    scene.dust.r = {0.75, 1.0, 1.33};
    fillStarTau(scene);
    return scene;
}

Vec3 starIndex(const RenderScene& scene, std::size_t s)
{
    const auto& p = scene.stars[s].position;
    return scene.fields.indexToWorld.inverse().apply(Vec3(p[0], p[1], p[2]));
}

} // namespace

// At the lit face the density ramps from 0 to n0 across the first cell, so tau grows as the
// square of the depth there: at depth 0.5 voxel it is 1/8 of the voxel's optical depth (0.625
// for 5), where trilinear tau gives 1/4 (1.25). tau bends at the lattice points 0 and 1 (its
// second difference there is 2.5), so the cells [0, 1] and [1, 2] are curved; StarDepth
// matches the exact integral to 1e-5 in them; deeper, where tau is linear, it returns the
// interpolated tau unchanged (exact there).
TEST(StarDepth, ExactAtTheLitFaceOfThickVoxels)
{
    const RenderScene scene = thickCube(5.0);
    const StarDepth depth(scene);
    const SparseVolume n = scene.fields.channel(0);
    const Vec3 star = starIndex(scene, 0);
    for (const Vec3 p : {Vec3(0.5, 20.3, 17.7), Vec3(0.9, 3.2, 30.5), Vec3(1.4, 12.6, 12.1)}) {
        float interp = 0.0f;
        scene.fields.sampleChannels(p, 2, 1, &interp);
        const double exact = KAPPA * columnDensityReference(n, star, p);
        EXPECT_EQ(depth.curved(0, p), p.x < 2.0) << p.x; // the ramp's cells and the next
        EXPECT_NEAR(depth(0, p, interp), exact, 1e-5 * std::max(1.0, exact)) << p.x;
        if (p.x < 0.6) {
            EXPECT_GT(double(interp) - exact, 0.6) << p.x; // interpolation is off
        }
    }
    EXPECT_NEAR(KAPPA * columnDensityReference(n, star, Vec3(0.5, 20.3, 17.7)), 0.625, 1e-4);
    const Vec3 inside(10.5, 20.3, 17.7);
    EXPECT_FALSE(depth.curved(0, inside));
    EXPECT_EQ(depth(0, inside, 7.25), 7.25);
    // A star inside a rough cell: the march reaches it.
    RenderScene near = thickCube(5.0);
    const Vec3 sw = near.fields.indexToWorld.apply(Vec3(0.6, 20.0, 20.0));
    near.stars[0].position = {sw.x, sw.y, sw.z};
    fillStarTau(near);
    const StarDepth nearDepth(near);
    const Vec3 q(1.3, 20.4, 19.9);
    const double exact = KAPPA * columnDensityReference(n, Vec3(0.6, 20.0, 20.0), q);
    EXPECT_NEAR(nearDepth.march(0, q), exact, 1e-5 * std::max(1.0, exact));
    // Curved: the cells within about two voxels of the cube's faces (tau bends across the
    // lit face and across the shadow's edge along the four side faces), not its inside.
    EXPECT_GT(depth.curvedFraction(0), 0.1);
    EXPECT_LT(depth.curvedFraction(0), 0.35);
}

// The single scattering seen face-on at the lit face of voxels of optical depth 5 (albedo
// 0.5, isotropic), against a brute-force integral along the pixel's ray of
// a k (1 / 4 pi) E e^-tau_star e^-tau_eye, tau_star exact (columnDensityReference) at every
// 1e-3 voxel: within 2 % per channel with StarDepth; the trilinear tau grid alone is more
// than 20 % too dark (it puts the face's light too deep).
TEST(StarDepth, SingleScatteringAtTheLitFaceMatchesBruteForce)
{
    RenderScene scene = thickCube(5.0);
    scene.dust.albedo = 0.5;
    scene.dust.g = 0.0;
    const SparseVolume n = scene.fields.channel(0);
    const Vec3 star = starIndex(scene, 0);
    RenderOptions o;
    o.camera.eye = Vec3(-8.0, 2.037, 2.061);
    o.camera.lookAt = Vec3(2.0, 2.037, 2.061);
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = 1;
    o.camera.fovDeg = 0.01;
    o.step = 0.05;
    o.drawStars = false;
    const Image exact = renderFrame(scene, o);
    o.exactStarDepth = false;
    const Image interp = renderFrame(scene, o);
    const Affine w2i = scene.fields.indexToWorld.inverse();
    for (int c = 0; c < 3; ++c) {
        const double r = scene.dust.r[std::size_t(c)];
        double L = 0.0, tauEye = 0.0;
        const double dt = 1e-3 * H;              // [pc]
        for (double x = 0.0; x < 0.4; x += dt) { // the first 4 voxels
            const Vec3 pI = w2i.apply(Vec3(x + 0.5 * dt, 2.037, 2.061));
            const double k = KAPPA * r * n.sample0(pI);
            const double tauStar = KAPPA * r * columnDensityReference(n, star, pI);
            L += scene.dust.albedo * k / (4.0 * PI) * std::exp(-tauStar - tauEye - 0.5 * k * dt) *
                 dt;
            tauEye += k * dt;
        }
        const double e = exact.rgba[std::size_t(c)], i = interp.rgba[std::size_t(c)];
        std::printf("channel %d: brute force %.6g, StarDepth %.6g (%+.2f %%), trilinear tau "
                    "%.6g (%+.1f %%)\n",
                    c, L, e, 100 * (e / L - 1), i, 100 * (i / L - 1));
        EXPECT_NEAR(e, L, 0.02 * L) << "channel " << c;
        EXPECT_LT(i, 0.8 * L) << "channel " << c;
    }
}
