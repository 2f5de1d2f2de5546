// SPDX-License-Identifier: Apache-2.0
/// @file spectral_scene_assembly.cpp
/// nebrender --spectral's scene (DESIGN §7, stages/scene_assembly.h): buildSpectralScene()
/// reads the emission grids and their lines, the temperature and velocity grids onto the RGB
/// scene's lattice; the integrator is render/spectral.cpp.

#include "nebula/stages/scene_assembly.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/spectral_grids.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/motion.h"

#include <openvdb/tools/ValueTransformer.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nebula {

namespace {

/// The emission grids: opts.emissionGrid, then every other FloatGrid with nebula:lines, each
/// with its lines and the unit that gives the line mix the RGB mode's luminance.
std::vector<openvdb::FloatGrid::ConstPtr>
emissionGrids(const GridSet& grids, const RenderOptions& opts, SpectralScene& scene)
{
    const SpectralOptions& so = opts.spectral;
    // Emission grids: the main one, then every other FloatGrid that says what it emits.
    std::vector<openvdb::FloatGrid::ConstPtr> emitGrids;
    std::vector<SpectralLine> fallback;
    try {
        fallback = parseLineList(so.lines.empty() ? DEFAULT_EMISSION_LINES : so.lines, "--lines");
    } catch (const UsageError&) {
        throw;
    } catch (const Error& e) {
        throw UsageError(e.what()); // a bad option value: usage error (exit 2)
    }
    const double targetY = linearSRGBToXYZ(opts.emissionColor)[1] * opts.emissionScale;
    auto addEmitter = [&](const openvdb::FloatGrid::Ptr& g, bool main) {
        requireFiniteNonNegative(*g, grids.source);
        SpectralEmitter e;
        e.grid = g->getName();
        e.lines = (main && !so.lines.empty()) ? fallback : gridLines(*g, grids.source, fallback);
        double Y = 0.0, strength = 0.0;
        for (const auto& l : e.lines) {
            Y += l.strength * cmfAt(l.wavelength)[1];
            strength += l.strength;
        }
        if (!(Y > 0.0)) {
            throw Error(grids.source + ": grid \"" + e.grid + "\" emits only lines outside " +
                        "360-830 nm (" + lineListToString(e.lines) + "): nothing to see");
        }
        // Calibrated: the grid times --emission-scale is the lines' summed emissivity.
        e.unit = opts.monochromatic ? opts.emissionScale / strength : targetY / Y;
        scene.emitters.push_back(e);
        emitGrids.push_back(g);
    };
    if (grids.find(opts.emissionGrid)) {
        addEmitter(grids.floatGrid(opts.emissionGrid, "--emission-grid"), true);
    }
    for (const auto& g : grids.grids) {
        if (!g || g->getName() == opts.emissionGrid) continue;
        if (!g->getMetadata<openvdb::StringMetadata>(META_LINES)) continue;
        addEmitter(grids.floatGrid(g->getName(), ""), false);
    }

    return emitGrids;
}

/// The absorption grids (`absorption.<species>`, DESIGN §7.6), each with its lines: a
/// FloatGrid of finite values >= 0 with a `nebula:absorption-lines` list (Error otherwise).
std::vector<openvdb::FloatGrid::ConstPtr> absorptionGrids(const GridSet& grids,
                                                          SpectralScene& scene)
{
    std::vector<openvdb::FloatGrid::ConstPtr> out;
    for (const std::string& name : absorptionGridNames(grids)) {
        const auto g = grids.floatGrid(name, "");
        requireFiniteNonNegative(*g, grids.source);
        SpectralAbsorber a;
        a.grid = name;
        a.lines = gridAbsorptionLines(*g, grids.source);
        scene.absorbers.push_back(a);
        out.push_back(g);
    }
    return out;
}

/// The velocity grid's three components as FloatGrids (empty without one), its fastest
/// speed in @p maxSpeed [km/s]; UsageError if --exaggerate-velocity makes any gas as fast as
/// light.
std::vector<openvdb::FloatGrid::Ptr> velocityComponents(const GridSet& grids,
                                                        const SpectralOptions& so, double& maxSpeed)
{
    std::vector<openvdb::FloatGrid::Ptr> velocity;
    if (grids.find(so.velocityGrid)) {
        const auto v = velocityGrid(grids, so.velocityGrid, "--velocity-grid");
        for (int c = 0; c < 3; ++c) {
            auto comp = openvdb::FloatGrid::create(0.0f);
            comp->setTransform(v->transform().copy());
            comp->setName(so.velocityGrid + "xyz"[c]);
            auto acc = comp->getAccessor();
            for (auto it = v->cbeginValueOn(); it; ++it) {
                if (it.isVoxelValue()) {
                    acc.setValue(it.getCoord(), (*it)[c]);
                } else {
                    openvdb::CoordBBox box;
                    it.getBoundingBox(box);
                    comp->tree().fill(box, (*it)[c], true);
                }
            }
            velocity.push_back(comp);
        }
        // Gas as fast as light (after exaggeration) has no Doppler factor: refuse it.
        double vmax2 = 0.0;
        for (auto it = v->cbeginValueOn(); it; ++it)
            vmax2 = std::max(vmax2, double((*it).lengthSqr()));
        maxSpeed = std::sqrt(vmax2);
        const double vmax = maxSpeed * std::abs(so.exaggerateVelocity);
        if (vmax >= SPEED_OF_LIGHT_KMS) {
            throw UsageError("--exaggerate-velocity " + std::to_string(so.exaggerateVelocity) +
                             " makes the fastest gas of grid \"" + so.velocityGrid + "\" move at " +
                             std::to_string(vmax) + " km/s, not slower than light (" +
                             std::to_string(SPEED_OF_LIGHT_KMS) + " km/s)");
        }
    }

    return velocity;
}

} // namespace

