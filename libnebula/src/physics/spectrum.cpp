// SPDX-License-Identifier: Apache-2.0
/// @file spectrum.cpp
/// Piecewise-linear spectra (DESIGN §7.1): insertion sweep, integrals, merging.

#include "nebula/physics/spectrum.h"

#include "nebula/core/error.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <utility>

namespace nebula {

namespace {

/// True if breakpoints @p x and @p y [nm] coincide within BREAKPOINT_REL_TOL.
bool sameBreakpoint(double x, double y)
{
    return std::fabs(x - y) <= BREAKPOINT_REL_TOL * std::max(std::fabs(x), std::fabs(y));
}

/// @p x [nm] moved onto the nearest existing breakpoint of @p pieces if it coincides with one
/// within BREAKPOINT_REL_TOL, else unchanged. The nearest breakpoints are the x1 of the last
/// piece ending before x and the ends of the first piece ending at or after x.
double snapToBreakpoint(const std::vector<Piece>& pieces, double x)
{
    const auto it = std::partition_point(pieces.begin(), pieces.end(),
                                         [x](const Piece& q) { return q.x1 < x; });
    double best = x;
    double bestDistance = std::numeric_limits<double>::infinity();
    const auto consider = [&](double candidate) {
        const double d = std::fabs(candidate - x);
        if (sameBreakpoint(candidate, x) && d < bestDistance) {
            best = candidate;
            bestDistance = d;
        }
    };
    if (it != pieces.begin()) {
        consider(std::prev(it)->x1);
    }
    if (it != pieces.end()) {
        consider(it->x0);
        consider(it->x1);
    }
    return best;
}

/// Integral over [@p lo, @p hi] [nm] of the product of the lines of @p f and @p g. The
/// product is a quadratic, so Simpson's rule is exact; it is the notes' closed form
/// m1 m2 x^3/3 + (m1 b2 + m2 b1) x^2/2 + b1 b2 x between the limits, without that form's
/// cancellation of large powers of x over a narrow overlap.
double productIntegral(const Piece& f, const Piece& g, double lo, double hi)
{
    const double mid = 0.5 * (lo + hi);
    return (hi - lo) / 6.0 *
           (f.at(lo) * g.at(lo) + 4.0 * f.at(mid) * g.at(mid) + f.at(hi) * g.at(hi));
}

/// Integral [value * nm] and moment about @p centre [value * nm^2] of the line of @p p over
/// its own interval, computed in t = x - centre to keep the terms small.
void addMoments(const Piece& p, double centre, double& I0, double& I1)
{
    const double tp = p.x0 - centre;
    const double tq = p.x1 - centre;
    const double v = p.at(centre); // line value at t = 0
    I0 += p.m * (tq * tq - tp * tp) / 2.0 + v * (tq - tp);
    I1 += p.m * (tq * tq * tq - tp * tp * tp) / 3.0 + v * (tq * tq - tp * tp) / 2.0;
}

/// True if neighbours @p a and @p c (a left of c) may merge under @p tolerance (see
/// Spectrum::merge()).
bool mergeable(const Piece& a, const Piece& c, double tolerance)
{
    const double width = c.x1 - a.x0;
    if (c.x0 - a.x1 > tolerance * width) {
        return false;
    }
    const double va = a.at(a.x1);
    const double vc = c.at(c.x0);
    if (std::fabs(va - vc) > tolerance * std::max(std::fabs(va), std::fabs(vc))) {
        return false;
    }
    const double slopeScale = std::max({std::fabs(a.m), std::fabs(c.m), 1e-300});
    return std::fabs(a.m - c.m) <= tolerance * slopeScale;
}

/// The line over [a.x0, c.x1] with the integral and first moment of the pair (@p a, @p c):
/// with centre x_c and half width h, value at x_c = I0 / (2h) and slope = 3 I1 / (2 h^3),
/// I1 being the moment about x_c (the 2x2 normal equations, diagonal in these coordinates).
Piece momentPreservingLine(const Piece& a, const Piece& c)
{
    const double centre = 0.5 * (a.x0 + c.x1);
    const double h = 0.5 * (c.x1 - a.x0);
    double I0 = 0.0;
    double I1 = 0.0;
    addMoments(a, centre, I0, I1);
    addMoments(c, centre, I0, I1);
    const double m = 3.0 * I1 / (2.0 * h * h * h);
    const double valueAtCentre = I0 / (2.0 * h);
    return Piece{a.x0, c.x1, m, valueAtCentre - m * centre};
}

} // namespace

Piece pieceThrough(double x0, double y0, double x1, double y1)
{
    const double m = (y1 - y0) / (x1 - x0);
    return Piece{x0, x1, m, y0 - m * x0};
}

Spectrum Spectrum::sum(std::vector<Piece> pieces)
{
    struct Event
    {
        double x;
        double dm, db;
        int dActive;
    };
    std::vector<Event> events;
    events.reserve(2 * pieces.size());
    for (const Piece& p : pieces) {
        if (!(p.x0 <= p.x1) || !std::isfinite(p.x0) || !std::isfinite(p.x1)) {
            std::ostringstream msg;
            msg << "spectrum piece with x0 > x1 (or not a number): [" << p.x0 << ", " << p.x1
                << "] nm";
            throw UsageError(msg.str());
        }
        if (sameBreakpoint(p.x0, p.x1)) continue;
        events.push_back({p.x0, p.m, p.b, 1});
        events.push_back({p.x1, -p.m, -p.b, -1});
    }
    std::sort(events.begin(), events.end(),
              [](const Event& a, const Event& b) { return a.x < b.x; });
    Spectrum out;
    out.mPieces.reserve(events.size());
    double m = 0.0, b = 0.0;
    int active = 0;
    std::size_t i = 0;
    while (i < events.size()) {
        // One breakpoint: every event within BREAKPOINT_REL_TOL of the first one.
        const double x = events[i].x;
        while (i < events.size() && sameBreakpoint(events[i].x, x)) {
            m += events[i].dm;
            b += events[i].db;
            active += events[i].dActive;
            ++i;
        }
        if (active == 0) {
            m = b = 0.0; // drop rounding residue: nothing is active here
            continue;
        }
        if (i < events.size()) out.mPieces.push_back(Piece{x, events[i].x, m, b});
    }
    return out;
}

void Spectrum::add(const Piece& piece)
{
    if (!(piece.x0 <= piece.x1)) {
        std::ostringstream msg;
        msg << "spectrum piece with x0 > x1 (or not a number): [" << piece.x0 << ", " << piece.x1
            << "] nm";
        throw UsageError(msg.str());
    }
    Piece p = piece;
    p.x0 = snapToBreakpoint(mPieces, p.x0);
    p.x1 = snapToBreakpoint(mPieces, p.x1);
    if (p.x1 <= p.x0 || sameBreakpoint(p.x0, p.x1)) {
        return; // zero width
    }

    // Affected pieces [lo, hi): those overlapping the open interval (p.x0, p.x1).
    const auto lo = std::partition_point(mPieces.begin(), mPieces.end(),
                                         [&](const Piece& q) { return q.x1 <= p.x0; });
    const auto hi =
        std::partition_point(lo, mPieces.end(), [&](const Piece& q) { return q.x0 < p.x1; });

    // Sorted breakpoints of p and the affected pieces.
    std::vector<double> breaks;
    breaks.reserve(2 * static_cast<std::size_t>(hi - lo) + 2);
    breaks.push_back(p.x0);
    breaks.push_back(p.x1);
    for (auto q = lo; q != hi; ++q) {
        breaks.push_back(q->x0);
        breaks.push_back(q->x1);
    }
    std::sort(breaks.begin(), breaks.end());
    breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());

