// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/view.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/file_format.h"
#include "nebula/core/units.h"
#include "nebula/render/camera_model.h"
#include "nebula/render/fast.h"
#include "nebula/render/sprites.h"
#include "nebula/render/star_depth.h"
#include "nebula/stages/scene_assembly.h"
#include "nebula/volume/block_walk.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace nebula {

std::string toString(ViewStage stage)
{
    switch (stage) {
    case ViewStage::Interactive: return "interactive";
    case ViewStage::Preview: return "preview";
    case ViewStage::Final: return "final";
    }
    return "final";
}

bool ViewShow::all() const
{
    return single && field && emission && sprites &&
           std::all_of(stars.begin(), stars.end(), [](bool on) { return on; });
}

ViewSession::ViewSession(std::shared_ptr<const GridSet> grids, const ViewSettings& settings,
                         const DustParams& dust, const Run& run)
    : mGrids(std::move(grids)), mSettings(settings), mDust(dust)
{
    if (mSettings.render.integrator != Integrator::Fast) {
        throw UsageError("nebview renders with the fast integrator only (--integrator path is "
                         "nebrender's reference)");
    }
    if (!(mSettings.fastStep > 0.0) || !std::isfinite(mSettings.fastStep)) {
        throw UsageError("--fast-step must be a number > 0 [voxels]");
    }
    if (!(mSettings.fastLod >= 0.0) || !std::isfinite(mSettings.fastLod)) {
        throw UsageError("--fast-lod must be a number >= 0");
    }
    const Camera& c = mSettings.render.camera;
    if (mSettings.interactiveWidth <= 0 || mSettings.interactiveHeight <= 0) {
        mSettings.interactiveWidth = std::max(1, c.width / 2);
        mSettings.interactiveHeight = std::max(1, c.height / 2);
    }
    (void)Projection(c); // a created camera is valid
    const auto start = std::chrono::steady_clock::now();
    mScene = buildScene(*mGrids, mSettings.render, mDust);
    requireRayStep(mScene, mSettings.render.step);
    requireRayStep(mScene, mSettings.fastStep);
    mDepth = std::make_unique<StarDepth>(mScene);
    run.info(fmt::format(
        "scene built in {:.3g} s: {}x{}x{} voxels, {} stars{}", // what the session holds
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
        mScene.fields.dims()[0], mScene.fields.dims()[1], mScene.fields.dims()[2],
        mScene.stars.size(),
        mScene.scatter.description.empty() ? "" : ", the " + mScene.scatter.description));
}

ViewSession::~ViewSession() = default;

bool ViewSession::hasEmission() const
{
    return mGrids->find(mSettings.render.emissionGrid) != nullptr;
}

std::array<int, 2> ViewSession::resolution(ViewStage stage) const
{
    if (stage == ViewStage::Interactive)
        return {mSettings.interactiveWidth, mSettings.interactiveHeight};
    return {mSettings.render.camera.width, mSettings.render.camera.height};
}

RenderOptions ViewSession::stageOptions(const Camera& camera, ViewStage stage, bool spectral) const
{
    RenderOptions opts = mSettings.render;
    opts.camera = camera;
    const auto size = resolution(stage);
    opts.camera.width = size[0];
    opts.camera.height = size[1];
    // The page switches models; each gets the image shape it needs from the stage's size.
    cameraModel(camera.model).fitSize(opts.camera.width, opts.camera.height);
    if (stage != ViewStage::Final) {
        opts.step = mSettings.fastStep;
        opts.exactStarDepth = false;
        if (stage == ViewStage::Interactive) {
            // Speed first: coarse levels in thick dust too (DESIGN §9, --lod-tau).
            opts.lod = std::max(opts.lod, mSettings.fastLod);
            opts.lodMaxDepth = std::numeric_limits<double>::infinity();
        }
    }
    opts.spectral.enabled = spectral;
    if (!spectral) { // the components apart; the sprites drawn by compose()
        opts.componentLayers = true;
        opts.drawStars = false;
    }
    return opts;
}

ViewFrame ViewSession::render(const Camera& camera, ViewStage stage, bool spectral,
                              const Run& run) const
{
    ViewFrame frame;
    frame.stage = stage;
    frame.spectral = spectral;
    const RenderOptions opts = stageOptions(camera, stage, spectral);
    (void)Projection(opts.camera); // a created camera is valid
    frame.camera = opts.camera;
    const auto start = std::chrono::steady_clock::now();
    if (spectral) {
        const SpectralScene* scene = nullptr;
        {
            const std::lock_guard<std::mutex> lock(mSpectralMutex);
            if (!mSpectral) {
                RenderOptions build = mSettings.render;
                build.spectral.enabled = true;
                mSpectral =
                    std::make_unique<SpectralScene>(buildSpectralScene(*mGrids, build, mDust));
            }
            scene = mSpectral.get();
        }
        frame.image = renderSpectral(*scene, opts, &run, &frame.stats);
    } else {
        frame.image = renderFrame(mScene, opts, &run, &frame.stats);
    }
    frame.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return frame;
}

