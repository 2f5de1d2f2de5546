#include "nebula/stages/render.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/io/grid_names.h"
#include "nebula/render/fast.h"
#include "nebula/render/path_tracer.h"
#include "nebula/render/spectral.h"

#include <nlohmann/json.hpp>

#include <chrono>

namespace nebula {

namespace {

bool endsWith(const std::string& s, const std::string& suffix)
{
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

} // namespace

void renderToFiles(const GridSet& grids, const RenderOptions& opts, const DustParams& dust,
                   const RenderOutput& out, const Run& run)
{
    if (!endsWith(out.exr, ".exr")) {
        throw UsageError("-o " + out.exr + ": expected an .exr file name");
    }
    std::string png = out.png;
    if (png.empty()) png = out.exr.substr(0, out.exr.size() - 4) + ".png";
    if (png == "none") png.clear();
    // Fail before the slow part if an output folder is not writable.
    checkOutputWritable(out.exr, "EXR");
    if (!png.empty()) checkOutputWritable(png, "PNG");

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
                 grids.source +
                 " -o phase.vdb) to use them, or "
                 "--levels 0 to say you mean it");
    }
    if (path && opts.phaseTable) {
        throw UsageError("--phase is for the fast integrator; --integrator path simulates "
                         "multiple scattering itself");
    }
    const bool spectral = opts.spectral.enabled;
    const auto start = std::chrono::steady_clock::now();
    SpectralScene sscene; // the spectral scene, or just its RGB base
    if (spectral) {
        sscene = buildSpectralScene(grids, opts, dust);
    } else {
        sscene.base = buildScene(grids, opts, dust);
    }
    const RenderScene& scene = sscene.base;
    const auto built = std::chrono::steady_clock::now();
    RenderStats stats;
    const Image img = spectral ? renderSpectral(sscene, opts, &run, &stats)
                      : path   ? renderPathTraced(scene, opts, &run, &stats)
                               : renderFrame(scene, opts, &run, &stats);
    const auto done = std::chrono::steady_clock::now();
    const double tBuild = std::chrono::duration<double>(built - start).count();
    const double tRender = std::chrono::duration<double>(done - built).count();
    if (path) {
        run.info("path tracing: " + std::to_string(stats.paths) + " walks, " +
                 std::to_string(stats.collisions) + " tentative collisions, " +
                 std::to_string(1e9 * tRender / double(std::max<std::uint64_t>(stats.paths, 1))) +
                 " ns wall per walk");
    }
    if (spectral) {
        run.info(
            std::string("spectral: ") +
            (opts.spectral.bands > 0 ? std::to_string(opts.spectral.bands) + " fixed bands"
                                     : "piecewise-linear") +
            ", " + std::to_string(sscene.emitters.size()) + " emission grid(s), " +
            std::to_string(stats.pieces) + " linear pieces projected (" +
            std::to_string(double(stats.pieces) / double(std::max<std::uint64_t>(stats.rays, 1))) +
            " per ray)");
        if (opts.spectral.countPieces && opts.spectral.bands == 0) {
            const double rays = double(std::max<std::uint64_t>(stats.rays, 1));
            run.info("spectral: the rays' spectra have " +
                     std::to_string(double(stats.spectrumPieces) / rays) +
                     " pieces on average (largest " + std::to_string(stats.maxSpectrumPieces) +
                     "), " + std::to_string(double(stats.mergedPieces) / rays) +
                     " after merging at tolerance " + std::to_string(opts.spectral.mergeTolerance));
        }
    }
    run.info("scene " + std::to_string(tBuild) + " s, render " + std::to_string(tRender) + " s, " +
             std::to_string(stats.rays) + " rays, " + std::to_string(stats.samples) + " samples (" +
             std::to_string(1e9 * tRender / double(std::max<std::uint64_t>(stats.samples, 1))) +
             " ns wall per sample)");

    if (stats.phaseClamped > 0) {
        run.warn("in " + std::to_string(stats.phaseClamped) + " of " +
                 std::to_string(3 * stats.samples) +
                 " channel samples the voxel optical "
                 "thickness exceeded the phase table's t_max = " +
                 std::to_string(opts.phaseTable->tMax) + "; its last row was used");
    }
    const ToneCurve curve = computeToneCurve(img, out.tone);
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
    writeExr(out.exr, img, attrs);
    if (!png.empty()) {
        writePng(png, img, curve,
                 {{"Software", std::string("nebrender ") + NEBULA_VERSION_STRING},
                  {"Comment", run.command()}});
    }
    run.info("wrote " + out.exr + (png.empty() ? std::string() : " and " + png));
}

} // namespace nebula
