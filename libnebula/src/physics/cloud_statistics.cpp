// SPDX-License-Identifier: Apache-2.0
#include "nebula/physics/cloud_statistics.h"

#include "nebula/core/error.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numeric>

namespace nebula {

namespace {

/// The lognormal is fitted to the bins that hold at least this fraction of the peak's count.
constexpr double PDF_FIT_FRACTION = 0.1;

/// Weighted least squares of y = c0 + c1 x (+ c2 x^2 with @p quadratic); false if singular.
bool leastSquares(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& w, bool quadratic, double c[3], double* slopeError)
{
    const int m = quadratic ? 3 : 2;
    double a[3][4] = {};
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double p[3] = {1.0, x[i], x[i] * x[i]};
        for (int r = 0; r < m; ++r) {
            for (int s = 0; s < m; ++s)
                a[r][s] += w[i] * p[r] * p[s];
            a[r][3] += w[i] * p[r] * y[i];
        }
    }
    double inv11 = 0.0;
    if (!quadratic) {
        const double det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        if (!(std::abs(det) > 0.0)) return false;
        c[0] = (a[0][3] * a[1][1] - a[0][1] * a[1][3]) / det;
        c[1] = (a[0][0] * a[1][3] - a[1][0] * a[0][3]) / det;
        c[2] = 0.0;
        inv11 = a[0][0] / det;
    } else {
        // Gaussian elimination with partial pivoting on the 3x4 system.
        for (int col = 0; col < 3; ++col) {
            int piv = col;
            for (int r = col + 1; r < 3; ++r) {
                if (std::abs(a[r][col]) > std::abs(a[piv][col])) piv = r;
            }
            if (!(std::abs(a[piv][col]) > 0.0)) return false;
            for (int s = 0; s < 4; ++s)
                std::swap(a[col][s], a[piv][s]);
            for (int r = 0; r < 3; ++r) {
                if (r == col) continue;
                const double f = a[r][col] / a[col][col];
                for (int s = 0; s < 4; ++s)
                    a[r][s] -= f * a[col][s];
            }
        }
        for (int r = 0; r < 3; ++r)
            c[r] = a[r][3] / a[r][r];
    }
    if (slopeError) {
        // Unweighted fits only: the residual variance times (X^T X)^-1's slope entry.
        double rss = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i) {
            const double r = y[i] - c[0] - c[1] * x[i];
            rss += w[i] * r * r;
        }
        const double dof = double(x.size()) - 2.0;
        *slopeError = dof > 0.0 ? std::sqrt(rss / dof * inv11) : 0.0;
    }
    return true;
}

/// The @p q quantile (nearest rank) of @p sorted.
double quantile(const std::vector<double>& sorted, double q)
{
    const std::size_t i = std::min(sorted.size() - 1, std::size_t(q * double(sorted.size())));
    return sorted[i];
}

} // namespace

