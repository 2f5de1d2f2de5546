// SPDX-License-Identifier: Apache-2.0
/// @file spectral_field_wavelengths.cpp
/// How many wavelengths nebscatter --spectral needs: the spectral render with a field of N
/// wavelengths against one of 41 (every 10 nm over 380-780 nm), for the N whose wavelengths
/// are a subset of the 41 (3, 5, 6, 9, 11, 21). The subsets are taken from the one dense
/// field, so every render carries the same Monte Carlo noise and the difference is the
/// wavelength interpolation alone.
///
///     build/bench/spectral_field_wavelengths LIT.vdb OUTDIR [PACKETS] [RES]
///
/// LIT.vdb: nebillum's output. Writes OUTDIR/dense.exr, OUTDIR/n<N>.exr and
/// OUTDIR/single.exr (no field), spectral renders of RES x RES pixels (default 96) from
/// nebrender's default camera (the example's view); compare them with
/// build/bench/colour_compare OUTDIR/dense.exr OUTDIR/n*.exr (CIEDE2000, white = the
/// reference's 99.5th-percentile luminance). PACKETS: per run (default 1000000).

#include "nebula/core/error.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"
#include "nebula/render/scatter_field.h"
#include "nebula/render/spectral.h"
#include "nebula/stages/scene_assembly.h"

#include <openvdb/openvdb.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace nebula;

int main(int argc, char** argv)
{
    if (argc < 3) {
        std::fprintf(stderr, "usage: spectral_field_wavelengths LIT.vdb OUTDIR [PACKETS] [RES]\n");
        return 2;
    }
    try {
        openvdb::initialize();
        const std::string out = argv[2];
        const GridSet grids = readGrids(argv[1]);
        const DustParams dust = grids.dust();
        RenderOptions ro;
        ro.spectral.enabled = true;
        ro.scatterField = false; // the field is added in memory below
        ro.drawStars = false;
        const int res = argc > 4 ? std::atoi(argv[4]) : 96;
        ro.camera.width = ro.camera.height = res;
        const SpectralScene sscene = buildSpectralScene(grids, ro, dust);

        RenderOptions base = ro;
        base.spectral.enabled = false;
        RenderScene scene = buildScene(grids, base, dust);
        ScatterOptions so;
        so.packets = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1000000;
        const std::vector<double> wl = spectralFieldWavelengths(41);
        const ScatterField dense = computeSpectralScatterField(scene, base, so, wl, nullptr);

        const auto render = [&](const ScatterField* field, const std::string& name) {
            SpectralScene s = sscene;
            s.base.scatter = field ? sceneScatterField(*field, ro) : SceneScatterField{};
            writeExr(out + "/" + name + ".exr", renderSpectral(s, ro), {});
            std::printf("%s/%s.exr\n", out.c_str(), name.c_str());
        };
        render(&dense, "dense");
        render(nullptr, "single");
        for (const int n : {3, 5, 6, 9, 11, 21}) {
            const ScatterField sub =
                spectralFieldSubset(dense, (wl.size() - 1) / std::size_t(n - 1));
            render(&sub, "n" + std::to_string(n));
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "spectral_field_wavelengths: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
