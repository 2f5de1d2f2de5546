// SPDX-License-Identifier: Apache-2.0
/// @file scatter_filter.cpp
/// nebscatter's noise filter (scatter_filter.h, DESIGN §5b "Noise filter").

#include "scatter_filter.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <utility>

namespace nebula::detail {

namespace {

/// @p inv = @p g^-1 for a symmetric positive definite 4x4 @p g (Gauss-Jordan with partial
/// pivoting); false where g is singular to rounding (the cells lie in a plane or a line).
bool invert4(const double (&g)[4][4], double (&inv)[4][4])
{
    double a[4][8];
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            a[r][c] = g[r][c];
            a[r][c + 4] = r == c ? 1.0 : 0.0;
        }
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (std::abs(a[r][c]) > std::abs(a[piv][c])) piv = r;
        if (!(std::abs(a[piv][c]) > 1e-9 * std::max(1.0, std::abs(g[0][0])))) return false;
        if (piv != c) std::swap(a[piv], a[c]);
        const double d = 1.0 / a[c][c];
        for (int k = 0; k < 8; ++k)
            a[c][k] *= d;
        for (int r = 0; r < 4; ++r) {
            if (r == c) continue;
            const double f = a[r][c];
            for (int k = 0; k < 8; ++k)
                a[r][k] -= f * a[c][k];
        }
    }
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            inv[r][c] = a[r][c + 4];
    return true;
}

} // namespace