    // Sweep: each elementary interval lies inside or outside p and inside at most one
    // affected piece; covered intervals get the sum of the lines that cover them.
    std::vector<Piece> swept;
    swept.reserve(breaks.size());
    auto q = lo;
    for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
        const double u = breaks[i];
        const double v = breaks[i + 1];
        Piece s{u, v, 0.0, 0.0};
        bool covered = false;
        if (p.x0 <= u && v <= p.x1) {
            s.m += p.m;
            s.b += p.b;
            covered = true;
        }
        while (q != hi && q->x1 <= u) {
            ++q;
        }
        if (q != hi && q->x0 <= u) {
            s.m += q->m;
            s.b += q->b;
            covered = true;
        }
        if (covered) {
            swept.push_back(s);
        }
    }

    // Replace [lo, hi) by the swept pieces, moving the tail at most once.
    const std::size_t first = static_cast<std::size_t>(lo - mPieces.begin());
    const std::size_t nOld = static_cast<std::size_t>(hi - lo);
    const std::size_t nCommon = std::min(nOld, swept.size());
    std::copy(swept.begin(), swept.begin() + static_cast<std::ptrdiff_t>(nCommon),
              mPieces.begin() + static_cast<std::ptrdiff_t>(first));
    const auto at = mPieces.begin() + static_cast<std::ptrdiff_t>(first + nCommon);
    if (swept.size() > nOld) {
        mPieces.insert(at, swept.begin() + static_cast<std::ptrdiff_t>(nCommon), swept.end());
    } else {
        mPieces.erase(at, at + static_cast<std::ptrdiff_t>(nOld - nCommon));
    }
}

