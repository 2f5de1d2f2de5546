// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/presets.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/volume/volume.h"

#include "nebula_model.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace nebula {

namespace {

// ---- Geometry helpers, in cube units (the cube is [-0.5, 0.5]^3). ----

using detail::smoothstep;

/// 1 inside, 0 outside: the soft edge of a body whose scaled radius @p rho is 1 at its
/// surface, falling from 1 at 1 - @p w to 0 at 1.
double softInside(double rho, double w)
{
    return 1.0 - smoothstep(1.0 - w, 1.0, rho);
}

/// |(p - c) / radii|: 1 on the ellipsoid's surface.
double ellipsoidRadius(const Vec3& p, const Vec3& c, const Vec3& radii)
{
    const Vec3 d = p - c;
    const double x = d.x / radii.x, y = d.y / radii.y, z = d.z / radii.z;
    return std::sqrt(x * x + y * y + z * z);
}

/// Distance from p to the segment [a, b], and the parameter t in [0, 1] of its nearest point.
double segmentDistance(const Vec3& p, const Vec3& a, const Vec3& b, double& t)
{
    const Vec3 ab = b - a;
    t = std::clamp((p - a).dot(ab) / ab.dot(ab), 0.0, 1.0);
    return (p - (a + ab * t)).length();
}

/// A Gaussian bump of width @p w at @p d = 0, brought to 0 between 2 w and 3 w (so that it
/// ends, and leaves the voxels beyond inactive).
double bump(double d, double w)
{
    const double a = std::abs(d);
    return a < 3.0 * w ? std::exp(-(d * d) / (w * w)) * (1.0 - smoothstep(2.0 * w, 3.0 * w, a))
                       : 0.0;
}

/// A dense core: n ~ 1 / (1 + (r / rc)^2), an isothermal sphere's profile (flat inside rc,
/// r^-2 outside: its column falls as 1 / r, the power-law tail of star-forming clouds' column
/// PDFs), ending softly at 8 rc.
double core(const Vec3& p, const Vec3& c, double rc)
{
    const double x = (p - c).length() / rc;
    return x < 8.0 ? softInside(x / 8.0, 0.5) / (1.0 + x * x) : 0.0;
}

/// A ball (centre, radius) that holds part of a preset's support.
struct Ball
{
    Vec3 c;
    double r;
};

/// One voxel's geometry: the dust factor G and emission factor E (before the lognormal
/// turbulence and the peaks), and the diffuse gas of an H II region's warm phase, in units of
/// the density scale: not cut at the cloud's edge, its turbulence half as strong (sqrt of the
/// turbulent density: warm gas moves at about its sound speed).
struct Shape
{
    double dust = 0.0, emission = 0.0, gas = 0.0;
};

/// What the geometry sees at a point: the point, two unit-variance noise values of large
/// scale (from the turbulence lattice) and the turbulent density there.
struct Where
{
    Vec3 p;
    double u1, u2;
    double turbulence; ///< exp(s) at the (warped) point: the turbulent density / n0
};

constexpr double NOISE_CLAMP = 2.0; ///< perturbations use the noise clamped to +-2 sigma

double clampNoise(double u)
{
    return std::clamp(u, -NOISE_CLAMP, NOISE_CLAMP);
}

/// A preset: its name, summary, defaults, stars (cube units, with class and luminosity) and
/// geometry. The one place to add one.
struct PresetDef
{
    NebulaPreset id;
    const char* name;
    const char* summary;
    void (*defaults)(NebulaParams&);
    std::vector<Star> (*stars)();
    /// The shape at a point; stars in cube units.
    Shape (*shape)(const Where&, const std::vector<Vec3>& stars);
    /// Balls that hold every point where shape() may be non-zero (empty: everywhere).
    std::vector<Ball> (*support)();
    /// Its glow is the gas its stars ionise (nebionize), not painted (PresetInfo::ionised).
    bool ionised = false;
};

Star makeStar(const char* name, Vec3 cube, double luminosity, const char* cls)
{
    Star s;
    s.name = name;
    s.position = {cube.x, cube.y, cube.z}; // cube units until presetStars() scales them
    s.luminosity = luminosity;
    s.temperature = spectralClassTemperature(cls);
    return s;
}

void turbulent(NebulaParams& p, double mach, double b, double density)
{
    p.turbulence.mach = mach;
    p.turbulence.forcingB = b;
    p.densityPeak = density;
    p.warp = 0.03;
    p.edgeCut = 0.1;
    p.cavity = 0.0;
    p.emissionPeak = 0.0;
}

// ---- box: turbulence alone. ----

void boxDefaults(NebulaParams& p)
{
    turbulent(p, 5.0, 0.4, 100.0);
    p.warp = 0.0;
    p.edgeCut = 0.0;
}
std::vector<Star> boxStars()
{
    return {makeStar("star", {0.0, 0.0, -0.45}, 1000.0, "B5V")};
}
Shape boxShape(const Where&, const std::vector<Vec3>&)
{
    return {1.0, 0.0};
}
std::vector<Ball> everywhere()
{
    return {};
}

/// A molecular cloud as a slab: an ellipse of semi-axes (a, b) in the xy plane (the sky of
/// the default camera), half-thickness h about z = zc, so that most sight lines cross the
/// same depth of it and the column's spread is the turbulence's; both edges moved by the
/// large-scale noise.
struct Slab
{
    double a, b, zc, h;
    double edgeNoise = 0.08; ///< the outline's relative displacement per unit noise
    double operator()(const Where& w, const Vec3& centre) const
    {
        const double x = (w.p.x - centre.x) / a, y = (w.p.y - centre.y) / b;
        const double r = std::sqrt(x * x + y * y) / (1.0 + edgeNoise * clampNoise(w.u1));
        const double z = std::abs(w.p.z - zc) / (h * (1.0 + 0.05 * clampNoise(w.u2)));
        return softInside(r, 0.1) * softInside(z, 0.15);
    }
    /// Its largest extent from its centre [cube edges].
    double reach() const
    {
        return std::hypot(std::max(a, b) * (1.0 + edgeNoise * NOISE_CLAMP),
                          h * (1.0 + 0.05 * NOISE_CLAMP));
    }
};

// ---- reflection: NGC 1999, NGC 7023. ----

const Slab REFLECTION_CLOUD{0.34, 0.3, 0.08, 0.12};
const Vec3 REFLECTION_CENTRE{-0.06, -0.03, REFLECTION_CLOUD.zc};
/// The cavity's radius [cube edges] (0.8 pc in the 10 pc cube).
constexpr double REFLECTION_CAVITY = 0.08;
/// The cavity's opening: from the star towards the default camera (4, 3, -19) pc.
const Vec3 REFLECTION_OPENING = Vec3{0.2, 0.15, -0.97}.normalized();
const Vec3 REFLECTION_STAR{0.1, 0.07, 0.0};

void reflectionDefaults(NebulaParams& p)
{
    turbulent(p, 2.5, 0.4, 3000.0);
    p.turbulence.index = 3.2;
    p.emissionRadius = 0.05;
}
std::vector<Star> reflectionStars()
{
    return {makeStar("star", REFLECTION_STAR, 4000.0, "B2V")};
}
Shape reflectionShape(const Where& w, const std::vector<Vec3>& stars)
{
    Shape s;
    s.dust = REFLECTION_CLOUD(w, REFLECTION_CENTRE);
    if (!stars.empty()) {
        // The cavity's cone, 35 degrees about the opening, cleared outwards from the star.
        const Vec3 d = w.p - stars.front();
        const double len = d.length();
        const double cosAngle = len > 0.0 ? d.dot(REFLECTION_OPENING) / len : 1.0;
        const double cone =
            smoothstep(std::cos(42.0 * PI / 180.0), std::cos(30.0 * PI / 180.0), cosAngle) *
            smoothstep(0.0, 0.04, len);
        s.dust *= 1.0 - 0.97 * cone;
        // The cavity the star has blown, its wall moved by the large-scale noise.
        const double rc = REFLECTION_CAVITY * (1.0 + 0.35 * clampNoise(w.u2));
        s.dust *= smoothstep(0.6 * rc, rc, len);
        // Its small H II region (off unless --emission): the star's ionised bubble.
        s.emission = 1.0 - smoothstep(0.02, 0.05, len);
    }
    return s;
}
std::vector<Ball> reflectionSupport()
{
    return {{REFLECTION_CENTRE, REFLECTION_CLOUD.reach()}};
}

// ---- external: the Merope nebula, IC 2118. ----

const Slab EXTERNAL_CLOUD{0.38, 0.26, 0.12, 0.1};

void externalDefaults(NebulaParams& p)
{
    turbulent(p, 2.5, 0.4, 120.0);
    p.turbulence.index = 3.2;
    p.turbulence.outerScale = 0.3;
    p.turbulence.anisotropy = 3.0;
    p.turbulence.axis = {1.0, 0.25, 0.0};
}
std::vector<Star> externalStars()
{
    return {makeStar("star", {-0.1, 0.1, -0.01}, 600.0, "B6V")};
}
Shape externalShape(const Where& w, const std::vector<Vec3>&)
{
    return {EXTERNAL_CLOUD(w, {0.0, -0.02, EXTERNAL_CLOUD.zc}), 0.0};
}
std::vector<Ball> externalSupport()
{
    return {{Vec3{0.0, -0.02, EXTERNAL_CLOUD.zc}, EXTERNAL_CLOUD.reach()}};
}

// ---- pillars: M16. ----

struct Pillar
{
    Vec3 base;
    double length, rBase, rHead;
};
const Pillar PILLARS[] = {
    {{-0.16, -0.32, 0.02}, 0.36, 0.055, 0.035},
    {{0.0, -0.32, -0.02}, 0.46, 0.06, 0.04},
    {{0.17, -0.32, 0.04}, 0.28, 0.05, 0.032},
};
/// The cluster's brightest star (NGC 6611): the columns point at it.
const Vec3 PILLARS_STAR{0.0, 0.26, 0.12};
/// The far wall of the cavity the cluster has cleared in the molecular cloud: a slab behind
/// the star, facing the viewer, whose face the stars ionise behind the columns.
const Slab PILLARS_BACK{0.4, 0.4, 0.4, 0.06};
constexpr double PILLARS_CORE_PEAK = 60.0, PILLARS_CORE_RADIUS = 0.012;
const Vec3 PILLARS_WALL_CENTRE{0.0, -0.34, 0.06}, PILLARS_WALL_RADII{0.36, 0.1, 0.28};

void pillarsDefaults(NebulaParams& p)
{
    turbulent(p, 6.0, 0.4, 1500.0);
    p.turbulence.outerScale = 0.25; // the columns' width, a few driving scales across
    p.turbulence.index = 3.3;
    p.emissionRadius = 0.45;
}
std::vector<Star> pillarsStars()
{
    // Three of NGC 6611's O stars: 2.5 x 10^49 ionising photons a second between them.
    return {makeStar("star", PILLARS_STAR, 300000.0, "O5V"),
            makeStar("star2", PILLARS_STAR + Vec3{0.06, 0.03, -0.04}, 120000.0, "O7V"),
            makeStar("star3", PILLARS_STAR + Vec3{-0.05, 0.05, 0.03}, 60000.0, "O9V")};
}
Shape pillarsShape(const Where& w, const std::vector<Vec3>& stars)
{
    const Vec3 star = stars.empty() ? PILLARS_STAR : stars.front();
    Shape s;
    // The molecular cloud's wall the columns rise from.
    const double wall = ellipsoidRadius(w.p, PILLARS_WALL_CENTRE, PILLARS_WALL_RADII) /
                        (1.0 + 0.25 * clampNoise(w.u1));
    s.dust = softInside(wall, 0.3);
    for (const Pillar& c : PILLARS) {
        const Vec3 axis = (star - c.base).normalized();
        const Vec3 head = c.base + axis * c.length;
        double t = 0.0;
        const double d = segmentDistance(w.p, c.base, head, t);
        const double r = (c.rBase + (c.rHead - c.rBase) * t) * (1.0 + 0.25 * clampNoise(w.u2));
        s.dust = std::max(s.dust, softInside(d / r, 0.35) * (1.0 + 0.8 * t));
        // The dense head.
        const double rh = 1.25 * c.rHead;
        s.dust = std::max(s.dust, 3.0 * softInside((w.p - head).length() / rh, 0.4));
        // A core forming a star in each head (the evaporating gaseous globules of M16).
        s.dust += PILLARS_CORE_PEAK * core(w.p, head - axis * (0.3 * rh), PILLARS_CORE_RADIUS);
    }
    // The cavity's far wall.
    s.dust = std::max(s.dust, 0.6 * PILLARS_BACK(w, {0.0, 0.0, PILLARS_BACK.zc}));
    // The cavity between holds little gas: what glows is the ionised skin of every surface
    // the stars see (nebionize). (Warm gas filling it, 30 cm^-3, would glow too, but costs
    // nebionize 14 times the time at 512^3: docs/presets.md.)
    return s;
}
std::vector<Ball> pillarsSupport()
{
    return {}; // the cavity and its walls fill most of the cube
}

// ---- bubble: NGC 7635. ----

const Vec3 BUBBLE_CENTRE{0.0, 0.0, 0.02};
constexpr double BUBBLE_RADIUS = 0.27, BUBBLE_WIDTH = 0.03;
const Vec3 BUBBLE_OPENING = Vec3{0.75, 0.35, -0.3}.normalized();
const Vec3 BUBBLE_CLOUD_CENTRE{-0.3, -0.04, 0.1}, BUBBLE_CLOUD_RADII{0.12, 0.32, 0.28};
const Vec3 BUBBLE_CORES[] = {
    {-1.0, 0.3, -0.2}, {-0.9, -0.4, 0.1}, {-0.8, 0.1, 0.5}, {-0.7, -0.6, -0.4}};

void bubbleDefaults(NebulaParams& p)
{
    turbulent(p, 8.0, 0.4, 150.0);
    p.emissionRadius = BUBBLE_RADIUS;
}
std::vector<Star> bubbleStars()
{
    return {makeStar("star", {-0.06, 0.03, 0.0}, 200000.0, "O6V")};
}
Shape bubbleShape(const Where& w, const std::vector<Vec3>&)
{
    Shape s;
    const Vec3 d = w.p - BUBBLE_CENTRE;
    const double r = d.length();
    const double R = BUBBLE_RADIUS * (1.0 + 0.08 * clampNoise(w.u1));
    const double cosOpen = r > 0.0 ? d.dot(BUBBLE_OPENING) / r : 0.0;
    // Broken where the wind blew out: no shell within 40 degrees of the opening.
    const double intact =
        1.0 - smoothstep(std::cos(60.0 * PI / 180.0), std::cos(40.0 * PI / 180.0), cosOpen);
    // Thicker and denser towards the cloud it ploughs into (-x).
    const double towardsCloud = std::max(0.0, -d.x / std::max(r, 1e-9));
    const double width = BUBBLE_WIDTH * (1.0 + 0.6 * towardsCloud);
    s.dust = intact * (1.0 + 1.5 * towardsCloud) * bump(r - R, width);
    const double cloud = ellipsoidRadius(w.p, BUBBLE_CLOUD_CENTRE, BUBBLE_CLOUD_RADII) /
                         (1.0 + 0.2 * clampNoise(w.u2));
    s.dust = std::max(s.dust, 2.0 * softInside(cloud, 0.4));
    // Cores the shell collected and that now collapse, on the cloud's side.
    for (const Vec3& dir : BUBBLE_CORES)
        s.dust += 40.0 * core(w.p, BUBBLE_CENTRE + dir.normalized() * BUBBLE_RADIUS, 0.012);
    // No gas to speak of inside: the shocked wind is too thin (< 1 cm^-3) to glow. The star
    // ionises the shell's inner face, or all of it where it is thin (nebionize).
    return s;
}
std::vector<Ball> bubbleSupport()
{
    return {{BUBBLE_CENTRE, 1.5 * BUBBLE_RADIUS * (1.0 + 0.08 * NOISE_CLAMP) + 0.1},
            {BUBBLE_CLOUD_CENTRE, 0.34 * (1.0 + 0.2 * NOISE_CLAMP) * 1.3}};
}

// ---- globule: IC 1396A, B68, CB 230. ----

const Vec3 GLOBULE_CENTRE{-0.05, -0.05, 0.05};
constexpr double GLOBULE_CORE = 0.035, GLOBULE_RADIUS = 0.19;
const Vec3 GLOBULE_STAR{0.36, 0.22, 0.12};

void globuleDefaults(NebulaParams& p)
{
    turbulent(p, 4.0, 0.4, 20000.0);
    p.edgeCut = 0.003; // the core's peak is n0: the tail's 100 cm^-3 must stay
    p.emissionPeak = 5.0;
    p.emissionRadius = 0.5;
}
std::vector<Star> globuleStars()
{
    return {makeStar("star", GLOBULE_STAR, 20000.0, "B0V")};
}
Shape globuleShape(const Where& w, const std::vector<Vec3>& stars)
{
    const Vec3 star = stars.empty() ? GLOBULE_STAR : stars.front();
    const Vec3 toStar = (star - GLOBULE_CENTRE).normalized();
    Shape s;
    const Vec3 d = w.p - GLOBULE_CENTRE;
    const double r = d.length();
    const double R = GLOBULE_RADIUS * (1.0 + 0.1 * clampNoise(w.u1));
    // A Bonnor-Ebert-like core, n ~ 1 / (1 + (r / r_c)^2), cut sharper on the star's side.
    const double facing = r > 0.0 ? d.dot(toStar) / r : 0.0;
    const double edge = 0.35 - 0.25 * std::max(facing, 0.0);
    const double x = r / GLOBULE_CORE;
    s.dust = softInside(r / R, edge) / (1.0 + x * x);
    // The cometary tail, pointing away from the star.
    double t = 0.0;
    const double dt = segmentDistance(w.p, GLOBULE_CENTRE, GLOBULE_CENTRE - toStar * 0.33, t);
    const double rt = (0.09 - 0.06 * t) * (1.0 + 0.2 * clampNoise(w.u2));
    s.dust = std::max(s.dust, 0.012 * (1.0 - 0.6 * t) * softInside(dt / rt, 0.5));
    // The bright rim: the ionised boundary layer on the star's side.
    s.emission = smoothstep(0.0, 0.6, facing) * bump(r - R - 0.004, 0.008);
    return s;
}
std::vector<Ball> globuleSupport()
{
    return {{GLOBULE_CENTRE, 0.33 + 0.09 * 1.4 + 0.05},
            {GLOBULE_CENTRE, GLOBULE_RADIUS * (1.0 + 0.1 * NOISE_CLAMP) + 0.05}};
}

// ---- bipolar: NGC 2261 (Hubble's variable nebula), Cep A. ----

const Vec3 BIPOLAR_AXIS = Vec3{0.25, 1.0, -0.35}.normalized();

void bipolarDefaults(NebulaParams& p)
{
    turbulent(p, 4.0, 0.5, 20000.0);
    p.edgeCut = 0.003; // the envelope's peak is n0
    p.emissionPeak = 2.0;
    p.emissionRadius = 0.4;
}
std::vector<Star> bipolarStars()
{
    return {makeStar("star", {0.0, 0.0, 0.0}, 1500.0, "B3V")};
}
Shape bipolarShape(const Where& w, const std::vector<Vec3>& stars)
{
    const Vec3 centre = stars.empty() ? Vec3{0.0, 0.0, 0.0} : stars.front();
    const Vec3 d = w.p - centre;
    const double r = d.length();
    const double z = d.dot(BIPOLAR_AXIS);
    const double rp = (d - BIPOLAR_AXIS * z).length();
    const double sin2 = r > 0.0 ? (rp / r) * (rp / r) : 1.0;
    // An envelope, n ~ r^-2 (an isothermal sphere), flattened towards the equator, in a cloud.
    const double x = r / 0.03;
    double dust = (0.25 + 0.75 * sin2) / (1.0 + x * x);
    const double outer = softInside(r / (0.4 * (1.0 + 0.1 * clampNoise(w.u1))), 0.4);
    dust = outer * std::max(dust, 0.03);
    // Paraboloidal cavities cleared by the outflow, their walls compressed.
    const double rc = 0.17 * std::sqrt(std::abs(z) / 0.3) * (1.0 + 0.15 * clampNoise(w.u2));
    const double cleared = smoothstep(0.85 * rc, 1.1 * rc, rp);
    const double wall = bump(rp - 1.15 * rc, 0.02 + 0.05 * rc);
    Shape s;
    s.dust = dust * (0.03 + 0.97 * cleared) + outer * 0.08 * wall;
    // Herbig-Haro knots along the jet.
    double knots = 0.0;
    for (double k : {0.12, 0.22, 0.32}) {
        knots = std::max(knots, bump(std::abs(z) - k, 0.015) * bump(rp, 0.02));
    }
    s.emission =
        std::max(knots, 0.3 * bump(rp, 0.006) * (1.0 - smoothstep(0.3, 0.36, std::abs(z))));
    return s;
}
std::vector<Ball> bipolarSupport()
{
    return {{Vec3{0.0, 0.0, 0.0}, 0.4 * (1.0 + 0.1 * NOISE_CLAMP) + 0.05}};
}

// ---- hii: M42, M8. ----

/// The molecular cloud behind the blister: a slab facing the viewer (-z).
const Slab HII_CLOUD{0.38, 0.36, 0.3, 0.15};
/// The cluster's brightest star (theta-1 Ori C in M42, Herschel 36 in M8).
const Vec3 HII_CLUSTER{-0.04, 0.03, 0.16};
/// The cloud's face: z = HII_FACE + HII_BOWL exp(-(rho / HII_BOWL_RADIUS)^2), rho the distance
/// from the cluster across the sky: the concave cavity the cluster has eaten into it.
constexpr double HII_FACE = 0.14, HII_BOWL = 0.1, HII_BOWL_RADIUS = 0.2;
/// The blister's gas [density scale] at the face (300 cm^-3 at the default density), falling
/// towards the viewer over HII_SCALE (0.8 pc), ending at 4 of them: the gas flowing off the
/// face.
constexpr double HII_GAS = 0.15, HII_SCALE = 0.08;

void hiiDefaults(NebulaParams& p)
{
    turbulent(p, 5.0, 0.4, 2000.0);
    p.turbulence.outerScale = 0.3;
    p.turbulence.index = 3.3;
    p.emissionRadius = 0.4;
}
std::vector<Star> hiiStars()
{
    // A Trapezium: an O7 star and its three B companions, 0.1-0.3 pc apart.
    return {makeStar("star", HII_CLUSTER, 200000.0, "O7V"),
            makeStar("star2", HII_CLUSTER + Vec3{0.025, -0.01, 0.005}, 30000.0, "B0V"),
            makeStar("star3", HII_CLUSTER + Vec3{-0.015, 0.02, -0.01}, 20000.0, "B0.5V"),
            makeStar("star4", HII_CLUSTER + Vec3{0.01, 0.03, 0.01}, 10000.0, "B1V")};
}
Shape hiiShape(const Where& w, const std::vector<Vec3>&)
{
    Shape s;
    const double rho2 = (w.p.x - HII_CLUSTER.x) * (w.p.x - HII_CLUSTER.x) +
                        (w.p.y - HII_CLUSTER.y) * (w.p.y - HII_CLUSTER.y);
    const double face = HII_FACE +
                        HII_BOWL * std::exp(-rho2 / (HII_BOWL_RADIUS * HII_BOWL_RADIUS)) +
                        0.03 * clampNoise(w.u2);
    const double cloud = HII_CLOUD(w, {0.0, 0.0, HII_CLOUD.zc});
    s.dust = cloud * smoothstep(face - 0.01, face + 0.02, w.p.z);
    // The blister's ionised gas, in front of the face and across the cavity.
    if (w.p.z < face) {
        const double across =
            softInside(std::sqrt(rho2) / (0.32 * (1.0 + 0.15 * clampNoise(w.u1))), 0.5);
        const double depth = face - w.p.z;
        s.gas = HII_GAS * std::exp(-depth / HII_SCALE) *
                (1.0 - smoothstep(3.0 * HII_SCALE, 4.0 * HII_SCALE, depth)) * across;
    }
    return s;
}
std::vector<Ball> hiiSupport()
{
    return {}; // the cloud fills the cube's far half
}

// ---- fbm: the seeds' model, built in generate.cpp. ----

void fbmDefaults(NebulaParams&) {}
std::vector<Star> fbmStars()
{
    return {};
}

const std::vector<PresetDef>& presetTable()
{
    static const std::vector<PresetDef> table = {
        {NebulaPreset::Fbm, "fbm",
         "the seeds' procedural cloud: domain-warped fBm in a soft envelope (the default)",
         fbmDefaults, fbmStars, nullptr, nullptr},
        {NebulaPreset::Box, "box",
         "a periodic box of lognormal turbulence filling the cube (for statistics)", boxDefaults,
         boxStars, boxShape, everywhere},
        {NebulaPreset::Reflection, "reflection",
         "a B star in a cavity at the edge of a turbulent cloud (NGC 1999, NGC 7023)",
         reflectionDefaults, reflectionStars, reflectionShape, reflectionSupport},
        {NebulaPreset::External, "external",
         "a striated cloud lit by a star outside it (Merope nebula, IC 2118)", externalDefaults,
         externalStars, externalShape, externalSupport},
        {NebulaPreset::Pillars, "pillars",
         "dense columns pointing at O stars in the cavity they ionise (M16)", pillarsDefaults,
         pillarsStars, pillarsShape, pillarsSupport, true},
        {NebulaPreset::Bubble, "bubble",
         "an O star's H II region in the wind-blown shell around it, broken on one side "
         "(NGC 7635)",
         bubbleDefaults, bubbleStars, bubbleShape, bubbleSupport, true},
        {NebulaPreset::Globule, "globule",
         "a Bok globule with a dark core, a bright rim and a tail (IC 1396A, B68)", globuleDefaults,
         globuleStars, globuleShape, globuleSupport},
        {NebulaPreset::Bipolar, "bipolar",
         "a young star's outflow cavities in a flattened envelope (NGC 2261, Cep A)",
         bipolarDefaults, bipolarStars, bipolarShape, bipolarSupport},
        {NebulaPreset::Hii, "hii",
         "an O cluster's H II region on the near face of a molecular cloud (M42, M8)", hiiDefaults,
         hiiStars, hiiShape, hiiSupport, true},
    };
    return table;
}

const PresetDef& presetDef(NebulaPreset id)
{
    for (const auto& d : presetTable()) {
        if (d.id == id) return d;
    }
    throw Error("unknown nebula preset");
}

} // namespace

