#include "nebula/stages/render.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/image_check.h"
#include "nebula/render/fast.h"
#include "nebula/render/path_tracer.h"
#include "nebula/render/spectral.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <optional>

namespace nebula {

namespace {

bool endsWith(const std::string& s, const std::string& suffix)
{
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// The PNG path: RenderOutput::png, or the EXR's name with .png; "" for none.
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

/// Refuses combinations the integrators cannot honour, and warns about pyramid levels that
/// no phase table will use.
void checkIntegratorOptions(const GridSet& grids, const RenderOptions& opts, const Run& run)
{
    const bool path = opts.integrator == Integrator::Path;
    if (path && opts.levels > 0) {
        throw UsageError("--levels is for the fast integrator; --integrator path simulates "
                         "multiple scattering itself");
    }
    if (opts.levels > 0 && !opts.phaseTable && !path) {
        throw UsageError("--levels needs a phase table (--phase): each level adds the change "
                         "of the per-voxel scattering Phi as the voxel doubles");
    }
    if (opts.levels < 0 && !opts.phaseTable && !opts.spectral.enabled &&
        grids.find(levelGridName(opts.densityGrid, 1))) {
        run.warn(grids.source + " has pyramid levels (" + levelGridName(opts.densityGrid, 1) +
                 ", ...), which only a phase table uses: this image is single scattering. "
                 "Pass --phase (nebphase -i " +
                 grids.source + " -o phase.vdb) to use them, or --levels 0 to say you mean it");
    }
    if (path && opts.phaseTable) {
        throw UsageError("--phase is for the fast integrator; --integrator path simulates "
                         "multiple scattering itself");
    }
}

/// What the render did, under -v; a warning if the phase table was too short.
void reportStats(const RenderOptions& opts, const SpectralScene& sscene, const RenderStats& stats,
                 double tBuild, double tRender, const Run& run)
{
    const auto perItem = [](double seconds, std::uint64_t n) {
        return 1e9 * seconds / double(std::max<std::uint64_t>(n, 1));
    };
    const double rays = double(std::max<std::uint64_t>(stats.rays, 1));
    if (opts.integrator == Integrator::Path) {
        run.info(fmt::format("path tracing: {} walks, {} tentative collisions, {:.4g} ns wall "
                             "per walk",
                             stats.paths, stats.collisions, perItem(tRender, stats.paths)));
    }
    if (opts.spectral.enabled) {
        run.info(fmt::format("spectral: {}, {} emission grid(s), {} linear pieces projected "
                             "({:.6g} per ray)",
                             opts.spectral.bands > 0
                                 ? fmt::format("{} fixed bands", opts.spectral.bands)
                                 : std::string("piecewise-linear"),
                             sscene.emitters.size(), stats.pieces, double(stats.pieces) / rays));
        if (opts.spectral.countPieces && opts.spectral.bands == 0) {
            run.info(fmt::format("spectral: the rays' spectra have {:.6g} pieces on average "
                                 "(largest {}), {:.6g} after merging at tolerance {}",
                                 double(stats.spectrumPieces) / rays, stats.maxSpectrumPieces,
                                 double(stats.mergedPieces) / rays, opts.spectral.mergeTolerance));
        }
    }
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
std::map<std::string, std::string> exrAttributes(const GridSet& grids, const RenderOptions& opts,
                                                 const DustParams& dust, const RenderScene& scene,
                                                 const ToneCurve& curve, const RenderOutput& out,
                                                 const Run& run)
{
    const bool path = opts.integrator == Integrator::Path;
    const bool spectral = opts.spectral.enabled;
    const auto vec = [](const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); };
    const nlohmann::json tone = {
        {"white", curve.white}, {"gamma", curve.gamma}, {"automatic", out.tone.automatic}};
    const nlohmann::json cam = {{"eye", vec(opts.camera.eye)},
                                {"look_at", vec(opts.camera.lookAt)},
                                {"up", vec(opts.camera.up)},
                                {"fov_deg", opts.camera.fovDeg},
                                {"projection", "perspective"}};
    std::map<std::string, std::string> attrs{
        {"comments",
         path ? "nebula reference path-traced render (DESIGN section 6); linear radiance"
         : spectral
             ? "nebula spectral ray-cast render (DESIGN section 7); linear sRGB of CIE 1931 XYZ"
             : "nebula ray-cast render (DESIGN sections 3-4); linear radiance"},
        {"nebula:tool", run.tool()},
        {"nebula:version", NEBULA_VERSION_STRING},
        {"nebula:command", run.command()},
        {"nebula:integrator",
         path ? "path tracing (reference), spp " + std::to_string(opts.spp) + ", seed " +
                    std::to_string(opts.seed)
         : spectral
             ? (opts.spectral.bands > 0
                    ? "spectral, " + std::to_string(opts.spectral.bands) + " fixed bands"
                    : std::string("spectral, piecewise-linear")) +
                   ", exaggerate-velocity " + std::to_string(opts.spectral.exaggerateVelocity) +
                   (opts.spectral.relativistic ? ", relativistic Doppler" : ", first-order Doppler")
         : opts.phaseTable ? std::string("effective phase function (") +
                                 (opts.phaseUse == PhaseUse::Gain ? "gain" : "replace") +
                                 "), levels " + std::to_string(scene.levels.size())
                           : "single-scattering"},
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

void renderToFiles(const GridSet& grids, const RenderOptions& opts, const DustParams& dust,
                   const RenderOutput& out, const Run& run)
{
    const std::string png = pngPath(out);
    // Fail before the slow part if an output folder is not writable.
    checkOutputWritable(out.exr, "EXR");
    if (!png.empty()) checkOutputWritable(png, "PNG");
    checkIntegratorOptions(grids, opts, run);

    const auto start = std::chrono::steady_clock::now();
    SpectralScene sscene; // the spectral scene, or just its RGB base
    if (opts.spectral.enabled) {
        sscene = buildSpectralScene(grids, opts, dust);
    } else {
        sscene.base = buildScene(grids, opts, dust);
    }
    const auto built = std::chrono::steady_clock::now();
    RenderStats stats;
    const Image img = opts.spectral.enabled ? renderSpectral(sscene, opts, &run, &stats)
                      : opts.integrator == Integrator::Path
                          ? renderPathTraced(sscene.base, opts, &run, &stats)
                          : renderFrame(sscene.base, opts, &run, &stats);
    const auto done = std::chrono::steady_clock::now();
    reportStats(opts, sscene, stats, std::chrono::duration<double>(built - start).count(),
                std::chrono::duration<double>(done - built).count(), run);

    requireFinitePixels(img, out.exr);
    const ToneCurve curve = computeToneCurve(img, out.tone);
    // Both outputs or neither: each is written and fsynced before either replaces its target.
    AtomicFile exrFile(out.exr);
    writeExr(exrFile, img, exrAttributes(grids, opts, dust, sscene.base, curve, out, run));
    std::optional<AtomicFile> pngFile;
    if (!png.empty()) {
        pngFile.emplace(png);
        writePng(*pngFile, img, curve,
                 {{"Software", std::string("nebrender ") + NEBULA_VERSION_STRING},
                  {"Comment", run.command()}});
        commitAll({&exrFile, &*pngFile});
    } else {
        exrFile.commit();
    }
    run.info("wrote " + out.exr + (png.empty() ? std::string() : " and " + png));
}

} // namespace nebula