PdfFit fitColumnPdf(const ColumnMap& map, double binWidth, double floor)
{
    PdfFit fit;
    fit.binWidth = binWidth;
    fit.floor = floor;
    double sum = 0.0;
    std::size_t positive = 0;
    for (double v : map.values) {
        if (v > 0.0) {
            sum += v;
            ++positive;
        }
    }
    if (positive == 0) return fit;
    const double mean = sum / double(positive);
    std::vector<double> eta;
    for (double v : map.values) {
        if (v > 0.0 && v >= floor * mean) eta.push_back(std::log(v / mean));
    }
    fit.pixels = eta.size();
    if (eta.size() < 10) return fit;
    double s1 = 0.0, s2 = 0.0;
    for (double e : eta) {
        s1 += e;
        s2 += e * e;
    }
    const double n = double(eta.size());
    fit.sampleSigma = std::sqrt(std::max(s2 / n - (s1 / n) * (s1 / n), 0.0));
    const auto [lo, hi] = std::minmax_element(eta.begin(), eta.end());
    const double origin = std::floor(*lo / binWidth) * binWidth;
    const int bins = int((*hi - origin) / binWidth) + 1;
    std::vector<double> count(std::size_t(bins), 0.0);
    for (double e : eta)
        count[std::size_t(std::min(bins - 1, int((e - origin) / binWidth)))] += 1.0;
    const auto centre = [&](int b) { return origin + (b + 0.5) * binWidth; };
    const int peak = int(std::max_element(count.begin(), count.end()) - count.begin());
    const double floorCount = std::max(PDF_FIT_FRACTION * count[std::size_t(peak)], 3.0);
    int b0 = peak, b1 = peak;
    while (b0 > 0 && count[std::size_t(b0 - 1)] >= floorCount)
        --b0;
    while (b1 + 1 < bins && count[std::size_t(b1 + 1)] >= floorCount)
        ++b1;
    std::vector<double> x, y, w;
    for (int b = b0; b <= b1; ++b) {
        x.push_back(centre(b));
        y.push_back(std::log(count[std::size_t(b)]));
        // Weights count^2: least squares on ln(count) so weighted approximates least squares
        // on the counts themselves (Guo 2011), which the peak dominates, not the wings.
        w.push_back(count[std::size_t(b)] * count[std::size_t(b)]);
    }
    double c[3];
    if (x.size() < 3 || !leastSquares(x, y, w, true, c, nullptr) || !(c[2] < 0.0)) return fit;
    fit.fitted = true;
    fit.fitBins = int(x.size());
    fit.sigma = std::sqrt(-1.0 / (2.0 * c[2]));
    fit.mu = -c[1] / (2.0 * c[2]);
    // The high side: from the first bin above mu + sigma whose count is 2x the lognormal's or
    // more (the deviation point; else from mu + sigma) to the last bin that holds 3 pixels.
    // Its slope is a line through ln(count) against eta (bins of 2 pixels or more, weighted by
    // their counts); it is a tail if it holds 2x or more the pixels the lognormal predicts.
    const auto model = [&](double e) { return std::exp(c[0] + c[1] * e + c[2] * e * e); };
    int last = bins - 1;
    while (last >= 0 && count[std::size_t(last)] < 3.0)
        --last;
    int first = -1, start = -1;
    for (int b = 0; b <= last; ++b) {
        if (centre(b) < fit.mu + fit.sigma) continue;
        if (start < 0) start = b;
        if (count[std::size_t(b)] >= 2.0 * model(centre(b))) {
            first = b;
            break;
        }
    }
    if (first < 0) first = start;
    x.clear();
    y.clear();
    w.clear();
    double observed = 0.0, predicted = 0.0;
    for (int b = std::max(first, 0); first >= 0 && b <= last; ++b) {
        const double e = centre(b), k = count[std::size_t(b)];
        observed += k;
        predicted += model(e);
        if (k >= 2.0) {
            x.push_back(e);
            y.push_back(std::log(k));
            w.push_back(k);
        }
    }
    if (x.size() >= 3 && leastSquares(x, y, w, false, c, nullptr)) {
        fit.highSide = true;
        fit.tailSlope = c[1];
        fit.tailFrom = x.front() - 0.5 * binWidth;
        fit.tailTo = x.back() + 0.5 * binWidth;
        fit.tailBins = int(x.size());
        fit.tailExcess = predicted > 0.0 ? observed / predicted : 0.0;
        fit.tail = fit.tailExcess >= 2.0;
    }
    return fit;
}

SpectrumFit powerSpectrum(const ColumnMap& map, double kMin, double kMax)
{
    const int n = std::max(map.nu, map.nv);
    if (n < 4) throw Error("power spectrum: the map is smaller than 4 pixels");
    const int nc = n / 2 + 1;
    std::vector<double> in(std::size_t(n) * std::size_t(n), 0.0);
    double mean = 0.0;
    for (double v : map.values)
        mean += v;
    mean /= double(map.values.size());
    for (int v = 0; v < map.nv; ++v) {
        for (int u = 0; u < map.nu; ++u)
            in[std::size_t(v) * std::size_t(n) + std::size_t(u)] = map.at(u, v) - mean;
    }
    std::vector<fftw_complex> out(std::size_t(n) * std::size_t(nc));
    {
        static std::mutex planner;
        std::lock_guard<std::mutex> lock(planner);
        fftw_plan plan = fftw_plan_dft_r2c_2d(n, n, in.data(), out.data(), FFTW_ESTIMATE);
        if (!plan) throw Error("power spectrum: FFTW could not plan the transform");
        fftw_execute(plan);
        fftw_destroy_plan(plan);
    }
    SpectrumFit fit;
    fit.kMin = kMin;
    fit.kMax = kMax;
    const int rings = n / 2;
    std::vector<double> sum(std::size_t(rings + 1), 0.0), modes(std::size_t(rings + 1), 0.0);
    double across = 0.0, along = 0.0, nAcross = 0.0, nAlong = 0.0;
    const double norm = 1.0 / (double(n) * n * double(n) * n);
    for (int v = 0; v < n; ++v) {
        const int kv = v <= n / 2 ? v : v - n;
        for (int u = 0; u < nc; ++u) {
            const int ku = u;
            // The r2c half plane: modes with 0 < u < n/2 stand for their mirror too.
            const double weight = (u == 0 || 2 * u == n) ? 1.0 : 2.0;
            const fftw_complex& f = out[std::size_t(v) * std::size_t(nc) + std::size_t(u)];
            const double p = (f[0] * f[0] + f[1] * f[1]) * norm;
            const double k = std::hypot(double(ku), double(kv));
            const int ring = int(std::lround(k));
            if (ring >= 1 && ring <= rings) {
                sum[std::size_t(ring)] += weight * p;
                modes[std::size_t(ring)] += weight;
            }
            if (k >= kMin && k <= kMax) {
                if (std::abs(kv) > ku) {
                    across += weight * p;
                    nAcross += weight;
                } else if (ku > std::abs(kv)) {
                    along += weight * p;
                    nAlong += weight;
                }
            }
        }
    }
    std::vector<double> x, y, w;
    for (int r = 1; r <= rings; ++r) {
        if (modes[std::size_t(r)] == 0.0) continue;
        const double p = sum[std::size_t(r)] / modes[std::size_t(r)];
        fit.k.push_back(r);
        fit.power.push_back(p);
        if (r >= kMin && r <= kMax && p > 0.0) {
            x.push_back(std::log(double(r)));
            y.push_back(std::log(p));
            w.push_back(1.0);
        }
    }
    if (x.size() < 3) {
        throw Error("power spectrum: fewer than 3 rings of k in [" + std::to_string(kMin) + ", " +
                    std::to_string(kMax) + "] for a map of edge " + std::to_string(n));
    }
    double c[3];
    if (leastSquares(x, y, w, false, c, &fit.slopeError)) {
        fit.fitted = true;
        fit.slope = c[1];
        fit.bins = int(x.size());
    }
    if (nAcross > 0.0 && nAlong > 0.0 && along > 0.0) {
        fit.anisotropy = (across / nAcross) / (along / nAlong);
    }
    return fit;
}

