// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small analytic scenes shared by the renderer tests (fast ray caster and path tracer).
#include "nebula/physics/optical_depth.h"
#include "nebula/render/fast.h"
#include "nebula/render/path_tracer.h"

#include <cmath>
#include <vector>

namespace nebula::test {

inline constexpr double H = 0.1; // voxel size [pc]
inline constexpr int N = 41;     // lattice 0..40; dust on 1..39, zero border
inline constexpr double KAPPA = 1.5e-3;

/// Every channel of every lattice point of @p v, z slowest and x fastest: to compare volumes.
inline std::vector<float> latticeValues(const SparseVolume& v)
{
    std::vector<float> out;
    const auto& lo = v.lo();
    const auto& d = v.dims();
    for (int k = lo[2]; k < lo[2] + d[2]; ++k)
        for (int j = lo[1]; j < lo[1] + d[1]; ++j)
            for (int i = lo[0]; i < lo[0] + d[0]; ++i) {
                const float* q = v.voxel(v.index(i, j, k));
                out.insert(out.end(), q, q + v.channels());
            }
    return out;
}

/// A uniform cube: density n0 and emission e0 on lattice points 1..39, zero on the border, so
/// along an axis through it the trilinear profile integrates to 39 voxels (38 + two half
/// ramps). One star per entry of @p stars with tau channel 0 (its light arrives unattenuated).
inline RenderScene cube(double n0, double e0, const std::vector<Star>& stars)
{
    RenderScene scene;
    scene.fields = SparseVolume({0, 0, 0}, {N, N, N}, 2 + int(stars.size()));
    scene.fields.indexToWorld.m = {H, 0, 0, 0, H, 0, 0, 0, H};
    for (int k = 1; k < N - 1; ++k)
        for (int j = 1; j < N - 1; ++j)
            for (int i = 1; i < N - 1; ++i) {
                float* v = scene.fields.writable(scene.fields.index(i, j, k));
                v[0] = float(n0);
                v[1] = float(e0);
            }
    scene.stars = stars;
    for (const auto& s : stars)
        scene.starColor.push_back({s.luminosity, s.luminosity, s.luminosity});
    scene.dust.kappa_V = KAPPA;
    scene.dust.r = {0.75, 1.0, 1.33};
    scene.buildOccupancy();
    return scene;
}

/// A 1x1 camera looking from @p eye at the cube's centre (2, 2, 2) pc. Full resolution
/// (no level of detail): the closed forms hold for the ray through the pixel's centre, and
/// these pixels span several voxels.
inline RenderOptions axisCamera(const Vec3& eye, double step)
{
    RenderOptions o;
    o.lod = 0.0;
    o.camera.eye = eye;
    o.camera.lookAt = Vec3(2, 2, 2);
    o.camera.up = std::abs(eye.y - 2) > 1e-9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    o.camera.width = o.camera.height = 1;
    o.camera.fovDeg = 1.0;
    o.step = step;
    o.drawStars = false;
    return o;
}

inline Star farStar(const Vec3& dir)
{
    // Far enough that 1/r^2 is constant across the cube to 4e-5.
    Star s;
    s.name = "far";
    const Vec3 p = Vec3(2, 2, 2) + dir * 1e5;
    s.position = {p.x, p.y, p.z};
    s.luminosity = 4.0 * PI * 1e10; // irradiance 1 L_sun pc^-2 at the cube
    return s;
}

/// Fills each star's tau channel (2 + s) of @p scene with the exact optical depth from the
/// star (nebillum's integrator), for scenes whose stars are near enough to integrate from.
inline void fillStarTau(RenderScene& scene)
{
    const SparseVolume& v = scene.fields;
    const SparseVolume n = v.channel(0);
    std::vector<std::uint32_t> points(v.voxelCount());
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        points[i] = std::uint32_t(i);
    const Affine w2i = v.indexToWorld.inverse();
    for (std::size_t s = 0; s < scene.stars.size(); ++s) {
        const auto& p = scene.stars[s].position;
        const auto tau =
            opticalDepthAt(n, w2i.apply(Vec3(p[0], p[1], p[2])), scene.dust.kappa_V, points);
        for (std::size_t i = 0; i < v.voxelCount(); ++i)
            scene.fields.writable(i)[2 + s] = tau[i];
    }
}

/// A slab z in [0, tau / k] pc of extinction k = 1 / pc in every channel (r_c = 1), wide in x
/// and y (+-20 pc, 20 optical depths), with fine voxels in z so that its faces are sharp (the
/// trilinear ramp at each face is 0.01 optical depths), lit along +z by a far star giving
/// irradiance 1 at the slab.
inline RenderScene slab(double tau, double albedo, double g)
{
    const double dz = 0.01;
    const int nz = int(std::lround(tau / dz)) + 1; // dust on points 1..nz-1: tau in total
    RenderScene scene;
    scene.fields = SparseVolume({-20, -20, 0}, {41, 41, nz + 1}, 3);
    scene.fields.indexToWorld.m = {1, 0, 0, 0, 1, 0, 0, 0, dz};
    scene.fields.indexToWorld.t = Vec3(0, 0, -0.5 * dz); // dust from z = 0.5 dz .. tau + 0.5 dz
    const double n0 = 1.0 / KAPPA;
    for (int k = 1; k <= nz - 1; ++k)
        for (int j = -19; j <= 19; ++j)
            for (int i = -19; i <= 19; ++i)
                scene.fields.writable(scene.fields.index(i, j, k))[0] = float(n0);
    Star s;
    s.name = "far";
    s.position = {0, 0, -1e5};
    s.luminosity = 4.0 * PI * 1e10;
    scene.stars = {s};
    scene.starColor = {{s.luminosity, s.luminosity, s.luminosity}};
    scene.dust.kappa_V = KAPPA;
    scene.dust.r = {1, 1, 1};
    scene.dust.albedo = albedo;
    scene.dust.g = g;
    scene.buildOccupancy();
    return scene;
}

/// A 1x1 camera 40 pc from the slab's centre at exit cosine @p mu to the normal of the face
/// it looks at: below the slab (reflection, the lit side) or above it (transmission). Full
/// resolution, as axisCamera().
inline RenderOptions slabCamera(double mu, bool reflected, double tau)
{
    RenderOptions o;
    o.lod = 0.0;
    const Vec3 centre(0, 0, reflected ? 0.0 : tau);
    const Vec3 away(std::sqrt(1 - mu * mu), 0, reflected ? -mu : mu);
    o.camera.eye = centre + away * 40.0;
    o.camera.lookAt = centre;
    o.camera.up = Vec3(0, 1, 0);
    o.camera.width = o.camera.height = 1;
    o.camera.fovDeg = 0.5;
    o.drawStars = false;
    return o;
}

} // namespace nebula::test
