// SPDX-License-Identifier: Apache-2.0
// nebtone - display frames of an EXR sequence under one slowly changing tone curve.
#include "nebula/cli/cli.h"
#include "nebula/cli/options.h"
#include "nebula/core/error.h"
#include "nebula/core/frames.h"
#include "nebula/stages/tone.h"

#include <string>

int main(int argc, char** argv)
{
    nebula::CommonOptions common;
    nebula::ToneSequenceOptions opts; // every default lives here
    std::string framesText, window = "1";

    CLI::App app{
        "nebtone - PNG frames of a nebrender EXR sequence with a tone curve that does not\n"
        "flicker: each frame's white point and log-mean luminance (from its pixels) are\n"
        "averaged over the frames within the --window, and the automatic curve is computed\n"
        "from the averages (a static camera gets one curve). With a window, the gamma is\n"
        "the sequence's and each frame's white point stays within --adapt stops of the\n"
        "sequence's, so a dark interior stays dark. Every frame is read and\n"
        "checked before any PNG is written; a frame whose white point is a million-fold\n"
        "from the sequence's median is left out of the smoothing, with a warning.\n\n"
        "Examples:\n"
        "  nebtone -i 'frames/f.####.exr' -o 'display/f.####.png'\n"
        "  nebtone -i 'frames/f.%04d.exr' --frames 1-240 --window 2 --bits 16 -o 'd/f.%04d.png'\n"
        "  nebtone -i 'frames/f.####.exr' --window all -o 'd/f.####.png'   # one curve\n"
        "  nebtone -i 'frames/f.####.exr' --gamma 0.6 -o 'd/f.####.png'  # a preset's look",
        "nebtone"};
    nebula::cli::addCommon(app, common, 0);
    nebula::cli::inputFile(app.add_option("-i,--input", opts.input,
                                          "EXR frames: a name with a frame pattern (#### or %04d)")
                               ->required());
    nebula::cli::outputFile(
        app.add_option("-o,--output", opts.output,
                       "PNG frames: a name with a frame pattern, ending in .png")
            ->required(),
        nebula::FileFormat::Png);
    app.add_option("--frames", framesText,
                   "Frames A-B[:STEP] (default: every frame of the pattern that exists); at most\n"
                   "1e6 frames in one range");
    app.add_option("--window", window,
                   "Smoothing window [s]: Gaussian weights of standard deviation window/2 over\n"
                   "the frames' log white point and log-mean luminance; 0: every frame its own\n"
                   "curve; all: one curve for the whole sequence")
        ->capture_default_str();
    app.add_option("--adapt", opts.adaptStops,
                   "With a window: how far a frame's white point may move from the\n"
                   "sequence's, in stops each way (a dark interior is not lifted into haze)")
        ->capture_default_str()
        ->check(nebula::cli::numberIn(0.0, 64.0));
    app.add_option("--fps", opts.fps,
                   "Frames per second (default: the EXRs' nebula:frame, else 24)")
        ->check(nebula::cli::numberIn(1e-3, 1e4));
    app.add_option("--bits", opts.bits, "PNG bit depth: 8 or 16")
        ->check(CLI::IsMember({8, 16}))
        ->capture_default_str();
    nebula::ToneOptions tone; // --exposure, --gamma, --percentile: nebrender's
    nebula::cli::addTone(app, opts.tone, tone, "");
    app.add_flag("--skip-existing", opts.skipExisting,
                 "Skip frames whose PNG exists and decodes whole");

    return nebula::cli::run(app, "nebtone", common, argc, argv, [&](nebula::Run& run) {
        tone.apply(opts.tone);
        if (!framesText.empty()) {
            opts.frames = nebula::parseFrameRange(framesText, "--frames").frames();
        }
        if (window == "all") {
            opts.whole = true;
        } else {
            std::size_t used = 0;
            double w = -1.0;
            try {
                w = std::stod(window, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used != window.size() || !(w >= 0.0 && w <= 1e6)) {
                throw nebula::UsageError("--window must be seconds in [0, 1e6] or \"all\", got \"" +
                                         window + "\"");
            }
            opts.window = w;
        }
        nebula::toneSequence(opts, run);
    });
}
