// SPDX-License-Identifier: Apache-2.0
/// @file phase_table.cpp
/// The effective phase-function table (DESIGN §4); see phase_table.h.

#include "nebula/physics/phase_table.h"

#include "nebula/core/format.h"

#include "nebula/core/error.h"
#include "nebula/core/memory.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace nebula {

using detail::numberText;

void PhaseTableSpec::validate() const
{
    if (!(tMin > 0.0) || !std::isfinite(tMin)) {
        throw UsageError("--t-min must be a finite number > 0, got " + numberText(tMin));
    }
    if (!(tMax > tMin) || !std::isfinite(tMax)) {
        throw UsageError("--t-max must be finite and greater than --t-min (" + numberText(tMin) +
                         "), got " + numberText(tMax));
    }
    if (tCount < 2) throw UsageError("--t-count must be >= 2, got " + std::to_string(tCount));
    if (muBins < 2 || muBins % 2 != 0) {
        throw UsageError("--mu-bins must be even and >= 2, got " + std::to_string(muBins));
    }
    if (minPhotons == 0) throw UsageError("--photons must be > 0");
    if (maxPhotons < minPhotons) {
        throw UsageError("--max-photons (" + std::to_string(maxPhotons) +
                         ") must be >= --photons (" + std::to_string(minPhotons) + ")");
    }
    if (!(targetError > 0.0) || !std::isfinite(targetError)) {
        throw UsageError("--error must be a finite number > 0, got " + numberText(targetError));
    }
    // Work bounds: photons per t, and in all (README, Failure behaviour).
    if (maxPhotons > MAX_PHOTONS_PER_T) {
        throw UsageError("--photons / --max-photons: " + std::to_string(maxPhotons) +
                         " photons per t; at most " + numberText(double(MAX_PHOTONS_PER_T)) +
                         " (the default is at most 4194304, about a second per t on 2 cores)");
    }
    const double total = double(tCount) * double(maxPhotons);
    if (total > MAX_TABLE_PHOTONS) {
        throw UsageError("--t-count " + std::to_string(tCount) + " x " +
                         std::to_string(maxPhotons) + " photons per t is " + numberText(total) +
                         " photons; at most " + numberText(MAX_TABLE_PHOTONS) +
                         " (the default table: 64 x 4194304 = 2.7e+08)");
    }
    // phi, error and single, and the three grids they are written as.
    requireMemory(double(tCount) * double(muBins) * 6.0 * sizeof(float),
                  "--t-count " + std::to_string(tCount) + " x --mu-bins " + std::to_string(muBins) +
                      ": the phase table");
}

double PhaseTable::t(int j) const
{
    if (j == tCount - 1) return tMax;
    return tMin * std::pow(tMax / tMin, double(j) / (tCount - 1));
}

double PhaseTable::worstRelativeError(double tLimit) const
{
    double worst = 0.0;
    for (int j = 0; j < tCount; ++j) {
        if (t(j) > tLimit * (1.0 + 1e-12)) continue;
        for (int i = muBins / 2; i < muBins; ++i) {
            const std::size_t k = std::size_t(j) * muBins + i;
            // A bin with Phi = 0 and no error (albedo 0) is exact.
            const double rel = phi[k] > 0.0 ? error[k] / phi[k] : (error[k] > 0.0 ? INFINITY : 0.0);
            worst = std::max(worst, rel);
        }
    }
    return worst;
}

void PhaseTable::validate(const std::string& source) const
{
    const std::string where = source + ": phase table: ";
    if (!(tMin > 0.0 && tMax > tMin && std::isfinite(tMax))) {
        throw Error(where + "t range must satisfy 0 < t_min < t_max, got t_min = " +
                    numberText(tMin) + ", t_max = " + numberText(tMax));
    }
    if (tCount < 2 || muBins < 2 || muBins % 2 != 0) {
        throw Error(where + "needs t_count >= 2 and an even mu_bins >= 2, got t_count = " +
                    std::to_string(tCount) + ", mu_bins = " + std::to_string(muBins));
    }
    const std::size_t n = std::size_t(tCount) * muBins;
    if (phi.size() != n || error.size() != n || photons.size() != std::size_t(tCount) ||
        (!single.empty() && single.size() != n)) {
        throw Error(where + "expected " + std::to_string(n) + " values (" + std::to_string(muBins) +
                    " mu bins x " + std::to_string(tCount) + " t values), got " +
                    std::to_string(phi.size()));
    }
    for (std::size_t k = 0; k < n; ++k) {
        if (!(phi[k] >= 0.0f) || !std::isfinite(phi[k])) {
            throw Error(where + "value " + std::to_string(k) + " is " + numberText(phi[k]) +
                        "; Phi must be finite and >= 0");
        }
    }
    try {
        medium.validate();
    } catch (const UsageError& e) {
        throw Error(where + e.what());
    }
}

std::vector<float> PhaseTable::gain() const
{
    if (single.size() != phi.size()) {
        throw Error("phase table: no single-scattering part (phase.single); rebuild it with "
                    "this version of nebphase");
    }
    std::vector<float> g(phi.size());
    for (std::size_t k = 0; k < phi.size(); ++k) {
        g[k] = single[k] > 0.0f ? phi[k] / single[k] : 1.0f;
    }
    return g;
}

double PhaseTable::eval(double tt, double mu) const
{
    const PhaseLookup l(*this);
    return l.lookup(l.locateLogT(std::log(tt)), l.locateMu(mu));
}

