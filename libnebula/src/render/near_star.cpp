// SPDX-License-Identifier: Apache-2.0
/// @file near_star.cpp
/// Single scattering next to a point star: see near_star.h and DESIGN §3.5.

#include "near_star.h"

#include <algorithm>
#include <cmath>

namespace nebula::detail {

namespace {

/// G(x, y) with d^2 G / dx dy = 1 / sqrt(x^2 + y^2) (the terms x ln|x| and y ln|y| of the
/// antiderivative left out: they cancel in a rectangle's four corners).
double inverseDistancePrimitive(double x, double y)
{
    double g = 0.0;
    if (x != 0.0) g += x * std::asinh(y / std::abs(x));
    if (y != 0.0) g += y * std::asinh(x / std::abs(y));
    return g;
}

} // namespace

double inverseDistanceIntegral(double a, double b)
{
    return inverseDistancePrimitive(a, b);
}

PixelFootprint pixelFootprint(const Projection& cam, double px, double py)
{
    PixelFootprint fp;
    Vec3 dl, dr, dt, db;
    if (!cam.direction(px - 0.5, py, dl) || !cam.direction(px + 0.5, py, dr) ||
        !cam.direction(px, py - 0.5, dt) || !cam.direction(px, py + 0.5, db))
        return fp;
    fp.ou = cam.origin(px + 0.5, py) - cam.origin(px - 0.5, py);
    fp.ov = cam.origin(px, py + 0.5) - cam.origin(px, py - 0.5);
    fp.du = dr - dl;
    fp.dv = db - dt;
    fp.valid = true;
    return fp;
}

double meanInverseDistance(double x, double y, double w)
{
    const double x0 = x - 0.5 * w, x1 = x + 0.5 * w, y0 = y - 0.5 * w, y1 = y + 0.5 * w;
    return (inverseDistancePrimitive(x1, y1) - inverseDistancePrimitive(x0, y1) -
            inverseDistancePrimitive(x1, y0) + inverseDistancePrimitive(x0, y0)) /
           (w * w);
}

RayStar rayStar(const Vec3& o, const Vec3& dir, const Vec3& star, const PixelFootprint& fp,
                double dFloor)
{
    RayStar rs;
    const Vec3 v = star - o;
    rs.s0 = v.dot(dir);
    rs.b2 = std::max(0.0, v.dot(v) - rs.s0 * rs.s0);
    const Vec3 b = v - dir * rs.s0; // from the closest point to the star
    const double b2 = b.dot(b), bLen = std::sqrt(b2);
    rs.d = bLen;
    if (fp.valid) {
        // The pixel's footprint at the closest approach (at the eye for a star behind it),
        // in the plane across the ray: a square of the same area, along the image's x.
        const double t = std::max(rs.s0, 0.0);
        Vec3 eu = fp.ou + fp.du * t, ev = fp.ov + fp.dv * t;
        eu = eu - dir * eu.dot(dir);
        ev = ev - dir * ev.dot(dir);
        const double eLen = eu.length();
        const double w = std::sqrt(eu.cross(ev).length());
        if (w > 0.0 && eLen > 0.0 && bLen < FOOTPRINT_REACH * w) {
            const Vec3 u = eu * (1.0 / eLen), uv = dir.cross(u);
            const double mean = meanInverseDistance(b.dot(u), b.dot(uv), w);
            // Tapered to 1/b from FOOTPRINT_REACH / 2 to FOOTPRINT_REACH footprints.
            const double x = std::clamp(2.0 * bLen / (FOOTPRINT_REACH * w) - 1.0, 0.0, 1.0);
            const double taper = 0.5 * (1.0 + std::cos(PI * x));
            rs.d = 1.0 / (taper >= 1.0 ? mean : (1.0 - taper) / bLen + taper * mean);
        }
    }
    rs.d = std::max(rs.d, dFloor);
    return rs;
}

void rayStars(const Projection& cam, double px, double py, const Vec3& o, const Vec3& dir,
              const std::vector<Vec3>& stars, double dFloor, std::vector<RayStar>& out)
{
    out.resize(stars.size());
    if (stars.empty()) return;
    const PixelFootprint fp = pixelFootprint(cam, px, py);
    for (std::size_t s = 0; s < stars.size(); ++s)
        out[s] = rayStar(o, dir, stars[s], fp, dFloor);
}

void starNodes(const RayStar& rs, double ta, double tb, StarNodes& out)
{
    const double seg = tb - ta, d = rs.d;
    // atan((tb - s0)/d) - atan((ta - s0)/d) = atan2(d seg, d^2 + (ta - s0)(tb - s0)).
    const double q = d * d + (ta - rs.s0) * (tb - rs.s0);
    const double z = d * seg;
    // One node: the midpoint, its cosine in the same geometry (the closest approach d), so
    // that the nodes of a whole line weigh the phase function as the pixel's mean does.
    const double sm = 0.5 * (ta + tb) - rs.s0;
    out.n = 1;
    out.mu[0] = -sm / std::sqrt(d * d + sm * sm);
    if (q > 0.0 && z < 0.05 * q) {
        // A narrow angle (far from the star): atan(z/q) / d by its series, no division by d.
        const double zq2 = (z / q) * (z / q);
        out.total = seg / q * (1.0 - zq2 * (1.0 / 3.0 - zq2 * 0.2));
        return;
    }
    const double angle = std::atan2(z, q);
    out.total = angle / d;
    const int n = std::min(StarNodes::MAX, int(std::ceil(angle / StarNodes::NODE_ANGLE)));
    if (n <= 1) return;
    out.n = n;
    // Points at equal angles theta from the closest approach, s - s0 = d tan(theta): the
    // light travels (s - s0) along the ray and d across it, so mu = -sin(theta).
    const double theta0 = std::atan((ta - rs.s0) / d), dTheta = angle / n;
    for (int i = 0; i < n; ++i)
        out.mu[i] = -std::sin(theta0 + (i + 0.5) * dTheta);
}

} // namespace nebula::detail
