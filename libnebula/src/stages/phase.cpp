// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/phase.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/phase_table_vdb.h"
#include "nebula/physics/montecarlo.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace nebula {

namespace {

using detail::numberText;

/// A figure for a report, to @p digits significant digits.
std::string approx(double v, int digits = 3)
{
    std::ostringstream out;
    out.precision(digits);
    out << v;
    return out.str();
}

/// Wall-clock time since @p start, "12.34 s".
std::string secondsSince(std::chrono::steady_clock::time_point start)
{
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char text[32];
    std::snprintf(text, sizeof text, "%.2f s", s);
    return text;
}

/// The dust: the input's nebula:dust (or the defaults) with the options applied.
DustParams loadDust(const Run& run, const PhaseOptions& opts)
{
    DustParams base;
    if (!opts.input.empty()) {
        const auto grids = readGrids(opts.input, run);
        if (!grids.hasDust()) {
            run.warn(grids.source + " has no " + META_DUST + "; using the default dust");
        }
        base = grids.dust(run);
    }
    const auto dust = opts.applyDust(base);
    run.info("dust: albedo " + numberText(dust.albedo) + ", g " + numberText(dust.g) + ", phase " +
             toString(dust.phase) + (opts.input.empty() ? "" : " (from " + opts.input + ")"));
    return dust;
}

/// Whether the table also goes to a JSON file (not stdout).
bool jsonToFile(const PhaseOptions& opts)
{
    return !opts.json.empty() && opts.json != "-";
}

/// -o given, and not the same stream or file as --json.
void checkTableOutputs(const PhaseOptions& opts)
{
    const std::string& output = opts.output;
    if (output.empty()) {
        throw UsageError("-o/--output is required: the phase table VDB file, or - for "
                         "stdout (or --slab --tau T for a slab run)");
    }
    refuseBinaryToTerminal(output, "-o");
    if (opts.json == "-" && output == "-") {
        throw UsageError("--json - and -o - both write to stdout; give one a file name");
    }
    const auto canonical = [](const std::string& p) {
        return std::filesystem::weakly_canonical(std::filesystem::absolute(p));
    };
    if (jsonToFile(opts) && output != "-" && canonical(opts.json) == canonical(output)) {
        throw UsageError("--json " + opts.json + " and -o " + output +
                         " are the same file; give the JSON another name");
    }
}

/// The table's spec with --photons and --max-photons applied, validated.
PhaseTableSpec tableSpec(const PhaseOptions& opts)
{
    PhaseTableSpec spec = opts.table;
    if (opts.photons) spec.minPhotons = *opts.photons;
    // --photons above the default maximum raises the maximum, unless --max-photons is given.
    spec.maxPhotons = opts.maxPhotons.value_or(std::max(spec.maxPhotons, spec.minPhotons));
    spec.validate();
    return spec;
}

/// The table's photons, worst relative error and time, and a warning where it missed
/// --error.
void reportTable(const Run& run, const PhaseTable& table, const PhaseTableSpec& spec,
                 const std::string& seconds)
{
    std::uint64_t photons = 0;
    for (auto n : table.photons)
        photons += n;
    const double worst = table.worstRelativeError(spec.errorTMax);
    run.info("worst relative error of Phi (mu > 0, t <= " + numberText(spec.errorTMax) +
             "): " + approx(worst) + " (target " + numberText(spec.targetError) + "); " +
             std::to_string(photons) + " photons in all; " + seconds);
    if (!std::isfinite(worst)) {
        run.warn("some bins with mu > 0 and t <= " + numberText(spec.errorTMax) +
                 " have Phi = 0 (no scattered light), so their relative error is undefined; "
                 "each such row used --max-photons " +
                 std::to_string(spec.maxPhotons));
    } else if (worst > spec.targetError) {
        run.warn("worst relative error of Phi is " + approx(worst) +
                 " (mu > 0, t <= " + numberText(spec.errorTMax) + "), above --error " +
                 numberText(spec.targetError) + ": --max-photons " +
                 std::to_string(spec.maxPhotons) + " reached; raise it for a more accurate table");
    }
}

/// Writes @p text to @p out (stdout), checked.
void writeStdout(std::ostream& out, const std::string& text)
{
    out << text;
    out.flush();
    if (!out) throw Error("<stdout>: write failed");
}

/// The table to -o and --json: both outputs or neither (each is written and fsynced before
/// either replaces its target); "-" to stdout.
void writeTableOutputs(const PhaseOptions& opts, const Run& run, const PhaseTable& table,
                       const DustParams& dust, std::ostream& out)
{
    const std::string& output = opts.output;
    const std::string jsonText = opts.json.empty() ? std::string() : table.toJson();
    GridSet grids; // only the table: the input's grids are not passed through
    grids.source = output;
    addPhaseTable(grids, table);
    grids.setDust(dust);
    if (output == "-") {
        writeGrids(output, std::move(grids), run);
        if (jsonToFile(opts)) {
            AtomicFile jsonFile(opts.json);
            jsonFile.stream() << jsonText;
            jsonFile.commit();
        }
    } else {
        AtomicFile vdbFile(output);
        writeGrids(vdbFile, std::move(grids), run.tool(), run.command());
        std::optional<AtomicFile> jsonFile;
        if (jsonToFile(opts)) {
            jsonFile.emplace(opts.json);
            jsonFile->stream() << jsonText;
            commitAll({&vdbFile, &*jsonFile});
        } else {
            vdbFile.commit();
        }
        run.info("wrote " + output + (jsonFile ? " and " + opts.json : std::string()));
    }
    if (opts.json == "-") writeStdout(out, jsonText);
}

/// The Monte Carlo settings of a slab run, its options checked.
McSettings slabSettings(const PhaseOptions& opts)
{
    const double tau = *opts.tau;
    if (!(tau > 0.0) || !std::isfinite(tau)) {
        throw UsageError("--tau must be a finite number > 0, got " + numberText(tau));
    }
    if (!(opts.mu0 > 0.0 && opts.mu0 <= 1.0)) {
        throw UsageError("--mu0 must be in (0, 1], got " + numberText(opts.mu0));
    }
    if (opts.bins < 1 || opts.bins > 100000) {
        throw UsageError("--bins must be in [1, 100000], got " + std::to_string(opts.bins));
    }
    McSettings set;
    set.photons = opts.photons.value_or(opts.slabPhotons);
    if (set.photons == 0 || set.photons > MAX_SLAB_PHOTONS) {
        throw UsageError("--photons must be in [1, 1e10] for --slab (1e6, the default, "
                         "takes about a second), got " +
                         std::to_string(set.photons));
    }
    set.seed = opts.table.seed;
    set.muBins = 2 * opts.bins;
    set.estimator = opts.estimator == "analog" ? McEstimator::Analog : McEstimator::NextEvent;
    return set;
}

nlohmann::ordered_json estimateJson(const Estimate& e)
{
    return {{"value", e.mean}, {"error", e.error}};
}

/// A slab run's result as nebphase --slab prints it.
nlohmann::ordered_json slabJson(const PhaseOptions& opts, const ScatteringMedium& medium,
                                const McSettings& set, const McResult& r)
{
    using Json = nlohmann::ordered_json;
    Json j;
    j["slab"] = {{"tau", *opts.tau},
                 {"mu0", opts.mu0},
                 {"albedo", medium.albedo},
                 {"g", medium.g},
                 {"phase", toString(medium.phase)}};
    j["photons"] = r.photons;
    j["events"] = r.events;
    j["estimator"] = opts.estimator;
    j["seed"] = set.seed;
    j["reflected"] = {{"diffuse", estimateJson(r.reflected)}};
    j["transmitted"] = {{"diffuse", estimateJson(r.transmitted)},
                        {"direct", estimateJson(r.direct)}};
    j["absorbed"] = estimateJson(r.absorbed);
    j["roulette"] = estimateJson(r.roulette);
    j["balance"] = estimateJson(r.balance);
    // Bins by the cosine to the outward normal of the face the light leaves: McResult's
    // reflected bins (mu_z < 0) are mirrored, so both lists run from mu = 0 to 1.
    const int half = opts.bins;
    const auto bin = [&](double lo, double hi, const Estimate& e) {
        return Json{{"mu_lo", lo}, {"mu_hi", hi}, {"per_sr", e.mean}, {"error", e.error}};
    };
    Json reflected = Json::array(), transmitted = Json::array();
    for (int k = half - 1; k >= 0; --k) {
        reflected.push_back(
            bin(std::fabs(r.muEdges[k + 1]), std::fabs(r.muEdges[k]), r.perSteradian[k]));
    }
    for (int k = half; k < 2 * half; ++k) {
        transmitted.push_back(bin(r.muEdges[k], r.muEdges[k + 1], r.perSteradian[k]));
    }
    j["angular"] = {{"reflected", reflected}, {"transmitted", transmitted}};
    return j;
}

} // namespace

