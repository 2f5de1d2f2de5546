// SPDX-License-Identifier: Apache-2.0
// nebview's frame costs on a real input: for a camera orbiting the look-at point, each
// stage's render, the composition, the tone and the JPEG (or PNG), median over the orbit.
// Usage: nebview_frames INPUT.vdb [FRAMES] [WxH] [FAST_LOD] [FAST_STEP] [STAGES]
// (bench/nebview.sh runs it; STAGES: "ipf" = interactive, preview, final)
#include "nebula/core/error.h"
#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/serve/view_protocol.h"
#include "nebula/serve/view_server.h"
#include "nebula/stages/view.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}

double msSince(std::chrono::steady_clock::time_point t)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

} // namespace

int main(int argc, char** argv)
{
    using namespace nebula;
    if (argc < 2) {
        std::fprintf(stderr, "usage: nebview_frames INPUT.vdb [FRAMES] [WxH]\n");
        return 2;
    }
    const int frames = argc > 2 ? std::max(1, std::atoi(argv[2])) : 12;
    int w = 512, h = 512;
    if (argc > 3) std::sscanf(argv[3], "%dx%d", &w, &h);
    const std::string stages = argc > 6 ? argv[6] : "ipf";
    const Run run;
    auto grids = std::make_shared<const GridSet>(readGrids(argv[1], run));
    ViewSettings settings;
    settings.render.camera.width = w;
    settings.render.camera.height = h;
    if (argc > 4) settings.fastLod = std::atof(argv[4]);
    if (argc > 5) settings.fastStep = std::atof(argv[5]);
    const auto t0 = std::chrono::steady_clock::now();
    const ViewSession session(grids, settings, grids->dust(run), run);
    std::printf("input %s, %dx%d, scene %.0f ms, fast lod %g, fast step %g\n", argv[1], w, h,
                msSince(t0), settings.fastLod, settings.fastStep);
    const Camera start = settings.render.camera;
    const double radius = (start.eye - start.lookAt).length();
    for (const ViewStage stage : {ViewStage::Interactive, ViewStage::Preview, ViewStage::Final}) {
        if (stages.find(toString(stage)[0]) == std::string::npos) continue;
        const int n = stage == ViewStage::Final ? std::min(frames, 3) : frames;
        std::vector<double> render, compose, tone, jpeg, bytes;
        long long samples = 0;
        for (int i = 0; i < n; ++i) { // 3 degrees a frame about the up axis
            const double a = 3.0 * i * PI / 180.0;
            Camera c = start;
            const Vec3 d = start.eye - start.lookAt;
            c.eye = start.lookAt + Vec3(d.x * std::cos(a) + d.z * std::sin(a), d.y,
                                        -d.x * std::sin(a) + d.z * std::cos(a)) *
                                       (radius / d.length());
            auto t = std::chrono::steady_clock::now();
            const ViewFrame f = session.render(c, stage, false, run);
            render.push_back(msSince(t));
            samples += (long long)f.stats.samples;
            t = std::chrono::steady_clock::now();
            const Image img = session.compose(f, ViewShow{});
            compose.push_back(msSince(t));
            t = std::chrono::steady_clock::now();
            const ToneCurve curve = requestTone(img, ToneRequest{}, settings.tone);
            const auto pixels = displayPixels(img, curve);
            tone.push_back(msSince(t));
            t = std::chrono::steady_clock::now();
            const std::string j = jpegBytes(pixels, img.width, img.height, 85);
            jpeg.push_back(msSince(t));
            bytes.push_back(double(j.size()));
        }
        const auto size = session.resolution(stage);
        const double total = median(render) + median(compose) + median(tone) + median(jpeg);
        std::printf("%-11s %4dx%-4d render %8.1f ms  compose %6.2f ms  tone %6.2f ms  jpeg %6.2f "
                    "ms (%5.1f KiB)  total %8.1f ms = %5.1f fps  (%lld samples/frame, median of "
                    "%d)\n",
                    toString(stage).c_str(), size[0], size[1], median(render), median(compose),
                    median(tone), median(jpeg), median(bytes) / 1024.0, total, 1e3 / total,
                    samples / n, n);
    }
    // How soon a newer camera stops a final frame in flight: cancelled 200 ms into it.
    if (stages.find('c') != std::string::npos || argc <= 6) {
        std::vector<double> stops;
        for (int i = 0; i < 5; ++i) {
            Run cancellable;
            std::atomic<bool> cancel{false};
            cancellable.setCancel(&cancel);
            std::chrono::steady_clock::time_point set;
            std::thread t([&] {
                std::this_thread::sleep_for(std::chrono::milliseconds(200 + 37 * i));
                set = std::chrono::steady_clock::now();
                cancel = true;
            });
            try {
                (void)session.render(start, ViewStage::Final, false, cancellable);
            } catch (const Cancelled&) {
            }
            stops.push_back(msSince(set));
            t.join();
        }
        std::printf("cancel: a final frame stops %.1f ms after the flag (median of 5, max %.1f)\n",
                    median(stops), *std::max_element(stops.begin(), stops.end()));
    }
    return 0;
}
