// SPDX-License-Identifier: Apache-2.0
// nebphase - the effective phase function Phi(t, mu) of a dust voxel by Monte Carlo
// (DESIGN §4), and plane-parallel slab runs of the same Monte Carlo core.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/phase_table_vdb.h"
#include "nebula/physics/montecarlo.h"
#include "nebula/physics/phase_table.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

/// The most photons of a --slab run (a work bound, README "Failure behaviour").
constexpr std::uint64_t MAX_SLAB_PHOTONS = 10000000000ULL;

namespace {

using nebula::detail::numberText;

/// nebphase's own options; the table's defaults live in PhaseTableSpec.
struct PhaseOptions
{
    nebula::PhaseTableSpec table;
    std::string json;                     ///< --json FILE: the table as JSON too
    std::optional<std::uint64_t> photons; ///< per t row at least (table) / in all (slab)
    std::optional<std::uint64_t> maxPhotons;
    bool slab = false;
    std::optional<double> tau; ///< slab optical depth
    double mu0 = 1.0;          ///< cosine of the incident beam to the slab normal
    int bins = 20;             ///< slab: equal-cos bins per hemisphere
    std::string estimator = "next-event";
    std::uint64_t slabPhotons = 1000000;
};

/// A figure for a report, to @p digits significant digits.
std::string approx(double v, int digits = 3)
{
    std::ostringstream out;
    out.precision(digits);
    out << v;
    return out.str();
}

/// The dust: the input's nebula:dust (or the defaults) with the options applied.
nebula::DustParams loadDust(const nebula::Run& run, const std::string& input,
                            const nebula::DustOptions& dustOpts)
{
    nebula::DustParams base;
    if (!input.empty()) {
        const auto grids = nebula::readGrids(input, run);
        if (!grids.hasDust()) {
            run.warn(grids.source + " has no " + nebula::META_DUST + "; using the default dust");
        }
        base = grids.dust(run);
    }
    const auto dust = dustOpts.apply(base);
    run.info("dust: albedo " + numberText(dust.albedo) + ", g " + numberText(dust.g) + ", phase " +
             nebula::toString(dust.phase) + (input.empty() ? "" : " (from " + input + ")"));
    return dust;
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

/// Table mode: Phi(t, mu) to a VDB (and JSON), DESIGN §4.
void tableMode(const nebula::Run& run, const nebula::CommonOptions& common,
               const nebula::DustOptions& dustOpts, PhaseOptions& opts)
{
    const std::string& output = common.output;
    if (output.empty()) {
        throw nebula::UsageError("-o/--output is required: the phase table VDB file, or - for "
                                 "stdout (or --slab --tau T for a slab run)");
    }
    nebula::refuseBinaryToTerminal(output, "-o");
    if (opts.json == "-" && output == "-") {
        throw nebula::UsageError("--json - and -o - both write to stdout; give one a file name");
    }
    const auto canonical = [](const std::string& p) {
        return std::filesystem::weakly_canonical(std::filesystem::absolute(p));
    };
    if (!opts.json.empty() && opts.json != "-" && output != "-" &&
        canonical(opts.json) == canonical(output)) {
        throw nebula::UsageError("--json " + opts.json + " and -o " + output +
                                 " are the same file; give the JSON another name");
    }
    auto& spec = opts.table;
    if (opts.photons) spec.minPhotons = *opts.photons;
    // --photons above the default maximum raises the maximum, unless --max-photons is given.
    spec.maxPhotons = opts.maxPhotons.value_or(std::max(spec.maxPhotons, spec.minPhotons));
    spec.validate();

    const auto dust = loadDust(run, common.input, dustOpts);
    // Fail before the Monte Carlo, not after it, on an output that cannot be written.
    if (output != "-") nebula::checkOutputWritable(output, "phase table");
    if (!opts.json.empty() && opts.json != "-") {
        nebula::checkOutputWritable(opts.json, "JSON table");
    }
    run.info("table: " + std::to_string(spec.tCount) + " t values " + numberText(spec.tMin) +
             " .. " + numberText(spec.tMax) + " (log), " + std::to_string(spec.muBins) +
             " mu bins, " + std::to_string(spec.minPhotons) + " .. " +
             std::to_string(spec.maxPhotons) + " photons per t, seed " + std::to_string(spec.seed));

    const auto start = std::chrono::steady_clock::now();
    nebula::PhaseTable table;
    {
        nebula::Progress bar(run, "nebphase", std::uint64_t(spec.tCount));
        int shown = 0;
        table = nebula::buildPhaseTable(dust, spec, [&](int rows) {
            bar.add(std::uint64_t(rows - shown));
            shown = rows;
        });
    }
    const std::string seconds = secondsSince(start);

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

    // Both outputs or neither: each is written and fsynced before either replaces its target.
    const std::string jsonText = opts.json.empty() ? std::string() : table.toJson();
    nebula::GridSet grids; // only the table: the input's grids are not passed through
    grids.source = output;
    nebula::addPhaseTable(grids, table);
    grids.setDust(dust);
    if (output == "-") {
        nebula::writeGrids(output, std::move(grids), run);
        if (!opts.json.empty() && opts.json != "-") {
            nebula::AtomicFile jsonFile(opts.json);
            jsonFile.stream() << jsonText;
            jsonFile.commit();
        }
    } else {
        nebula::AtomicFile vdbFile(output);
        nebula::writeGrids(vdbFile, std::move(grids), run.tool(), run.command());
        std::optional<nebula::AtomicFile> jsonFile;
        if (!opts.json.empty() && opts.json != "-") {
            jsonFile.emplace(opts.json);
            jsonFile->stream() << jsonText;
            nebula::commitAll({&vdbFile, &*jsonFile});
        } else {
            vdbFile.commit();
        }
        run.info("wrote " + output + (jsonFile ? " and " + opts.json : std::string()));
    }
    if (opts.json == "-") {
        std::cout << jsonText;
        std::cout.flush();
        if (!std::cout) throw nebula::Error("<stdout>: write failed");
    }
}

nlohmann::ordered_json estimateJson(const nebula::Estimate& e)
{
    return {{"value", e.mean}, {"error", e.error}};
}

/// Slab mode: the Monte Carlo core in a plane-parallel slab, JSON on stdout.
void slabMode(const nebula::Run& run, const nebula::CommonOptions& common,
              const nebula::DustOptions& dustOpts, const PhaseOptions& opts)
{
    const double tau = *opts.tau;
    if (!(tau > 0.0) || !std::isfinite(tau)) {
        throw nebula::UsageError("--tau must be a finite number > 0, got " + numberText(tau));
    }
    if (!(opts.mu0 > 0.0 && opts.mu0 <= 1.0)) {
        throw nebula::UsageError("--mu0 must be in (0, 1], got " + numberText(opts.mu0));
    }
    if (opts.bins < 1 || opts.bins > 100000) {
        throw nebula::UsageError("--bins must be in [1, 100000], got " + std::to_string(opts.bins));
    }
    nebula::McSettings set;
    set.photons = opts.photons.value_or(opts.slabPhotons);
    if (set.photons == 0 || set.photons > MAX_SLAB_PHOTONS) {
        throw nebula::UsageError("--photons must be in [1, 1e10] for --slab (1e6, the default, "
                                 "takes about a second), got " +
                                 std::to_string(set.photons));
    }
    set.seed = opts.table.seed;
    set.muBins = 2 * opts.bins;
    set.estimator =
        opts.estimator == "analog" ? nebula::McEstimator::Analog : nebula::McEstimator::NextEvent;
    const auto dust = loadDust(run, common.input, dustOpts);
    const nebula::ScatteringMedium& medium = dust; // the dust's scattering

    const auto start = std::chrono::steady_clock::now();
    nebula::McTally tally;
    {
        nebula::Progress bar(run, "nebphase", set.photons);
        tally = nebula::simulateSlab(medium, tau, opts.mu0, set, 0, set.photons,
                                     [&](std::uint64_t n) { bar.add(n); });
    }
    const auto r = nebula::summarize(tally, set.muBins);
    run.info(std::to_string(r.photons) + " photons, " + std::to_string(r.events) +
             " interactions, " + secondsSince(start));

    using Json = nlohmann::ordered_json;
    Json j;
    j["slab"] = {{"tau", tau},
                 {"mu0", opts.mu0},
                 {"albedo", medium.albedo},
                 {"g", medium.g},
                 {"phase", nebula::toString(medium.phase)}};
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
    const auto bin = [&](double lo, double hi, const nebula::Estimate& e) {
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

    std::cout << j.dump(2) << "\n";
    std::cout.flush();
    if (!std::cout) throw nebula::Error("<stdout>: write failed");
}

} // namespace

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    PhaseOptions opts; // every default lives here (and in PhaseTableSpec)
    nebula::DustOptions dustOpts;
    const nebula::PhaseTableSpec& spec = opts.table;

    CLI::App app{
        "nebphase - effective phase function Phi(t, mu) of a dust voxel, by Monte Carlo\n\n"
        "Examples:\n"
        "  nebphase -o phase.vdb                                 # default dust, t 1e-4 .. 1e3\n"
        "  nebphase -i nebula.vdb -o phase.vdb --json phase.json # the nebula's dust\n"
        "  nebphase --albedo 0.6 --g 0.6 --t-count 16 --mu-bins 64 --error 0.03 -o quick.vdb\n"
        "  nebphase -i lit.vdb -o phase.vdb && nebrender -i lit.vdb --phase phase.vdb -o f.exr\n"
        "  nebphase --slab --tau 1 --albedo 0.9 --g 0.75 --mu0 0.5 > slab.json\n\n"
        "Table mode (default): photons enter one face of a cube of optical edge t along its\n"
        "normal. Phi(t, mu) [1/sr per unit optical depth] is the light scattered out of the\n"
        "cube per sr at cosine mu to the entry direction, per entering photon, divided by t\n"
        "(unscattered light excluded; Phi -> albedo p(mu) as t -> 0). Each of the --t-count\n"
        "log-spaced t gets photons (at least --photons) until every mu > 0 bin of the rows\n"
        "with t <= 10 has a relative standard error below --error, or --max-photons is\n"
        "reached (then a warning). The output holds only the grids phase and phase.error\n"
        "(index space: x = mu bin, y = t row; the axes, photons and seed as metadata) and\n"
        "nebula:dust. The dust is the input's nebula:dust (-i) or the defaults, with the dust\n"
        "options applied; the input's grids are NOT passed through. nebrender --phase uses it.\n\n"
        "Slab mode (--slab): a plane-parallel slab of optical depth --tau lit by a beam at\n"
        "cosine --mu0 to the normal. Prints JSON to stdout: diffuse reflection and\n"
        "transmission, direct transmission, absorption, roulette, balance (direct +\n"
        "reflected + transmitted + absorbed - roulette; 1 in expectation), and per bin the\n"
        "power per sr leaving each face [fraction of the incident power / sr], in --bins\n"
        "equal-cos bins per face of the cosine to that face's outward normal. The\n"
        "next-event estimator (default) forces the first interaction, so the direct\n"
        "transmission exp(-tau/mu0) is then exact (error 0); analog (MCML) balances each\n"
        "photon exactly.",
        "nebphase"};
    nebula::cli::addCommon(app, common, 0);
    nebula::cli::inputFile(
        app.add_option("-i,--input", common.input,
                       "VDB whose nebula:dust is the dust (file, or - for stdin); optional"));
    auto* output = nebula::cli::outputFile(
        app.add_option("-o,--output", common.output,
                       "Output phase table VDB, or - for stdout (table mode)"),
        nebula::FileFormat::Vdb);
    app.add_option("--seed", opts.table.seed,
                   "Random seed (same seed, same result whatever --threads)")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(0, UINT64_MAX));
    app.add_option("--photons", opts.photons,
                   "Photons: per t at least (table, default " + std::to_string(spec.minPhotons) +
                       "); in all (--slab, default " + std::to_string(opts.slabPhotons) + ")")
        ->check(nebula::cli::integerIn(1, UINT64_MAX));
    nebula::cli::addDust(app, dustOpts, /*withKappa=*/false);

