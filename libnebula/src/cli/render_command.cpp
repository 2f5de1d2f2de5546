// SPDX-License-Identifier: Apache-2.0
/// @file render_command.cpp
/// nebrender's options and run (cli/render_command.h).
#include "nebula/cli/render_command.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/frames.h"
#include "nebula/core/input.h"
#include "nebula/io/phase_table_vdb.h"
#include "nebula/render/integrator.h"
#include "nebula/stages/framing.h"

#include <fmt/format.h>

#include <cstdint>
#include <map>

namespace nebula::cli {

namespace {

/// The integrators --integrator NAME chooses (the registry's; --spectral chooses its own).
std::vector<std::string> commandLineIntegrators()
{
    const std::string prefix = "--integrator ";
    std::vector<std::string> names;
    for (const IntegratorType* t : integratorTypes()) {
        if (t->chosenBy.rfind(prefix, 0) == 0) names.push_back(t->chosenBy.substr(prefix.size()));
    }
    return names;
}

} // namespace

std::shared_ptr<CameraPath> readCameraPathOption(const std::string& file, const Camera& defaults)
{
    InputSpec spec;
    spec.option = "--camera-path";
    spec.format = "a JSON file";
    spec.head = jsonHead("{", "a camera path (a JSON object)");
    return std::make_shared<CameraPath>(
        parseCameraPath(readInput(file, spec), inputName(file), defaults));
}

namespace {

/// The outputs: -o, --png, --fits and --sed, and how they are written.
void addOutputOptions(CLI::App& app, RenderCommand& c)
{
    outputFile(app.add_option("-o,--output", c.out.exr, "Output EXR file")->required(),
               FileFormat::Exr);
    outputFile(app.add_option("--png", c.out.png, "Output PNG (default: the EXR name with .png)"),
               FileFormat::Png);
    outputFile(app.add_option(
                   "--fits", c.out.fits.path,
                   "Also a calibrated FITS image: surface brightness at each --wavelengths\n"
                   "(monochromatic; stars as black bodies of bolometric luminosity; the EXR\n"
                   "then holds spectral radiance per nm), components TOTAL, DIRECT, SCATTERED,\n"
                   "SINGLE, FIELD as HDUs (see --fits-layout); --camera orthographic (or\n"
                   "perspective with --sky). With --spectral: cubes of --spectral-layers bands\n"
                   "(47 of 10 nm if not given) on a linear WAVE axis, and EMISSION, the gas's\n"
                   "lines calibrated (grid x --emission-scale = their emissivity, L_sun pc^-3\n"
                   "sr^-1)"),
               FileFormat::Fits);
    outputFile(
        app.add_option("--sed", c.out.fits.sed,
                       "Also the SED: flux density at the observer [Jy] per component at each\n"
                       "wavelength, as CSV (also the table SED of --fits); calibrated like --fits"),
        FileFormat::Csv);
    app.add_option("--fits-unit", c.out.fits.unit, "FITS unit: MJy/sr or W/m2/sr/nm")
        ->capture_default_str();
    app.add_option("--fits-layout", c.fitsLayout,
                   "FITS in RGB mode: planes = one 2-D image per component and wavelength\n"
                   "(EXTNAME the component, EXTVER 1..3 in ascending wavelength, WAVELEN [nm]),\n"
                   "each opens with a plain astropy WCS(header); tab = one cube per component\n"
                   "on a WAVE-TAB axis (Greisen et al. 2006), which needs WCS(header, hdul)")
        ->check(CLI::IsMember({"planes", "tab"}))
        ->capture_default_str();
    c.skyOption = app.add_option("--sky", c.sky,
                                 "FITS: the look-at point's RA,DEC [degrees, ICRS]: a celestial\n"
                                 "TAN WCS (without it: offsets in pc)")
                      ->delimiter(',')
                      ->expected(2)
                      ->type_name("RA,DEC");
    app.add_option("--position-angle", c.out.fits.positionAngle,
                   "FITS: the image's up on the c.sky [degrees from north through east]; 0: north\n"
                   "up, east left")
        ->capture_default_str();
    app.add_flag("--no-png", c.noPng, "Write no PNG");
    app.add_option("--png-bits", c.out.pngBits, "PNG bit depth: 8 or 16")
        ->check(CLI::IsMember({8, 16}))
        ->capture_default_str();
}

/// The camera, frames, ray march, light, dust, phase table and integrator.
void addSceneOptions(CLI::App& app, RenderCommand& c)
{
    addCamera(app, c.camera);
    inputFile(app.add_option("--camera-path", c.pathFile,
                             "Keyframed camera path (JSON: fps, keyframes of time, eye,\n"
                             "look_at, up, fov, roll; see the README); renders its frames,\n"
                             "all of them unless --frame or --frames"));
    auto* frameOpt =
        app.add_option("--frame", c.frameText, "With --camera-path: render frame N (1 = time 0)");
    app.add_option("--frames", c.framesText,
                   "With --camera-path: render frames A-B[:STEP] in one process (the scene is\n"
                   "loaded once); -o (and --png) then need a frame pattern: f.####.exr or\n"
                   "f.%04d.exr; at most 1e6 frames in one range")
        ->excludes(frameOpt);
    app.add_flag("--skip-existing", c.out.skipExisting,
                 "Skip frames whose EXR (and PNG) exist and read back whole: a killed batch\n"
                 "resumes where it stopped");
    app.add_option("--step", c.opts.step,
                   "Ray step [voxels]; at most 1e6 steps across the grid's diagonal")
        ->capture_default_str()
        ->check(positive());
    app.add_option("--lod", c.opts.lod,
                   "Level of detail (fast integrator): sample a copy of the fields at 2^L times\n"
                   "the voxel (L <= 3) where its voxel spans at most LOD pixels, in steps of\n"
                   "--step of its voxels; 0: full resolution everywhere")
        ->capture_default_str()
        ->check(numberIn(0.0, 1e6));
    app.add_option("--lod-tau", c.opts.lodMaxDepth,
                   "Level of detail in thick dust: sample level L in an 8^3-voxel block only if\n"
                   "a level-L voxel of the densest dust near it has at most this optical depth\n"
                   "across (most opaque channel); thicker coarse voxels would change what the\n"
                   "dust transmits. Larger: faster and less exact (1e30: no limit)")
        ->capture_default_str()
        ->check(positive());
    c.wavelengthsOption = addVec3(app, "--wavelengths", c.opts.wavelengths,
                                  "R,G,B channel wavelengths [nm] for the extinction curve (and\n"
                                  "--fits): in [0.001, 1e7), and 125-3333 with the CCM89 curve");
    addFilter(app, c.filter,
              "--fits and --sed give its band average, rendered at the band's three\n"
              "quadrature wavelengths (with --spectral: from the spectral layers);\n"
              "a field must be made with the same --filter");
    addEmissionAndStars(app, c.opts, c.noStars);
    addDust(app, c.dust, /*withKappa=*/false);
    inputFile(app.add_option(
        "--phase", c.phaseFile,
        "Effective phase-function table from nebphase: scattering uses Phi(t, mu) of\n"
        "each voxel's optical thickness t (multiple scattering inside voxels) instead\n"
        "of the single-scattering a*p(mu)"));
    app.add_option("--phase-use", c.phaseUse,
                   "How --phase enters: gain = a p(mu) times the voxel's multiple-scattering\n"
                   "gain Phi/Phi_1 (the ray caster supplies the extinction); replace = Phi itself\n"
                   "(DESIGN section 4 literally; extinction inside the voxel counted twice)")
        ->check(CLI::IsMember({"gain", "replace"}))
        ->capture_default_str();
    app.add_option("--levels", c.opts.levels,
                   "Global scattering from nebpyramid's levels 1..K (needs --phase): each adds\n"
                   "the change of the voxel scattering as the voxel doubles (default: with\n"
                   "--phase, every level the input has; 0: none)")
        ->check(integerIn(0, 16));
    app.add_flag("--interpolated-tau", c.interpolatedTau,
                 "Take each star's optical depth from the trilinear tau grid everywhere, instead\n"
                 "of exactly through the cells where it bends: 5-20x faster on the presets at\n"
                 "128^3, the total light within 2 %, but up to 30 % moved between 8x8 blocks\n"
                 "(too deep at lit faces, around embedded stars): a draft (docs/accuracy.md)");
    app.add_flag("--no-scatter-field", c.noScatterField,
                 "Ignore the input's scattered-light field (nebscatter): single scattering,\n"
                 "or --phase and --levels");
    app.add_option("--integrator", c.integrator,
                   "fast: ray caster (single scattering, or --phase); path: reference Monte\n"
                   "Carlo path tracer, all orders of scattering (--spp, --seed)")
        ->check(CLI::IsMember(commandLineIntegrators()))
        ->capture_default_str();
    app.add_option("--spp", c.opts.spp,
                   "Path tracer: random walks per pixel (one serves R, G and B); --spp x the\n"
                   "pixels at most 1e10, a work bound refused with its estimate")
        ->capture_default_str()
        ->check(integerIn(1, 1 << 30));
    app.add_option("--seed", c.opts.seed, "Path tracer: random seed (same seed, same image)")
        ->capture_default_str()
        ->check(integerIn(0, UINT64_MAX));
    app.add_flag(
        "--phase-ignore-dust", c.opts.phaseIgnoreDust,
        "Use the --phase table even if its albedo, g or phase model differ from the dust's");
}

/// --spectral and the options of the spectral integrator.
void addSpectralOptions(CLI::App& app, RenderCommand& c)
{
    auto& sp = c.opts.spectral;
    auto* spectral = app.add_option_group("Spectral", "Spectral rendering (DESIGN section 7)");
    spectral->add_flag("--spectral", sp.enabled,
                       "Render spectra: piecewise-linear (exact Doppler trapezoids) by default;\n"
                       "emission grids (nebula:lines) emit, absorption.<species> grids\n"
                       "(nebula:absorption-lines) absorb, at their Doppler-shifted lines");
    c.bandsOption =
        spectral
            ->add_option("--bands", sp.bands,
                         "Fixed-band mode instead: N bands over 360-830 nm, point-sampled at\n"
                         "their centres (for comparison; implies --spectral)")
            ->check(integerIn(1, MAX_SPECTRAL_BANDS));
    spectral
        ->add_option("--continuum-step", sp.continuumStep,
                     "Piecewise-linear mode: continuum node spacing [nm]")
        ->capture_default_str()
        ->check(numberIn(MIN_CONTINUUM_STEP, 50.0));
    spectral
        ->add_option("--exaggerate-velocity", sp.exaggerateVelocity,
                     "Multiply every velocity by F before the Doppler shift (visualisation):\n"
                     "the velocity grid and the line width alike")
        ->capture_default_str()
        ->check(positive());
    spectral->add_flag("--relativistic", sp.relativistic,
                       "Relativistic Doppler factor gamma (1 + v_r/c): gas moving across the\n"
                       "line of sight is red-shifted too (default: first order, 1 + v_r/c)");
    spectral
        ->add_option("--line-width", sp.lineWidth,
                     "Half-width of each line's rest-frame box profile [km/s] (thermal and\n"
                     "turbulent broadening)")
        ->capture_default_str()
        ->check(positive());
    spectral->add_option("--lines", sp.lines,
                         "Lines of the emission grid, e.g. H-alpha:1,H-beta:0.35,[O III]5007:0.5\n"
                         "(overrides its nebula:lines; default H-alpha:1,H-beta:0.35)");
    spectral
        ->add_option("--blackbody-scale", sp.blackbodyScale,
                     "Multiply the black-body emission (1 = Kirchhoff's law, physical)")
        ->capture_default_str()
        ->check(numberIn(0.0, 1e6));
    spectral
        ->add_option("--temperature-scale", sp.temperatureScale,
                     "Multiply the temperature grid (visualisation of cold dust)")
        ->capture_default_str()
        ->check(positive());
    spectral->add_option("--temperature-grid", sp.temperatureGrid, "Temperature grid [K]")
        ->capture_default_str();
    spectral
        ->add_option("--velocity-grid", sp.velocityGrid, "Velocity grid (Vec3f, km/s, world axes)")
        ->capture_default_str();
    spectral
        ->add_option("--spectral-layers", sp.layers,
                     "Also write N spectral EXR channels S0.<centre>nm: mean radiance per nm\n"
                     "in N equal bands over 360-830 nm")
        ->check(integerIn(1, 470));
    spectral->add_flag("--count-pieces", sp.countPieces,
                       "Assemble each ray's piecewise-linear spectrum and report its piece count\n"
                       "with -v (slower; for benchmarks)");
    spectral
        ->add_option("--merge-tolerance", sp.mergeTolerance,
                     "With --count-pieces: also count the pieces left after merging\n"
                     "neighbours under this relative tolerance (Spectrum::merge)")
        ->check(numberIn(0.0, 1.0));
}

} // namespace

void addRenderCommand(CLI::App& app, RenderCommand& c)
{
    addCommon(app, c.common, INPUT | DENSITY_GRID);
    addOutputOptions(app, c);
    addSceneOptions(app, c);
    addSpectralOptions(app, c);
    addTone(app, c.out.tone, c.tone, "PNG: ");
    // The options of one integrator (or --spectral), from the registry: each is refused
    // with another (OptionScopes::check() in runRenderCommand()).
    std::map<std::string, std::vector<std::string>> scopes;
    for (const IntegratorType* t : integratorTypes()) {
        for (const std::string& option : t->options)
            scopes[option].push_back(t->chosenBy);
    }
    for (const auto& [option, by] : scopes)
        c.scopes.add(by, app.get_option(option));
}

void runRenderCommand(CLI::App& app, RenderCommand& c, Run& run)
{
    refuseSharedStream({{"-i", c.common.input}, {"--phase", c.phaseFile}}, "stdin");
    if (c.bandsOption->count() > 0) c.opts.spectral.enabled = true;
    c.opts.integrator = c.integrator;
    const IntegratorType& chosen = chosenIntegrator(c.opts);
    c.scopes.check({chosen.chosenBy}, chosen.chosenBy);
    c.opts.camera = makeCamera(c.camera);
    FramingChoice framing;
    if (c.camera.frameNebula) framing = framingChoice(c.camera, !c.pathFile.empty());
    if (!c.pathFile.empty()) {
        auto path = readCameraPathOption(c.pathFile, c.opts.camera);
        FrameRange range{1, path->frameCount(), 1};
        if (!c.frameText.empty()) {
            range = parseFrameRange(c.frameText, "--frame");
            if (c.frameText.find_first_not_of("0123456789") != std::string::npos) {
                throw UsageError("--frame takes one frame number; for a range use "
                                 "--frames A-B[:STEP]");
            }
        } else if (!c.framesText.empty()) {
            range = parseFrameRange(c.framesText, "--frames");
        }
        // The first frame of the range beyond the path's end, found before the frames are
        // listed.
        const long n = path->frameCount();
        const long beyond = range.first > n
                                ? range.first
                                : range.first + ((n - range.first) / range.step + 1) * range.step;
        if (beyond <= range.last) {
            throw UsageError("frame " + std::to_string(beyond) + " is beyond the end of " +
                             c.pathFile + ", which has " + std::to_string(n) + " frames at " +
                             fmt::format("{:g}", path->fps) + " fps");
        }
        c.out.frames = range.frames();
        c.out.path = path;
    } else if (!c.frameText.empty() || !c.framesText.empty()) {
        throw UsageError("--frame and --frames need a --camera-path");
    }
    if (c.skyOption->count() > 0) {
        c.out.fits.sky = true;
        c.out.fits.ra = c.sky.at(0);
        c.out.fits.dec = c.sky.at(1);
    }
    c.out.fits.layout = c.fitsLayout == "tab" ? FitsLayout::Tab : FitsLayout::Planes;
    if (const auto band = loadFilter(c.filter)) {
        if (!calibrated(c.out.fits)) {
            throw UsageError("--filter and --filter-file need --fits or --sed");
        }
        c.opts.wavelengths = filterWavelengths(*band, c.wavelengthsOption->count() > 0);
        c.out.fits.filter = *band;
    }
    c.opts.drawStars = !c.noStars;
    c.opts.scatterField = !c.noScatterField;
    c.opts.exactStarDepth = !c.interpolatedTau;
    c.opts.phaseUse = c.phaseUse == "replace" ? PhaseUse::Replace : PhaseUse::Gain;
    if (c.noPng) c.out.png = "none";
    if (c.out.png.empty()) { // the PNG the EXR's name gives: checked as the outputs named
        checkFileOptions(
            app, c.common,
            {{"the PNG (-o's name with .png)", pngPath(c.out), true, FileFormat::Png}});
    }
    c.tone.apply(c.out.tone);
    if (!c.phaseFile.empty()) {
        c.opts.phaseTable = std::make_shared<const PhaseTable>(
            readPhaseTable(readGrids(c.phaseFile, run, "--phase")));
        c.opts.phaseSource = c.phaseFile;
    }
    const auto grids = readGrids(c.common.input, run);
    const auto dust = c.dust.apply(grids.dust(run));
    // The channels' wavelengths, blaming the option that set them.
    checkChannelWavelengths(c.opts.wavelengths, dust,
                            !c.filter.file.empty() ? "--filter-file " + c.filter.file +
                                                         " (the band's quadrature wavelengths)"
                            : !c.filter.name.empty() ? "--filter " + c.filter.name +
                                                           " (the band's quadrature wavelengths)"
                                                     : std::string("--wavelengths"));
    c.opts.densityGrid = c.common.densityGrid;
    if (c.camera.frameNebula) {
        c.opts.camera = frameNebula(grids, c.opts.densityGrid, c.opts.camera, framing, run);
    }
    renderToFiles(grids, c.opts, dust, c.out, run);
}

} // namespace nebula::cli
