#include "nebula/optical_depth.h"

#include "nebula/error.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nebula {

namespace {

/// integral_0^1 n(a + t d) dt, exact for the trilinear interpolant: the segment is cut at
/// every lattice plane it crosses and each piece is integrated with Simpson's rule.
double unitIntegral(const DenseVolume& n, const Vec3& a, const Vec3& d)
{
    // Per axis: parameter of the next lattice-plane crossing and the spacing between them.
    double tNext[3], tStep[3];
    for (int ax = 0; ax < 3; ++ax) {
        const double da = d[ax];
        if (std::abs(da) < 1e-300) {
            tNext[ax] = tStep[ax] = std::numeric_limits<double>::infinity();
            continue;
        }
        const double a0 = a[ax];
        const double plane = da > 0 ? std::floor(a0) + 1.0 : std::ceil(a0) - 1.0;
        tNext[ax] = (plane - a0) / da;
        tStep[ax] = 1.0 / std::abs(da);
    }
    double t0 = 0.0, f0 = n.sample0(a), sum = 0.0;
    while (t0 < 1.0) {
        const int ax = tNext[0] < tNext[1] ? (tNext[0] < tNext[2] ? 0 : 2)
                                           : (tNext[1] < tNext[2] ? 1 : 2);
        const double t1 = std::min(tNext[ax], 1.0);
        if (tNext[ax] <= 1.0) tNext[ax] += tStep[ax];
        if (t1 <= t0) continue;
        const double fm = n.sample0(a + d * (0.5 * (t0 + t1)));
        const double f1 = n.sample0(a + d * t1);
        sum += (t1 - t0) * (f0 + 4.0 * fm + f1) / 6.0;
        t0 = t1;
        f0 = f1;
    }
    return sum;
}

/// Trilinear interpolation of a scalar lattice field that is NOT zero outside the lattice;
/// points on the upper faces use the last cell. Returns 0 for points outside the lattice box
/// (valid for tau: see opticalDepthField).
float interpolateField(const DenseVolume& box, const float* field, const Vec3& p)
{
    const auto& lo = box.lo();
    const auto& dims = box.dims();
    double f[3];
    int i[3];
    for (int ax = 0; ax < 3; ++ax) {
        const double q = p[ax] - lo[ax];
        if (q < -1e-9 || q > dims[ax] - 1 + 1e-9) return 0.0f;
        const int cells = std::max(dims[ax] - 1, 1);
        i[ax] = std::clamp(int(std::floor(q)), 0, cells - 1);
        f[ax] = std::clamp(q - i[ax], 0.0, 1.0);
        if (dims[ax] == 1) { i[ax] = 0; f[ax] = 0.0; }
    }
    const std::size_t sx = 1, sy = std::size_t(dims[0]), sz = sy * std::size_t(dims[1]);
    const std::size_t dx = dims[0] > 1 ? sx : 0, dy = dims[1] > 1 ? sy : 0,
                      dz = dims[2] > 1 ? sz : 0;
    const float* q = field + std::size_t(i[2]) * sz + std::size_t(i[1]) * sy + std::size_t(i[0]);
    const double c00 = q[0] + f[0] * (q[dx] - q[0]);
    const double c10 = q[dy] + f[0] * (q[dy + dx] - q[dy]);
    const double c01 = q[dz] + f[0] * (q[dz + dx] - q[dz]);
    const double c11 = q[dz + dy] + f[0] * (q[dz + dy + dx] - q[dz + dy]);
    const double c0 = c00 + f[1] * (c10 - c00);
    const double c1 = c01 + f[1] * (c11 - c01);
    return float(c0 + f[2] * (c1 - c0));
}

Vec3 latticePoint(const DenseVolume& n, std::size_t idx)
{
    const auto& lo = n.lo();
    const auto& dims = n.dims();
    const std::size_t nx = std::size_t(dims[0]), ny = std::size_t(dims[1]);
    return Vec3(double(lo[0] + int(idx % nx)), double(lo[1] + int((idx / nx) % ny)),
                double(lo[2] + int(idx / (nx * ny))));
}

} // namespace

double columnDensity(const DenseVolume& n, const Vec3& a, const Vec3& b)
{
    const Vec3 d = b - a;
    const double worldLength = n.indexToWorld.applyLinear(d).length();
    if (worldLength == 0.0) return 0.0;
    return worldLength * unitIntegral(n, a, d);
}

std::vector<float> opticalDepthReference(const DenseVolume& n, const Vec3& starIndex,
                                         double kappa_V)
{
    std::vector<float> tau(n.voxelCount());
    tbb::parallel_for(std::size_t(0), tau.size(), [&](std::size_t idx) {
        tau[idx] = float(kappa_V * columnDensity(n, starIndex, latticePoint(n, idx)));
    });
    return tau;
}

std::vector<float> opticalDepthField(const DenseVolume& n, const Vec3& s, double kappa_V,
                                     const OpticalDepthParams& params,
                                     const std::function<void(std::size_t)>& progress)
{
    const double L = params.segment;
    if (!(L >= 4.0)) throw UsageError("optical depth segment length must be >= 4 voxels");
    const std::size_t N = n.voxelCount();

    // Shell of a lattice point: floor of its Chebyshev distance from the star. The start
    // p = v - L u of a voxel's last segment has Chebyshev distance at least L/sqrt(3) less
    // than v, so all 8 lattice neighbours of p lie in earlier shells when L > 2 sqrt(3).
    std::vector<std::uint32_t> shell(N);
    tbb::parallel_for(std::size_t(0), N, [&](std::size_t idx) {
        const Vec3 d = latticePoint(n, idx) - s;
        shell[idx] = std::uint32_t(std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}));
    });
    const std::uint32_t shells = *std::max_element(shell.begin(), shell.end()) + 1;
    std::vector<std::size_t> start(std::size_t(shells) + 1, 0);
    for (const auto sh : shell) ++start[sh + 1];
    for (std::uint32_t k = 0; k < shells; ++k) start[k + 1] += start[k];
    std::vector<std::uint32_t> order(N);
    {
        std::vector<std::size_t> fill(start.begin(), start.end() - 1);
        for (std::size_t idx = 0; idx < N; ++idx) order[fill[shell[idx]]++] = std::uint32_t(idx);
    }
    shell.clear();
    shell.shrink_to_fit();

    std::vector<float> tau(N, 0.0f);
    for (std::uint32_t k = 0; k < shells; ++k) {
        const std::size_t b = start[k], e = start[k + 1];
        if (b == e) continue;
        tbb::parallel_for(tbb::blocked_range<std::size_t>(b, e, 256),
                          [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t o = r.begin(); o != r.end(); ++o) {
                const std::size_t idx = order[o];
                const Vec3 v = latticePoint(n, idx);
                const Vec3 d = v - s;
                const double len = d.length();
                // Near the star tau is a cone (|x - s| n) that trilinear interpolation
                // resolves badly, so voxels within 3L integrate the whole ray exactly.
                if (len <= 3.0 * L) {
                    tau[idx] = float(kappa_V * columnDensity(n, s, v));
                } else {
                    const Vec3 p = v - d * (L / len);
                    tau[idx] = interpolateField(n, tau.data(), p) +
                               float(kappa_V * columnDensity(n, p, v));
                }
            }
        });
        if (progress) progress(e - b);
    }
    return tau;
}

} // namespace nebula
