// SPDX-License-Identifier: Apache-2.0
#include "nebula/render/sprites.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"
#include "nebula/core/units.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/optical_depth.h"
#include "nebula/render/frame_layers.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace nebula {

double spriteFootprintEdge(const RenderOptions& opts)
{
    return 2.0 * (std::ceil(2.0 * opts.spriteRadius) + 1.0) + 1.0;
}

void requireSpriteMemory(const RenderOptions& opts)
{
    if (!(opts.spriteRadius > 0.0) || !std::isfinite(opts.spriteRadius)) {
        throw UsageError("--sprite-radius must be a finite number > 0 [pixels], got " +
                         detail::numberText(opts.spriteRadius));
    }
    const double edge = spriteFootprintEdge(opts);
    requireMemory(edge * edge * sizeof(double),
                  "--sprite-radius " + detail::numberText(opts.spriteRadius) +
                      ": the star sprite footprint (" + fmt::format("{:.3g} x {:.3g}", edge, edge) +
                      " pixels)");
}

namespace {

/// Image::starPixel: 1 where the sprites' luminance @p spriteY (per pixel touched, a pixel
/// possibly more than once) is more than half the pixel's.
void markStarPixels(Image& img, std::vector<std::pair<std::size_t, double>>& spriteY)
{
    std::sort(spriteY.begin(), spriteY.end());
    for (std::size_t i = 0; i < spriteY.size();) {
        const std::size_t pix = spriteY[i].first;
        double sum = 0.0;
        for (; i < spriteY.size() && spriteY[i].first == pix; ++i)
            sum += spriteY[i].second;
        const float* p = &img.rgba[pix * 4];
        if (!(sum > 0.5 * linearSRGBLuminance(p[0], p[1], p[2]))) continue;
        if (img.starPixel.empty()) {
            img.starPixel.assign(std::size_t(img.width) * std::size_t(img.height), 0);
        }
        img.starPixel[pix] = 1;
    }
}

} // namespace

void drawStarSprites(Image& img, const RenderScene& scene, const RenderOptions& opts,
                     const std::function<std::array<double, 3>(std::size_t, double)>& colour,
                     const std::function<void(std::size_t, std::size_t, double)>& footprint,
                     std::vector<float>* direct)
{
    const Projection cam(opts.camera);
    const int W = opts.camera.width, H = opts.camera.height;
    const std::size_t S = scene.stars.size();
    const SparseVolume& vol = scene.fields;
    const Affine& i2w = vol.indexToWorld;
    const Affine w2i = i2w.inverse();
    const auto& dust = scene.dust;
    std::vector<Vec3> starPos;
    for (const auto& s : scene.stars)
        starPos.emplace_back(s.position[0], s.position[1], s.position[2]);
    // Star sprites: the attenuated flux F_c = L_c / (4 pi d^2) e^(-r_c tau) spread over a
    // small Gaussian footprint whose radiance times pixel solid angle sums to F_c.
    if (S > 0) {
        requireSpriteMemory(opts); // before R below, which it keeps within an int
        // Column density eye -> star through the dust (channel 0), exact; the scene's
        // integrator (its cell occupancy built once per scene).
        const ColumnIntegrator& column = scene.column.get(vol);
        std::vector<LayerId> starLayer; // each star's own layer
        // Per pixel a sprite touches: the sprites' luminance there (Image::starPixel).
        std::vector<std::pair<std::size_t, double>> spriteY;
        for (const auto& s : scene.stars)
            starLayer.push_back(img.layerId(starLayerName(s.name)));
        for (std::size_t s = 0; s < S; ++s)
            for (int view = 0; view < cam.views(); ++view) { // ODS: each eye
                double sx, sy;
                if (!cam.project(starPos[s], sx, sy, view)) continue;
                int y0 = 0, y1 = H;
                cam.viewRows(view, y0, y1);
                const double d2 = cam.distanceSquared(starPos[s]);
                const double tauV = dust.kappa_V * column(w2i.apply(cam.originTowards(starPos[s])),
                                                          w2i.apply(starPos[s]));
                const double sigma = std::max(0.3, 0.5 * opts.spriteRadius);
                const int R = int(std::ceil(2.0 * opts.spriteRadius)) + 1;
                const int cx = int(std::floor(sx)), cy = int(std::floor(sy));
                std::vector<double> w;
                double wsum = 0.0;
                for (int y = cy - R; y <= cy + R; ++y)
                    for (int x = cx - R; x <= cx + R; ++x) {
                        const double dx = x + 0.5 - sx, dy = y + 0.5 - sy;
                        w.push_back(std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma)));
                        wsum += w.back();
                    }
                std::array<double, 3> F;
                for (int c = 0; c < 3; ++c) {
                    F[std::size_t(c)] =
                        scene.starColor[s][c] / (4.0 * PI * d2) * std::exp(-dust.r[c] * tauV);
                }
                if (colour) {
                    const auto col = colour(s, tauV);
                    for (int c = 0; c < 3; ++c)
                        F[std::size_t(c)] = col[std::size_t(c)] / (4.0 * PI * d2);
                }
                std::size_t wi = 0;
                for (int y = cy - R; y <= cy + R; ++y)
                    for (int x = cx - R; x <= cx + R; ++x, ++wi) {
                        // A panorama wraps around: its column W is column 0.
                        const int xi = cam.wrapsHorizontally() ? ((x % W) + W) % W : x;
                        if (xi < 0 || y < y0 || xi >= W || y >= y1) continue; // in its view
                        if (!cam.inView(xi + 0.5, y + 0.5)) continue; // outside a dome's circle
                        const double omega = cam.pixelSolidAngle(xi + 0.5, y + 0.5);
                        const std::size_t pix = std::size_t(y) * W + xi;
                        if (footprint) footprint(s, pix, w[wi] / wsum / omega / (4.0 * PI * d2));
                        float L[3];
                        for (int c = 0; c < 3; ++c) {
                            const float Lpix = float(F[std::size_t(c)] * w[wi] / wsum / omega);
                            L[c] = Lpix;
                            img.rgba[pix * 4 + c] += Lpix;
                            img.rgb(starLayer[s])[pix * 3 + c] += Lpix;
                            if (direct) (*direct)[pix * 3 + c] += Lpix;
                        }
                        spriteY.push_back({pix, linearSRGBLuminance(L[0], L[1], L[2])});
                    }
            }
        markStarPixels(img, spriteY);
    }
}

} // namespace nebula