void writePhaseTable(const PhaseOptions& opts, const Run& run, std::ostream& out)
{
    checkTableOutputs(opts);
    const PhaseTableSpec spec = tableSpec(opts);
    const auto dust = loadDust(run, opts);
    // Fail before the Monte Carlo, not after it, on an output that cannot be written.
    if (opts.output != "-") checkOutputWritable(opts.output, "phase table");
    if (jsonToFile(opts)) checkOutputWritable(opts.json, "JSON table");
    run.info("table: " + std::to_string(spec.tCount) + " t values " + numberText(spec.tMin) +
             " .. " + numberText(spec.tMax) + " (log), " + std::to_string(spec.muBins) +
             " mu bins, " + std::to_string(spec.minPhotons) + " .. " +
             std::to_string(spec.maxPhotons) + " photons per t, seed " + std::to_string(spec.seed));

    const auto start = std::chrono::steady_clock::now();
    PhaseTable table;
    {
        Progress bar(run, "nebphase", std::uint64_t(spec.tCount));
        int shown = 0;
        table = buildPhaseTable(dust, spec, [&](int rows) {
            bar.add(std::uint64_t(rows - shown));
            shown = rows;
        });
    }
    reportTable(run, table, spec, secondsSince(start));
    writeTableOutputs(opts, run, table, dust, out);
}

void writeSlabJson(const PhaseOptions& opts, const Run& run, std::ostream& out)
{
    const McSettings set = slabSettings(opts);
    const auto dust = loadDust(run, opts);
    const ScatteringMedium& medium = dust; // the dust's scattering

    const auto start = std::chrono::steady_clock::now();
    McTally tally;
    {
        Progress bar(run, "nebphase", set.photons);
        tally = simulateSlab(medium, *opts.tau, opts.mu0, set, 0, set.photons,
                             [&](std::uint64_t n) { bar.add(n); });
    }
    const auto r = summarize(tally, set.muBins);
    run.info(std::to_string(r.photons) + " photons, " + std::to_string(r.events) +
             " interactions, " + secondsSince(start));
    writeStdout(out, slabJson(opts, medium, set, r).dump(2) + "\n");
}

} // namespace nebula