DenoiseReport denoiseField(SparseVolume& moments, const std::array<int, 3>& lo,
                           const std::array<int, 3>& dims, const std::vector<float>& relError,
                           int noiseChannel, int radius)
{
    DenoiseReport report;
    if (radius <= 0) return report;
    const int C = moments.channels();
    const std::size_t nx = std::size_t(dims[0]), nxy = nx * std::size_t(dims[1]);
    const auto cellOf = [&](int I, int J, int K) {
        return std::size_t(K) * nxy + std::size_t(J) * nx + std::size_t(I);
    };
    const SparseVolume in = moments; // read from the unfiltered field, write into moments
    std::atomic<std::size_t> cells{0};
    // Per z-slab sums of k (fixed order within a slab; slabs summed in order below).
    std::vector<double> slabWeight(std::size_t(dims[2]), 0.0), slabBefore(slabWeight),
        slabAfter(slabWeight);
    std::vector<std::size_t> slabKnown(std::size_t(dims[2]), 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, dims[2]), [&](const tbb::blocked_range<int>& r) {
        // Per channel: the sums of y, dx y, dy y, dz y over the neighbourhood.
        std::vector<double> T(4 * static_cast<std::size_t>(C), 0.0);
        for (int K = r.begin(); K < r.end(); ++K) {
            std::size_t done = 0;
            for (int J = 0; J < dims[1]; ++J)
                for (int I = 0; I < dims[0]; ++I) {
                    const float rel = relError[cellOf(I, J, K)];
                    if (rel == NOISE_INACTIVE) continue;
                    const float* y = in.voxel(in.index(I + lo[0], J + lo[1], K + lo[2]));
                    const double x = y[noiseChannel];
                    // The neighbourhood's active cells: the normal equations G of a plane
                    // a + b . (offset) fitted to them, the sums T, the noise channel's
                    // squares and the cells' noise variances.
                    std::fill(T.begin(), T.end(), 0.0);
                    double G[4][4] = {};
                    double sxx = 0.0, sNoise = 0.0;
                    int n = 0, nNoise = 0;
                    for (int k = std::max(0, K - radius); k <= std::min(dims[2] - 1, K + radius);
                         ++k)
                        for (int j = std::max(0, J - radius);
                             j <= std::min(dims[1] - 1, J + radius); ++j)
                            for (int i = std::max(0, I - radius);
                                 i <= std::min(dims[0] - 1, I + radius); ++i) {
                                const float ri = relError[cellOf(i, j, k)];
                                if (ri == NOISE_INACTIVE) continue;
                                const float* v =
                                    in.voxel(in.index(i + lo[0], j + lo[1], k + lo[2]));
                                const double phi[4] = {1.0, double(i - I), double(j - J),
                                                       double(k - K)};
                                for (int a = 0; a < 4; ++a)
                                    for (int b = 0; b < 4; ++b)
                                        G[a][b] += phi[a] * phi[b];
                                for (int q = 0; q < C; ++q)
                                    for (int a = 0; a < 4; ++a)
                                        T[4 * std::size_t(q) + std::size_t(a)] += phi[a] * v[q];
                                const double xv = v[noiseChannel];
                                sxx += xv * xv;
                                ++n;
                                if (ri >= 0.0f) {
                                    sNoise += double(ri) * ri * xv * xv;
                                    ++nNoise;
                                }
                            }
                    // w: the first row of G^-1, so that the plane's value at the cell is
                    // w . T; where the cells do not fix a plane (fewer than 4, or all in a
                    // line or a plane), the mean.
                    double w[4] = {1.0 / n, 0.0, 0.0, 0.0};
                    double inv[4][4];
                    const bool plane = n >= 5 && invert4(G, inv);
                    if (plane) {
                        for (int a = 0; a < 4; ++a)
                            w[a] = inv[0][a];
                    }
                    // The noise channel's residual spread about its plane (about its mean
                    // without one): sum y^2 - beta . T over n - p degrees of freedom.
                    const double* Tx = &T[4 * std::size_t(noiseChannel)];
                    double fitted = Tx[0] * Tx[0] / n;
                    int p = 1;
                    if (plane) {
                        fitted = 0.0;
                        for (int a = 0; a < 4; ++a)
                            for (int b = 0; b < 4; ++b)
                                fitted += Tx[a] * inv[a][b] * Tx[b];
                        p = 4;
                    }
                    const double spread = n > p ? std::max(0.0, sxx - fitted) / (n - p) : 0.0;
                    const double noise = nNoise ? sNoise / nNoise : 0.0;
                    const double signal = std::max(0.0, spread - noise);
                    double k = 1.0; // unknown noise: the neighbours' plane
                    if (rel >= 0.0f) {
                        const double sigma2 = double(rel) * rel * x * x;
                        k = sigma2 + signal > 0.0 ? sigma2 / (sigma2 + signal) : 0.0;
                        if (x > 0.0) {
                            // The plane's value has the variance of a mean of n cells.
                            const double after = (1.0 - k) * (1.0 - k) * sigma2 + k * k * noise / n;
                            slabBefore[std::size_t(K)] += rel;
                            slabAfter[std::size_t(K)] += std::sqrt(after) / x;
                            ++slabKnown[std::size_t(K)];
                        }
                    }
                    float* out = moments.writable(moments.index(I + lo[0], J + lo[1], K + lo[2]));
                    for (int q = 0; q < C; ++q) {
                        const double* Tq = &T[4 * std::size_t(q)];
                        const double at = w[0] * Tq[0] + w[1] * Tq[1] + w[2] * Tq[2] + w[3] * Tq[3];
                        out[q] = float(y[q] + k * (at - y[q]));
                    }
                    slabWeight[std::size_t(K)] += k;
                    ++done;
                }
            cells.fetch_add(done, std::memory_order_relaxed);
        }
    });
    report.cells = cells.load();
    double sum = 0.0, before = 0.0, after = 0.0;
    std::size_t known = 0;
    for (std::size_t K = 0; K < slabWeight.size(); ++K) {
        sum += slabWeight[K];
        before += slabBefore[K];
        after += slabAfter[K];
        known += slabKnown[K];
    }
    report.meanWeight = report.cells ? sum / double(report.cells) : 0.0;
    report.noiseBefore = known ? before / double(known) : 0.0;
    report.noiseAfter = known ? after / double(known) : 0.0;
    return report;
}

} // namespace nebula::detail