namespace {

/// Areas and perimeters of the 4-connected regions of @p inside that do not touch the edge.
void regions(const std::vector<char>& inside, int nu, int nv, int minArea,
             std::vector<double>& areas, std::vector<double>& perimeters)
{
    std::vector<int> label(inside.size(), -1);
    std::vector<int> stack;
    const auto id = [nu](int u, int v) {
        return std::size_t(v) * std::size_t(nu) + std::size_t(u);
    };
    for (int v0 = 0; v0 < nv; ++v0) {
        for (int u0 = 0; u0 < nu; ++u0) {
            if (!inside[id(u0, v0)] || label[id(u0, v0)] >= 0) continue;
            long area = 0, perimeter = 0;
            bool edge = false;
            stack.assign(1, int(id(u0, v0)));
            label[id(u0, v0)] = 1;
            while (!stack.empty()) {
                const int c = stack.back();
                stack.pop_back();
                const int u = c % nu, v = c / nu;
                ++area;
                if (u == 0 || v == 0 || u == nu - 1 || v == nv - 1) edge = true;
                const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
                for (int d = 0; d < 4; ++d) {
                    const int a = u + du[d], b = v + dv[d];
                    if (a < 0 || b < 0 || a >= nu || b >= nv || !inside[id(a, b)]) {
                        ++perimeter;
                        continue;
                    }
                    if (label[id(a, b)] < 0) {
                        label[id(a, b)] = 1;
                        stack.push_back(int(id(a, b)));
                    }
                }
            }
            if (!edge && area >= minArea) {
                areas.push_back(double(area));
                perimeters.push_back(double(perimeter));
            }
        }
    }
}

} // namespace

PerimeterAreaFit perimeterAreaDimension(const ColumnMap& map, int levels, int minArea)
{
    PerimeterAreaFit fit;
    std::vector<double> positive;
    for (double v : map.values) {
        if (v > 0.0) positive.push_back(v);
    }
    if (positive.size() < 10 || levels < 1) return fit;
    std::sort(positive.begin(), positive.end());
    const double l0 = std::log(quantile(positive, 0.2)), l1 = std::log(quantile(positive, 0.9));
    std::vector<double> areas, perimeters;
    std::vector<char> above(map.values.size()), below(map.values.size());
    for (int i = 0; i < levels; ++i) {
        const double level =
            std::exp(levels == 1 ? l0 : l0 + (l1 - l0) * double(i) / double(levels - 1));
        for (std::size_t p = 0; p < map.values.size(); ++p) {
            above[p] = map.values[p] > level;
            below[p] = !above[p];
        }
        regions(above, map.nu, map.nv, minArea, areas, perimeters);
        regions(below, map.nu, map.nv, minArea, areas, perimeters);
    }
    fit.levels = levels;
    fit.contours = int(areas.size());
    if (areas.size() < 5) return fit;
    const auto [amin, amax] = std::minmax_element(areas.begin(), areas.end());
    fit.areaMin = *amin;
    fit.areaMax = *amax;
    if (*amax < 10.0 * *amin) return fit;
    std::vector<double> x, y, w(areas.size(), 1.0);
    for (std::size_t i = 0; i < areas.size(); ++i) {
        x.push_back(std::log(areas[i]));
        y.push_back(std::log(perimeters[i]));
    }
    double c[3];
    double err = 0.0;
    if (leastSquares(x, y, w, false, c, &err)) {
        fit.fitted = true;
        fit.dimension = 2.0 * c[1];
        fit.error = 2.0 * err;
    }
    return fit;
}

} // namespace nebula