const std::vector<PresetInfo>& nebulaPresets()
{
    static const std::vector<PresetInfo> infos = [] {
        std::vector<PresetInfo> v;
        for (const auto& d : presetTable())
            v.push_back({d.id, d.name, d.summary, d.ionised});
        return v;
    }();
    return infos;
}

NebulaPreset parsePreset(const std::string& name)
{
    std::string known;
    for (const auto& d : presetTable()) {
        if (name == d.name) return d.id;
        known += std::string(known.empty() ? "" : ", ") + d.name;
    }
    throw UsageError("--preset: unknown preset '" + name + "'; the presets are " + known);
}

const char* presetName(NebulaPreset preset)
{
    return presetDef(preset).name;
}

bool presetIonised(NebulaPreset preset)
{
    return presetDef(preset).ionised;
}

NebulaParams presetParams(NebulaPreset preset)
{
    NebulaParams p;
    p.preset = preset;
    presetDef(preset).defaults(p);
    p.stars = presetStars(preset, p.size);
    return p;
}

std::vector<Star> presetStars(NebulaPreset preset, double size)
{
    if (preset == NebulaPreset::Fbm) return exampleStars();
    std::vector<Star> stars = presetDef(preset).stars();
    for (auto& s : stars) {
        for (auto& c : s.position)
            c *= size;
    }
    return stars;
}

