// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/scatter_field_vdb.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/spherical_harmonics.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace nebula {

using detail::numberText;

namespace {

/// A field grid of the kind: "scatter.*" (R, G, B) or "scatter.spectral.*".
bool isFieldGrid(const std::string& name, bool spectral)
{
    const bool spectralGrid = name.rfind(SPECTRAL_SCATTER_PREFIX, 0) == 0;
    return spectral ? spectralGrid : name.rfind("scatter.", 0) == 0 && !spectralGrid;
}

std::string gridName(const std::string& source, int l, int m, int c,
                     const std::vector<double>& wavelengths, bool spectral)
{
    return spectral ? spectralScatterGridName(source, l, m, wavelengths[std::size_t(c)])
                    : scatterGridName(source, l, m, c);
}

} // namespace

float storedFieldValue(float value, float reference, int bits)
{
    if (bits >= FIELD_FLOAT_BITS || value == 0.0f || !std::isfinite(value)) return value;
    float ref = std::abs(reference);
    if (!(ref > 0.0f) || !std::isfinite(ref)) ref = std::abs(value);
    int e = 0;
    std::frexp(ref, &e); // 2^(e - 1) <= ref < 2^e
    const double step = std::ldexp(1.0, e - bits);
    return float(std::round(double(value) / step) * step);
}

const char* scatterMetaKey(bool spectral)
{
    return spectral ? META_SCATTER_SPECTRAL : META_SCATTER;
}

