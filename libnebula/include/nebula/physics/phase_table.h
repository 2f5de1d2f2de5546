// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file phase_table.h
/// The effective phase-function table Phi(t, mu) of nebphase (DESIGN §4): built with the
/// Monte Carlo core in a cubic voxel, evaluated by nebrender. No OpenVDB here; the grid
/// form is in phase_table_vdb.h.

#include "nebula/physics/montecarlo.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nebula {

/// Work bounds of a table (PhaseTableSpec::validate()): photons per t, and in all.
inline constexpr std::uint64_t MAX_PHOTONS_PER_T = 1000000000;
inline constexpr double MAX_TABLE_PHOTONS = 1e11;

/// What to tabulate and how accurately.
struct PhaseTableSpec
{
    double tMin = 1e-4; ///< smallest voxel optical thickness
    double tMax = 1e3;  ///< largest
    int tCount = 64;    ///< log-spaced t values, tMin and tMax included
    int muBins = 128;   ///< equal-cos bins over [-1, 1]
    std::uint64_t seed = 1;
    std::uint64_t minPhotons = 16384;   ///< photons per t at least
    std::uint64_t maxPhotons = 4194304; ///< photons per t at most
    /// Photons are added (deterministically) until the relative standard error of every bin
    /// with mu > 0 is below this, for every t <= errorTMax (or maxPhotons is reached).
    double targetError = 0.01;
    double errorTMax = 10.0;

    /// Throws UsageError naming the option (--t-min, --t-max, --t-count, --mu-bins,
    /// --photons, --max-photons, --error) on invalid values, and (requireMemory()) if the
    /// table of tCount x muBins bins would not fit in memory.
    void validate() const;
};

/// Phi(t, mu) [1/sr per unit optical depth] = power scattered out of the voxel per sr in
/// direction mu (cosine to the entry direction) per entering photon, divided by t; the
/// unscattered light is not included. Phi -> albedo * p(mu) as t -> 0.
struct PhaseTable
{
    ScatteringMedium medium;
    double tMin = 0.0, tMax = 0.0;
    int tCount = 0, muBins = 0;
    std::uint64_t seed = 0;
    double targetError = 0.0, errorTMax = 0.0;
    std::vector<std::uint64_t> photons; ///< per t
    std::vector<float> phi;             ///< [j * muBins + i]: t index j, mu bin i
    std::vector<float> error;           ///< standard error of phi, same layout
    /// The part of phi scattered exactly once (same layout; empty if the table has none):
    /// the single-scattering Phi_1(t, mu), which includes the voxel's own extinction of the
    /// light on its way in and out. Phi / Phi_1 is the voxel's multiple-scattering gain.
    std::vector<float> single;

    /// t of row j (log-spaced).
    double t(int j) const;
    /// Centre cosine of mu bin i.
    double muCentre(int i) const { return -1.0 + (i + 0.5) * 2.0 / muBins; }
    float value(int j, int i) const { return phi[std::size_t(j) * muBins + i]; }
    /// Multiple-scattering gain Phi / Phi_1 per cell (1 where Phi_1 is 0), for
    /// PhaseUse::Gain. Throws Error if the table has no single-scattering part.
    std::vector<float> gain() const;
    /// Phi at (t, mu): linear in log t between rows and in mu between bin centres; mu is
    /// clamped to the outer bin centres, t below tMin uses row 0 (the thin limit) and t above
    /// tMax uses the last row.
    double eval(double t, double mu) const;
    /// Largest relative standard error over the bins with mu > 0 of rows with t <= tLimit.
    double worstRelativeError(double tLimit) const;
    /// Throws Error (prefixed by @p source) unless sizes, axes and values are consistent.
    void validate(const std::string& source) const;
    /// The table as JSON: axes, medium, photons, and per t the rows of Phi and its error.
    std::string toJson() const;
};

/// Runs the Monte Carlo for every t (NextEvent estimator, DESIGN §4). @p progress is called
/// with the number of t rows finished.
PhaseTable buildPhaseTable(const ScatteringMedium& medium, const PhaseTableSpec& spec,
                           const std::function<void(int)>& progress = {});

/// Fast evaluation inside nebrender's sample loop: per sample, locate log t once per
/// channel (locateT) and mu once per star (locateMu), then lookup() is a bilinear blend.
struct PhaseLookup
{
    const PhaseTable* table = nullptr;
    double logTMin = 0.0, invDLogT = 0.0;
    struct Pos
    {
        int i0;
        float w;
    };
    explicit PhaseLookup(const PhaseTable& t);
    Pos locateLogT(double logT) const;
    Pos locateMu(double mu) const;
    double lookup(Pos tp, Pos mp) const
    {
        const float* r0 = &table->phi[std::size_t(tp.i0) * table->muBins];
        const float* r1 = r0 + table->muBins;
        const float a = r0[mp.i0] + mp.w * (r0[mp.i0 + 1] - r0[mp.i0]);
        const float b = r1[mp.i0] + mp.w * (r1[mp.i0 + 1] - r1[mp.i0]);
        return a + tp.w * (b - a);
    }
};

} // namespace nebula
