// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file near_star.h
/// Internal to render/: single scattering next to a point star (DESIGN §3.5). A star's
/// irradiance grows as 1/r^2 towards it, too fast for a ray's fixed steps to sample within a
/// voxel or two of it, and the pixels next to its image see its scattered light grow as 1/b
/// (b the ray's closest approach), too fast for one ray per pixel. The deterministic
/// integrators therefore take, per ray step [ta, tb], the exact integral of 1/r^2 along the
/// step, int ds / (d^2 + (s - s0)^2) = (atan((tb - s0)/d) - atan((ta - s0)/d)) / d, with the
/// phase function sampled at equal angles where the step subtends a wide angle at the star
/// (ds / r^2 = dtheta / d: the integrand is uniform in the angle theta), the density, the
/// star's transmittance and the ray's taken at the step's midpoint as before; and d is not
/// the ray's closest approach b but the one whose 1/d is the mean of 1/b over the pixel's
/// footprint at the star (the exact flux of a line through uniform dust, pi/b, averaged over
/// the pixel). The path tracer samples the same integral equiangularly (Kulla & Fajardo 2012).

#include "nebula/core/units.h"
#include "nebula/render/camera.h"

#include <cmath>
#include <vector>

namespace nebula::detail {

/// The least effective closest approach d to a star [voxels]: it bounds only a ray that
/// passes exactly through a star with a pixel of no extent (a pixel's mean of 1/b is finite).
inline constexpr double NEAR_STAR_FLOOR = 1e-3;

/// How far from a star's image the pixel's mean of 1/b replaces the centre ray's b
/// [footprints]: fully within half of it, tapered (a half cosine) to none at it. The mean
/// assumes the dust uniform across the pixel; far from the image the point sample's own
/// error is small and the density's variation across the pixel matters more.
inline constexpr double FOOTPRINT_REACH = 4.0;

/// How one pixel's rays spread: their origin and direction change per pixel across the
/// image (ou, du) and down it (ov, dv), so that the pixel's footprint at ray distance t is
/// spanned by ou + t du and ov + t dv. Invalid where a neighbour is out of view.
struct PixelFootprint
{
    Vec3 ou, du, ov, dv;
    bool valid = false;
};

/// The footprint of the pixel centred at (px, py) of @p cam (central differences).
PixelFootprint pixelFootprint(const Projection& cam, double px, double py);

/// The integral of 1 / sqrt(x^2 + y^2) over the rectangle [0, @p a] x [0, @p b] (a, b >= 0):
/// a asinh(b / a) + b asinh(a / b).
double inverseDistanceIntegral(double a, double b);

/// The mean of 1 / sqrt(x'^2 + y'^2) over the square of side @p w centred at (@p x, @p y)
/// (exact: the integral of 1/rho over a rectangle in closed form).
double meanInverseDistance(double x, double y, double w);

/// One star as one ray sees it: the ray distance s0 of its closest approach and the
/// effective distance d of that approach (near the star's image, 1 / the pixel's mean of 1/b:
/// FOOTPRINT_REACH; at least dFloor).
struct RayStar
{
    double s0 = 0.0;
    double d = 0.0;
    double b2 = 0.0; ///< the true closest approach squared (the level of detail's cap)
};

/// The star at world point @p star seen by the ray from @p o along unit @p dir, the pixel's
/// footprint @p fp (invalid: d = b), d at least @p dFloor (> 0).
RayStar rayStar(const Vec3& o, const Vec3& dir, const Vec3& star, const PixelFootprint& fp,
                double dFloor);

/// rayStar() of every star at @p stars for the ray of pixel (@p px, @p py) of @p cam (its
/// centre), from @p o along unit @p dir, into @p out (sized to the stars).
void rayStars(const Projection& cam, double px, double py, const Vec3& o, const Vec3& dir,
              const std::vector<Vec3>& stars, double dFloor, std::vector<RayStar>& out);

/// A ray step's integral of 1/r^2 and the cosines at which to take the phase function: the
/// midpoint, or where the step subtends more than NODE_ANGLE at the star, n points at equal
/// angles (equal weights total / n).
struct StarNodes
{
    static constexpr int MAX = 32;
    static constexpr double NODE_ANGLE = PI / MAX;
    double total = 0.0; ///< int ds / r^2 over the step [1 / length]
    int n = 1;          ///< how many nodes (1: the step's midpoint)
    /// The nodes' cosines, in the geometry of the effective closest approach RayStar::d.
    double mu[MAX] = {};
};

/// The integral of 1/r^2 over the ray distances [@p ta, @p tb] of the ray that sees @p rs,
/// and its nodes (see StarNodes). mu is the cosine between the light's travel direction
/// (star -> point) and the direction to the eye.
void starNodes(const RayStar& rs, double ta, double tb, StarNodes& out);

} // namespace nebula::detail