Image ViewSession::compose(const ViewFrame& frame, const ViewShow& show) const
{
    Image img = frame.image;
    if (frame.spectral) return img;
    const RenderOptions opts = stageOptions(frame.camera, frame.stage, false);
    RenderOptions sprites = opts;
    sprites.drawStars = true;
    const std::size_t stars = mScene.stars.size();
    const bool drawSprites = show.sprites && mSettings.render.drawStars;
    if (show.all()) { // nebrender's beauty: the sprites added as renderFrame() adds them
        if (drawSprites) drawStarSprites(img, mScene, sprites);
        return img;
    }
    const auto starOn = [&](std::size_t s) { return s >= show.stars.size() || show.stars[s]; };
    const std::size_t n = std::size_t(img.width) * std::size_t(img.height);
    const std::vector<float>& field = frame.image.layers.at(stars + 1).rgb;
    const std::vector<float>& emission = frame.image.layers.at(stars + 2).rgb;
    for (std::size_t i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
            const std::size_t k = 3 * i + std::size_t(c);
            double v = 0.0;
            if (show.single) {
                for (std::size_t s = 0; s < stars; ++s)
                    if (starOn(s)) v += frame.image.layers[s].rgb[k];
            }
            if (show.field) v += field[k];
            if (show.emission) v += emission[k];
            img.rgba[4 * i + std::size_t(c)] = float(v);
        }
    }
    if (drawSprites) {
        Image alone(img.width, img.height);
        for (const auto& s : mScene.stars)
            alone.layers.push_back({"star." + s.name, std::vector<float>(3 * n, 0.0f)});
        drawStarSprites(alone, mScene, sprites);
        for (std::size_t s = 0; s < stars; ++s) {
            if (!starOn(s)) continue;
            for (std::size_t i = 0; i < n; ++i)
                for (std::size_t c = 0; c < 3; ++c)
                    img.rgba[4 * i + c] += alone.layers[s].rgb[3 * i + c];
        }
    }
    return img;
}

ProbeResult ViewSession::probe(const Camera& camera, double px, double py) const
{
    const Projection projection(camera); // a created camera is valid
    ProbeResult result;
    Vec3 dir;
    if (!projection.direction(px, py, dir)) return result; // outside a fisheye's circle
    const SparseVolume& f = mScene.fields;
    const Vec3 origin = projection.origin(px, py);
    // The ray clipped to the lattice's box, in index space: oI + t dI, t in pc.
    const BlockRay ray(f, f.indexToWorld.inverse(), mScene.blocks, origin, dir);
    if (!ray.hits()) return result;
    const Vec3 &o = ray.oI, &d = ray.dI;
    const double t0 = ray.t0, t1 = ray.t1;
    const double kappa = mScene.dust.kappa_V;
    const double step = 0.25 * voxelSize(f.indexToWorld); // [pc]
    const auto at = [&](double t) { return Vec3(o.x + t * d.x, o.y + t * d.y, o.z + t * d.z); };
    double tau = 0.0;
    double nPrev = f.sample0(at(t0));
    bool found = false;
    double tHit = 0.0;
    for (double t = t0; t < t1;) {
        const double dt = std::min(step, t1 - t);
        const double nNext = f.sample0(at(t + dt));
        const double dTau = 0.5 * (nPrev + nNext) * dt * kappa;
        if (!found && tau + dTau >= PROBE_TAU) {
            found = true;
            tHit = t + dt * (PROBE_TAU - tau) / dTau; // linear within the step
        }
        tau += dTau;
        nPrev = nNext;
        t += dt;
    }
    result.tauRay = tau;
    if (!found) return result;
    result.hit = true;
    result.position = origin + dir * tHit;
    const Vec3 pI = at(tHit);
    std::vector<float> channels(std::size_t(f.channels()));
    f.sample(pI, channels.data());
    result.density = channels[0];
    for (std::size_t s = 0; s < mScene.stars.size(); ++s) {
        const double interp = channels[2 + s];
        result.tau.push_back(mSettings.render.exactStarDepth ? (*mDepth)(s, pI, interp) : interp);
    }
    const SceneScatterField& field = mScene.scatter;
    if (field.order >= 0 && field.wavelengths.empty()) {
        const Vec3 q = field.moments.indexToWorld.inverse().apply(result.position);
        float c00[3];
        field.moments.sampleChannels(q, 0, 3, c00); // shIndex(0, 0) = 0: c_00 of R, G, B
        for (double c : c00)
            result.J.push_back(c / (2.0 * std::sqrt(PI))); // J = c_00 / (4 pi Y_00)
    }
    return result;
}

std::string cameraPathJson(const CameraPath& path)
{
    using nlohmann::json;
    json keys = json::array();
    for (const auto& k : path.keys) {
        keys.push_back({{"time", k.time},
                        {"eye", {k.eye.x, k.eye.y, k.eye.z}},
                        {"look_at", {k.lookAt.x, k.lookAt.y, k.lookAt.z}},
                        {"up", {k.up.x, k.up.y, k.up.z}},
                        {"fov_deg", k.fovDeg},
                        {"roll_deg", k.rollDeg}});
    }
    const json j = {{"version", CAMERA_PATH_VERSION},
                    {"fps", path.fps},
                    {"constant_speed", path.constantSpeed},
                    {"ease_in", path.easeIn},
                    {"ease_out", path.easeOut},
                    {"keyframes", keys}};
    return j.dump(2) + "\n";
}

void writeCameraPath(const std::string& file, const CameraPath& path)
{
    checkOutputName(file, "--path-out", FileFormat::Json);
    const std::string text = cameraPathJson(path);
    // What nebrender will read: the text must parse back to this path.
    const CameraPath back = parseCameraPath(text, file, Camera{});
    if (back.keys.size() != path.keys.size()) {
        throw Error(file + ": the camera path does not read back (" +
                    std::to_string(back.keys.size()) + " keyframes instead of " +
                    std::to_string(path.keys.size()) + ")");
    }
    AtomicFile out(file);
    out.stream() << text;
    out.commit();
}

} // namespace nebula
