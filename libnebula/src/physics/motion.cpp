// SPDX-License-Identifier: Apache-2.0
/// @file motion.cpp
/// Velocity models (expansion, rotation, curl-noise turbulence) and the velocity-grid check.

#include "nebula/physics/motion.h"

#include "nebula/core/error.h"
#include "nebula/physics/noise.h"

#include <cmath>
#include <sstream>

namespace nebula {

namespace {

/// Turbulence potential: 4 octaves, gain 2^(-4/3). Each octave doubles the frequency, and
/// the curl multiplies the amplitude by the frequency, so the velocity's octaves fall as
/// 2^(-1/3) per halving of scale: Kolmogorov's v_l ~ l^(1/3).
const FbmParams TURBULENCE_FBM{4, 2.0, 0.39685026299204984}; // 2^(-4/3)

/// Cells per axis of the lattice the turbulence RMS is measured on.
constexpr int RMS_CELLS = 32;

/// Decorrelates the turbulence from nebgen's density and emission noise of the same seed.
constexpr std::uint64_t TURBULENCE_SEED_MIX = 0xBB67AE8584CAA73Bull;

std::string numberText(double v)
{
    std::ostringstream s;
    s << v;
    return s.str();
}

void requireFinite(double v, const std::string& option, const std::string& unit)
{
    if (!std::isfinite(v)) {
        throw UsageError(option + " must be a finite number [" + unit + "], got " + numberText(v));
    }
}

} // namespace

void MotionParams::validate() const
{
    requireFinite(expansion, "--expansion", "km/s");
    requireFinite(rotation, "--rotation", "km/s");
    for (double a : axis)
        requireFinite(a, "--rotation-axis", "any unit");
    if (axis[0] == 0.0 && axis[1] == 0.0 && axis[2] == 0.0) {
        throw UsageError("--rotation-axis must not be the zero vector");
    }
    if (!(turbulence >= 0.0) || !std::isfinite(turbulence)) {
        throw UsageError("--turbulence must be a finite RMS speed >= 0 [km/s], got " +
                         numberText(turbulence));
    }
    if (!(turbulenceFrequency > 0.0) || !std::isfinite(turbulenceFrequency)) {
        throw UsageError("--turbulence-frequency must be a finite number > 0, got " +
                         numberText(turbulenceFrequency));
    }
    for (double c : centre)
        requireFinite(c, "--motion-centre", "pc");
    if (!(radius > 0.0) || !std::isfinite(radius)) {
        throw UsageError("--motion-radius must be a finite number > 0 [pc], got " +
                         numberText(radius));
    }
}

MotionField::MotionField(const MotionParams& params, double cubeSize)
    : mParams(params), mCubeSize(cubeSize)
{
    params.validate();
    if (!(cubeSize > 0.0) || !std::isfinite(cubeSize)) {
        throw UsageError("motion field: the cube size must be a finite number > 0 [pc], got " +
                         numberText(cubeSize));
    }
    const double len = std::sqrt(params.axis[0] * params.axis[0] + params.axis[1] * params.axis[1] +
                                 params.axis[2] * params.axis[2]);
    for (int a = 0; a < 3; ++a)
        mAxis[a] = params.axis[a] / len;

    if (params.turbulence > 0.0) {
        // RMS of the raw curl noise over the cube, summed in a fixed order.
        double sum = 0.0;
        for (int k = 0; k < RMS_CELLS; ++k) {
            for (int j = 0; j < RMS_CELLS; ++j) {
                for (int i = 0; i < RMS_CELLS; ++i) {
                    const std::array<double, 3> x = {((i + 0.5) / RMS_CELLS - 0.5) * cubeSize,
                                                     ((j + 0.5) / RMS_CELLS - 0.5) * cubeSize,
                                                     ((k + 0.5) / RMS_CELLS - 0.5) * cubeSize};
                    const auto v = turbulent(x);
                    sum += v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                }
            }
        }
        const double rms = std::sqrt(sum / (double(RMS_CELLS) * RMS_CELLS * RMS_CELLS));
        mTurbulenceScale = rms > 0.0 ? params.turbulence / rms : 0.0;
    }
}

std::array<double, 3> MotionField::turbulent(const std::array<double, 3>& x) const
{
    // Noise coordinates: `turbulenceFrequency` base features across the cube.
    const double s = mParams.turbulenceFrequency / mCubeSize;
    return curlNoise(x[0] * s, x[1] * s, x[2] * s, TURBULENCE_FBM,
                     mParams.seed ^ TURBULENCE_SEED_MIX);
}

std::array<double, 3> MotionField::operator()(const std::array<double, 3>& x) const
{
    const auto& p = mParams;
    const std::array<double, 3> d = {x[0] - p.centre[0], x[1] - p.centre[1], x[2] - p.centre[2]};
    std::array<double, 3> v{0, 0, 0};
    // Homologous expansion: v = expansion (x - centre) / radius.
    if (p.expansion != 0.0) {
        for (int a = 0; a < 3; ++a)
            v[a] += p.expansion * d[a] / p.radius;
    }
    // Solid-body rotation: v = rotation (axis x (x - centre)) / radius.
    if (p.rotation != 0.0) {
        const auto& n = mAxis;
        const std::array<double, 3> c = {n[1] * d[2] - n[2] * d[1], n[2] * d[0] - n[0] * d[2],
                                         n[0] * d[1] - n[1] * d[0]};
        for (int a = 0; a < 3; ++a)
            v[a] += p.rotation * c[a] / p.radius;
    }
    // Divergence-free turbulence, RMS `turbulence` over the cube.
    if (mTurbulenceScale > 0.0) {
        const auto t = turbulent(x);
        for (int a = 0; a < 3; ++a)
            v[a] += mTurbulenceScale * t[a];
    }
    return v;
}

} // namespace nebula