void refuseAbsorptionGrids(const GridSet& grids)
{
    const auto names = absorptionGridNames(grids);
    if (names.empty()) return;
    throw UsageError(grids.source + ": grid \"" + names.front() +
                     "\" holds absorption lines, which only the spectral renderer draws; "
                     "render with --spectral");
}

SpectralScene buildSpectralScene(const GridSet& grids, const RenderOptions& opts,
                                 const DustParams& dust)
{
    const SpectralOptions& so = opts.spectral;
    validateSpectralOptions(opts);
    SpectralScene scene;
    scene.dust = dust;
    RenderOptions base = opts;
    base.levels = 0;
    base.lineColours = false; // the emission grids are read below, with their spectra
    scene.base = buildScene(grids, base, dust);
    const auto emitGrids = emissionGrids(grids, opts, scene);
    const auto absorbGrids = absorptionGrids(grids, scene);
    openvdb::FloatGrid::Ptr temperature;
    if (grids.find(so.temperatureGrid)) {
        temperature = grids.floatGrid(so.temperatureGrid, "--temperature-grid");
        requireValidTemperature(*temperature, grids.source);
        float hottest = 0.0f;
        for (auto it = temperature->cbeginValueOn(); it; ++it)
            hottest = std::max(hottest, *it);
        if (!(double(hottest) * so.temperatureScale <= MAX_STAR_TEMPERATURE)) {
            throw UsageError(grids.source + ": --temperature-scale " +
                             detail::numberText(so.temperatureScale) + " times grid \"" +
                             so.temperatureGrid + "\"'s hottest voxel, " +
                             fmt::format("{:.4g}", hottest) + " K, exceeds " +
                             detail::numberText(MAX_STAR_TEMPERATURE) +
                             " K, beyond any dust or star; use a smaller --temperature-scale");
        }
    }
    const auto velocity = velocityComponents(grids, so, scene.maxSpeed);

    // One lattice for everything: channels as documented in SpectralScene.
    const auto density = grids.floatGrid(opts.densityGrid, "--density-grid");
    std::vector<openvdb::FloatGrid::ConstPtr> boundsGrids{density};
    for (const auto& g : emitGrids)
        boundsGrids.push_back(g);
    for (const auto& g : absorbGrids)
        boundsGrids.push_back(g);
    std::vector<openvdb::FloatGrid::ConstPtr> fields{density};
    auto empty = openvdb::FloatGrid::create(0.0f);
    empty->setTransform(density->transform().copy());
    fields.push_back(empty); // channel 1: filled below with the sum of the emission grids
    for (const auto& s : scene.base.stars)
        fields.push_back(grids.floatGrid(tauGridName(s.name), ""));
    int ch = int(fields.size());
    for (std::size_t k = 0; k < emitGrids.size(); ++k) {
        scene.emitters[k].channel = ch++;
        fields.push_back(emitGrids[k]);
    }
    for (std::size_t k = 0; k < absorbGrids.size(); ++k) {
        scene.absorbers[k].channel = ch++;
        fields.push_back(absorbGrids[k]);
    }
    if (temperature) {
        scene.temperatureChannel = ch++;
        fields.push_back(temperature);
    }
    if (!velocity.empty()) {
        scene.velocityChannel = ch;
        ch += 3;
        for (const auto& v : velocity)
            fields.push_back(v);
    }
    SparseVolume vol = volumeFromGrids(fields, activeBounds(boundsGrids, 1), grids.source);
    vol.forEachStoredBrick([&](std::size_t first) { // zeros sum to zero
        for (std::size_t i = first; i < first + SparseVolume::BRICK_VOXELS; ++i) {
            float* q = vol.writable(i);
            float sum = 0.0f;
            for (const auto& e : scene.emitters)
                sum += q[e.channel];
            for (const auto& a : scene.absorbers)
                sum += q[a.channel];
            q[1] = sum;
        }
    });
    scene.base.fields = std::move(vol);
    scene.base.buildOccupancy();
    return scene;
}

} // namespace nebula
