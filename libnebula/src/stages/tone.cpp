// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/tone.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/frames.h"
#include "nebula/core/version.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>

namespace nebula {

std::vector<ToneCurve> sequenceToneCurves(const std::vector<double>& times,
                                          const std::vector<LuminanceStats>& stats, double window,
                                          bool whole, double adaptStops)
{
    if (times.size() != stats.size()) throw Error("tone: one time per frame's statistics");
    if (!(adaptStops >= 0.0)) throw Error("tone: the white point's adaptation must be >= 0 stops");
    const std::size_t n = stats.size();
    const double sigma = 0.5 * window;
    // The frames' log statistics averaged with weight(j) over the lit frames; false if none.
    const auto average = [&](const auto& weight, LuminanceStats& out) {
        double sumW = 0.0, logWhite = 0.0, logMean = 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            const auto& s = stats[j];
            if (!(s.white > 0.0) || !(s.logMean > 0.0)) continue; // a black frame
            const double w = weight(j);
            if (!(w > 0.0)) continue;
            sumW += w;
            logWhite += w * std::log(s.white);
            logMean += w * std::log(s.logMean);
        }
        if (sumW <= 0.0) return false;
        out.white = std::exp(logWhite / sumW);
        out.logMean = std::exp(logMean / sumW);
        return true;
    };
    LuminanceStats sequence;
    const bool lit = average([](std::size_t) { return 1.0; }, sequence);
    const ToneCurve sequenceCurve = toneCurveFromStats(sequence);
    // One curve for the whole sequence: the sequence's (white 1, gamma 1 if nothing is lit).
    if (whole) return std::vector<ToneCurve>(n, lit ? sequenceCurve : ToneCurve{});
    std::vector<ToneCurve> curves(n);
    for (std::size_t i = 0; i < n; ++i) {
        LuminanceStats smoothed;
        const bool any = average(
            [&](std::size_t j) {
                if (sigma <= 0.0) return j == i ? 1.0 : 0.0;
                const double x = (times[j] - times[i]) / sigma;
                return std::fabs(x) > 3.0 ? 0.0 : std::exp(-0.5 * x * x);
            },
            smoothed);
        if (!any) continue; // nothing lit nearby: white 1, gamma 1
        curves[i] = toneCurveFromStats(smoothed);
        if (sigma > 0.0) { // the sequence's gamma; the white point adapts within limits
            const double f = std::exp2(adaptStops);
            curves[i].white =
                std::clamp(curves[i].white, sequenceCurve.white / f, sequenceCurve.white * f);
            curves[i].gamma = sequenceCurve.gamma;
        }
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

double frameAttributeFps(const std::string& text, const std::string& where)
{
    const auto j = detail::parseJson(text, where, "attribute nebula:frame is ");
    if (!j.is_object() || !j.contains("fps")) return 0.0;
    const auto& v = j["fps"];
    if (!v.is_number() || !(v.get<double>() >= 1e-3 && v.get<double>() <= 1e4)) {
        throw Error(where + ": attribute nebula:frame has fps " + detail::printable(v.dump(), 40) +
                    ", expected a number in [0.001, 10000]; give --fps");
    }
    return v.get<double>();
}

double luminanceAttributeWhite(const std::string& text, double percentile, const std::string& where,
                               bool stars)
{
    const auto j = detail::parseJson(text, where, "attribute nebula:luminance is ");
    if (!j.is_object() || !j.contains("white") || !j["white"].is_number() ||
        !j.contains("percentile") || !j["percentile"].is_number()) {
        throw Error(where + ": attribute nebula:luminance lacks a numeric \"white\" or "
                            "\"percentile\"");
    }
    if (j["percentile"].get<double>() != percentile) return -1.0;
    if (j.contains("stars") && j["stars"].is_boolean() && j["stars"].get<bool>() != stars) {
        return -1.0;
    }
    const double w = j["white"].get<double>();
    if (!(w >= 0.0) || !std::isfinite(w)) {
        throw Error(where + ": attribute nebula:luminance has white point " +
                    detail::numberText(w) + ", expected a finite number >= 0");
    }
    return w;
}

namespace {

bool endsWithPng(const std::string& name)
{
    if (name.size() < 4) return false;
    std::string ext = name.substr(name.size() - 4);
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext == ".png";
}

/// A frame's statistics from its pixels (the frame is decoded whole, so a damaged frame is
/// found before any PNG is written), and the fps its nebula:frame records (where @p fps is
/// not set yet). A frame's nebula:luminance is only compared with its pixels: a warning when
/// they disagree.
LuminanceStats frameStats(const std::string& exr, long frame, double percentile, bool stars,
                          double& fps, const Run& run)
{
    std::map<std::string, std::string> attrs;
    const Image img = readExr(exr, &attrs);
    const std::string where = exr + " (frame " + std::to_string(frame) + ")";
    if (const auto it = attrs.find("nebula:frame"); it != attrs.end() && fps <= 0.0) {
        fps = frameAttributeFps(it->second, where);
    }
    const LuminanceStats stats = luminanceStats(img, percentile, stars);
    if (!std::isfinite(stats.white) || !std::isfinite(stats.logMean)) {
        throw Error(where + ": its luminance statistics are not finite (white point " +
                    detail::numberText(stats.white) + ")");
    }
    if (const auto it = attrs.find("nebula:luminance"); it != attrs.end()) {
        std::string why;
        try {
            const double w = luminanceAttributeWhite(it->second, percentile, where, stars);
            if (w >= 0.0 && !(std::fabs(w - stats.white) <= 0.01 * stats.white)) {
                why = "it says white point " + detail::numberText(w) + ", its pixels " +
                      detail::numberText(stats.white);
            }
        } catch (const Error& e) {
            why = e.what();
        }
        if (!why.empty()) {
            run.warn(where + ": attribute nebula:luminance disagrees with the pixels (" +
                     detail::printable(why, 160) + "); using the pixels");
        }
    }
    return stats;
}

/// Leaves out of the smoothing (with a warning) a lit frame whose white point is more than
/// OUTLIER_FACTOR from the median of the sequence's lit frames: no genuine camera move
/// changes the brightness a million-fold, and one such frame would set its neighbours'
/// curves (black or blown out).
constexpr double OUTLIER_FACTOR = 1e6;

std::vector<LuminanceStats> withoutOutliers(const std::vector<LuminanceStats>& stats,
                                            const std::vector<long>& frames, const Run& run)
{
    std::vector<double> whites;
    for (const auto& s : stats)
        if (s.white > 0.0) whites.push_back(s.white);
    if (whites.size() < 3) return stats;
    std::nth_element(whites.begin(), whites.begin() + std::ptrdiff_t(whites.size() / 2),
                     whites.end());
    const double median = whites[whites.size() / 2];
    std::vector<LuminanceStats> kept = stats;
    for (std::size_t i = 0; i < stats.size(); ++i) {
        const double w = stats[i].white;
        if (w > 0.0 && (w > OUTLIER_FACTOR * median || w < median / OUTLIER_FACTOR)) {
            run.warn(fmt::format("frame {}: white point {} is more than {:g} times from the "
                                 "sequence's median {}; left out of the smoothing",
                                 frames[i], detail::numberText(w), OUTLIER_FACTOR,
                                 detail::numberText(median)));
            kept[i] = LuminanceStats{}; // as a black frame: its neighbours set its curve
        }
    }
    return kept;
}

} // namespace

void toneSequence(const ToneSequenceOptions& opts, const Run& run)
{
    if (!hasFramePattern(opts.output)) {
        throw UsageError("-o " + opts.output +
                         ": expected PNG names with a frame pattern, e.g. display/f.####.png");
    }
    if (!endsWithPng(opts.output)) {
        throw UsageError("-o " + opts.output +
                         ": nebtone writes PNG frames; the names must end in .png");
    }
    std::vector<long> frames = opts.frames.empty() ? framesOnDisk(opts.input) : opts.frames;
    if (frames.empty()) {
        throw Error(opts.input + ": no frames found (no file matches the pattern)");
    }
    // Every frame is read and checked before any PNG is written: all or nothing.
    double fps = opts.fps;
    std::vector<LuminanceStats> stats;
    for (const long f : frames) {
        const std::string exr = expandFramePattern(opts.input, f);
        stats.push_back(frameStats(exr, f, opts.tone.percentile, opts.tone.stars, fps, run));
    }
    if (!(fps > 0.0)) fps = 24.0;
    std::vector<double> times;
    for (const long f : frames)
        times.push_back(double(f - 1) / fps);
    const bool smoothing = opts.whole || opts.window > 0.0;
    std::vector<ToneCurve> curves;
    std::string how;
    if (!opts.tone.automatic) { // a fixed curve: the same for every frame, as nebrender's
        curves.assign(frames.size(), computeToneCurve(Image(1, 1), opts.tone));
        how = fmt::format("fixed: exposure {:g}, gamma {:g}", opts.tone.exposure, opts.tone.gamma);
    } else {
        curves = sequenceToneCurves(times, smoothing ? withoutOutliers(stats, frames, run) : stats,
                                    opts.window, opts.whole, opts.adaptStops);
        how = opts.whole ? std::string("one curve for the sequence")
              : smoothing
                  ? fmt::format("window {:g} s at {:g} fps, the sequence's gamma, white point "
                                "within {:g} stops of the sequence's",
                                opts.window, fps, opts.adaptStops)
                  : std::string("each frame its own curve");
        if (opts.tone.fixedGamma) { // the white point follows the sequence, gamma does not
            const double gamma = computeToneCurve(Image(1, 1), opts.tone).gamma; // checked
            for (auto& c : curves)
                c.gamma = gamma;
            how += fmt::format(", gamma {:g}", gamma);
        }
    }
    run.info(fmt::format("{} frames, {}", frames.size(), how));
    std::size_t skipped = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const std::string exr = expandFramePattern(opts.input, frames[i]);
        const std::string png = expandFramePattern(opts.output, frames[i]);
        if (run.verbosity().verbose > 1) {
            run.info(fmt::format("frame {}: white {:.6g} (its own {:.6g}), gamma {:.4g}", frames[i],
                                 curves[i].white, stats[i].white, curves[i].gamma));
        }
        if (opts.skipExisting && pngReadsBack(png)) {
            ++skipped;
            continue;
        }
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
    run.info("wrote " + std::to_string(frames.size() - skipped) + " frames to " + opts.output +
             (skipped ? fmt::format(" ({} existed and were skipped)", skipped) : std::string()));
}

} // namespace nebula
