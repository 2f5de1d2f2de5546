// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/render.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/frames.h"
#include "nebula/core/memory.h"
#include "nebula/core/version.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/image_check.h"
#include "nebula/render/camera_model.h"
#include "nebula/render/frame_layers.h"
#include "nebula/render/integrator.h"
#include "nebula/render/spectral.h"
#include "nebula/stages/scene_assembly.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>

namespace nebula {

namespace {

bool endsWith(const std::string& s, const std::string& suffix)
{
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

} // namespace

std::string pngPath(const RenderOutput& out)
{
    if (!endsWith(out.exr, ".exr")) {
        throw UsageError("-o " + out.exr + ": expected an .exr file name");
    }
    std::string png = out.png;
    if (png.empty()) png = out.exr.substr(0, out.exr.size() - 4) + ".png";
    if (png == "none") png.clear();
    return png;
}

namespace {

/// What RGB mode makes of the emission grids (DESIGN §3.4), said before the render: with
/// --emission-color given (RenderOptions::lineColours false), a warning naming the line
/// grids it leaves out; else, with -v, each grid drawn and its colour, and a warning if
/// nebscatter's field scatters the glow of --emission-grid only while others glow too.
void reportEmission(const GridSet& grids, const RenderScene& scene, const RenderOptions& opts,
                    const Run& run)
{
    std::string names;
    if (!opts.lineColours) {
        for (const auto& g : grids.grids) {
            if (g->getName() != opts.emissionGrid && (*g)[META_LINES]) {
                names += (names.empty() ? "\"" : ", \"") + g->getName() + "\"";
            }
        }
        if (!names.empty()) {
            run.warn("--emission-color paints only the emission grid \"" + opts.emissionGrid +
                     "\"; the lines of " + names +
                     " are drawn in their colours without --emission-color, and by --spectral");
        }
        return;
    }
    const SceneEmission& se = scene.emission;
    for (std::size_t k = 0; k < se.grids.size(); ++k) {
        const auto& [name, c] = se.grids[k];
        const auto groups = std::count_if(se.lines.begin(), se.lines.end(),
                                          [&](const auto& l) { return l.grid == int(k); });
        run.info(fmt::format(
            "emission grid \"{}\": linear sRGB {:.4g}, {:.4g}, {:.4g} per unit "
            "(times --emission-scale){}",
            name, c[0], c[1], c[2],
            se.gridChannel < 0
                ? std::string()
                : fmt::format(", {} line group(s) dimmed at their wavelengths", groups)));
        if (name != opts.emissionGrid) names += (names.empty() ? "\"" : ", \"") + name + "\"";
    }
    if (scene.scatter.emissionSource && !names.empty()) {
        run.warn("the scattered-light field (nebscatter) holds the scattered glow of \"" +
                 opts.emissionGrid + "\" only; that of " + names + " is left out");
    }
}

/// Refuses what @p integrator cannot honour, and has it warn about what in the input it
/// will not use.
void checkIntegrator(const IntegratorType& integrator, const GridSet& grids,
                     const RenderOptions& opts, const Run& run)
{
    integrator.validate(opts);
    IntegratorInput input;
    input.source = grids.source;
    input.rgbField = opts.scatterField && !grids.metaString(META_SCATTER).empty();
    input.spectralField = opts.scatterField && !grids.metaString(META_SCATTER_SPECTRAL).empty();
    const std::string level = levelGridName(opts.densityGrid, 1);
    if (grids.find(level)) input.pyramidLevel = level;
    integrator.checkInput(input, opts, run);
}

/// What the render did, under -v; a warning if the phase table was too short.
void reportStats(const IntegratorType& integrator, const RenderOptions& opts,
                 const SpectralScene& sscene, const RenderStats& stats, double tBuild,
                 double tRender, const Run& run)
{
    const auto perItem = [](double seconds, std::uint64_t n) {
        return 1e9 * seconds / double(std::max<std::uint64_t>(n, 1));
    };
    if (integrator.report) integrator.report(opts, sscene, stats, tRender, run);
    run.info(fmt::format("scene {:.3g} s, render {:.3g} s, {} rays, {} samples ({:.4g} ns wall "
                         "per sample)",
                         tBuild, tRender, stats.rays, stats.samples,
                         perItem(tRender, stats.samples)));
    if (stats.phaseClamped > 0) {
        run.warn(fmt::format("in {} of {} channel samples the voxel optical thickness exceeded "
                             "the phase table's t_max = {}; its last row was used",
                             stats.phaseClamped, 3 * stats.samples, opts.phaseTable->tMax));
    }
}

/// The EXR's attributes: how it was made (tool, command, the whole history), what it holds
/// (units, integrator), and the scene (dust, stars, camera, exposure, phase table).
std::map<std::string, std::string>
exrAttributes(const IntegratorType& integrator, const GridSet& grids, const RenderOptions& opts,
              const DustParams& dust, const SpectralScene& sscene, const ToneCurve& curve,
              const RenderOutput& out, const Run& run)
{
    const RenderScene& scene = sscene.base;
    const nlohmann::json tone = {
        {"white", curve.white}, {"gamma", curve.gamma}, {"automatic", out.tone.automatic}};
    const nlohmann::json cam = cameraToJson(opts.camera);
    std::map<std::string, std::string> attrs{
        {"comments", integrator.comment},
        {"nebula:tool", run.tool()},
        {"nebula:version", NEBULA_VERSION_STRING},
        {"nebula:command", run.command()},
        {"nebula:integrator", integrator.describe(opts, sscene)},
        {"nebula:units", "L_sun pc^-2 sr^-1"},
        {"nebula:dust", dust.toJson()},
        {"nebula:stars", starsToJson(scene.stars)},
        {"nebula:camera", cam.dump()},
        {"nebula:exposure", tone.dump()},
        {"nebula:history", grids.historyWith(run.tool(), run.command()).dump()},
    };
    if (opts.phaseTable) {
        const auto& t = *opts.phaseTable;
        const nlohmann::json table = {
            {"file", opts.phaseSource},          {"albedo", t.medium.albedo}, {"g", t.medium.g},
            {"phase", toString(t.medium.phase)}, {"t_min", t.tMin},           {"t_max", t.tMax}};
        attrs["nebula:phase_table"] = table.dump();
    }
    return attrs;
}

} // namespace

namespace {

/// Whether the frame's outputs are already there, whole: the EXR reads back (our writes are
/// atomic, so a file under the final name is complete unless something else damaged it).
bool frameExists(const std::string& exr, const std::string& png)
{
    std::error_code ec;
    if (!std::filesystem::is_regular_file(exr, ec)) return false;
    if (!png.empty() && !pngReadsBack(png)) return false;
    try {
        readExr(exr, nullptr);
    } catch (const Error&) {
        return false;
    }
    return true;
}

/// The observer's and the inputs' header cards of --fits.
std::vector<FitsCard> fitsCards(const GridSet& grids, const RenderOptions& opts,
                                const DustParams& dust, const RenderOutput& out, const Run& run)
{
    const Camera& c = opts.camera;
    const auto vec = [](const Vec3& v) {
        return fmt::format("{:.10g},{:.10g},{:.10g}", v.x, v.y, v.z);
    };
    std::vector<FitsCard> cards{
        {"ORIGIN", std::string("nebula ") + NEBULA_VERSION_STRING, "the software"},
        {"CAMERA", c.model, "nebrender --camera"},
        {"EYE", vec(c.eye), "camera position [pc]"},
        {"LOOKAT", vec(c.lookAt), "the image centre [pc]"},
        {"UP", vec(c.up), "camera up"},
    };
    for (const CameraCard& card : cameraModel(c.model).fitsCards(c))
        cards.push_back({card.key, card.value, card.comment});
    cards.push_back({"PIXSR", Projection(c).pixelSolidAngle(0.5 * c.width, 0.5 * c.height),
                     "solid angle of the central pixel [sr]"});
    if (out.fits.sky) cards.push_back({"POSANG", out.fits.positionAngle, "up, N through E [deg]"});
    cards.push_back({"DUST", dust.toJson(), "the dust model (nebula:dust)"});
    const bool spectral = opts.spectral.enabled;
    std::string how = spectral
                          ? (out.fits.filter ? "Band averages of the spectrum (constant across "
                                               "each band of BANDWID nm) through the filter."
                                             : "Spectral cube: each plane the spectrum's mean "
                                               "over its band, BANDWID nm wide.")
                          : (out.fits.filter ? "Band averages: monochromatic images at the "
                                               "quadrature wavelengths QNODEi, weighted by "
                                               "QWGHTi."
                                             : "Monochromatic images at their wavelengths "
                                               "(WAVELEN, or the WAVE-TAB axis).");
    how += " Each star a black body of its bolometric luminosity";
    how += spectral ? "; the emission grid times EMSCALE is the lines' emissivity [L_sun pc^-3 "
                      "sr^-1] (DESIGN section 13)."
                    : " (DESIGN section 13).";
    if (spectral) cards.push_back({"EMSCALE", opts.emissionScale, "nebrender --emission-scale"});
    cards.push_back({"COMMENT", how, ""});
    for (const auto& h : grids.historyWith(run.tool(), run.command())) {
        const std::string tool = h.value("tool", std::string("?"));
        const std::string command = h.value("command", std::string());
        cards.push_back({"HISTORY", tool + ": " + command, ""});
    }
    return cards;
}

/// Renders one frame with @p integrator and @p opts' camera and writes its EXR and PNG, both or
/// neither.
void renderOneFrame(const IntegratorType& integrator, const GridSet& grids,
                    const RenderOptions& opts, const DustParams& dust, const SpectralScene& sscene,
                    const RenderOutput& out, const std::string& exr, const std::string& png,
                    const std::map<std::string, std::string>& extra,
                    const std::vector<std::string>& exrChannels, double tBuild, const Run& run)
{
    const auto start = std::chrono::steady_clock::now();
    RenderStats stats;
    Image img = integrator.render(sscene, opts, &run, &stats);
    const auto done = std::chrono::steady_clock::now();
    reportStats(integrator, opts, sscene, stats, tBuild,
                std::chrono::duration<double>(done - start).count(), run);

    requireFinitePixels(img, exr);
    const ToneCurve curve = computeToneCurve(img, out.tone);
    auto attrs = exrAttributes(integrator, grids, opts, dust, sscene, curve, out, run);
    for (const auto& [k, v] : extra)
        attrs[k] = v;
    // What the automatic tone curve reads, so that nebtone can tone a whole sequence.
    const LuminanceStats lum = luminanceStats(img, out.tone.percentile, out.tone.stars);
    attrs["nebula:luminance"] = nlohmann::json({{"percentile", lum.percentile},
                                                {"stars", out.tone.stars},
                                                {"white", lum.white},
                                                {"log_mean", lum.logMean},
                                                {"lit_pixels", lum.lit}})
                                    .dump();
    // All outputs or none: each is written and fsynced before any replaces its target. The
    // calibrated outputs first: they read the component layers, which the EXR leaves out.
    std::optional<AtomicFile> fitsFile, sedFile;
    std::vector<SedRow> sed; // the FITS's table and the CSV: computed once
    if (calibrated(out.fits)) sed = imageSed(img, opts, out.fits.filter);
    if (!out.fits.path.empty()) {
        fitsFile.emplace(out.fits.path);
        writeCalibratedFits(*fitsFile, img, opts, out.fits, sed,
                            fitsCards(grids, opts, dust, out, run));
    }
    if (!out.fits.sed.empty()) {
        sedFile.emplace(out.fits.sed);
        const Camera& c = opts.camera;
        std::string band =
            opts.spectral.enabled
                ? fmt::format("the spectrum's mean over bands of {:g} nm",
                              (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / opts.spectral.layers)
                : "monochromatic at each wavelength";
        if (out.fits.filter && sed.front().total > 0.0) {
            band = fmt::format("band averages <f_nu> through {} at its pivot wavelength; AB "
                               "magnitude of the total {:.4f}",
                               out.fits.filter->name, abMagnitude(sed.front().total));
        }
        writeSedCsv(
            *sedFile, sed, hasCalibratedEmission(opts),
            {"nebula SED: flux density at the observer [Jy] per component (DESIGN section 13), " +
                 band,
             "camera " + c.model + ", " + cameraModel(c.model).observer(c),
             "command: " + run.command()});
    }
    // The components (and layers the user did not ask for) stay out of the EXR.
    if (opts.componentLayers) img.removeLayers({FIELD_LAYER, EMISSION_LAYER, DIRECT_LAYER});
    const auto unasked = [&](const ImageChannel& c) {
        return std::find(exrChannels.begin(), exrChannels.end(), c.name) == exrChannels.end();
    };
    img.channels.erase(std::remove_if(img.channels.begin(), img.channels.end(), unasked),
                       img.channels.end());
    AtomicFile exrFile(exr);
    writeExr(exrFile, img, attrs);
    std::vector<AtomicFile*> files{&exrFile};
    std::optional<AtomicFile> pngFile;
    if (!png.empty()) {
        pngFile.emplace(png);
        writePng(*pngFile, img, curve,
                 {{"Software", std::string("nebrender ") + NEBULA_VERSION_STRING},
                  {"Comment", run.command()}},
                 out.pngBits);
        files.push_back(&*pngFile);
    }
    for (auto* f : {&fitsFile, &sedFile})
        if (*f) files.push_back(&**f);
    commitAll(files);
    std::string names = exr;
    for (std::size_t i = 1; i < files.size(); ++i)
        names += (i + 1 == files.size() ? " and " : ", ") + files[i]->path();
    run.info("wrote " + names);
}

} // namespace

void renderToFiles(const GridSet& grids, const RenderOptions& given, const DustParams& dust,
                   const RenderOutput& out, const Run& run)
{
    RenderOptions opts = given;
    // The EXR's single channels: the spectral layers asked for.
    std::vector<std::string> exrChannels;
    const std::size_t asked = std::size_t(std::max(given.spectral.layers, 0));
    for (std::size_t b = 0; b < asked; ++b)
        exrChannels.push_back(spectralChannelName(b, asked));
    if (calibrated(out.fits)) { // calibrated light and its components
        opts.monochromatic = true;
        opts.componentLayers = true;
        if (opts.spectral.enabled && opts.spectral.layers == 0)
            opts.spectral.layers = CALIBRATED_SPECTRAL_LAYERS;
    }
    const std::string png = pngPath(out);
    std::vector<long> frames = out.frames;
    if (out.path && frames.empty()) {
        throw UsageError("--camera-path needs the frames to render: --frame N or --frames A-B");
    }
    if (!out.path && !frames.empty()) {
        throw UsageError("--frame and --frames need a --camera-path");
    }
    if (frames.size() > 1) {
        if (!hasFramePattern(out.exr)) {
            throw UsageError("-o " + out.exr + ": " + std::to_string(frames.size()) +
                             " frames need a frame pattern in the name, e.g. frames/f.####.exr "
                             "or frames/f.%04d.exr");
        }
        if (!png.empty() && !hasFramePattern(png)) {
            throw UsageError("--png " + png + ": " + std::to_string(frames.size()) +
                             " frames need a frame pattern in the name, e.g. f.####.png");
        }
    }
    if (frames.empty()) frames.push_back(0); // one frame, no path: the names as given
    // Fail before the slow part if an output folder is not writable.
    for (const long f : {frames.front(), frames.back()}) {
        checkOutputWritable(expandFramePattern(out.exr, f), "EXR");
        if (!png.empty()) checkOutputWritable(expandFramePattern(png, f), "PNG");
    }
    const IntegratorType& integrator = chosenIntegrator(opts);
    checkFitsOutput(out.fits, opts, frames.size() > 1);
    if (calibrated(out.fits)) {
        if (!out.fits.path.empty()) checkOutputWritable(out.fits.path, "FITS");
        if (!out.fits.sed.empty()) checkOutputWritable(out.fits.sed, "SED");
        const std::string option = out.fits.path.empty() ? "--sed" : "--fits";
        if (!integrator.calibrated) {
            throw UsageError(option + " needs the fast integrator (its component layers)");
        }
        if (grids.find(opts.emissionGrid) && !hasCalibratedEmission(opts)) {
            run.warn(option + ": the gas's glow (grid \"" + opts.emissionGrid +
                     "\") has no spectral calibration in RGB mode and is left out "
                     "(--spectral calibrates it)");
        }
    }
    checkIntegrator(integrator, grids, opts, run);
    // Every frame's camera, computed once and checked before the scene is built.
    std::vector<Camera> cameras(frames.size(), opts.camera);
    if (out.path) {
        for (std::size_t i = 0; i < frames.size(); ++i) {
            cameras[i] = out.path->at(out.path->frameTime(frames[i]), opts.camera);
            try {
                (void)Projection(cameras[i]); // a created camera is valid
            } catch (const UsageError& e) {
                throw UsageError(out.path->source + ": frame " + std::to_string(frames[i]) + ": " +
                                 e.what());
            }
        }
    }

    const auto start = std::chrono::steady_clock::now();
    SpectralScene sscene; // the spectral scene, or just its RGB base: built once
    if (opts.spectral.enabled) {
        sscene = buildSpectralScene(grids, opts, dust);
    } else {
        refuseAbsorptionGrids(grids);
        sscene.base = buildScene(grids, opts, dust);
        reportEmission(grids, sscene.base, opts, run);
    }
    const double tBuild =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    { // e.g. a stereo base beyond the scene
        const SparseVolume& v = sscene.base.fields;
        const double across =
            v.indexToWorld.applyLinear(Vec3(v.dims()[0], v.dims()[1], v.dims()[2])).length();
        cameraModel(opts.camera.model).validateInScene(opts.camera, across);
    }
    {
        const SparseVolume& v = sscene.base.fields;
        const double box = double(v.dims()[0]) * v.dims()[1] * v.dims()[2] * v.channels() * 4.0;
        run.info(fmt::format("scene fields: {}x{}x{} voxels, {} channels, {} bricks of {}^3 "
                             "stored: {} ({:.3g} % of the dense box, {})",
                             v.dims()[0], v.dims()[1], v.dims()[2], v.channels(), v.storedBricks(),
                             SparseVolume::BRICK, bytesText(double(v.storedBytes())),
                             100.0 * double(v.storedBytes()) / box, bytesText(box)));
    }
    if (!sscene.base.scatter.description.empty()) {
        run.info("using the " + sscene.base.scatter.description + " (--no-scatter-field: off)");
    }
    std::size_t skipped = 0;
    RenderOptions frameOpts = opts;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const long f = frames[i];
        const std::string exr = out.path ? expandFramePattern(out.exr, f) : out.exr;
        const std::string framePng = out.path && !png.empty() ? expandFramePattern(png, f) : png;
        if (out.skipExisting && frameExists(exr, framePng)) {
            run.info("frame " + std::to_string(f) + ": " + exr + " exists, skipped");
            ++skipped;
            continue;
        }
        std::map<std::string, std::string> extra;
        if (out.path) {
            const double t = out.path->frameTime(f);
            extra["nebula:frame"] = nlohmann::json({{"frame", f},
                                                    {"time_s", t},
                                                    {"fps", out.path->fps},
                                                    {"camera_path", out.path->source}})
                                        .dump();
            if (frames.size() > 1)
                run.info("frame " + std::to_string(f) + " (t = " + fmt::format("{:.4g}", t) +
                         " s)");
        }
        frameOpts.camera = cameras[i];
        renderOneFrame(integrator, grids, frameOpts, dust, sscene, out, exr, framePng, extra,
                       exrChannels, tBuild, run);
    }
    if (skipped > 0) {
        run.info(std::to_string(skipped) + " of " + std::to_string(frames.size()) +
                 " frames existed and were skipped (--skip-existing)");
    }
}

} // namespace nebula
