// SPDX-License-Identifier: Apache-2.0
// nebview - explore a nebula live in a web page, and author camera paths there.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/cli/render_command.h"
#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/input.h"
#include "nebula/io/phase_table_vdb.h"
#include "nebula/serve/view_server.h"
#include "nebula/stages/framing.h"
#include "nebula/stages/view.h"

#include <fmt/format.h>

#include <cstdio>
#include <iostream>

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::ViewSettings settings;
    nebula::RenderOptions& opts = settings.render; // nebrender's defaults
    nebula::ViewServerOptions server;
    nebula::DustOptions dustOpts;
    nebula::cli::CameraOptions camera;
    camera.res = "512x512";
    camera.fitSize = true;
    std::string interactiveRes, phaseFile, listen, pathFile;
    bool noStars = false;
    int port = 0;

    CLI::App app{
        "nebview - explore a nebula live in a web page, and author camera paths there\n\n"
        "Examples:\n"
        "  nebview -i out/scattered.vdb                  # prints the URL to open\n"
        "  nebview -i out/scattered.vdb --path-out fly.json   # Save writes the path here\n"
        "  nebview -i s.vdb --camera-path fly.json --path-out fly.json   # edit a path\n"
        "  nebview -i s.vdb --res 1024x576 --port 8080\n"
        "  nebview -i s.vdb --listen 0.0.0.0:8080        # other machines too (a warning)\n\n"
        "Serves one page on 127.0.0.1 (a random free port unless --port) and prints its\n"
        "URL, with a random access token, as the first line of stdout: open it in a browser.\n"
        "The page shows the nebula as nebrender renders it, for a camera you move with the\n"
        "mouse (drag: orbit; right-drag or shift-drag: pan; wheel: zoom) and the keys (WASD,\n"
        "Q/E: fly). While it moves, frames come at the interactive resolution (half --res\n"
        "on each side) with the faster settings (the stars' optical depth from the tau grid,\n"
        "steps of --fast-step voxels, level of detail --fast-lod); when it stops, the full "
        "resolution with the same\n"
        "settings (preview), then nebrender's image for the camera (final). A newer camera\n"
        "cancels the frame in flight. The page switches the light's components (single\n"
        "scattering, nebscatter's field, the gas's glow, the stars, each star's light), sets\n"
        "the tone and camera model, probes the dust under a pixel, and authors camera paths:\n"
        "keyframes from the view, a timeline to scrub, Save to --path-out (the file\n"
        "nebrender --camera-path reads) or download. Every request needs the token; the\n"
        "only file nebview writes is --path-out. Ctrl-C stops it.",
        "nebview"};
    nebula::cli::addCommon(app, common, nebula::cli::INPUT | nebula::cli::DENSITY_GRID);
    app.add_option("--port", port, "Port on 127.0.0.1 (0: a free one)")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(0, 65535));
    auto* listenOpt = app.add_option("--listen", listen,
                                     "ADDR:PORT to listen on instead of 127.0.0.1 (other\n"
                                     "machines can then reach the viewer: a warning)");
    nebula::cli::outputFile(
        app.add_option("--path-out", server.pathOut,
                       "Where the page's Save writes the camera path (*.json; checked at\n"
                       "start: a regular file or a new name in a writable folder, not an input)"),
        nebula::FileFormat::Json);
    nebula::cli::inputFile(
        app.add_option("--camera-path", pathFile, "A camera path (JSON) to start with and edit"));
    app.add_option("--res", camera.res,
                   "Full resolution WxH of the preview and final frames (equirect: W x W/2;\n"
                   "fisheye: the smaller side squared)")
        ->capture_default_str();
    app.add_option("--interactive-res", interactiveRes,
                   "Resolution WxH of the frames while the camera moves (default: half --res)");
    app.add_option("--fast-step", settings.fastStep,
                   "Ray step of the interactive and preview frames [voxels]")
        ->capture_default_str()
        ->check(nebula::cli::positive());
    app.add_option("--fast-lod", settings.fastLod,
                   "Level of detail of the interactive frames (nebrender's --lod: a coarser\n"
                   "copy of the fields where its voxel spans at most this many pixels)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1e6));
    app.add_option("--jpeg-quality", server.jpegQuality, "JPEG quality of the frames (1-100)")
        ->capture_default_str()
        ->check(nebula::cli::integerIn(1, 100));
    nebula::cli::addCamera(app, camera, "Starting ", /*withRes=*/false);
    app.add_option("--step", opts.step, "Ray step of the final frames [voxels] (nebrender's)")
        ->capture_default_str()
        ->check(nebula::cli::positive());
    app.add_option("--lod", opts.lod, "Level of detail (nebrender's --lod)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 1e6));
    app.add_option("--lod-tau", opts.lodMaxDepth,
                   "Level of detail in thick dust (nebrender's --lod-tau)")
        ->capture_default_str()
        ->check(nebula::cli::positive());
    nebula::cli::addVec3(app, "--wavelengths", opts.wavelengths,
                         "R,G,B channel wavelengths [nm] for the extinction curve");
    nebula::cli::addEmissionAndStars(app, opts, noStars);
    nebula::cli::addDust(app, dustOpts, /*withKappa=*/false);
    nebula::cli::inputFile(
        app.add_option("--phase", phaseFile, "Effective phase-function table from nebphase"));
    app.add_option("--levels", opts.levels, "Pyramid levels with --phase (nebrender's)")
        ->check(nebula::cli::integerIn(0, 16));
    bool noScatterField = false, interpolatedTau = false;
    app.add_flag("--interpolated-tau", interpolatedTau,
                 "Final frames too take the stars' optical depth from the tau grid");
    app.add_flag("--no-scatter-field", noScatterField,
                 "Ignore the input's scattered-light field (nebscatter)");
    nebula::ToneOptions toneOpts;
    nebula::cli::addTone(app, settings.tone, toneOpts, "The page's starting tone: ");

    return nebula::cli::run(app, "nebview", common, argc, argv, [&](nebula::Run& run) {
        nebula::cli::refuseSharedStream({{"-i", common.input}, {"--phase", phaseFile}}, "stdin");
        if (!interactiveRes.empty()) {
            nebula::cli::parseResolution(interactiveRes, settings.interactiveWidth,
                                         settings.interactiveHeight);
        }
        server.port = std::uint16_t(port);
        if (listenOpt->count() > 0) nebula::cli::parseListen(listen, server.address, server.port);
        // Refused now, not at the first save.
        if (!server.pathOut.empty()) nebula::checkOutputTarget(server.pathOut, "--path-out");
        opts.camera = nebula::cli::makeCamera(camera);
        if (!pathFile.empty())
            server.path = nebula::cli::readCameraPathOption(pathFile, opts.camera);
        opts.drawStars = !noStars;
        opts.scatterField = !noScatterField;
        opts.exactStarDepth = !interpolatedTau;
        toneOpts.apply(settings.tone);
        if (!phaseFile.empty()) {
            opts.phaseTable = std::make_shared<const nebula::PhaseTable>(
                nebula::readPhaseTable(nebula::readGrids(phaseFile, run, "--phase")));
            opts.phaseSource = phaseFile;
        }
        auto grids = std::make_shared<const nebula::GridSet>(nebula::readGrids(common.input, run));
        const auto dust = dustOpts.apply(grids->dust(run));
        opts.densityGrid = common.densityGrid;
        if (camera.frameNebula) { // the starting view
            opts.camera =
                nebula::frameNebula(*grids, opts.densityGrid, opts.camera,
                                    nebula::cli::framingChoice(camera, !pathFile.empty()), run);
        }
        const nebula::ViewSession session(grids, settings, dust, run);
        nebula::ViewServer viewer(session, server, run);
        if (server.address != "127.0.0.1" && server.address != "::1" &&
            server.address != "localhost") {
            run.warn("listening on " + server.address +
                     ": other machines can reach this viewer (anyone with the token can "
                     "see the nebula and write --path-out)");
        }
        std::cout << viewer.url() << std::endl; // the first line: scripts read it
        run.info(fmt::format("serving {} on port {}", common.input, viewer.port()));
        viewer.run();
    });
}
