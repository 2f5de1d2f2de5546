// SPDX-License-Identifier: Apache-2.0
#include "nebula/physics/optical_depth.h"

#include "nebula/core/error.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace nebula {

namespace {

/// integral_0^1 n(a + t d) dt, exact for the trilinear interpolant: the segment is walked
/// cell by cell (Amanatides-Woo), and inside a cell, where the interpolant is a cubic in t,
/// Simpson's rule is exact. Each cell's 8 corners are loaded once; cells whose corners are
/// all zero (and cells off the lattice) contribute nothing and are not sampled. The hot loop
/// of nebillum (one call per voxel and star): the walk's state lives in scalars, not arrays
/// indexed by axis, so it stays in registers.
double unitIntegral(const SparseVolume& n, const VoxelBits& dusty, const Vec3& a, const Vec3& d)
{
    const auto& lo = n.lo();
    const auto& dims = n.dims();
    // Per axis: the cell, its step, the t of the next plane crossed, and t between planes.
    struct Axis
    {
        int cell, step;
        double next, delta;
    };
    const auto axis = [](double a, double d) {
        Axis s;
        const double c = std::floor(a);
        s.cell = int(c);
        s.step = d > 0 ? 1 : -1;
        if (std::abs(d) < 1e-300) {
            s.next = s.delta = std::numeric_limits<double>::infinity();
            return s;
        }
        if (d < 0 && a == c) --s.cell; // on a plane, moving down: the lower cell
        const double plane = d > 0 ? s.cell + 1.0 : double(s.cell);
        s.next = (plane - a) / d;
        s.delta = 1.0 / std::abs(d);
        return s;
    };
    Axis X = axis(a.x, d.x), Y = axis(a.y, d.y), Z = axis(a.z, d.z);
    // A cell is on the lattice when its lower corner is in [lo, lo + dims - 2].
    const unsigned mx = unsigned(dims[0] - 1), my = unsigned(dims[1] - 1),
                   mz = unsigned(dims[2] - 1);
    double t0 = 0.0, f0 = 0.0, sum = 0.0;
    bool haveF0 = false;
    for (;;) {
        // The axis whose plane comes first (ties: z, then y, as before).
        Axis& A = X.next < Y.next ? (X.next < Z.next ? X : Z) : (Y.next < Z.next ? Y : Z);
        const double t1 = std::min(A.next, 1.0);
        if (t1 > t0) {
            double f1 = 0.0; // the exit face of an empty cell has only zero corners
            if (unsigned(X.cell - lo[0]) < mx && unsigned(Y.cell - lo[1]) < my &&
                unsigned(Z.cell - lo[2]) < mz) {
                const std::size_t idx = n.index(X.cell, Y.cell, Z.cell);
                if (dusty[idx]) {
                    const float* q[8];
                    n.cellCorners(X.cell, Y.cell, Z.cell, idx, q);
                    const double c000 = q[0][0], c100 = q[1][0], c010 = q[2][0], c110 = q[3][0],
                                 c001 = q[4][0], c101 = q[5][0], c011 = q[6][0], c111 = q[7][0];
                    const double ox = a.x - X.cell, oy = a.y - Y.cell, oz = a.z - Z.cell;
                    const auto f = [&](double t) {
                        const double u = ox + d.x * t, v = oy + d.y * t, w = oz + d.z * t;
                        const double c00 = c000 + u * (c100 - c000), c10 = c010 + u * (c110 - c010);
                        const double c01 = c001 + u * (c101 - c001), c11 = c011 + u * (c111 - c011);
                        const double c0 = c00 + v * (c10 - c00), c1 = c01 + v * (c11 - c01);
                        return c0 + w * (c1 - c0);
                    };
                    if (!haveF0) f0 = f(t0);
                    f1 = f(t1);
                    sum += (t1 - t0) * (f0 + 4.0 * f(0.5 * (t0 + t1)) + f1);
                }
            }
            f0 = f1;
            haveF0 = true;
            t0 = t1;
        }
        if (A.next >= 1.0) break;
        A.cell += A.step;
        A.next += A.delta;
    }
    return sum * (1.0 / 6.0);
}

Vec3 latticePoint(const SparseVolume& n, std::size_t idx)
{
    const auto p = n.point(idx);
    return Vec3(double(p[0]), double(p[1]), double(p[2]));
}

bool insideLattice(const SparseVolume& n, const Vec3& p)
{
    for (int ax = 0; ax < 3; ++ax) {
        if (!(p[ax] >= n.lo()[ax] && p[ax] <= n.lo()[ax] + n.dims()[ax] - 1)) return false;
    }
    return true;
}

/// The part [t0, t1] of o + e t, t in [0, 1], inside the lattice's box; false if none.
bool clipToLattice(const SparseVolume& n, const Vec3& o, const Vec3& e, double& t0, double& t1)
{
    t0 = 0.0;
    t1 = 1.0;
    for (int ax = 0; ax < 3; ++ax) {
        const double lo = n.lo()[ax], hi = lo + n.dims()[ax] - 1;
        if (e[ax] == 0.0) {
            if (o[ax] < lo || o[ax] > hi) return false;
            continue;
        }
        double ta = (lo - o[ax]) / e[ax], tb = (hi - o[ax]) / e[ax];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t0 < t1;
}

/// integral n dl [cm^-3 pc] from a to b. Only the chord inside the lattice is walked, so a
/// star's distance costs nothing; the chord is measured from the end inside the lattice (a
/// voxel), so a star 1e12 grid widths away still gives it to full precision.
double column(const SparseVolume& n, const VoxelBits& dusty, const Vec3& a, const Vec3& b)
{
    for (int ax = 0; ax < 3; ++ax) {
        if (!std::isfinite(a[ax]) || !std::isfinite(b[ax])) {
            throw Error("optical depth: a segment end is not finite");
        }
    }
    // The integral is symmetric: start from the end inside the lattice.
    const bool swap = !insideLattice(n, a) && insideLattice(n, b);
    const Vec3& o = swap ? b : a;
    const Vec3 e = (swap ? a : b) - o;
    double t0 = 0.0, t1 = 1.0;
    if (!clipToLattice(n, o, e, t0, t1)) return 0.0;
    if (t0 == 0.0 && t1 == 1.0) { // all inside: the segment as given
        const double worldLength = n.indexToWorld.applyLinear(e).length();
        if (worldLength == 0.0) return 0.0;
        return worldLength * unitIntegral(n, dusty, o, e);
    }
    const Vec3 p0 = o + e * t0, chord = e * (t1 - t0);
    const double chordLength = n.indexToWorld.applyLinear(chord).length();
    if (chordLength == 0.0) return 0.0;
    return chordLength * unitIntegral(n, dusty, p0, chord);
}

} // namespace

// Bricks are visited in parallel, and only those that hold a corner of a dusty cell: the
// brick or one of its upper neighbours is stored. Per brick, the 9^3 points its cells touch
// are read once into rows of bits (x along a row), and the 2x2x2 stencil is three ORs of
// shifted rows: a word of bits per z slice.
VoxelBits dustyCells(const SparseVolume& n)
{
    constexpr int B = SparseVolume::BRICK;
    static_assert(B == 8, "a brick's z slice is one 64-bit word of VoxelBits");
    const auto& lo = n.lo();
    const auto& dims = n.dims();
    VoxelBits dusty(n, false);
    const std::size_t bricks = n.voxelCount() / SparseVolume::BRICK_VOXELS;
    tbb::parallel_for(std::size_t(0), bricks, [&](std::size_t b) {
        const auto p0 = n.point(b * SparseVolume::BRICK_VOXELS); // the brick's first point
        bool any = false;
        for (int c = 0; c < 8 && !any; ++c) {
            const int i = p0[0] + (c & 1) * B, j = p0[1] + (c >> 1 & 1) * B,
                      k = p0[2] + (c >> 2) * B;
            // A neighbour's stored state where it overlaps the lattice (clamped to it).
            const int ci = std::clamp(i, lo[0], lo[0] + dims[0] - 1);
            const int cj = std::clamp(j, lo[1], lo[1] + dims[1] - 1);
            const int ck = std::clamp(k, lo[2], lo[2] + dims[2] - 1);
            any = n.stored(n.index(ci, cj, ck));
        }
        if (!any) return;
        // The cells of this brick on the lattice: lower corners in [lo, lo + dims - 2].
        int first[3], last[3]; // brick-relative, half-open
        for (int a = 0; a < 3; ++a) {
            first[a] = std::max(0, lo[a] - p0[a]);
            last[a] = std::min(B, lo[a] + dims[a] - 1 - p0[a]);
            if (first[a] >= last[a]) return;
        }
        // Points p0 + (0..8)^3 that are on the lattice and non-zero: bit x of P[z][y].
        unsigned on[3] = {0, 0, 0}; // bit t: p0[a] + t on the lattice
        for (int a = 0; a < 3; ++a)
            for (int t = 0; t <= B; ++t)
                if (unsigned(p0[a] + t - lo[a]) < unsigned(dims[a])) on[a] |= 1u << t;
        std::uint16_t P[B + 1][B + 1];
        const float* brick = n.voxel(b * SparseVolume::BRICK_VOXELS);
        const std::size_t sx = std::size_t(n.channels());
        for (int z = 0; z <= B; ++z)
            for (int y = 0; y <= B; ++y) {
                unsigned row = 0;
                if ((on[2] >> z & 1u) && (on[1] >> y & 1u)) {
                    if (z < B && y < B) { // inside the brick: straight from its storage
                        const float* v = brick + std::size_t((z * B + y) * B) * sx;
                        for (int x = 0; x < B; ++x)
                            row |= unsigned(v[std::size_t(x) * sx] != 0.0f) << x;
                    } else {
                        for (int x = 0; x < B; ++x)
                            if (n.voxel(n.index(p0[0] + x, p0[1] + y, p0[2] + z))[0] != 0.0f)
                                row |= 1u << x;
                    }
                    if ((on[0] >> B & 1u) &&
                        n.voxel(n.index(p0[0] + B, p0[1] + y, p0[2] + z))[0] != 0.0f)
                        row |= 1u << B;
                    row &= on[0];
                }
                P[z][y] = std::uint16_t(row);
            }
        const unsigned xMask = ((1u << last[0]) - 1u) & ~((1u << first[0]) - 1u);
        for (int z = first[2]; z < last[2]; ++z) {
            std::uint64_t word = 0;
            for (int y = first[1]; y < last[1]; ++y) {
                const unsigned r = unsigned(P[z][y] | P[z][y + 1] | P[z + 1][y] | P[z + 1][y + 1]);
                const unsigned cells = (r | (r >> 1)) & xMask;
                word |= std::uint64_t(cells) << (y * B);
            }
            // This brick's own word: threads write different words.
            dusty.setWord((b * SparseVolume::BRICK_VOXELS + std::size_t(z) * B * B) / 64, word);
        }
    });
    return dusty;
}

ColumnIntegrator::ColumnIntegrator(const SparseVolume& n) : mN(n), mDusty(dustyCells(n)) {}

double ColumnIntegrator::operator()(const Vec3& a, const Vec3& b) const
{
    return column(mN, mDusty, a, b);
}

double columnDensity(const SparseVolume& n, const Vec3& a, const Vec3& b)
{
    // One ray: build the occupancy of just the cells it can touch would be cleverer; a whole
    // lattice pass is fine for the few rays (star sprites, tests) that call this.
    const auto dusty = dustyCells(n);
    return column(n, dusty, a, b);
}

double columnDensityReference(const SparseVolume& n, const Vec3& a, const Vec3& b)
{
    // Every parameter where the segment crosses a lattice plane, sorted; between two of them
    // the trilinear interpolant is a cubic in t and Simpson's rule is exact. No cell walk, no
    // occupancy: deliberately independent of ColumnIntegrator.
    const Vec3 d = b - a;
    std::vector<double> ts{0.0, 1.0};
    for (int ax = 0; ax < 3; ++ax) {
        if (d[ax] == 0.0) continue;
        // Planes outside the lattice bound only zero density: a far star adds none.
        const double lo = std::max(std::min(a[ax], b[ax]), double(n.lo()[ax]) - 1.0);
        const double hi = std::min(std::max(a[ax], b[ax]), double(n.lo()[ax] + n.dims()[ax]));
        for (double plane = std::ceil(lo); plane <= hi; plane += 1.0) {
            ts.push_back((plane - a[ax]) / d[ax]);
        }
    }
    std::sort(ts.begin(), ts.end());
    double sum = 0.0;
    for (std::size_t i = 0; i + 1 < ts.size(); ++i) {
        const double t0 = std::clamp(ts[i], 0.0, 1.0), t1 = std::clamp(ts[i + 1], 0.0, 1.0);
        if (t1 <= t0) continue;
        // The piece lies in one cell: the one holding its midpoint. Its ends are on that
        // cell's faces, where the field may jump (the lattice's outer faces: dust inside,
        // zero outside), so they take that cell's interpolant, not sample()'s value there.
        const Vec3 mid = a + d * (0.5 * (t0 + t1));
        int ijk[3];
        double frac[3];
        if (!n.cellAt(mid, ijk, frac)) continue; // off the lattice: zero
        const float* q[8];
        n.cellCorners(ijk[0], ijk[1], ijk[2], q);
        const auto f = [&](double t) {
            const Vec3 p = a + d * t;
            const double u = p.x - ijk[0], v = p.y - ijk[1], w = p.z - ijk[2];
            double value = 0.0;
            for (int c = 0; c < 8; ++c)
                value += q[c][0] * ((c & 1) ? u : 1.0 - u) * ((c >> 1 & 1) ? v : 1.0 - v) *
                         ((c >> 2) ? w : 1.0 - w);
            return value;
        };
        sum += (t1 - t0) * (f(t0) + 4.0 * f(0.5 * (t0 + t1)) + f(t1)) / 6.0;
    }
    return sum * n.indexToWorld.applyLinear(d).length();
}

std::vector<float> opticalDepthReference(const SparseVolume& n, const Vec3& starIndex,
                                         double kappa_V)
{
    std::vector<float> tau(n.voxelCount());
    tbb::parallel_for(std::size_t(0), tau.size(), [&](std::size_t idx) {
        tau[idx] = float(kappa_V * columnDensityReference(n, starIndex, latticePoint(n, idx)));
    });
    return tau;
}

std::vector<float> opticalDepthAt(const SparseVolume& n, const Vec3& starIndex, double kappa_V,
                                  const std::vector<std::uint32_t>& points,
                                  const std::function<void(std::size_t)>& progress)
{
    const auto dusty = dustyCells(n);
    std::vector<float> tau(n.voxelCount(), 0.0f);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t o = r.begin(); o != r.end(); ++o) {
                              const std::size_t idx = points[o];
                              // The column of a non-negative density is >= 0; Simpson's weights can
                              // leave a rounding residue of -1e-33 next to empty cells, which
                              // readers rightly reject.
                              tau[idx] =
                                  float(std::max(0.0, kappa_V * column(n, dusty, starIndex,
                                                                       latticePoint(n, idx))));
                          }
                          if (progress) progress(r.size());
                      });
    return tau;
}

} // namespace nebula
