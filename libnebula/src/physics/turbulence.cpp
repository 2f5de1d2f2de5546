// SPDX-License-Identifier: Apache-2.0
#include "nebula/physics/turbulence.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"
#include "nebula/core/rng.h"
#include "nebula/core/units.h"

#include <fftw3.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <vector>

namespace nebula {

using detail::numberText;

double TurbulenceParams::sigmaS() const
{
    return std::sqrt(std::log1p(forcingB * forcingB * mach * mach));
}

void TurbulenceParams::validate() const
{
    if (!(mach > 0.0) || !std::isfinite(mach)) {
        throw UsageError("--mach must be a finite number > 0 (the RMS sonic Mach number), got " +
                         numberText(mach));
    }
    if (!(forcingB > 0.0 && forcingB <= 1.0)) {
        throw UsageError("--forcing-b must be in (0, 1] (1/3: solenoidal, 1: compressive), got " +
                         numberText(forcingB));
    }
    if (!(index >= 0.0 && index <= 10.0)) {
        throw UsageError("--power-index must be in [0, 10], got " + numberText(index));
    }
    if (!(outerScale > 0.0 && outerScale <= 100.0)) {
        throw UsageError("--outer-scale must be in (0, 100] cube edges, got " +
                         numberText(outerScale));
    }
    if (!(anisotropy >= 0.0 && anisotropy <= 100.0)) {
        throw UsageError("--anisotropy must be in [0, 100] (0: isotropic), got " +
                         numberText(anisotropy));
    }
    const double len = std::hypot(axis[0], axis[1], axis[2]);
    if (!(len > 0.0) || !std::isfinite(len)) {
        throw UsageError("--anisotropy-axis must be a finite, non-zero vector");
    }
}

int turbulenceLattice(int res)
{
    return std::min(res, TURBULENCE_MAX_LATTICE);
}

double LognormalField::bytes(int n)
{
    return double(n) * double(n) * 2.0 * (n / 2 + 1) * sizeof(float);
}

namespace {

/// FFTW's planner is not thread-safe, and its threads are set up once.
std::mutex& fftwMutex()
{
    static std::mutex m;
    return m;
}

/// FFTW threads per transform: fixed, so the plan (FFTW_ESTIMATE) and its rounding do not
/// depend on the machine.
constexpr int FFT_THREADS = 4;

/// Wavenumber of FFT index @p i of @p n [cycles per cube edge].
double waveNumber(int i, int n)
{
    return i <= n / 2 ? i : i - n;
}

/// SplitMix64 (Steele, Lea & Flood 2014): advances @p state and returns 64 well-mixed bits,
/// so that neighbouring keys give independent numbers.
std::uint64_t splitMix64(std::uint64_t& state)
{
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/// The key of the mode with integer wavevector (kx, ky, kz), |k| < 2^20.
std::uint64_t modeKey(int kx, int ky, int kz)
{
    constexpr std::int64_t offset = 1 << 20;
    return (std::uint64_t(kx + offset) << 42) | (std::uint64_t(ky + offset) << 21) |
           std::uint64_t(kz);
}

} // namespace

LognormalField::LognormalField(const TurbulenceParams& p, int n, std::uint64_t seed,
                               const std::string& what)
    : mN(n)
{
    p.validate();
    if (n < 2 || n > TURBULENCE_MAX_LATTICE) {
        throw UsageError(what + ": lattice " + std::to_string(n) + " outside [2, " +
                         std::to_string(TURBULENCE_MAX_LATTICE) + "]");
    }
    requireMemory(bytes(n), what + " (" + std::to_string(n) + "^3)");
    const int nz = n / 2 + 1;
    mRow = std::size_t(2 * nz);
    const std::size_t total = std::size_t(n) * std::size_t(n) * mRow;
    mData = static_cast<float*>(fftwf_malloc(total * sizeof(float)));
    if (!mData) throw Error(what + ": out of memory");
    auto* modes = reinterpret_cast<fftwf_complex*>(mData);

    // The modes, each from its own random numbers (deterministic whatever the threads).
    const double len = std::hypot(p.axis[0], p.axis[1], p.axis[2]);
    const double ax = p.axis[0] / len, ay = p.axis[1] / len, az = p.axis[2] / len;
    const double stretch = (1.0 + p.anisotropy) * (1.0 + p.anisotropy) - 1.0;
    const double k0sq = 1.0 / (p.outerScale * p.outerScale);
    tbb::parallel_for(0, n, [&](int i) {
        const double kx = waveNumber(i, n);
        for (int j = 0; j < n; ++j) {
            const double ky = waveNumber(j, n);
            fftwf_complex* row = modes + (std::size_t(i) * n + std::size_t(j)) * std::size_t(nz);
            for (int k = 0; k < nz; ++k) {
                const double kz = k;
                // Each mode draws from the stream of its wavevector, so lattices of every
                // size share their common modes: a finer grid is the same cloud, finer.
                std::uint64_t state = modeKey(int(kx), int(ky), k) * 0xD1342543DE82EF95ull ^ seed;
                // Box-Muller: two independent normal deviates.
                const double u1 = 1.0 - unitDoubleFromBits(splitMix64(state));
                const double u2 = unitDoubleFromBits(splitMix64(state));
                const double radius = std::sqrt(-2.0 * std::log(u1));
                const double kpar = kx * ax + ky * ay + kz * az;
                const double keff2 = kx * kx + ky * ky + kz * kz + stretch * kpar * kpar;
                const double amp =
                    (i == 0 && j == 0 && k == 0) ? 0.0 : std::pow(keff2 + k0sq, -0.25 * p.index);
                row[k][0] = float(amp * radius * std::cos(2.0 * PI * u2));
                row[k][1] = float(amp * radius * std::sin(2.0 * PI * u2));
            }
        }
    });

    {
        std::lock_guard<std::mutex> lock(fftwMutex());
        static const bool threads = fftwf_init_threads() != 0;
        fftwf_plan_with_nthreads(threads ? FFT_THREADS : 1);
        fftwf_plan plan = fftwf_plan_dft_c2r_3d(n, n, n, modes, mData, FFTW_ESTIMATE);
        if (!plan) {
            fftwf_free(mData);
            throw Error(what + ": FFTW could not plan a " + std::to_string(n) + "^3 transform");
        }
        fftwf_execute(plan);
        fftwf_destroy_plan(plan);
    }

    // Mean and variance, per x-plane then summed in order (deterministic).
    std::vector<double> sum(std::size_t(n), 0.0), sumSq(std::size_t(n), 0.0);
    tbb::parallel_for(0, n, [&](int i) {
        double s = 0.0, q = 0.0;
        for (int j = 0; j < n; ++j) {
            const float* row = mData + (std::size_t(i) * n + std::size_t(j)) * mRow;
            for (int k = 0; k < n; ++k) {
                s += row[k];
                q += double(row[k]) * row[k];
            }
        }
        sum[std::size_t(i)] = s;
        sumSq[std::size_t(i)] = q;
    });
    double s = 0.0, q = 0.0;
    for (int i = 0; i < n; ++i) {
        s += sum[std::size_t(i)];
        q += sumSq[std::size_t(i)];
    }
    const double count = double(n) * n * n;
    const double mean = s / count;
    const double sd = std::sqrt(std::max(q / count - mean * mean, 0.0));
    mSigma = p.sigmaS();
    const double scale = sd > 0.0 ? mSigma / sd : 0.0;
    const double shift = -0.5 * mSigma * mSigma;
    tbb::parallel_for(0, n, [&](int i) {
        for (int j = 0; j < n; ++j) {
            float* row = mData + (std::size_t(i) * n + std::size_t(j)) * mRow;
            for (int k = 0; k < n; ++k)
                row[k] = float((row[k] - mean) * scale + shift);
        }
    });
}

LognormalField::~LognormalField()
{
    fftwf_free(mData);
}

float LognormalField::at(int i, int j, int k) const
{
    const auto wrap = [n = mN](int v) { return ((v % n) + n) % n; };
    return mData[(std::size_t(wrap(i)) * mN + std::size_t(wrap(j))) * mRow + std::size_t(wrap(k))];
}

float LognormalField::operator()(double x, double y, double z) const
{
    // Lattice coordinates: point i sits at (i + 0.5) / n - 0.5.
    const int n = mN;
    const auto corner = [n](double v, int& i0, int& i1, float& t) {
        const double g = (v + 0.5) * n - 0.5, f = std::floor(g);
        t = float(g - f);
        i0 = int(std::fmod(f, double(n)));
        if (i0 < 0) i0 += n;
        i1 = i0 + 1 == n ? 0 : i0 + 1;
    };
    int i0, i1, j0, j1, k0, k1;
    float tx, ty, tz;
    corner(x, i0, i1, tx);
    corner(y, j0, j1, ty);
    corner(z, k0, k1, tz);
    const float* r00 = mData + (std::size_t(i0) * n + std::size_t(j0)) * mRow;
    const float* r10 = mData + (std::size_t(i1) * n + std::size_t(j0)) * mRow;
    const float* r01 = mData + (std::size_t(i0) * n + std::size_t(j1)) * mRow;
    const float* r11 = mData + (std::size_t(i1) * n + std::size_t(j1)) * mRow;
    const auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
    const float c00 = lerp(r00[k0], r10[k0], tx), c10 = lerp(r01[k0], r11[k0], tx);
    const float c01 = lerp(r00[k1], r10[k1], tx), c11 = lerp(r01[k1], r11[k1], tx);
    return lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), tz);
}

} // namespace nebula