    auto* tbl = app.add_option_group("Table", "Table mode (the default)");
    std::vector<CLI::Option*> tableOnly{
        output,
        tbl->add_option("--t-min", opts.table.tMin, "Smallest voxel optical thickness t")
            ->capture_default_str()
            ->check(nebula::cli::positive()),
        tbl->add_option("--t-max", opts.table.tMax, "Largest t")
            ->capture_default_str()
            ->check(nebula::cli::positive()),
        tbl->add_option("--t-count", opts.table.tCount,
                        "Log-spaced t values, both ends included (--t-count x --mu-bins as far "
                        "as the table fits in memory)")
            ->capture_default_str()
            ->check(nebula::cli::integerIn(2, 1000000)),
        tbl->add_option("--mu-bins", opts.table.muBins, "Equal-cos bins over [-1, 1] (even)")
            ->capture_default_str()
            ->check(nebula::cli::integerIn(2, 1000000)),
        tbl->add_option("--max-photons", opts.maxPhotons,
                        "Photons per t at most (default " + std::to_string(spec.maxPhotons) +
                            ", or --photons if larger; at most 1e9 per t and 1e11 in the "
                            "table)")
            ->check(nebula::cli::integerIn(1, UINT64_MAX)),
        tbl->add_option("--error", opts.table.targetError,
                        "Target relative standard error of Phi (mu > 0 bins, t <= " +
                            numberText(spec.errorTMax) + ")")
            ->capture_default_str()
            ->check(nebula::cli::positive()),
        nebula::cli::outputFile(
            tbl->add_option("--json", opts.json, "Also write the table as JSON (file, or -)"),
            nebula::FileFormat::Json),
    };