std::string PhaseTable::toJson() const
{
    nlohmann::ordered_json j;
    j["table"] = "nebula effective phase function Phi(t, mu) [1/sr per unit optical depth]";
    j["albedo"] = medium.albedo;
    j["g"] = medium.g;
    j["phase"] = toString(medium.phase);
    j["t_min"] = tMin;
    j["t_max"] = tMax;
    j["t_count"] = tCount;
    j["t_spacing"] = "log";
    j["mu_bins"] = muBins;
    j["mu_binning"] = "equal-cos over [-1, 1]; bin i has centre -1 + (i + 0.5) * 2 / mu_bins";
    j["seed"] = seed;
    j["target_error"] = targetError;
    j["error_t_max"] = errorTMax;
    std::vector<double> mus;
    for (int i = 0; i < muBins; ++i)
        mus.push_back(muCentre(i));
    j["mu"] = mus;
    auto rows = nlohmann::ordered_json::array();
    for (int r = 0; r < tCount; ++r) {
        nlohmann::ordered_json row;
        row["t"] = t(r);
        row["photons"] = photons[r];
        std::vector<float> p(phi.begin() + std::ptrdiff_t(r) * muBins,
                             phi.begin() + std::ptrdiff_t(r + 1) * muBins);
        std::vector<float> e(error.begin() + std::ptrdiff_t(r) * muBins,
                             error.begin() + std::ptrdiff_t(r + 1) * muBins);
        row["phi"] = p;
        row["error"] = e;
        if (!single.empty()) {
            row["single"] = std::vector<float>(single.begin() + std::ptrdiff_t(r) * muBins,
                                               single.begin() + std::ptrdiff_t(r + 1) * muBins);
        }
        rows.push_back(row);
    }
    j["rows"] = rows;
    return j.dump(1) + "\n";
}

PhaseTable buildPhaseTable(const ScatteringMedium& medium, const PhaseTableSpec& spec,
                           const std::function<void(int)>& progress)
{
    medium.validate();
    spec.validate();
    PhaseTable table;
    table.medium = medium;
    table.tMin = spec.tMin;
    table.tMax = spec.tMax;
    table.tCount = spec.tCount;
    table.muBins = spec.muBins;
    table.seed = spec.seed;
    table.targetError = spec.targetError;
    table.errorTMax = spec.errorTMax;
    table.photons.resize(spec.tCount);
    table.phi.resize(std::size_t(spec.tCount) * spec.muBins);
    table.error.resize(table.phi.size());
    table.single.resize(table.phi.size());

    McSettings set;
    set.muBins = spec.muBins;
    set.seed = spec.seed;
    set.estimator = McEstimator::NextEvent;
    constexpr std::uint64_t BATCH = 1024;
    for (int j = 0; j < spec.tCount; ++j) {
        const double t = table.t(j);
        // Each row has its own photon streams: row j's photon i uses stream j * 2^40 + i.
        const std::uint64_t base = std::uint64_t(j) << 40;
        std::uint64_t n = spec.minPhotons;
        McTally tally = simulateCube(medium, t, set, base, n);
        for (;;) {
            const McResult r = summarize(tally, spec.muBins);
            double worst = 0.0;
            if (t <= spec.errorTMax * (1.0 + 1e-12)) {
                for (int i = spec.muBins / 2; i < spec.muBins; ++i) {
                    const auto& e = r.perSteradian[i];
                    worst = std::max(worst, e.mean > 0.0    ? e.error / e.mean
                                            : e.error > 0.0 ? INFINITY
                                                            : 0.0);
                }
            }
            if (worst <= spec.targetError || n >= spec.maxPhotons) {
                for (int i = 0; i < spec.muBins; ++i) {
                    table.phi[std::size_t(j) * spec.muBins + i] = float(r.perSteradian[i].mean / t);
                    table.error[std::size_t(j) * spec.muBins + i] =
                        float(r.perSteradian[i].error / t);
                    table.single[std::size_t(j) * spec.muBins + i] =
                        float(r.singlePerSteradian[i].mean / t);
                }
                table.photons[j] = n;
                break;
            }
            // Error ~ 1/sqrt(N): aim 20% past the estimate, in whole batches.
            const double want = double(n) * std::pow(worst / spec.targetError, 2) * 1.2;
            std::uint64_t next = std::min<std::uint64_t>(
                spec.maxPhotons,
                std::max<std::uint64_t>(n + BATCH, std::uint64_t(std::ceil(want / BATCH)) * BATCH));
            tally.merge(simulateCube(medium, t, set, base + n, next - n));
            n = next;
        }
        if (progress) progress(j + 1);
    }
    return table;
}

PhaseLookup::PhaseLookup(const PhaseTable& t)
    : table(&t), logTMin(std::log(t.tMin)),
      invDLogT((t.tCount - 1) / (std::log(t.tMax) - std::log(t.tMin)))
{}

PhaseLookup::Pos PhaseLookup::locateLogT(double logT) const
{
    const double x = (logT - logTMin) * invDLogT;
    const int n = table->tCount;
    if (!(x > 0.0)) return {0, 0.0f};
    if (x >= n - 1) return {n - 2, 1.0f};
    const int i = static_cast<int>(x);
    return {std::min(i, n - 2), float(x - i)};
}

PhaseLookup::Pos PhaseLookup::locateMu(double mu) const
{
    // Bin centres at -1 + (i + 0.5) h: x = (mu + 1)/h - 0.5 in centre units.
    const int n = table->muBins;
    const double x = (mu + 1.0) * 0.5 * n - 0.5;
    if (!(x > 0.0)) return {0, 0.0f};
    if (x >= n - 1) return {n - 2, 1.0f};
    const int i = static_cast<int>(x);
    return {std::min(i, n - 2), float(x - i)};
}

} // namespace nebula