namespace detail {

void validatePresetParams(const NebulaParams& p)
{
    if (p.preset == NebulaPreset::Fbm) return;
    p.turbulence.validate();
    if (!(p.edgeCut >= 0.0 && p.edgeCut <= 100.0)) {
        throw UsageError("--edge-cut must be in [0, 100] (times --density; 0: no edge), got " +
                         numberText(p.edgeCut));
    }
    if (!(p.warp >= 0.0 && p.warp <= 0.5)) {
        throw UsageError("--warp must be in [0, 0.5] cube edges for a turbulent preset, got " +
                         numberText(p.warp));
    }
}

namespace {

/// Offsets of the lattice's decorrelated copies [cube edges] (irrational, so no mode lines up).
const Vec3 OFFSET_U1{0.318, 0.414, 0.271}, OFFSET_U2{0.173, 0.732, 0.577},
    OFFSET_WX{0.618, 0.123, 0.847}, OFFSET_WY{0.236, 0.902, 0.445}, OFFSET_WZ{0.781, 0.359, 0.664},
    OFFSET_EMISSION{0.447, 0.564, 0.129};

/// A turbulent preset: n_H = densityPeak exp(s(q)) G(p), emission = emissionPeak
/// exp(s(p + o) / 2) E(p), q = p + warp (u_x, u_y, u_z) (DESIGN §2b).
class PresetModel final : public NebulaModel
{
public:
    PresetModel(const NebulaParams& p, bool withLattice)
        : mP(p), mDef(presetDef(p.preset)), mSupport(mDef.support())
    {
        for (const auto& s : p.stars)
            mStars.push_back(Vec3{s.position[0], s.position[1], s.position[2]} * (1.0 / p.size));
        const auto c = motionCentre(p);
        mMotionCentre = Vec3{c[0], c[1], c[2]} * (1.0 / p.size);
        if (withLattice) {
            mField.emplace(p.turbulence, turbulenceLattice(p.res), p.seed,
                           "--res " + std::to_string(p.res) + ": the turbulence lattice");
            mInvSigma = mField->sigma() > 0.0 ? 1.0 / mField->sigma() : 0.0;
            mHalfVar = 0.5 * mField->sigma() * mField->sigma();
        }
    }

