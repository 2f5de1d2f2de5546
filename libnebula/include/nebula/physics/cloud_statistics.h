// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file cloud_statistics.h
/// The statistics observers measure on column-density maps (nebstats; DESIGN §2b): the
/// lognormal fit of the column-density PDF and its power-law tail, the power spectrum's
/// slope, and the perimeter-area dimension of the contours. Plain arrays, no grids.

#include <cmath>
#include <cstddef>
#include <vector>

namespace nebula {

/// A map of positive (or zero: no cloud) values, row-major: value(u, v) = values[v * nu + u].
struct ColumnMap
{
    int nu = 0, nv = 0;
    std::vector<double> values;
    double at(int u, int v) const
    {
        return values[std::size_t(v) * std::size_t(nu) + std::size_t(u)];
    }
    /// Pixels with a value > 0.
    std::size_t positive() const
    {
        std::size_t n = 0;
        for (double v : values)
            n += v > 0.0;
        return n;
    }
};

/// The lognormal fit of the PDF of eta = ln(N / <N>) over the pixels with N >= floor <N> (<N>
/// the mean of the pixels with N > 0), and its power-law tail.
struct PdfFit
{
    bool fitted = false;
    double sigma = 0.0;     ///< the fitted lognormal's width, sigma of ln N
    double mu = 0.0;        ///< its peak, in eta
    double binWidth = 0.0;  ///< histogram bins in eta
    int fitBins = 0;        ///< bins the parabola was fitted to
    std::size_t pixels = 0; ///< pixels with N >= floor <N>
    double floor = 0.0;     ///< the floor, in units of <N>
    double sampleSigma =
        0.0;                ///< the plain standard deviation of eta over the pixels, for comparison
    bool highSide = false;  ///< the high side's slope was fitted
    double tailSlope = 0.0; ///< the high side: p(eta) ~ N^tailSlope (p(N) ~ N^(tailSlope - 1))
    double tailFrom = 0.0, tailTo = 0.0; ///< its range in eta
    int tailBins = 0;
    double tailExcess = 0.0; ///< its pixels over the lognormal's prediction there
    bool tail = false;       ///< a power-law tail: tailExcess >= 2
};

/// Fits the PDF (Kainulainen et al. 2009's method in essence) over the pixels with N >= @p floor
/// <N> (an observer's completeness limit: the faint rim of a finite cloud, which a real map
/// sees against the diffuse medium around it, is left out): a histogram of eta in bins of
/// @p binWidth; a parabola fitted to ln(count), weighted by the counts squared (so that it
/// approximates a least-squares Gaussian fit to the counts themselves, which the peak
/// dominates, not the wings; Guo 2011), over the contiguous bins about the peak that hold at
/// least a tenth of the peak's count (and 3 pixels): a Gaussian in eta, sigma =
/// sqrt(-1 / (2 a)). The high side: from the deviation point (the first bin above mu + sigma
/// that holds 2x the lognormal's count or more; else mu + sigma) to the last bin that holds 3
/// pixels; its slope is a line through ln(count) against eta (bins of 2 pixels or more,
/// weighted by their counts), and it is a power-law tail if it holds 2x or more the pixels
/// the fitted lognormal predicts there. Not fitted if fewer than 3 bins qualify or the
/// parabola opens upwards.
PdfFit fitColumnPdf(const ColumnMap& map, double binWidth = 0.1, double floor = 0.0);

/// The azimuthally averaged power spectrum and its slope.
struct SpectrumFit
{
    bool fitted = false;
    double slope = 0.0, slopeError = 0.0; ///< P(k) ~ k^slope, least squares in log-log
    double kMin = 0.0, kMax = 0.0;        ///< the fitted range [cycles per map edge]
    int bins = 0;                         ///< integer-k rings fitted
    /// Mean power of the modes in [kMin, kMax] with |k_v| > |k_u| over those with
    /// |k_u| > |k_v|: above 1 when structures run along u (more power across it).
    double anisotropy = 0.0;
    std::vector<double> k, power; ///< the ring spectrum, k = 1 .. edge / 2
};

/// The power spectrum of @p map, zero-padded to a square of edge max(nu, nv), mean removed:
/// |FFT|^2 averaged in rings of integer |k| (cycles per edge), the slope fitted over the rings
/// with kMin <= k <= kMax. Throws Error if fewer than 3 rings fall in the range.
SpectrumFit powerSpectrum(const ColumnMap& map, double kMin, double kMax);

/// The perimeter-area dimension of the map's contours.
struct PerimeterAreaFit
{
    bool fitted = false;
    double dimension = 0.0, error = 0.0; ///< D, P ~ A^(D/2), and its standard error
    int contours = 0;                    ///< closed contours fitted
    int levels = 0;
    double areaMin = 0.0, areaMax = 0.0; ///< the fitted contours' areas [pixels]
};

/// Falgarone, Phillips & Walker (1991)'s perimeter-area relation: at each of @p levels levels,
/// spaced in ln N from the 20th to the 90th percentile of the pixels with N > 0, the
/// 4-connected regions above the level (clouds) and below it (holes) that do not touch the
/// map's edge and cover at least @p minArea pixels; their area A (pixels) and perimeter P
/// (pixel edges between inside and outside); D = 2 d ln P / d ln A by least squares. Not
/// fitted with fewer than 5 contours or areas spanning less than a factor 10.
PerimeterAreaFit perimeterAreaDimension(const ColumnMap& map, int levels = 8, int minArea = 4);

/// The mean and standard deviation of ln x over the values x > 0 added (the 3-D density
/// PDF's sigma_s), by Welford's update; merge() joins two (Chan et al.'s formula).
class LogMoments
{
public:
    void add(double x)
    {
        if (!(x > 0.0)) return;
        const double y = std::log(x);
        ++mCount;
        const double d = y - mMean;
        mMean += d / double(mCount);
        mM2 += d * (y - mMean);
    }
    /// add(x) @p n times at once (an active tile's voxels).
    void add(double x, std::size_t n)
    {
        if (!(x > 0.0) || n == 0) return;
        LogMoments same;
        same.mCount = n;
        same.mMean = std::log(x);
        merge(same);
    }
    void merge(const LogMoments& o)
    {
        if (o.mCount == 0) return;
        const double n = double(mCount) + double(o.mCount), d = o.mMean - mMean;
        mM2 += o.mM2 + d * d * double(mCount) * double(o.mCount) / n;
        mMean += d * double(o.mCount) / n;
        mCount += o.mCount;
    }
    std::size_t count() const { return mCount; }
    double mean() const { return mMean; }
    double sigma() const { return mCount > 1 ? std::sqrt(mM2 / double(mCount)) : 0.0; }

private:
    std::size_t mCount = 0;
    double mMean = 0.0, mM2 = 0.0;
};

} // namespace nebula
