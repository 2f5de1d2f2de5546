// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file phase.h
/// nebphase's entry points: the effective phase function Phi(t, mu) of a dust voxel as a
/// table (DESIGN §4), and plane-parallel slab runs of the same Monte Carlo core.

#include "nebula/core/run.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/phase_table.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>

namespace nebula {

/// The most photons of a --slab run (a work bound, README "Failure behaviour").
inline constexpr std::uint64_t MAX_SLAB_PHOTONS = 10000000000ULL;

/// nebphase's options; the table's defaults live in PhaseTableSpec.
struct PhaseOptions
{
    PhaseTableSpec table;
    std::string input;                    ///< -i: a VDB whose nebula:dust is the dust; "": none
    std::string output;                   ///< -o: the table VDB, "-" stdout (table mode)
    std::string json;                     ///< --json FILE: the table as JSON too ("-": stdout)
    std::optional<std::uint64_t> photons; ///< per t row at least (table) / in all (slab)
    std::optional<std::uint64_t> maxPhotons;
    bool slab = false;
    std::optional<double> tau; ///< slab optical depth
    double mu0 = 1.0;          ///< cosine of the incident beam to the slab normal
    int bins = 20;             ///< slab: equal-cos bins per hemisphere
    std::string estimator = "next-event";
    std::uint64_t slabPhotons = 1000000;
    /// The dust: the input's nebula:dust (or the defaults) with the command line's dust
    /// options applied and validated (DustOptions::apply()).
    std::function<DustParams(const DustParams&)> applyDust = [](const DustParams& d) { return d; };
};

/// Table mode: Phi(t, mu) to opts.output (the phase and phase.error grids and nebula:dust;
/// the input's grids are not passed through) and, with opts.json, the table as JSON, both
/// or neither; "-" writes to stdout, the JSON to @p out. Throws UsageError for missing or
/// conflicting outputs and bad table options, before any work.
void writePhaseTable(const PhaseOptions& opts, const Run& run, std::ostream& out);

/// Slab mode: the Monte Carlo core in a plane-parallel slab of optical depth opts.tau lit
/// at cosine opts.mu0; its reflection, transmission, absorption and balance as JSON to @p out.
/// Throws UsageError for options out of range.
void writeSlabJson(const PhaseOptions& opts, const Run& run, std::ostream& out);

} // namespace nebula