    NebulaVoxel at(int i, int j, int k, bool withOiii) const override
    {
        const int n = mP.res;
        const Vec3 p{cubeCoordinate(i, n), cubeCoordinate(j, n), cubeCoordinate(k, n)};
        Vec3 q = p;
        if (mP.warp > 0.0) {
            q = q + Vec3{unit(p + OFFSET_WX), unit(p + OFFSET_WY), unit(p + OFFSET_WZ)} * mP.warp;
        }
        const Where w{p, unit(p + OFFSET_U1), unit(p + OFFSET_U2), std::exp(double(sample(q)))};
        const Shape shape = mDef.shape(w, mStars);
        NebulaVoxel v;
        if (shape.dust > 0.0 && mP.densityPeak > 0.0) {
            // The cloud ends where its density falls below edgeCut n0: a phase boundary that
            // follows the turbulence, so the edges are sharp and fractal, not a fog.
            const double x = w.turbulence * shape.dust;
            const double c = mP.edgeCut;
            v.density = mP.densityPeak * x * (c > 0.0 ? smoothstep(c, 2.0 * c, x) : 1.0);
        }
        if (shape.gas > 0.0 && mP.densityPeak > 0.0)
            v.density += mP.densityPeak * shape.gas * std::sqrt(w.turbulence);
        if (v.density > 0.0) {
            clearStarCavities(v.density, {p.x * mP.size, p.y * mP.size, p.z * mP.size}, mP.stars,
                              mP.cavity);
        }
        if (shape.emission > 0.0 && mP.emissionPeak > 0.0) {
            v.emission = mP.emissionPeak * shape.emission *
                         std::exp(0.5 * double(sample(p + OFFSET_EMISSION)));
        }
        if (withOiii && v.emission > 0.0) {
            // [O III] nearer the star: 1 inside half the emission radius, 0 beyond 0.8.
            const double dc = (p - mMotionCentre).length();
            const double R = mP.emissionRadius;
            v.oiii = mP.spectral.oiii * v.emission * (1.0 - smoothstep(0.5 * R, 0.8 * R, dc));
        }
        return v;
    }

