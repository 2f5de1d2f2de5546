// SPDX-License-Identifier: Apache-2.0
/// @file scene_assembly.cpp
/// The RGB scene from the grids (stages/scene_assembly.h): density, emission and tau.<star>
/// onto one lattice, the stars, the channel dust, pyramid levels, and nebscatter's field,
/// checked against the scene. buildSpectralScene() is in spectral_scene_assembly.cpp.

#include "nebula/stages/scene_assembly.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/scatter_field_vdb.h"
#include "nebula/io/spectral_grids.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/blackbody.h"
#include "nebula/physics/colour.h"
#include "nebula/render/scatter_field.h"

#include <fmt/format.h>
#include <openvdb/tools/Count.h>

#include <algorithm>
#include <cmath>

namespace nebula {

using detail::numberText;

namespace {

/// The tau grid of star @p star (with @p suffix, ".L<k>" for a level); Error naming the file,
/// the grid and the command that makes it if it is missing.
openvdb::FloatGrid::Ptr tauGrid(const GridSet& grids, const Star& star, const std::string& suffix,
                                const std::string& missingHint)
{
    const std::string name = tauGridName(star.name) + suffix;
    if (!grids.find(name)) {
        throw Error(grids.source + ": no grid \"" + name + "\" for star \"" + star.name + "\"" +
                    missingHint);
    }
    return grids.floatGrid(name, "");
}

/// Throws Error unless @p tau was computed with the dust's kappa_V (its metadata, if any).
void requireSameKappa(const GridSet& grids, const openvdb::FloatGrid& tau, const DustParams& dust)
{
    if (const auto k = tau.getMetadata<openvdb::DoubleMetadata>("kappa_V")) {
        if (std::abs(k->value() - dust.kappa_V) > 1e-9 * dust.kappa_V) {
            throw Error(grids.source + ": grid \"" + tau.getName() +
                        "\" was computed with kappa_V = " + std::to_string(k->value()) +
                        " but the dust has kappa_V = " + std::to_string(dust.kappa_V) +
                        "; rerun nebillum");
        }
    }
}

/// Throws Error unless the phase table was made for the dust's albedo, g and phase model
/// (or opts.phaseIgnoreDust).
void requireTableForDust(const GridSet& grids, const RenderOptions& opts, const DustParams& dust)
{
    const auto& table = opts.phaseTable;
    if (!table) return;
    const auto& m = table->medium;
    const bool same = std::abs(m.albedo - dust.albedo) <= 1e-9 && std::abs(m.g - dust.g) <= 1e-9 &&
                      m.phase == dust.phase;
    if (!same && !opts.phaseIgnoreDust) {
        throw Error(opts.phaseSource + ": the phase table was made for albedo " +
                    numberText(m.albedo) + ", g " + numberText(m.g) + ", phase " +
                    toString(m.phase) + " but " + grids.source + "'s dust has albedo " +
                    numberText(dust.albedo) + ", g " + numberText(dust.g) + ", phase " +
                    toString(dust.phase) + "; rebuild it (nebphase -i " + grids.source +
                    " -o phase.vdb) or pass --phase-ignore-dust");
    }
}

/// How many pyramid levels to read: opts.levels, or (auto, -1) every level the input has
/// when there is a phase table.
int levelCount(const GridSet& grids, const RenderOptions& opts)
{
    int count = opts.levels;
    if (count < 0) {
        count = 0;
        while (opts.phaseTable && grids.find(levelGridName(opts.densityGrid, count + 1)))
            ++count;
    }
    if (count > 0 && !opts.phaseTable) {
        throw UsageError("--levels needs a phase table (--phase): each level adds the change "
                         "of the per-voxel scattering Phi as the voxel doubles");
    }
    return count;
}

/// Pyramid level @p k: density.L<k> and tau.<star>.L<k> as dense fields (channel 1, the
/// emission, empty); Error if a grid is missing or its voxels are not 2^k times level 0's
/// (@p a0: level 0's index-to-world map).
RenderLevel readLevel(const GridSet& grids, const RenderOptions& opts,
                      const std::vector<Star>& stars, int k, const Affine& a0)
{
    const std::string suffix = ".L" + std::to_string(k);
    const std::string dName = levelGridName(opts.densityGrid, k);
    if (!grids.find(dName)) {
        throw Error(grids.source + ": no grid \"" + dName + "\" for level " + std::to_string(k) +
                    " of --levels " + std::to_string(opts.levels) + "; run nebpyramid --levels " +
                    std::to_string(opts.levels) + " first");
    }
    auto dk = grids.floatGrid(dName, "");
    requireFiniteNonNegative(*dk, grids.source);
    auto empty = openvdb::FloatGrid::create(0.0f);
    empty->setTransform(dk->transform().copy());
    std::vector<openvdb::FloatGrid::ConstPtr> lf{dk, empty};
    for (const auto& st : stars) {
        lf.push_back(tauGrid(grids, st, suffix,
                             " at level " + std::to_string(k) + "; run nebpyramid on this file"));
    }
    RenderLevel level;
    level.level = k;
    level.fields = volumeFromGrids(lf, activeBounds({dk}, 1), grids.source);
    // Voxels 2^k times level 0's (same orientation): compare the linear maps.
    const auto& ak = level.fields.indexToWorld;
    const double scale = double(1 << k);
    double worst = 0.0, norm = 0.0;
    for (int i = 0; i < 9; ++i) {
        worst = std::max(worst, std::abs(ak.m[std::size_t(i)] - scale * a0.m[std::size_t(i)]));
        norm = std::max(norm, std::abs(scale * a0.m[std::size_t(i)]));
    }
    if (worst > 1e-6 * norm) {
        throw Error(grids.source + ": grid \"" + dName + "\" has voxels that are not " +
                    std::to_string(1 << k) + " times those of \"" + opts.densityGrid +
                    "\" (level " + std::to_string(k) + "); rebuild the levels with nebpyramid");
    }
    return level;
}

bool close(double a, double b, double rel = 1e-9)
{
    return std::abs(a - b) <= rel * std::max({std::abs(a), std::abs(b), 1e-300});
}

/// What differs between the stars a field was made for and the scene's ("" if nothing):
/// names, places, colours, and (for a summed field) luminosities; a per-star field is
/// scaled to the scene's.
std::string starDifference(const std::vector<Star>& fieldStars, const std::vector<Star>& stars,
                           bool perStar)
{
    if (fieldStars.size() != stars.size()) {
        return std::to_string(fieldStars.size()) + " stars, the scene has " +
               std::to_string(stars.size());
    }
    for (std::size_t s = 0; s < fieldStars.size(); ++s) {
        const Star& a = fieldStars[s];
        const Star& b = stars[s];
        if (a.name != b.name) {
            return "star " + std::to_string(s + 1) + " \"" + a.name + "\", the scene's is \"" +
                   b.name + "\"";
        }
        if (!close(a.position[0], b.position[0]) || !close(a.position[1], b.position[1]) ||
            !close(a.position[2], b.position[2])) {
            return "star \"" + a.name + "\" at another position";
        }
        if (!close(a.temperature, b.temperature)) {
            return "star \"" + a.name + "\" at " + numberText(a.temperature) +
                   " K, the scene's at " + numberText(b.temperature) + " K";
        }
        if (!perStar && !close(a.luminosity, b.luminosity)) {
            return "star \"" + a.name + "\" of luminosity " + numberText(a.luminosity) +
                   " L_sun, the scene's is " + numberText(b.luminosity) +
                   " (nebscatter --per-star makes a field that follows the luminosity)";
        }
    }
    return "";
}

/// A star's field was made with its sRGB colour times the luminosity it had then
/// (@p made): the factors per channel that scale it to @p power, the star's spectral
/// luminosity at each channel's wavelength (RenderOptions::monochromatic).
std::array<double, 3> monochromaticFieldFactors(const std::array<double, 3>& power,
                                                const Star& made, const std::string& what,
                                                const std::string& rerun)
{
    const auto rgb = blackbodyLinearSRGB(made.temperature);
    std::array<double, 3> f;
    for (std::size_t c = 0; c < 3; ++c) {
        if (!(rgb[c] > 0.0)) {
            throw Error(what + ": star " + made.name + "'s sRGB colour has " +
                        std::string(1, "RGB"[c]) +
                        " = 0, so its field cannot be scaled to its spectrum" + rerun);
        }
        f[c] = power[c] / (rgb[c] * made.luminosity);
    }
    return f;
}

/// A star's spectral field was made with starSpectralPower() (luminance Y = L) of the star
/// as it was then (@p made): the factor, the same at every wavelength, that scales it to the
/// black body of bolometric luminosity @p now.luminosity (RenderOptions::monochromatic).
double calibratedSpectralFieldFactor(const Star& now, const Star& made)
{
    constexpr double lambda = 550.0; // any: both are the same black body's shape
    return blackbodySpectralLuminosity(now.luminosity, now.temperature, lambda) /
           starSpectralPower(made, lambda);
}

/// Throws unless nebscatter's field (@p meta) was made for this scene and render: no phase
/// table or levels beside it (UsageError), the same dust, channel wavelengths (RGB), star
/// distance clamp, grids, stars and level-0 transform (Error naming @p what, ending in
/// @p rerun).
void requireFieldForScene(const ScatterFieldMeta& meta, const GridSet& grids,
                          const RenderOptions& opts, const DustParams& dust,
                          const RenderScene& scene, bool spectral, const std::string& what,
                          const std::string& rerun)
{
    if (opts.phaseTable || opts.levels > 0) {
        throw UsageError(grids.source +
                         " has a scattered-light field (nebscatter), which "
                         "already holds the multiply scattered light that --phase and --levels "
                         "approximate: together they would count it twice. Pass "
                         "--no-scatter-field to use the table and levels instead");
    }
    const DustParams& fieldDust = meta.dust;
    const bool sameDust = close(fieldDust.albedo, dust.albedo) && close(fieldDust.g, dust.g) &&
                          fieldDust.phase == dust.phase && close(fieldDust.kappa_V, dust.kappa_V) &&
                          fieldDust.curve == dust.curve && close(fieldDust.R_V, dust.R_V);
    if (!sameDust) {
        throw Error(what + " was made for other dust: " + fieldDust.toJson() +
                    ", but the scene's is " + dust.toJson() + rerun);
    }
    const auto& wl = meta.wavelengths;
    for (int c = 0; c < 3 && !spectral; ++c) {
        if (!close(wl[std::size_t(c)], opts.wavelengths[std::size_t(c)])) {
            throw Error(what + " was made for channel wavelengths " + detail::numbersText(wl) +
                        " nm, but this render's channels (--wavelengths or --filter) are " +
                        numberText(opts.wavelengths[0]) + ", " + numberText(opts.wavelengths[1]) +
                        ", " + numberText(opts.wavelengths[2]) + rerun);
        }
    }
    const ScatterSceneSettings& made = meta.scene;
    if (!close(made.minStarDistance, opts.minStarDistance)) {
        throw Error(what + " was made with --min-star-distance " +
                    numberText(made.minStarDistance) + ", but this render uses " +
                    numberText(opts.minStarDistance) + rerun);
    }
    if (made.densityGrid != opts.densityGrid || made.emissionGrid != opts.emissionGrid) {
        throw Error(what + " was made from the grids \"" + made.densityGrid + "\" and \"" +
                    made.emissionGrid + "\", but this render uses \"" + opts.densityGrid +
                    "\" and \"" + opts.emissionGrid + "\"" + rerun);
    }
    const std::string starDiff = starDifference(meta.stars, scene.stars, meta.settings.perStar);
    if (!starDiff.empty()) throw Error(what + " was made for other stars: " + starDiff + rerun);
    // Transform: level 0's, and each grid on the field level's.
    const Affine& s0 = scene.fields.indexToWorld;
    const Affine& a0 = meta.indexToWorld;
    double worst = 0.0, size = 0.0;
    for (std::size_t i = 0; i < 9; ++i) {
        worst = std::max(worst, std::abs(s0.m[i] - a0.m[i]));
        size = std::max(size, std::abs(s0.m[i]));
    }
    for (int i = 0; i < 3; ++i) {
        worst = std::max(worst, std::abs(s0.t[i] - a0.t[i]));
        size = std::max(size, std::abs(s0.t[i]));
    }
    if (worst > 1e-9 * std::max(size, 1e-300)) {
        throw Error(what +
                    " was made for a grid with another transform (voxel size, "
                    "orientation or position) than \"" +
                    opts.densityGrid + "\"" + rerun);
    }
}

/// The factor per channel that scales source @p source's moments to the scene: the emission's
/// --emission-scale and colour (0 when calibrated: RGB mode leaves the glow out), a star's
/// luminosity now over then, and, calibrated (RenderOptions::monochromatic), the stars'
/// spectral luminosities. The field's stars are the scene's (requireFieldForScene()).
std::vector<double> sourceFactor(const ScatterSource& source, const ScatterFieldMeta& meta,
                                 const RenderOptions& opts, const RenderScene& scene, bool spectral,
                                 const std::string& what, const std::string& rerun)
{
    std::vector<double> factor(meta.wavelengths.size(), 1.0);
    switch (source.kind) {
    case ScatterSource::Kind::Emission: {
        // The field holds the glow of --emission-grid (colour 1): its colour in this scene.
        std::array<double, 3> colour = opts.emissionColor;
        for (const auto& [name, c] : scene.emission.grids)
            if (name == opts.emissionGrid) colour = c;
        for (std::size_t c = 0; c < 3 && c < factor.size(); ++c)
            factor[c] = opts.monochromatic ? 0.0 : opts.emissionScale * colour[c];
        break;
    }
    case ScatterSource::Kind::Stars:
        // All stars in one field, each made with luminance Y = L (spectral) or its sRGB colour:
        // one factor (per channel) scales it to the stars' spectral luminosities only if it is
        // the same for every star (one star, or stars of one temperature).
        for (std::size_t s = 0; s < scene.stars.size() && opts.monochromatic; ++s) {
            if (spectral) {
                const double f = calibratedSpectralFieldFactor(scene.stars[s], meta.stars[s]);
                if (s > 0 && std::abs(f - factor[0]) > 1e-9 * std::abs(factor[0])) {
                    throw Error(what + " holds the stars' light as one field; stars of "
                                       "different temperatures need a field per star for "
                                       "--fits: run nebscatter --spectral --per-star");
                }
                std::fill(factor.begin(), factor.end(), f);
                continue;
            }
            const auto f =
                monochromaticFieldFactors(scene.starColor[s], meta.stars[s], what, rerun);
            for (std::size_t c = 0; c < 3; ++c) {
                if (s > 0 && std::abs(f[c] - factor[c]) > 1e-9 * std::abs(factor[c])) {
                    throw Error(what + " holds the stars' light as one field, made with their "
                                       "colours; stars of different temperatures need a "
                                       "field per star for --fits: run nebscatter --per-star");
                }
                factor[c] = f[c];
            }
        }
        break;
    case ScatterSource::Kind::Star: {
        const std::size_t s = source.star;
        std::fill(factor.begin(), factor.end(),
                  scene.stars[s].luminosity / meta.stars[s].luminosity);
        if (!opts.monochromatic) break;
        if (spectral) {
            std::fill(factor.begin(), factor.end(),
                      calibratedSpectralFieldFactor(scene.stars[s], meta.stars[s]));
            break;
        }
        const auto f = monochromaticFieldFactors(scene.starColor[s], meta.stars[s], what, rerun);
        factor.assign(f.begin(), f.end());
        break;
    }
    }
    return factor;
}

/// Reads nebscatter's field (DESIGN §5b, io/scatter_field_vdb.h) into scene.scatter, checking
/// that it was made for this scene; see buildScene(). @p spectral: the spectral field
/// (nebscatter --spectral, for the spectral renderer) instead of the R, G, B one.
void readScatterField(const GridSet& grids, const RenderOptions& opts, const DustParams& dust,
                      RenderScene& scene, bool spectral)
{
    const auto found = readScatterFieldMeta(grids, spectral);
    if (!found) return;
    const ScatterFieldMeta& meta = *found;
    const std::string what = grids.source + ": the " + (spectral ? "spectral " : "") +
                             "scattered-light field (nebscatter" + (spectral ? " --spectral" : "") +
                             ")";
    const std::string rerun = "; rerun nebscatter" + std::string(spectral ? " --spectral" : "") +
                              " on this scene, or pass --no-scatter-field";
    requireFieldForScene(meta, grids, opts, dust, scene, spectral, what, rerun);
    if (meta.sources.empty()) return;

    std::vector<std::vector<double>> factors;
    std::string names;
    for (const auto& source : meta.sources) {
        factors.push_back(sourceFactor(source.source, meta, opts, scene, spectral, what, rerun));
        names += (names.empty() ? "" : ", ") + scatterSourceName(source.source, meta.stars);
    }
    const ScatterSettings& made = meta.settings;
    SceneScatterField& out = scene.scatter;
    for (const auto& source : meta.sources)
        out.emissionSource =
            out.emissionSource || source.source.kind == ScatterSource::Kind::Emission;
    out.moments =
        readScatterMoments(grids, meta, spectral, factors,
                           fieldLevelMap(scene.fields.indexToWorld, made.fieldLevel), what, rerun);
    out.order = made.order;
    out.level = made.fieldLevel;
    const auto& wl = meta.wavelengths;
    if (spectral) out.wavelengths = wl;
    out.description = fmt::format(
        "{}scattered-light field: order {}, level {} (cells of {}^3 "
        "voxels), sources {}{}",
        spectral ? "spectral " : "", made.order, made.fieldLevel, fieldCellVoxels(made.fieldLevel),
        names,
        spectral ? fmt::format(", {} wavelengths {:g}-{:g} nm", wl.size(), wl.front(), wl.back())
                 : std::string());
}

} // namespace

namespace {

/// The largest active value of @p grid (0 for none).
float largestValue(const openvdb::FloatGrid& grid)
{
    if (grid.tree().activeVoxelCount() == 0) return 0.0f;
    return std::max(0.0f, openvdb::tools::minMax(grid.tree()).max()); // threaded
}

/// Throws UsageError naming --emission-scale (and the grid's largest value) if @p scale times
/// @p emission's largest value across @p lattice's diagonal exceeds MAX_RADIANCE.
void requireFiniteEmission(const openvdb::FloatGrid& emission, double scale,
                           const SparseVolume& lattice, const std::string& source)
{
    const double largest = largestValue(emission);
    const auto& d = lattice.dims();
    const Vec3 diagonal = lattice.indexToWorld.applyLinear(Vec3(d[0], d[1], d[2]));
    const double length =
        std::sqrt(diagonal.x * diagonal.x + diagonal.y * diagonal.y + diagonal.z * diagonal.z);
    const double radiance = scale * largest * length;
    if (!(radiance <= MAX_RADIANCE)) {
        throw UsageError(source + ": --emission-scale " + detail::numberText(scale) +
                         " times the emission grid \"" + emission.getName() +
                         "\"'s largest value " + fmt::format("{:.4g}", largest) + " over " +
                         fmt::format("{:.4g}", length) + " pc gives radiances up to " +
                         fmt::format("{:.4g}", radiance) + ", beyond " +
                         detail::numberText(MAX_RADIANCE) + "; use a smaller --emission-scale");
    }
}

/// An emission grid RGB mode draws and its colour per grid unit (linear sRGB).
struct RgbEmitter
{
    openvdb::FloatGrid::Ptr grid;
    std::array<double, 3> colour;
    std::vector<SpectralLine> lines; ///< empty: painted in --emission-color
    double luminance = 0.0;          ///< the luminance its lines are scaled to
};

/// The emission grids RGB mode draws (DESIGN §3.4): opts.emissionGrid (if the file has it)
/// and, with opts.lineColours, every other FloatGrid with nebula:lines, as
/// buildSpectralScene() takes them. A grid with lines gets their colour at the luminance of
/// --emission-color (linesLinearSRGB()), the spectral renderer's brightness; a grid without,
/// or every grid without opts.lineColours, --emission-color. None when calibrated
/// (RenderOptions::monochromatic). Error for values that are negative or not finite, lines
/// that do not parse, or lines that are all outside 360-830 nm.
std::vector<RgbEmitter> rgbEmitters(const GridSet& grids, const RenderOptions& opts)
{
    std::vector<RgbEmitter> out;
    if (opts.monochromatic) return out;
    const double luminance = linearSRGBToXYZ(opts.emissionColor)[1];
    const auto add = [&](const openvdb::FloatGrid::Ptr& g) {
        requireFiniteNonNegative(*g, grids.source);
        RgbEmitter e{g, opts.emissionColor, {}, 0.0};
        if (opts.lineColours && (*g)[META_LINES]) {
            const auto lines = gridLines(*g, grids.source, {});
            if (!(linesXYZ(lines)[1] > 0.0)) {
                throw Error(grids.source + ": grid \"" + g->getName() + "\" emits only lines " +
                            "outside 360-830 nm (" + lineListToString(lines) + "): nothing to see");
            }
            e.colour = linesLinearSRGB(lines, luminance);
            e.lines = lines;
            e.luminance = luminance;
        }
        out.push_back(e);
    };
    if (grids.find(opts.emissionGrid)) add(grids.floatGrid(opts.emissionGrid, "--emission-grid"));
    for (const auto& g : grids.grids) {
        if (!opts.lineColours || !g || g->getName() == opts.emissionGrid) continue;
        if (!g->getMetadata<openvdb::StringMetadata>(META_LINES)) continue;
        add(grids.floatGrid(g->getName(), ""));
    }
    return out;
}

/// The line groups of emitter @p k (DESIGN §3.4): its lines sorted by wavelength, neighbours
/// whose extinction ratios differ by under 1 % (a doublet) in one group at their
/// luminance-weighted ratio, each group's colour its share of the emitter's; one painted
/// group for a grid without lines.
std::vector<SceneEmission::Line> lineGroups(const RgbEmitter& e, int k, const DustParams& dust)
{
    if (e.lines.empty()) return {SceneEmission::Line{k, e.colour, 1.0, true}};
    auto lines = e.lines;
    std::sort(lines.begin(), lines.end(), [](const SpectralLine& a, const SpectralLine& b) {
        return a.wavelength < b.wavelength;
    });
    const double unit = e.luminance / linesXYZ(lines)[1];
    std::vector<SceneEmission::Line> out;
    std::vector<SpectralLine> group;
    double ratio0 = 0.0, weighted = 0.0, Y = 0.0;
    const auto flush = [&] {
        if (group.empty() || !(Y > 0.0)) return;
        XYZ xyz = linesXYZ(group);
        for (auto& v : xyz)
            v *= unit;
        out.push_back(SceneEmission::Line{k, xyzToLinearSRGB(xyz), weighted / Y, false});
    };
    for (const auto& l : lines) {
        const double y = l.strength * cmfAt(l.wavelength)[1];
        if (!(y > 0.0)) continue; // outside 360-830 nm: no colour
        const double r = extinctionRatio(dust, l.wavelength);
        if (!group.empty() && std::abs(r - ratio0) > 0.01 * ratio0) {
            flush();
            group.clear();
            weighted = Y = 0.0;
        }
        if (group.empty()) ratio0 = r;
        group.push_back(l);
        weighted += y * r;
        Y += y;
    }
    flush();
    return out;
}

/// Fills scene.emission (DESIGN §3.4) from @p emitters: one grid is channel 1 already, with
/// its colour and, if it has lines, its line groups (gridChannel 1); several go to the
/// channels from @p first on, one each, with their line groups (extinction ratios from
/// @p dust), and their plain sum into channel 1.
void colourEmission(RenderScene& scene, const std::vector<RgbEmitter>& emitters, int first,
                    const DustParams& dust)
{
    for (const auto& e : emitters)
        scene.emission.grids.emplace_back(e.grid->getName(), e.colour);
    if (emitters.size() == 1) {
        const RgbEmitter& e = emitters.front();
        scene.emission.colour = e.colour;
        if (e.lines.empty()) return;    // painted: channel 1 times the colour, per channel
        scene.emission.gridChannel = 1; // the grid itself, dimmed at its lines' wavelengths
        scene.emission.lines = lineGroups(e, 0, dust);
        return;
    }
    if (emitters.size() < 2) return;
    scene.emission.gridChannel = first;
    for (std::size_t k = 0; k < emitters.size(); ++k) {
        const RgbEmitter& e = emitters[k];
        addGridToVolume(scene.fields, *e.grid, 1, 1.0);
        for (const auto& g : lineGroups(e, int(k), dust))
            scene.emission.lines.push_back(g);
    }
}

} // namespace

RenderScene buildScene(const GridSet& grids, const RenderOptions& opts, const DustParams& dust)
{
    RenderScene scene;
    const auto density = grids.floatGrid(opts.densityGrid, "--density-grid");
    requireFiniteNonNegative(*density, grids.source);
    const auto emitters = rgbEmitters(grids, opts);
    // One emitter: channel 1 itself (the layout of old scenes); several: summed below.
    openvdb::FloatGrid::Ptr emission;
    if (emitters.size() == 1) emission = emitters.front().grid;
    scene.stars = grids.stars();
    if (scene.stars.empty()) {
        throw Error(grids.source + ": no stars: the file has no " + std::string(META_STARS) +
                    " metadata (run nebgen and nebillum, or nebillum --star)");
    }
    if (!emission) {
        emission = openvdb::FloatGrid::create(0.0f); // no emission: an empty grid
        emission->setTransform(density->transform().copy());
    }
    std::vector<openvdb::FloatGrid::ConstPtr> fields{density, emission};
    for (const auto& s : scene.stars) {
        auto tau = tauGrid(grids, s, "", "; run nebillum on this file first");
        requireSameKappa(grids, *tau, dust);
        fields.push_back(tau);
    }
    std::vector<openvdb::FloatGrid::ConstPtr> bounds{density, fields[1]};
    const int first = int(fields.size());
    for (std::size_t k = 0; k < emitters.size() && emitters.size() > 1; ++k) {
        fields.push_back(emitters[k].grid); // volumeFromGrids() checks its transform
        bounds.push_back(emitters[k].grid);
    }
    scene.fields = volumeFromGrids(fields, activeBounds(bounds, 1), grids.source);
    requireFiniteEmission(*emission, opts.emissionScale, scene.fields, grids.source);
    for (std::size_t k = 0; k < emitters.size() && emitters.size() > 1; ++k)
        requireFiniteEmission(*emitters[k].grid, opts.emissionScale, scene.fields, grids.source);
    colourEmission(scene, emitters, first, dust);

    scene.starColor = starColors(scene.stars, opts);
    scene.dust = channelDust(dust, opts.wavelengths);
    requireTableForDust(grids, opts, dust);
    scene.buildOccupancy();

    if (opts.scatterField && opts.integrator == Integrator::Fast) {
        readScatterField(grids, opts, dust, scene, opts.spectral.enabled);
    }
    const int levels = levelCount(grids, opts);
    for (int k = 1; k <= levels; ++k) {
        scene.levels.push_back(readLevel(grids, opts, scene.stars, k, scene.fields.indexToWorld));
    }
    return scene;
}

} // namespace nebula
