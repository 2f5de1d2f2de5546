// SPDX-License-Identifier: Apache-2.0
#include "nebula/physics/spherical_harmonics.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <cmath>
#include <string>

namespace nebula {

void realSphericalHarmonics(const Vec3& d, int L, double* out)
{
    if (L < 0 || L > SH_MAX_DEGREE) {
        throw Error("spherical harmonics: degree " + std::to_string(L) + " is outside [0, " +
                    std::to_string(SH_MAX_DEGREE) + "]");
    }
    const double x = d.x, y = d.y, z = d.z;
    out[0] = 0.28209479177387814; // 1 / (2 sqrt(pi))
    if (L < 1) return;
    constexpr double C1 = 0.4886025119029199; // sqrt(3 / (4 pi))
    out[1] = C1 * y;
    out[2] = C1 * z;
    out[3] = C1 * x;
    if (L < 2) return;
    const double x2 = x * x, y2 = y * y, z2 = z * z;
    out[4] = 1.0925484305920792 * x * y;
    out[5] = 1.0925484305920792 * y * z;
    out[6] = 0.31539156525252005 * (3.0 * z2 - 1.0);
    out[7] = 1.0925484305920792 * x * z;
    out[8] = 0.5462742152960396 * (x2 - y2);
    if (L < 3) return;
    out[9] = 0.5900435899266435 * y * (3.0 * x2 - y2);
    out[10] = 2.890611442640554 * x * y * z;
    out[11] = 0.4570457994644658 * y * (5.0 * z2 - 1.0);
    out[12] = 0.3731763325901154 * z * (5.0 * z2 - 3.0);
    out[13] = 0.4570457994644658 * x * (5.0 * z2 - 1.0);
    out[14] = 1.445305721320277 * z * (x2 - y2);
    out[15] = 0.5900435899266435 * x * (x2 - 3.0 * y2);
    if (L < 4) return;
    out[16] = 2.5033429417967046 * x * y * (x2 - y2);
    out[17] = 1.7701307697799304 * y * z * (3.0 * x2 - y2);
    out[18] = 0.9461746957575601 * x * y * (7.0 * z2 - 1.0);
    out[19] = 0.6690465435572892 * y * z * (7.0 * z2 - 3.0);
    out[20] = 0.10578554691520431 * (35.0 * z2 * z2 - 30.0 * z2 + 3.0);
    out[21] = 0.6690465435572892 * x * z * (7.0 * z2 - 3.0);
    out[22] = 0.47308734787878004 * (x2 - y2) * (7.0 * z2 - 1.0);
    out[23] = 1.7701307697799304 * x * z * (x2 - 3.0 * y2);
    out[24] = 0.6258357354491761 * (x2 * (x2 - 3.0 * y2) - y2 * (3.0 * x2 - y2));
}

double legendre(int l, double x)
{
    if (l == 0) return 1.0;
    double p0 = 1.0, p1 = x;
    for (int k = 2; k <= l; ++k) { // Bonnet: k P_k = (2k - 1) x P_k-1 - (k - 1) P_k-2
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    return p1;
}

namespace {

/// Nodes and weights of n-point Gauss-Legendre quadrature on [-1, 1] (Newton on P_n).
void gaussLegendre(int n, std::vector<double>& x, std::vector<double>& w)
{
    x.assign(std::size_t(n), 0.0);
    w.assign(std::size_t(n), 0.0);
    for (int i = 0; i < n; ++i) {
        double t = std::cos(PI * (i + 0.75) / (n + 0.5));
        for (int it = 0; it < 100; ++it) {
            const double pn = legendre(n, t), pn1 = legendre(n - 1, t);
            const double dp = n * (t * pn - pn1) / (t * t - 1.0);
            const double step = pn / dp;
            t -= step;
            if (std::fabs(step) < 1e-16) break;
        }
        const double pn1 = legendre(n - 1, t);
        const double dp = n * (t * legendre(n, t) - pn1) / (t * t - 1.0);
        x[std::size_t(i)] = t;
        w[std::size_t(i)] = 2.0 / ((1.0 - t * t) * dp * dp);
    }
}

} // namespace

std::vector<double> phaseLegendreMoments(PhaseModel model, double g, int L)
{
    if (L < 0 || L > SH_MAX_DEGREE) {
        throw Error("phase moments: degree " + std::to_string(L) + " is outside [0, " +
                    std::to_string(SH_MAX_DEGREE) + "]");
    }
    std::vector<double> p(std::size_t(L) + 1, 0.0);
    if (model == PhaseModel::HenyeyGreenstein) {
        for (int l = 0; l <= L; ++l)
            p[std::size_t(l)] = std::pow(g, l);
        return p;
    }
    // The other phase functions are polynomials in mu of degree <= 32 (murky), so 24 nodes
    // (exact to degree 47) integrate p(mu) P_l(mu) exactly for l <= 4.
    std::vector<double> x, w;
    gaussLegendre(24, x, w);
    for (int l = 0; l <= L; ++l) {
        double sum = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i)
            sum += w[i] * phaseFunction(model, x[i], g) * legendre(l, x[i]);
        p[std::size_t(l)] = 2.0 * PI * sum;
    }
    return p;
}

} // namespace nebula
