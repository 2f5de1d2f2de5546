// SPDX-License-Identifier: Apache-2.0
/// @file integrator.cpp
/// The registry of integrators (render/integrator.h): one line per integrator, each defined
/// in its own file.

#include "nebula/render/integrator.h"

#include "frame.h"

#include "nebula/core/error.h"
#include "nebula/volume/block_walk.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nebula {

namespace detail {
// Each integrator's type, defined in its own file. A new integrator: one line here, and its
// entry in integratorTypes().
const IntegratorType& fastIntegrator();     // fast.cpp
const IntegratorType& pathIntegrator();     // path_tracer.cpp
const IntegratorType& spectralIntegrator(); // spectral.cpp
} // namespace detail

const std::vector<const IntegratorType*>& integratorTypes()
{
    static const std::vector<const IntegratorType*> types{
        &detail::fastIntegrator(), &detail::pathIntegrator(), &detail::spectralIntegrator()};
    return types;
}

const IntegratorType& integratorType(const std::string& name, const std::string& option)
{
    std::string known;
    for (const IntegratorType* type : integratorTypes()) {
        if (type->name == name) return *type;
        known += (known.empty() ? "" : ", ") + type->name;
    }
    throw UsageError(option + " " + name + ": no such integrator; the integrators are " + known);
}

const IntegratorType& chosenIntegrator(const RenderOptions& opts)
{
    // The spectral renderer is the fast integrator's spectral mode on the command line.
    const IntegratorType& spectral = detail::spectralIntegrator();
    if (opts.spectral.enabled) {
        if (opts.integrator != detail::fastIntegrator().name) {
            throw UsageError("--spectral is for the fast integrator (--integrator fast)");
        }
        return spectral;
    }
    const IntegratorType& type = integratorType(opts.integrator);
    if (&type == &spectral) {
        throw UsageError("--integrator " + type.name + ": chosen by " + type.chosenBy);
    }
    return type;
}

namespace detail {

std::vector<std::uint64_t> rowCosts(const RenderScene& scene, const RenderOptions& opts,
                                    const StarDepth* depth)
{
    const Camera& cam = opts.camera;
    const Projection proj(cam);
    const SparseVolume& v = scene.fields;
    const Affine w2i = v.indexToWorld.inverse();
    const int columns = std::min(cam.width, ROW_COST_COLUMNS);
    const auto& r = scene.dust.r;
    const double perDensity = scene.dust.kappa_V * std::min({r[0], r[1], r[2]});
    const double tauStop = -std::log(std::max(opts.minTransmittance, 1e-300));
    const double stepVoxels = opts.step * ROW_COST_STRIDE;
    std::vector<std::uint64_t> weight(std::size_t(std::max(cam.height, 0)), 1);
    const bool hasVolume = v.channels() > 0;
    // The exact optical depth towards a star (DESIGN §3.3) marches up to StarDepth::MAX_STEPS
    // voxels from each sample where the star's tau bends: most of a lit face's cost.
    if (!hasVolume || scene.stars.empty()) depth = nullptr;
    const std::size_t stars = scene.stars.size();
    tbb::parallel_for(0, cam.height, [&](int y) {
        double pixels = 0.0, steps = 0.0, curved = 0.0;
        for (int i = 0; i < columns; ++i) {
            const double px = (i + 0.5) * cam.width / columns, py = y + 0.5;
            Vec3 d;
            if (!proj.direction(px, py, d)) continue; // not in view: not rendered
            pixels += 1.0;
            if (!hasVolume) continue;
            const BlockRay ray(v, w2i, scene.blocks, proj.origin(px, py), d);
            if (!ray.hits()) continue;
            const double dt = stepVoxels / ray.dI.length();
            double tau = 0.0;
            for (double t = ray.t0; t < ray.t1 && tau < tauStop;) {
                const double seg = std::min(dt, ray.t1 - t);
                const Vec3 pI = ray.oI + ray.dI * (t + 0.5 * seg);
                int b = 0, bb[3];
                if (ray.blockAt(pI, b, bb) && !scene.occupied.empty() &&
                    !scene.occupied[std::size_t(b)]) {
                    t = std::max(ray.blockExit(bb), t + 1e-6 * dt);
                    continue;
                }
                const double n = v.sample0(pI);
                steps += ROW_COST_STRIDE * seg / dt;
                if (depth && n > 0.0 && depth->anyCurved(pI)) {
                    for (std::size_t s = 0; s < stars; ++s)
                        curved += depth->curved(s, pI) ? ROW_COST_STRIDE * seg / dt : 0.0;
                }
                tau += perDensity * n * seg;
                t += seg;
            }
        }
        const double cost = ROW_COST_PIXEL * pixels + steps + ROW_COST_STAR_DEPTH * curved;
        weight[std::size_t(y)] = 1 + std::uint64_t(std::llround(16.0 * cost));
    });
    return weight;
}

void warnUnusedLevels(const IntegratorInput& input, const RenderOptions& opts, bool field,
                      const Run& run)
{
    if (opts.levels < 0 && !opts.phaseTable && !field && !input.pyramidLevel.empty()) {
        run.warn(input.source + " has pyramid levels (" + input.pyramidLevel +
                 ", ...), which only a phase table uses: this image is single scattering. "
                 "Pass --phase (nebphase -i " +
                 input.source + " -o phase.vdb) to use them, or --levels 0 to say you mean it");
    }
}

} // namespace detail

} // namespace nebula
