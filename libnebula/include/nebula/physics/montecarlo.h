// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file montecarlo.h
/// The Monte Carlo transport core (DESIGN §4): weighted photon packets in the
/// Hanrahan-Krueger / MCML style (papers/001 §5.2, appendix A.2) in two geometries, a
/// plane-parallel slab (to check the core against published results) and the cubic voxel
/// of nebphase's effective phase function.
///
/// Units: every length is optical (extinction coefficient 1), so a slab of optical depth
/// tau is z in [0, tau] and a voxel of optical edge t is [0, t]^3.
///
/// Tallies are fractions of the entering power. Exit directions are binned by their
/// z component mu_z (the slab normal / the voxel's entry direction), in equal-cos bins
/// over [-1, 1], so every bin has solid angle 2 pi (2 / bins) after integrating over
/// azimuth. Each photon has its own PCG32 stream (photon index, seed), and photons are
/// summed with a deterministic reduction, so results do not depend on the thread count.

#include "nebula/physics/dust.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace nebula {

/// How scattered light is counted.
enum class McEstimator {
    /// MCML: free paths -ln(u), weight times the albedo at each interaction, the exit
    /// direction binned with the photon's weight when it leaves. Every photon's weight is
    /// accounted for exactly: direct + reflected + transmitted + absorbed - roulette = 1 to
    /// rounding, photon by photon.
    Analog,
    /// Expected-value estimation: the first interaction is forced inside the medium (the
    /// unscattered fraction exp(-s) is then exact and noise-free); at every interaction the
    /// probability of leaving directly into each mu bin, a * int_bin p e^-tau_exit dOmega,
    /// is added, estimated by one random direction per bin and the direction the photon
    /// scatters into, combined by multiple importance sampling (balance heuristic); the
    /// photon then continues with a forced interaction. Far less noise in thin media and in
    /// sparse bins, and robust to forward-peaked phase functions; unbiased, balanced in
    /// expectation (not photon by photon).
    NextEvent,
};

/// Monte Carlo run parameters.
struct McSettings
{
    std::uint64_t photons = 100000;
    std::uint64_t seed = 1;
    int muBins = 40; ///< equal-cos bins of mu_z over [-1, 1]; even, so mu = 0 is an edge
    McEstimator estimator = McEstimator::NextEvent;
    /// Russian roulette below this fraction of the weight at the first interaction: the
    /// packet survives with probability w / w_r and then carries w_r (unbiased).
    double rouletteWeight = 0.01;
    /// NextEvent only: exit cosines mu_z at which the azimuth-averaged power per steradian
    /// dF/dOmega is also estimated exactly (no binning), e.g. to compare with tabulated
    /// reflection functions.
    std::vector<double> muPoints;

    /// Throws UsageError on zero photons, an odd or non-positive bin count, a roulette
    /// weight outside (0, 1), or a mu point outside [-1, 1].
    void validate() const;
};

/// A Monte Carlo mean and its standard error (standard deviation of the mean).
struct Estimate
{
    double mean = 0.0;
    double error = 0.0;
};

/// Running sums over photons; mergeable, so a run can be extended with more photons.
struct McTally
{
    std::uint64_t photons = 0;
    /// Per-photon totals, each as (sum, sum of squares): direct (unscattered), reflected
    /// (scattered, leaving with mu_z < 0), transmitted (scattered, mu_z > 0), absorbed,
    /// roulette (net weight roulette created; zero in expectation), balance (the photon's
    /// direct + reflected + transmitted + absorbed - roulette).
    enum Total { DIRECT, REFLECTED, TRANSMITTED, ABSORBED, ROULETTE, BALANCE, TOTALS };
    std::vector<double> sum, sumSq;             ///< TOTALS entries
    std::vector<double> binSum, binSumSq;       ///< per mu bin: power fraction
    std::vector<double> singleSum, singleSumSq; ///< per mu bin: of it, scattered exactly once
    std::vector<double> pointSum, pointSumSq;   ///< per mu point: dF/dOmega
    std::uint64_t events = 0;                   ///< interactions simulated

    McTally() = default;
    McTally(int muBins, std::size_t muPoints);
    /// Adds @p other's photons (same bins and points).
    void merge(const McTally& other);
};

/// A finished run, per entering photon.
struct McResult
{
    std::uint64_t photons = 0;
    std::uint64_t events = 0;
    Estimate direct;      ///< unscattered transmission
    Estimate reflected;   ///< diffuse (scattered) power leaving with mu_z < 0
    Estimate transmitted; ///< diffuse (scattered) power leaving with mu_z > 0
    Estimate absorbed;
    Estimate roulette;
    Estimate balance;                   ///< direct + reflected + transmitted + absorbed - roulette
    std::vector<double> muEdges;        ///< muBins + 1 bin edges, -1 .. 1
    std::vector<Estimate> perSteradian; ///< per bin: scattered power per sr, dF/dOmega
    std::vector<Estimate> singlePerSteradian; ///< the part scattered exactly once
    std::vector<Estimate> points;             ///< per McSettings::muPoints: dF/dOmega
};

/// Turns sums into means and standard errors.
McResult summarize(const McTally& tally, int muBins);

/// Optional progress report: photons finished so far (called from worker threads).
using McProgress = std::function<void(std::uint64_t)>;

/// Plane-parallel slab of optical depth @p tau, lit by a collimated beam entering the
/// z = 0 face with direction cosine @p mu0 > 0 to the normal. Photons
/// [first, first + count) of @p settings' seed.
McTally simulateSlab(const ScatteringMedium& medium, double tau, double mu0,
                     const McSettings& settings, std::uint64_t first, std::uint64_t count,
                     const McProgress& progress = {});

/// Cube of optical edge @p t (DESIGN §4): photons enter the z = 0 face uniformly over it,
/// travelling along +z; mu_z is then the cosine between exit and entry directions.
McTally simulateCube(const ScatteringMedium& medium, double t, const McSettings& settings,
                     std::uint64_t first, std::uint64_t count, const McProgress& progress = {});

/// Convenience: the whole run of settings.photons photons, summarized.
McResult runSlab(const ScatteringMedium& medium, double tau, double mu0,
                 const McSettings& settings);
McResult runCube(const ScatteringMedium& medium, double t, const McSettings& settings);

} // namespace nebula
