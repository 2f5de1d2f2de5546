// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file view.h
/// nebview's stage: a scene built once from the grids and rendered again and again for a
/// moving camera, at three stages of refinement, with the light's components kept apart so
/// that they can be switched on and off without a new render; the voxel probe; a camera path
/// as the JSON nebrender --camera-path reads. It knows no network: the server (serve/) asks it
/// for frames.

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"
#include "nebula/render/camera_path.h"
#include "nebula/render/options.h"
#include "nebula/render/scene.h"
#include "nebula/render/spectral.h"

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace nebula {

class StarDepth;

/// How refined a frame is. Interactive and Preview use the faster settings (the star's optical
/// depth from the trilinear tau grid, rays in steps of ViewSettings::fastStep voxels; the
/// interactive frames also a coarser level of detail, ViewSettings::fastLod);
/// Final is nebrender's image for the camera, pixel for pixel.
enum class ViewStage { Interactive, Preview, Final };

/// "interactive", "preview", "final".
std::string toString(ViewStage stage);

/// What nebview renders with: nebrender's settings (the final frames) and the faster ones.
struct ViewSettings
{
    /// nebrender's options; camera.width x camera.height is the full resolution (Preview and
    /// Final), and the camera the one the page starts with.
    RenderOptions render;
    /// The interactive frames' size; 0: half the full resolution on each side.
    int interactiveWidth = 0;
    int interactiveHeight = 0;
    /// Interactive and preview frames: the ray step [voxels].
    double fastStep = 1.0;
    /// Interactive frames: the level of detail (RenderOptions::lod), coarser than nebrender's
    /// 2 (a level-L voxel may span up to this many pixels).
    double fastLod = 8.0;
    ToneParams tone; ///< the tone nebview starts with (--exposure, --gamma, --percentile)
};

/// Which of the light's components a composed frame shows (fast integrator; a spectral frame
/// is shown whole).
struct ViewShow
{
    bool single = true;   ///< starlight scattered once
    bool field = true;    ///< starlight scattered more than once (nebscatter's field)
    bool emission = true; ///< the gas's glow
    bool sprites = true;  ///< the stars themselves (the direct starlight)
    /// Per star (RenderScene::stars order): its light, scattered once and direct; empty: all.
    std::vector<bool> stars;

    bool all() const;
};

/// A rendered frame with its parts kept apart.
struct ViewFrame
{
    ViewStage stage = ViewStage::Final;
    Camera camera; ///< with the stage's resolution
    bool spectral = false;
    /// Fast integrator: the beauty without the star sprites, with the layers "star.<name>"
    /// (each star's light scattered once), "transmittance", "field", "emission", "direct"
    /// (renderFrame()'s component layers). Spectral: renderSpectral()'s image, sprites drawn.
    Image image;
    RenderStats stats;
    double seconds = 0.0; ///< the render's wall time
};

/// What the voxel probe found along a pixel's ray.
struct ProbeResult
{
    bool hit = false;        ///< the ray's optical depth from the eye reached PROBE_TAU
    Vec3 position;           ///< [pc] where it did
    double density;          ///< n_H [cm^-3] there
    std::vector<double> tau; ///< tau_V from each star to there (exact: render/star_depth.h)
    /// The field's mean intensity J there [L_sun pc^-2 sr^-1] per channel; empty without an
    /// R, G, B field.
    std::vector<double> J;
    double tauRay = 0.0; ///< tau_V of the whole ray through the grid
};

/// The V-band optical depth from the eye at which the probe says the ray "hits" dust.
inline constexpr double PROBE_TAU = 0.05;

/// A scene for many frames (nebview). Thread-safe for const calls: frames and probes may run
/// while others do (the server runs one frame at a time, probes beside it).
class ViewSession
{
public:
    /// Builds the scene from @p grids (as nebrender does, with the same checks and messages);
    /// the spectral scene is built when a spectral frame is first asked for.
    ViewSession(std::shared_ptr<const GridSet> grids, const ViewSettings& settings,
                const DustParams& dust, const Run& run);
    ~ViewSession();
    ViewSession(const ViewSession&) = delete;
    ViewSession& operator=(const ViewSession&) = delete;

    const RenderScene& scene() const { return mScene; }
    const ViewSettings& settings() const { return mSettings; }
    const GridSet& grids() const { return *mGrids; }
    /// The size of a frame of @p stage.
    std::array<int, 2> resolution(ViewStage stage) const;
    /// The render options of a frame of @p stage for @p camera (its view; the stage's size,
    /// shaped for the model: equirect W x W/2, fisheye the smaller side squared).
    RenderOptions stageOptions(const Camera& camera, ViewStage stage, bool spectral) const;

    /// Renders @p camera's view (model, view, fov; the size comes from @p stage). Throws
    /// Cancelled if @p run is cancelled while rendering, UsageError for a camera nebrender
    /// would refuse.
    ViewFrame render(const Camera& camera, ViewStage stage, bool spectral, const Run& run) const;

    /// The frame's image with the components @p show asks for. With everything shown, the
    /// beauty nebrender writes (the sprites added the same way, so the same floats).
    Image compose(const ViewFrame& frame, const ViewShow& show) const;

    /// The voxel probe: along the ray through image point (@p px, @p py) of @p camera (at
    /// its own resolution), the first point where the optical depth from the eye reaches
    /// PROBE_TAU, marched in steps of a quarter voxel through the trilinear density.
    ProbeResult probe(const Camera& camera, double px, double py) const;

    /// Whether the input has nebscatter's R, G, B field, and an emission grid.
    bool hasField() const { return mScene.scatter.order >= 0; }
    bool hasEmission() const;

private:
    std::shared_ptr<const GridSet> mGrids;
    ViewSettings mSettings;
    DustParams mDust;
    RenderScene mScene;
    std::unique_ptr<StarDepth> mDepth;
    mutable std::mutex mSpectralMutex;
    mutable std::unique_ptr<SpectralScene> mSpectral;
};

/// The camera path's JSON, as parseCameraPath() reads it: fps, constant_speed, ease_in,
/// ease_out, and each keyframe's time, eye, look_at, up, fov and roll.
std::string cameraPathJson(const CameraPath& path);

/// Writes @p path to @p file through an AtomicFile (checked, atomic), after checking that it
/// parses back (parseCameraPath()) to the same keyframes. Throws Error naming @p file.
void writeCameraPath(const std::string& file, const CameraPath& path);

} // namespace nebula