void writeScatterField(GridSet& grids, const ScatterFieldMeta& meta,
                       const std::vector<const SparseVolume*>& moments,
                       const std::vector<std::uint8_t>& active,
                       const openvdb::math::Transform& fieldTransform, bool spectral)
{
    // Replace any earlier field of the same kind (R, G, B or spectral).
    openvdb::GridPtrVec kept;
    for (auto& g : grids.grids)
        if (!isFieldGrid(g->getName(), spectral)) kept.push_back(g);
    grids.grids = kept;

    const int L = meta.settings.order;
    const int C = int(meta.wavelengths.size()); // channels per moment
    nlohmann::json sources = nlohmann::json::array();
    for (std::size_t s = 0; s < meta.sources.size(); ++s) {
        const ScatterSourceSummary& src = meta.sources[s];
        const std::string name = scatterSourceName(src.source, meta.stars);
        const SparseVolume& m = *moments[s];
        const double j0 = 0.5 / std::sqrt(PI); // Y_00: J = c_00 / (4 pi Y_00)
        for (int l = 0; l <= L; ++l)
            for (int mm = -l; mm <= l; ++mm)
                for (int c = 0; c < C; ++c) {
                    const int ch = shIndex(l, mm) * C + c;
                    // The grid's units: J for l = 0, c_lm else; each value is stored
                    // against its cell's c_00 in the same units (J for the J grids).
                    const double scale = l == 0 ? 1.0 / (4.0 * PI * j0) : 1.0;
                    auto grid = openvdb::FloatGrid::create(0.0f);
                    auto acc = grid->getAccessor();
                    for (int K = m.lo()[2]; K < m.lo()[2] + m.dims()[2]; ++K)
                        for (int J = m.lo()[1]; J < m.lo()[1] + m.dims()[1]; ++J)
                            for (int I = m.lo()[0]; I < m.lo()[0] + m.dims()[0]; ++I) {
                                // active: x fastest, then y, then z (ScatterField::active).
                                const std::size_t cell =
                                    (std::size_t(K - m.lo()[2]) * std::size_t(m.dims()[1]) +
                                     std::size_t(J - m.lo()[1])) *
                                        std::size_t(m.dims()[0]) +
                                    std::size_t(I - m.lo()[0]);
                                if (!active[cell]) continue;
                                const float* v = m.voxel(m.index(I, J, K));
                                acc.setValue(openvdb::Coord(I, J, K),
                                             storedFieldValue(float(v[ch] * scale),
                                                              float(v[c] * scale),
                                                              meta.storedBits));
                            }
                    grid->setTransform(fieldTransform.copy());
                    grid->setName(gridName(name, l, mm, c, meta.wavelengths, spectral));
                    grid->setGridClass(openvdb::GRID_UNKNOWN);
                    const char* units =
                        spectral ? (l == 0 ? "L_sun pc^-2 sr^-1 nm^-1 (mean intensity J per nm)"
                                           : "L_sun pc^-2 nm^-1 (c_lm per nm)")
                                 : (l == 0 ? "L_sun pc^-2 sr^-1 (mean intensity J)"
                                           : "L_sun pc^-2 (c_lm)");
                    grid->insertMeta("units", openvdb::StringMetadata(units));
                    if (spectral) {
                        grid->insertMeta("wavelength_nm",
                                         openvdb::DoubleMetadata(meta.wavelengths[std::size_t(c)]));
                    }
                    grid->insertMeta("source", openvdb::StringMetadata(name));
                    grid->insertMeta("l", openvdb::Int32Metadata(l));
                    grid->insertMeta("m", openvdb::Int32Metadata(mm));
                    grid->insertMeta("level", openvdb::Int32Metadata(meta.settings.fieldLevel));
                    grids.replace(grid);
                }
        sources.push_back({{"name", name},
                           {"packets", src.packets},
                           {"flights", src.flights},
                           {"power", src.power},
                           {"escaped", src.escaped},
                           {"absorbed", src.absorbed},
                           {"relative_error", src.relativeError}});
    }
    const Affine& a0 = meta.indexToWorld;
    const ScatterSettings& set = meta.settings;
    const nlohmann::json json = {{"order", L},
                                 {"level", set.fieldLevel},
                                 {"per_star", set.perStar},
                                 {"packets", set.packets},
                                 {"seed", set.seed},
                                 {"refine_tau", set.refineTau},
                                 {"denoise", set.denoise},
                                 {"sources", sources},
                                 {"dust", nlohmann::json::parse(meta.dust.toJson())},
                                 {"stars", nlohmann::json::parse(starsToJson(meta.stars))},
                                 {"wavelengths", meta.wavelengths},
                                 {"min_star_distance", meta.scene.minStarDistance},
                                 {"exact_star_depth", meta.scene.exactStarDepth},
                                 {"density_grid", meta.scene.densityGrid},
                                 {"emission_grid", meta.scene.emissionGrid},
                                 {"index_to_world",
                                  {a0.m[0], a0.m[1], a0.m[2], a0.t.x, a0.m[3], a0.m[4], a0.m[5],
                                   a0.t.y, a0.m[6], a0.m[7], a0.m[8], a0.t.z}},
                                 {"seconds", meta.seconds},
                                 {"stored_bits", meta.storedBits}};
    grids.setMetaString(scatterMetaKey(spectral), json.dump());
}