    auto* slb = app.add_option_group("Slab", "Slab mode (--slab)");
    slb->add_flag("--slab", opts.slab, "Run a plane-parallel slab instead; JSON to stdout");
    std::vector<CLI::Option*> slabOnly{
        slb->add_option("--tau", opts.tau, "Optical depth of the slab")
            ->check(nebula::cli::positive()),
        slb->add_option("--mu0", opts.mu0, "Cosine of the incident beam to the normal")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 1.0, true)),
        slb->add_option("--bins", opts.bins, "Equal-cos angular bins per face")
            ->capture_default_str()
            ->check(nebula::cli::integerIn(1, 100000)),
        slb->add_option("--estimator", opts.estimator, "analog or next-event")
            ->capture_default_str()
            ->check(CLI::IsMember({"analog", "next-event"})),
    };

    return nebula::cli::run(app, "nebphase", common, argc, argv, [&](nebula::Run& run) {
        // Options of the other mode are refused rather than silently ignored.
        for (const auto* o : opts.slab ? tableOnly : slabOnly) {
            if (o->count() == 0) continue;
            throw nebula::UsageError(o->get_name() +
                                     (opts.slab ? " is for table mode; --slab prints JSON to stdout"
                                                : " is for slab mode; add --slab"));
        }
        if (opts.slab && !opts.tau) {
            throw nebula::UsageError("--slab needs --tau T, the slab's optical depth");
        }
        if (opts.slab) {
            slabMode(run, common, dustOpts, opts);
        } else {
            tableMode(run, common, dustOpts, opts);
        }
    });
}
