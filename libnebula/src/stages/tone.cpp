#include "nebula/stages/tone.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/frames.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace nebula {

std::vector<ToneCurve> sequenceToneCurves(const std::vector<double>& times,
                                          const std::vector<LuminanceStats>& stats, double window,
                                          bool whole)
{
    if (times.size() != stats.size()) throw Error("tone: one time per frame's statistics");
    const std::size_t n = stats.size();
    const double sigma = 0.5 * window;
    std::vector<ToneCurve> curves(n);
    for (std::size_t i = 0; i < n; ++i) {
        double sumW = 0.0, logWhite = 0.0, logMean = 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            const auto& s = stats[j];
            if (!(s.white > 0.0) || !(s.logMean > 0.0)) continue; // a black frame
            double w = 1.0;
            if (!whole) {
                if (sigma <= 0.0) {
                    if (j != i) continue;
                } else {
                    const double x = (times[j] - times[i]) / sigma;
                    if (std::fabs(x) > 3.0) continue;
                    w = std::exp(-0.5 * x * x);
                }
            }
            sumW += w;
            logWhite += w * std::log(s.white);
            logMean += w * std::log(s.logMean);
        }
        if (sumW <= 0.0) continue; // nothing lit nearby: white 1, gamma 1
        LuminanceStats smoothed;
        smoothed.white = std::exp(logWhite / sumW);
        smoothed.logMean = std::exp(logMean / sumW);
        curves[i] = toneCurveFromStats(smoothed);
    }
    return curves;
}

std::vector<long> framesOnDisk(const std::string& pattern)
{
    if (!hasFramePattern(pattern)) {
        throw UsageError("-i " + pattern +
                         ": expected EXR names with a frame pattern, e.g. frames/f.####.exr");
    }
    const std::filesystem::path p(pattern);
    const std::string file = p.filename().string();
    if (!hasFramePattern(file)) {
        throw UsageError("-i " + pattern + ": the frame pattern must be in the file name");
    }
    const auto dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
    std::vector<long> frames;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
        long f;
        if (matchFramePattern(file, e.path().filename().string(), f)) frames.push_back(f);
    }
    if (ec) throw Error(dir.string() + ": cannot list the folder: " + ec.message());
    std::sort(frames.begin(), frames.end());
    return frames;
}

namespace {

/// A frame's statistics: nebula:luminance if the EXR has it (and at the same percentile),
/// else from its pixels.
LuminanceStats frameStats(const std::string& exr, double percentile, double& fps)
{
    const auto attrs = readExrAttributes(exr);
    if (const auto it = attrs.find("nebula:frame"); it != attrs.end() && fps <= 0.0) {
        const auto j = nlohmann::json::parse(it->second, nullptr, false);
        if (j.is_object() && j.contains("fps") && j["fps"].is_number()) {
            fps = j["fps"].get<double>();
        }
    }
    if (const auto it = attrs.find("nebula:luminance"); it != attrs.end()) {
        const auto j = nlohmann::json::parse(it->second, nullptr, false);
        if (j.is_object() && j.value("percentile", -1.0) == percentile && j.contains("white") &&
            j.contains("log_mean")) {
            LuminanceStats s;
            s.percentile = percentile;
            s.white = j["white"].get<double>();
            s.logMean = j["log_mean"].get<double>();
            s.lit = j.value("lit_pixels", std::size_t(0));
            if (std::isfinite(s.white) && std::isfinite(s.logMean)) return s;
        }
    }
    return luminanceStats(readExr(exr, nullptr), percentile);
}

} // namespace

void toneSequence(const ToneSequenceOptions& opts, const Run& run)
{
    if (!hasFramePattern(opts.output)) {
        throw UsageError("-o " + opts.output +
                         ": expected PNG names with a frame pattern, e.g. display/f.####.png");
    }
    std::vector<long> frames = opts.frames.empty() ? framesOnDisk(opts.input) : opts.frames;
    if (frames.empty()) {
        throw Error(opts.input + ": no frames found (no file matches the pattern)");
    }
    double fps = opts.fps;
    std::vector<LuminanceStats> stats;
    for (const long f : frames) {
        const std::string exr = expandFramePattern(opts.input, f);
        stats.push_back(frameStats(exr, opts.percentile, fps));
    }
    if (!(fps > 0.0)) fps = 24.0;
    std::vector<double> times;
    for (const long f : frames)
        times.push_back(double(f - 1) / fps);
    const auto curves = sequenceToneCurves(times, stats, opts.window, opts.whole);
    const std::string how = opts.whole ? std::string("one curve for the sequence")
                                       : fmt::format("window {:g} s at {:g} fps", opts.window, fps);
    run.info(fmt::format("{} frames, {}", frames.size(), how));
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const std::string exr = expandFramePattern(opts.input, frames[i]);
        const std::string png = expandFramePattern(opts.output, frames[i]);
        if (run.verbosity().verbose > 1) {
            run.info(fmt::format("frame {}: white {:.6g} (its own {:.6g}), gamma {:.4g}", frames[i],
                                 curves[i].white, stats[i].white, curves[i].gamma));
        }
        std::error_code ec;
        if (opts.skipExisting && std::filesystem::is_regular_file(png, ec)) continue;
        const Image img = readExr(exr, nullptr);
        AtomicFile file(png);
        writePng(file, img, curves[i],
                 {{"Software", std::string("nebtone ") + NEBULA_VERSION_STRING},
                  {"Comment", run.command()},
                  {"Source", exr},
                  {"Description", fmt::format("tone curve: white {:.9g}, gamma {:.6g} ({})",
                                              curves[i].white, curves[i].gamma, how)}},
                 opts.bits);
        file.commit();
    }
    run.info("wrote " + std::to_string(frames.size()) + " frames to " + opts.output);
}

} // namespace nebula