std::optional<ScatterFieldMeta> readScatterFieldMeta(const GridSet& grids, bool spectral)
{
    const char* metaKey = scatterMetaKey(spectral);
    const std::string metaText = grids.metaString(metaKey);
    if (metaText.empty()) {
        for (const auto& g : grids.grids) {
            const std::string& name = g->getName();
            if (isFieldGrid(name, spectral)) {
                throw Error(grids.source + ": grid \"" + name + "\" looks like a " +
                            (spectral ? "spectral " : "") +
                            "scattered-light field but the file has no " + metaKey +
                            " metadata saying what it was made for; rerun nebscatter" +
                            (spectral ? " --spectral" : "") + ", or pass --no-scatter-field");
            }
        }
        return std::nullopt;
    }
    ScatterFieldMeta meta;
    ScatterSettings& set = meta.settings;
    std::vector<std::string> names;
    std::string layout; // absent: one FloatGrid per source, moment and channel
    detail::checkJsonBounds(metaText, grids.source, std::string(metaKey) + " metadata is ");
    try {
        const nlohmann::json json = nlohmann::json::parse(metaText);
        set.order = json.at("order").get<int>();
        set.fieldLevel = json.at("level").get<int>();
        for (const auto& src : json.at("sources")) {
            ScatterSourceSummary s;
            names.push_back(src.at("name").get<std::string>());
            s.packets = src.value("packets", std::uint64_t(0));
            s.flights = src.value("flights", std::uint64_t(0));
            s.power = src.value("power", std::vector<double>());
            s.escaped = src.value("escaped", std::vector<double>());
            s.absorbed = src.value("absorbed", std::vector<double>());
            s.relativeError = src.value("relative_error", 0.0);
            meta.sources.push_back(s);
        }
        meta.stars = parseStars(json.at("stars").dump(), grids.source + " (" + metaKey + ")");
        meta.dust =
            DustParams::fromJson(json.at("dust").dump(), grids.source + " (" + metaKey + ")");
        meta.wavelengths = json.at("wavelengths").get<std::vector<double>>();
        const auto a = json.at("index_to_world").get<std::array<double, 12>>();
        meta.indexToWorld.m = {a[0], a[1], a[2], a[4], a[5], a[6], a[8], a[9], a[10]};
        meta.indexToWorld.t = Vec3(a[3], a[7], a[11]);
        meta.scene.minStarDistance = json.at("min_star_distance").get<double>();
        meta.scene.densityGrid = json.at("density_grid").get<std::string>();
        meta.scene.emissionGrid = json.at("emission_grid").get<std::string>();
        set.perStar = json.value("per_star", false);
        set.packets = json.value("packets", std::uint64_t(0));
        set.seed = json.value("seed", std::uint64_t(0));
        set.refineTau = json.value("refine_tau", 0.0);
        set.denoise = json.value("denoise", 0);
        meta.scene.exactStarDepth = json.value("exact_star_depth", false);
        meta.seconds = json.value("seconds", 0.0);
        meta.storedBits = json.value("stored_bits", FIELD_FLOAT_BITS);
        layout = json.value("layout", std::string());
    } catch (const nlohmann::json::exception& e) {
        throw Error(grids.source + ": " + metaKey +
                    " metadata is not nebscatter's: " + detail::jsonErrorText(e));
    }
    if (set.order < 0 || set.order > SH_MAX_DEGREE || set.fieldLevel < MIN_FIELD_LEVEL ||
        set.fieldLevel > MAX_FIELD_LEVEL) {
        throw Error(grids.source + ": " + metaKey + " has order " + std::to_string(set.order) +
                    " and level " + std::to_string(set.fieldLevel) + "; expected 0..4 and " +
                    std::to_string(MIN_FIELD_LEVEL) + ".." + std::to_string(MAX_FIELD_LEVEL));
    }
    if (!layout.empty()) {
        throw Error(grids.source + ": " + metaKey + " has layout \"" +
                    detail::printable(layout, 40) +
                    "\", which this version does not read (it reads fields without \"layout\": "
                    "one FloatGrid per source, moment and channel); use a newer nebula, or rerun "
                    "this nebscatter");
    }
    if (meta.storedBits < FIELD_MIN_BITS || meta.storedBits > FIELD_FLOAT_BITS) {
        throw Error(grids.source + ": " + metaKey + " has stored_bits " +
                    std::to_string(meta.storedBits) + "; expected " +
                    std::to_string(FIELD_MIN_BITS) + ".." + std::to_string(FIELD_FLOAT_BITS) +
                    " (the significant bits its moments keep)");
    }
    if (set.denoise < 0 || set.denoise > MAX_DENOISE_RADIUS) {
        throw Error(grids.source + ": " + metaKey + " has denoise " + std::to_string(set.denoise) +
                    "; expected 0.." + std::to_string(MAX_DENOISE_RADIUS) +
                    " (the noise filter's radius)");
    }
    const auto& wl = meta.wavelengths;
    bool wlOk = spectral ? wl.size() >= 2 : wl.size() == 3;
    for (std::size_t i = 0; i < wl.size() && wlOk; ++i)
        wlOk = std::isfinite(wl[i]) && wl[i] > 0.0 && (i == 0 || wl[i] > wl[i - 1] || !spectral);
    if (!wlOk) {
        throw Error(grids.source + ": " + metaKey + " has wavelengths " + detail::numbersText(wl) +
                    "; expected " + (spectral ? "at least 2 increasing" : "3 (R, G, B)") +
                    " wavelengths > 0 nm");
    }
    for (std::size_t s = 0; s < meta.sources.size(); ++s) {
        ScatterSource& source = meta.sources[s].source;
        source = parseScatterSource(names[s], meta.stars, grids.source + ": " + metaKey);
        if (spectral && source.kind == ScatterSource::Kind::Emission) {
            throw Error(grids.source + ": the spectral scattered-light field (nebscatter "
                                       "--spectral) has an emission source, which a spectral "
                                       "field does not have; rerun nebscatter --spectral on "
                                       "this scene, or pass --no-scatter-field");
        }
    }
    return meta;
}