    bool mayHoldNebula(const openvdb::Coord& lo, const openvdb::Coord& hi) const override
    {
        if (mSupport.empty()) return true;
        const CubeBox box = cubeBox(lo, hi, mP.res);
        for (const Ball& b : mSupport) {
            if (minDistance({b.c.x, b.c.y, b.c.z}, box) < b.r + 1e-9) return true;
        }
        return false;
    }

    double heldBytes() const override { return LognormalField::bytes(turbulenceLattice(mP.res)); }

private:
    float sample(const Vec3& p) const { return (*mField)(p.x, p.y, p.z); }
    /// The lattice as a zero-mean, unit-variance noise.
    double unit(const Vec3& p) const { return (double(sample(p)) + mHalfVar) * mInvSigma; }

    const NebulaParams& mP;
    const PresetDef& mDef;
    std::vector<Ball> mSupport;
    std::vector<Vec3> mStars;
    Vec3 mMotionCentre;
    std::optional<LognormalField> mField;
    double mInvSigma = 0.0, mHalfVar = 0.0;
};

} // namespace

std::unique_ptr<NebulaModel> makePresetModel(const NebulaParams& params, bool withLattice)
{
    return std::make_unique<PresetModel>(params, withLattice);
}

} // namespace detail

} // namespace nebula
