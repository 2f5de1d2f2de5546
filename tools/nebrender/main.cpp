// SPDX-License-Identifier: Apache-2.0
// nebrender - single-scattering ray caster: scattered starlight + gas emission to EXR/PNG.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/frames.h"
#include "nebula/core/input.h"
#include "nebula/io/phase_table_vdb.h"
#include "nebula/stages/render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace {

/// The nearest an orthographic observer may be [pc]: 0.2 au. Nearer, a star's flux
/// L / (4 pi D^2) is no telescope's (and D^2 underflows long before D does).
constexpr double MIN_OBSERVER_DISTANCE_PC = 1e-6;

/// Throws UsageError naming --distance unless the orthographic observer is at least a pixel
/// away (a pixel spans at most a radian: its solid angle (pixel / D)^2 at most a steradian)
/// and MIN_OBSERVER_DISTANCE_PC: --distance 1e-300 overflowed the stars' sprites, and the
/// error blamed their luminosity.
void checkObserverDistance(const nebula::Camera& camera)
{
    if (camera.model != nebula::CameraModel::Orthographic) return;
    const double d = camera.observerDistance(), p = camera.orthographicPixel();
    if (d >= std::max(p, MIN_OBSERVER_DISTANCE_PC)) return;
    const std::string what = std::isnan(camera.distancePc)
                                 ? "the observer's distance (--distance; default |--look-at - "
                                   "--eye|)"
                                 : "--distance";
    throw nebula::UsageError(fmt::format(
        "{} {} pc is too near: the orthographic observer must be at least a pixel ({} pc: a "
        "pixel spans at most a radian) and {} pc away, for the pixels' solid angles and the "
        "stars' fluxes L / (4 pi D^2)",
        what, nebula::detail::numberText(d), nebula::detail::numberText(p),
        nebula::detail::numberText(MIN_OBSERVER_DISTANCE_PC)));
}

} // namespace

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::RenderOptions opts; // every default lives here
    nebula::RenderOutput out;
    nebula::DustOptions dustOpts;
    std::string res, phaseFile;
    bool noStars = false, noPng = false;

    CLI::App app{
        "nebrender - render a nebula: starlight scattered by dust, plus gas emission\n\n"
        "Examples:\n"
        "  nebrender -i lit.vdb -o frame.exr                 # also writes frame.png\n"
        "  nebscatter -i lit.vdb -o s.vdb && nebrender -i s.vdb -o f.exr  # all orders\n"
        "  nebrender -i lit.vdb --eye 0,0,-25 --look-at 0,0,0 --fov 40 --res 1024x768 -o f.exr\n"
        "  nebrender -i lit.vdb --rv 5 --albedo 0.6 --g 0.6 -o rv5.exr\n"
        "  nebphase -i lit.vdb -o phase.vdb && nebrender -i lit.vdb --phase phase.vdb -o f.exr\n"
        "  nebrender -i lit.vdb --integrator path --spp 256 -o reference.exr\n"
        "  nebrender -i lit.vdb --camera fisheye --eye 0,0,-5 --res 1024x1024 -o dome.exr\n"
        "  nebrender -i lit.vdb --camera equirect --eye 0,0,-5 --res 2048x1024 -o 360.exr\n"
        "  nebrender -i lit.vdb --spectral -o spectral.exr      # lines, black bodies, Doppler\n"
        "  nebrender -i shell.vdb --spectral --exaggerate-velocity 50 --spectral-layers 47 -o "
        "d.exr\n"
        "  nebgen -o - | nebillum -i - -o - | nebrender -i - -o frame.exr\n\n"
        "Needs the density grid, the tau.<star> grids from nebillum and nebula:stars;\n"
        "uses the emission grid if present, and nebscatter's scattered-light field if present\n"
        "(the light scattered more than once, right at every optical depth). EXR: linear radiance "
        "[L_sun pc^-2 sr^-1], R,G,B,A\n"
        "(A = 1 - transmittance), layers star.<name>.R/G/B and transmittance.R/G/B (and\n"
        "variance.R/G/B, the squared standard error of each pixel, with --integrator path).\n"
        "PNG: sRGB after the automatic exposure and tone curve (or --exposure).\n"
        "--spectral: spectra per ray (360-830 nm) instead of R,G,B: line emission from each\n"
        "emission grid's nebula:lines (Doppler-shifted by the velocity grid, v_r > 0\n"
        "receding: lambda' = lambda (1 + v_r/c)), black-body (Kirchhoff) emission from the\n"
        "temperature grid, starlight scattered by dust with the extinction curve at every\n"
        "wavelength (and more than once from nebscatter --spectral's field, if present);\n"
        "colour = CIE 1931 XYZ -> linear sRGB (may be negative out of gamut).",
        "nebrender"};
    nebula::cli::addCommon(app, common, nebula::cli::INPUT | nebula::cli::DENSITY_GRID);
    using nebula::FileFormat;
    nebula::cli::outputFile(app.add_option("-o,--output", out.exr, "Output EXR file")->required(),
                            FileFormat::Exr);
    nebula::cli::outputFile(
        app.add_option("--png", out.png, "Output PNG (default: the EXR name with .png)"),
        FileFormat::Png);
    nebula::cli::outputFile(
        app.add_option(
            "--fits", out.fits.path,
            "Also a calibrated FITS image: surface brightness at each --wavelengths\n"
            "(monochromatic; stars as black bodies of bolometric luminosity; the EXR\n"
            "then holds spectral radiance per nm), components TOTAL, DIRECT, SCATTERED,\n"
            "SINGLE, FIELD as HDUs (see --fits-layout); --camera orthographic (or\n"
            "perspective with --sky). With --spectral: cubes of --spectral-layers bands\n"
            "(47 of 10 nm if not given) on a linear WAVE axis, and EMISSION, the gas's\n"
            "lines calibrated (grid x --emission-scale = their emissivity, L_sun pc^-3\n"
            "sr^-1)"),
        FileFormat::Fits);
    nebula::cli::outputFile(
        app.add_option("--sed", out.fits.sed,
                       "Also the SED: flux density at the observer [Jy] per component at each\n"
                       "wavelength, as CSV (also the table SED of --fits); calibrated like --fits"),
        FileFormat::Csv);
    app.add_option("--fits-unit", out.fits.unit, "FITS unit: MJy/sr or W/m2/sr/nm")
        ->capture_default_str();
    std::string fitsLayout = "planes";
    app.add_option("--fits-layout", fitsLayout,
                   "FITS in RGB mode: planes = one 2-D image per component and wavelength\n"
                   "(EXTNAME the component, EXTVER 1..3 in ascending wavelength, WAVELEN [nm]),\n"
                   "each opens with a plain astropy WCS(header); tab = one cube per component\n"
                   "on a WAVE-TAB axis (Greisen et al. 2006), which needs WCS(header, hdul)")
        ->check(CLI::IsMember({"planes", "tab"}))
        ->capture_default_str();
    std::vector<double> sky;
    auto* skyOpt = app.add_option("--sky", sky,
                                  "FITS: the look-at point's RA,DEC [degrees, ICRS]: a celestial\n"
                                  "TAN WCS (without it: offsets in pc)")
                       ->delimiter(',')
                       ->expected(2)
                       ->type_name("RA,DEC");
    app.add_option("--position-angle", out.fits.positionAngle,
                   "FITS: the image's up on the sky [degrees from north through east]; 0: north\n"
                   "up, east left")
        ->capture_default_str();
    app.add_flag("--no-png", noPng, "Write no PNG");
    app.add_option("--png-bits", out.pngBits, "PNG bit depth: 8 or 16")
        ->check(CLI::IsMember({8, 16}))
        ->capture_default_str();
    nebula::cli::addVec3(app, "--eye", opts.camera.eye, "Camera position [pc]");
    nebula::cli::addVec3(app, "--look-at", opts.camera.lookAt, "Point the camera looks at [pc]");
    nebula::cli::addVec3(app, "--up", opts.camera.up, "Up direction");
    std::string cameraModel = "perspective";
    app.add_option("--camera", cameraModel,
                   "perspective; fisheye: an azimuthal-equidistant dome master (square, the\n"
                   "view inside the circle, --fov the full angle); equirect: a 360 x 180\n"
                   "latitude-longitude panorama (2:1), the view direction at the centre;\n"
                   "orthographic: a telescope's parallel view along --eye -> --look-at, the rays\n"
                   "starting on the plane through --eye (put it outside the nebula); ods:\n"
                   "omni-directional stereo, two equirect panoramas (left eye on top, square\n"
                   "image) from eyes --ipd apart")
        ->check(CLI::IsMember({"perspective", "fisheye", "equirect", "orthographic", "ods"}))
        ->capture_default_str();
    auto* fovOpt = app.add_option("--fov", opts.camera.fovDeg,
                                  "Field of view [degrees]: perspective: horizontal, in (0, 179]\n"
                                  "(default 36); fisheye: the circle's full angle, up to 360\n"
                                  "(default 180); equirect: always 360 x 180")
                       ->check(nebula::cli::numberIn(0.01, 360.0));
    app.add_option("--roll", opts.camera.rollDeg,
                   "Turn the camera about its view direction [degrees], clockwise as seen\n"
                   "from behind it (the picture turns counter-clockwise)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(-360.0, 360.0));
    app.add_option("--dome-tilt", opts.camera.domeTiltDeg,
                   "Fisheye: a planetarium dome tilted T degrees, the audience facing\n"
                   "--look-at: the dome's centre is --up tipped T towards the view direction\n"
                   "(0 a horizontal dome: the look-at point on the bottom edge; 90 the same as\n"
                   "no tilt: the centre at --look-at)")
        ->check(nebula::cli::numberIn(0.0, 90.0));
    app.add_option("--ipd", opts.camera.ipdPc,
                   "ODS: the inter-pupillary distance [pc] (required; about 1/30 of the distance\n"
                   "to the nebula gives a comfortable depth)");
    std::vector<double> poleMerge;
    app.add_option("--pole-merge", poleMerge,
                   "ODS: the latitudes FROM,TO [degrees] between which the IPD fades to 0, so\n"
                   "the poles have no parallax (default 60,75)")
        ->delimiter(',')
        ->expected(2)
        ->type_name("FROM,TO");
    std::string pixelSizeText;
    app.add_option("--pixel-size", pixelSizeText,
                   "Orthographic: the pixel's size, 0.01pc (pc if no unit) or, with --distance,\n"
                   "2arcsec (default: the width --fov spans at --look-at, over the width)");
    app.add_option("--distance", opts.camera.distancePc,
                   "Orthographic: the observer's distance [pc]: pixel solid angles (pixel /\n"
                   "distance)^2, star fluxes, arcsec pixels, fluxes in --sed (default: the\n"
                   "distance from --eye to --look-at); at least a pixel and 1e-6 pc");
    std::string pathFile, frameText, framesText;
    auto* pathOpt = nebula::cli::inputFile(
        app.add_option("--camera-path", pathFile,
                       "Keyframed camera path (JSON: fps, keyframes of time, eye,\n"
                       "look_at, up, fov, roll; see the README); renders its frames,\n"
                       "all of them unless --frame or --frames"));
    auto* frameOpt =
        app.add_option("--frame", frameText, "With --camera-path: render frame N (1 = time 0)");
    app.add_option("--frames", framesText,
                   "With --camera-path: render frames A-B[:STEP] in one process (the scene is\n"
                   "loaded once); -o (and --png) then need a frame pattern: f.####.exr or\n"
                   "f.%04d.exr; at most 1e6 frames in one range")
        ->excludes(frameOpt);
    app.add_flag("--skip-existing", out.skipExisting,
                 "Skip frames whose EXR (and PNG) exist and read back whole: a killed batch\n"
                 "resumes where it stopped");
    app.add_option("--res", res,
                   "Image size WxH, each in [1, 65536] (default 512x512; equirect 1024x512), as\n"
                   "far as the image fits in memory");
    app.add_option("--step", opts.step,
                   "Ray step [voxels]; at most 1e6 steps across the grid's diagonal")
        ->capture_default_str()
        ->check(nebula::cli::positive());
    app.add_option("--lod", opts.lod,
                   "Level of detail (fast integrator): sample a copy of the fields at 2^L times\n"
                   "the voxel (L <= 3) where its voxel spans at most LOD pixels, in steps of\n"
                   "--step of its voxels; 0: full resolution everywhere")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1e6));
    auto* wavelengthsOpt =
        nebula::cli::addVec3(app, "--wavelengths", opts.wavelengths,
                             "R,G,B channel wavelengths [nm] for the extinction curve (and\n"
                             "--fits): in [0.001, 1e7), and 125-3333 with the CCM89 curve");
    nebula::FilterOptions filterOpts;
    nebula::cli::addFilter(app, filterOpts,
                           "--fits and --sed give its band average, rendered at the band's three\n"
                           "quadrature wavelengths (with --spectral: from the spectral layers);\n"
                           "a field must be made with the same --filter");
    nebula::cli::addEmissionAndStars(app, opts, noStars);
    nebula::cli::addDust(app, dustOpts, /*withKappa=*/false);
    nebula::cli::inputFile(app.add_option(
        "--phase", phaseFile,
        "Effective phase-function table from nebphase: scattering uses Phi(t, mu) of\n"
        "each voxel's optical thickness t (multiple scattering inside voxels) instead\n"
        "of the single-scattering a*p(mu)"));
    std::string phaseUse = "gain";
    app.add_option("--phase-use", phaseUse,
                   "How --phase enters: gain = a p(mu) times the voxel's multiple-scattering\n"
                   "gain Phi/Phi_1 (the ray caster supplies the extinction); replace = Phi itself\n"
                   "(DESIGN section 4 literally; extinction inside the voxel counted twice)")
        ->check(CLI::IsMember({"gain", "replace"}))
        ->capture_default_str();
    app.add_option("--levels", opts.levels,
                   "Global scattering from nebpyramid's levels 1..K (needs --phase): each adds\n"
                   "the change of the voxel scattering as the voxel doubles (default: with\n"
                   "--phase, every level the input has; 0: none)")
        ->check(nebula::cli::integerIn(0, 16));
    bool noScatterField = false, interpolatedTau = false;
    app.add_flag("--interpolated-tau", interpolatedTau,
                 "Take each star's optical depth from the trilinear tau grid everywhere, instead\n"
                 "of exactly through the cells where it bends (faster; too dark at the lit face\n"
                 "of optically thick voxels)");
    app.add_flag("--no-scatter-field", noScatterField,
                 "Ignore the input's scattered-light field (nebscatter): single scattering,\n"
                 "or --phase and --levels");
    std::string integrator = "fast";
    app.add_option("--integrator", integrator,
                   "fast: ray caster (single scattering, or --phase); path: reference Monte\n"
                   "Carlo path tracer, all orders of scattering (--spp, --seed)")
        ->check(CLI::IsMember({"fast", "path"}))
        ->capture_default_str();
    app.add_option("--spp", opts.spp,
                   "Path tracer: random walks per pixel (one serves R, G and B); --spp x the\n"
                   "pixels at most 1e10, a work bound refused with its estimate")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(1, 1 << 30));
    app.add_option("--seed", opts.seed, "Path tracer: random seed (same seed, same image)")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(0, UINT64_MAX));
    app.add_flag(
        "--phase-ignore-dust", opts.phaseIgnoreDust,
        "Use the --phase table even if its albedo, g or phase model differ from the dust's");
    auto& sp = opts.spectral;
    auto* spectral = app.add_option_group("Spectral", "Spectral rendering (DESIGN section 7)");
    spectral->add_flag("--spectral", sp.enabled,
                       "Render spectra: piecewise-linear (exact Doppler trapezoids) by default");
    auto* bandsOpt =
        spectral
            ->add_option("--bands", sp.bands,
                         "Fixed-band mode instead: N bands over 360-830 nm, point-sampled at\n"
                         "their centres (for comparison; implies --spectral)")
            ->check(nebula::cli::integerIn(1, nebula::MAX_SPECTRAL_BANDS));
    std::vector<CLI::Option*> spectralOnly;
    spectralOnly.push_back(spectral
                               ->add_option("--continuum-step", sp.continuumStep,
                                            "Piecewise-linear mode: continuum node spacing [nm]")
                               ->capture_default_str()
                               ->check(nebula::cli::numberIn(nebula::MIN_CONTINUUM_STEP, 50.0)));
    spectralOnly.push_back(
        spectral
            ->add_option("--exaggerate-velocity", sp.exaggerateVelocity,
                         "Multiply every velocity by F before the Doppler shift (visualisation):\n"
                         "the velocity grid and the line width alike")
            ->capture_default_str()
            ->check(nebula::cli::positive()));
    spectralOnly.push_back(
        spectral->add_flag("--relativistic", sp.relativistic,
                           "Relativistic Doppler factor gamma (1 + v_r/c): gas moving across the\n"
                           "line of sight is red-shifted too (default: first order, 1 + v_r/c)"));
    spectralOnly.push_back(
        spectral
            ->add_option("--line-width", sp.lineWidth,
                         "Half-width of each line's rest-frame box profile [km/s] (thermal and\n"
                         "turbulent broadening)")
            ->capture_default_str()
            ->check(nebula::cli::positive()));
    spectralOnly.push_back(spectral->add_option(
        "--lines", sp.lines,
        "Lines of the emission grid, e.g. H-alpha:1,H-beta:0.35,[O III]5007:0.5\n"
        "(overrides its nebula:lines; default H-alpha:1,H-beta:0.35)"));
    spectralOnly.push_back(
        spectral
            ->add_option("--blackbody-scale", sp.blackbodyScale,
                         "Multiply the black-body emission (1 = Kirchhoff's law, physical)")
            ->capture_default_str()
            ->check(nebula::cli::numberIn(0.0, 1e6)));
    spectralOnly.push_back(
        spectral
            ->add_option("--temperature-scale", sp.temperatureScale,
                         "Multiply the temperature grid (visualisation of cold dust)")
            ->capture_default_str()
            ->check(nebula::cli::positive()));
    spectralOnly.push_back(
        spectral->add_option("--temperature-grid", sp.temperatureGrid, "Temperature grid [K]")
            ->capture_default_str());
    spectralOnly.push_back(spectral
                               ->add_option("--velocity-grid", sp.velocityGrid,
                                            "Velocity grid (Vec3f, km/s, world axes)")
                               ->capture_default_str());
    spectralOnly.push_back(
        spectral
            ->add_option("--spectral-layers", sp.layers,
                         "Also write N spectral EXR channels S0.<centre>nm: mean radiance per nm\n"
                         "in N equal bands over 360-830 nm")
            ->check(nebula::cli::integerIn(1, 470)));
    spectralOnly.push_back(spectral->add_flag(
        "--count-pieces", sp.countPieces,
        "Assemble each ray's piecewise-linear spectrum and report its piece count\n"
        "with -v (slower; for benchmarks)"));
    spectralOnly.push_back(
        spectral
            ->add_option("--merge-tolerance", sp.mergeTolerance,
                         "With --count-pieces: also count the pieces left after merging\n"
                         "neighbours under this relative tolerance (Spectrum::merge)")
            ->check(nebula::cli::numberIn(0.0, 1.0)));
    nebula::ToneOptions toneOpts;
    nebula::cli::addTone(app, out.tone, toneOpts, "PNG: ");

    return nebula::cli::run(app, "nebrender", common, argc, argv, [&](nebula::Run& run) {
        nebula::cli::refuseSharedStream({{"-i", common.input}, {"--phase", phaseFile}}, "stdin");
        opts.camera.model = nebula::cameraModelFromString(cameraModel);
        if (fovOpt->count() == 0 && opts.camera.model == nebula::CameraModel::Fisheye) {
            opts.camera.fovDeg = 180.0;
        }
        if (!res.empty()) {
            nebula::cli::parseResolution(res, opts.camera.width, opts.camera.height);
        } else if (opts.camera.model == nebula::CameraModel::Equirect) {
            opts.camera.width = 2 * opts.camera.height;
        }
        if (poleMerge.size() == 2) {
            opts.camera.poleMergeFromDeg = poleMerge[0];
            opts.camera.poleMergeToDeg = poleMerge[1];
        }
        if (!pixelSizeText.empty()) {
            opts.camera.pixelSizePc =
                nebula::cli::parsePixelSize(pixelSizeText, opts.camera.distancePc);
        }
        nebula::validateCamera(opts.camera);
        checkObserverDistance(opts.camera);
        if (pathOpt->count() > 0) {
            nebula::InputSpec spec;
            spec.option = "--camera-path";
            spec.format = "a JSON file";
            spec.head = nebula::jsonHead("{", "a camera path (a JSON object)");
            auto path = std::make_shared<nebula::CameraPath>(nebula::parseCameraPath(
                nebula::readInput(pathFile, spec), nebula::inputName(pathFile), opts.camera));
            nebula::FrameRange range{1, path->frameCount(), 1};
            if (!frameText.empty()) {
                range = nebula::parseFrameRange(frameText, "--frame");
                if (frameText.find_first_not_of("0123456789") != std::string::npos) {
                    throw nebula::UsageError("--frame takes one frame number; for a range use "
                                             "--frames A-B[:STEP]");
                }
            } else if (!framesText.empty()) {
                range = nebula::parseFrameRange(framesText, "--frames");
            }
            // The first frame of the range beyond the path's end, found before the frames are
            // listed.
            const long n = path->frameCount();
            const long beyond =
                range.first > n ? range.first
                                : range.first + ((n - range.first) / range.step + 1) * range.step;
            if (beyond <= range.last) {
                throw nebula::UsageError("frame " + std::to_string(beyond) +
                                         " is beyond the end of " + pathFile + ", which has " +
                                         std::to_string(n) + " frames at " +
                                         fmt::format("{:g}", path->fps) + " fps");
            }
            out.frames = range.frames();
            out.path = path;
        } else if (!frameText.empty() || !framesText.empty()) {
            throw nebula::UsageError("--frame and --frames need a --camera-path");
        }
        if (skyOpt->count() > 0) {
            out.fits.sky = true;
            out.fits.ra = sky.at(0);
            out.fits.dec = sky.at(1);
        }
        out.fits.layout =
            fitsLayout == "tab" ? nebula::FitsLayout::Tab : nebula::FitsLayout::Planes;
        if (const auto band = nebula::cli::loadFilter(filterOpts)) {
            if (!nebula::calibrated(out.fits)) {
                throw nebula::UsageError("--filter and --filter-file need --fits or --sed");
            }
            opts.wavelengths = nebula::cli::filterWavelengths(*band, wavelengthsOpt->count() > 0);
            out.fits.filter = *band;
        }
        opts.drawStars = !noStars;
        opts.scatterField = !noScatterField;
        opts.exactStarDepth = !interpolatedTau;
        if (bandsOpt->count() > 0) sp.enabled = true;
        nebula::cli::requireMode(spectralOnly, sp.enabled, "--spectral");
        opts.integrator =
            integrator == "path" ? nebula::Integrator::Path : nebula::Integrator::Fast;
        opts.phaseUse = phaseUse == "replace" ? nebula::PhaseUse::Replace : nebula::PhaseUse::Gain;
        if (noPng) out.png = "none";
        if (out.png.empty()) { // the PNG the EXR's name gives: checked as the outputs named
            nebula::cli::checkFileOptions(
                app, common,
                {{"the PNG (-o's name with .png)", nebula::pngPath(out), true, FileFormat::Png}});
        }
        toneOpts.apply(out.tone);
        if (!phaseFile.empty()) {
            opts.phaseTable = std::make_shared<const nebula::PhaseTable>(
                nebula::readPhaseTable(nebula::readGrids(phaseFile, run, "--phase")));
            opts.phaseSource = phaseFile;
        }
        const auto grids = nebula::readGrids(common.input, run);
        const auto dust = dustOpts.apply(grids.dust(run));
        // The channels' wavelengths, blaming the option that set them.
        nebula::checkChannelWavelengths(
            opts.wavelengths, dust,
            !filterOpts.file.empty()
                ? "--filter-file " + filterOpts.file + " (the band's quadrature wavelengths)"
            : !filterOpts.name.empty()
                ? "--filter " + filterOpts.name + " (the band's quadrature wavelengths)"
                : std::string("--wavelengths"));
        opts.densityGrid = common.densityGrid;
        nebula::renderToFiles(grids, opts, dust, out, run);
    });
}