SparseVolume readScatterMoments(const GridSet& grids, const ScatterFieldMeta& meta, bool spectral,
                                const std::vector<std::vector<double>>& factors,
                                const Affine& fieldMap, const std::string& what,
                                const std::string& rerun)
{
    const int C = int(meta.wavelengths.size()); // channels per moment
    // Every grid, checked to be on the field level's transform, before any is read.
    std::vector<std::vector<openvdb::FloatGrid::ConstPtr>> perSource;
    std::vector<openvdb::FloatGrid::ConstPtr> jGrids;
    for (const auto& src : meta.sources) {
        const std::string source = scatterSourceName(src.source, meta.stars);
        std::vector<openvdb::FloatGrid::ConstPtr> list;
        for (int l = 0; l <= meta.settings.order; ++l)
            for (int m = -l; m <= l; ++m)
                for (int c = 0; c < C; ++c) {
                    const std::string name = gridName(source, l, m, c, meta.wavelengths, spectral);
                    if (!grids.find(name)) {
                        throw Error(what + " lacks its grid \"" + name + "\"" + rerun);
                    }
                    const auto g = grids.floatGrid(name, "");
                    const Affine a = affineFromTransform(g->transform());
                    double off = 0.0, norm = 0.0;
                    for (std::size_t i = 0; i < 9; ++i) {
                        off = std::max(off, std::abs(a.m[i] - fieldMap.m[i]));
                        norm = std::max(norm, std::abs(fieldMap.m[i]));
                    }
                    off =
                        std::max({off, std::abs(a.t.x - fieldMap.t.x),
                                  std::abs(a.t.y - fieldMap.t.y), std::abs(a.t.z - fieldMap.t.z)});
                    if (off > 1e-6 * norm) {
                        throw Error(what + ": grid \"" + name + "\" is not on field level " +
                                    std::to_string(meta.settings.fieldLevel) +
                                    "'s transform (cells of " +
                                    fieldCellVoxels(meta.settings.fieldLevel) + " voxels of \"" +
                                    meta.scene.densityGrid + "\")" + rerun);
                    }
                    if (l == 0) jGrids.push_back(g);
                    list.push_back(g);
                }
        perSource.push_back(std::move(list));
    }
    const int channels = shCount(meta.settings.order) * C;
    const double c00PerJ =
        4.0 * PI * (0.5 / std::sqrt(PI)); // the l = 0 grids hold J = c_00 / (4 pi Y_00)
    SparseVolume out = emptyVolume(
        activeBounds(jGrids, 1), channels,
        what + ": its " + std::to_string(perSource.size() * std::size_t(channels)) + " grids");
    out.indexToWorld =
        perSource.empty() ? fieldMap : affineFromTransform(perSource[0][0]->transform());
    // Channel k * C + c of source s is its grid k * C + c, in the order of the loop above.
    for (std::size_t s = 0; s < perSource.size(); ++s)
        for (int q = 0; q < channels; ++q)
            addGridToVolume(out, *perSource[s][std::size_t(q)], q, factors[s][std::size_t(q % C)],
                            q < C ? c00PerJ : 1.0);
    return out;
}

} // namespace nebula