void Spectrum::addTrapezoid(double x0, double x1, double y0, double y1)
{
    if (x0 > x1) {
        std::swap(x0, x1);
        std::swap(y0, y1);
    }
    if (x0 == x1 || sameBreakpoint(x0, x1)) {
        return; // zero width
    }
    add(pieceThrough(x0, y0, x1, y1));
}

void Spectrum::scale(double s)
{
    for (Piece& p : mPieces) {
        p.m *= s;
        p.b *= s;
    }
}

double Spectrum::operator()(double x) const
{
    const auto it = std::partition_point(mPieces.begin(), mPieces.end(),
                                         [x](const Piece& q) { return q.x1 <= x; });
    if (it != mPieces.end() && it->x0 <= x) {
        return it->at(x);
    }
    if (!mPieces.empty() && x == mPieces.back().x1) {
        return mPieces.back().at(x);
    }
    return 0.0;
}

double Spectrum::integral() const
{
    double sum = 0.0;
    for (const Piece& p : mPieces) {
        sum += 0.5 * (p.x1 - p.x0) * (p.at(p.x0) + p.at(p.x1));
    }
    return sum;
}

double Spectrum::integral(const Spectrum& other) const
{
    // Linear merge of the two sorted lists over their overlaps.
    double sum = 0.0;
    std::size_t i = 0;
    std::size_t j = 0;
    const std::vector<Piece>& a = mPieces;
    const std::vector<Piece>& c = other.mPieces;
    while (i < a.size() && j < c.size()) {
        const double lo = std::max(a[i].x0, c[j].x0);
        const double hi = std::min(a[i].x1, c[j].x1);
        if (hi > lo) {
            sum += productIntegral(a[i], c[j], lo, hi);
        }
        if (a[i].x1 <= c[j].x1) {
            ++i;
        } else {
            ++j;
        }
    }
    return sum;
}

void Spectrum::merge(double tolerance)
{
    if (mPieces.size() < 2) {
        return;
    }
    std::vector<Piece> out;
    out.reserve(mPieces.size());
    out.push_back(mPieces.front());
    for (std::size_t i = 1; i < mPieces.size(); ++i) {
        if (mergeable(out.back(), mPieces[i], tolerance)) {
            out.back() = momentPreservingLine(out.back(), mPieces[i]);
        } else {
            out.push_back(mPieces[i]);
        }
    }
    mPieces = std::move(out);
}

} // namespace nebula
