// SPDX-License-Identifier: Apache-2.0
// nebgen's presets (stages/presets.h) measured by nebstats' statistics (stages/stats.h): the
// ranges docs/presets.md documents, the observed targets, determinism, and the turbulence's
// Mach number and anisotropy as the grids carry them.
#include "nebula/io/checksum.h"
#include "nebula/stages/presets.h"
#include "nebula/stages/stats.h"

#include "test_util.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using nebula::NebulaPreset;

namespace {

nebula::GridSet generate(NebulaPreset preset, int res, std::uint64_t seed = 1)
{
    openvdb::initialize();
    nebula::NebulaParams p = nebula::presetParams(preset);
    p.res = res;
    p.seed = seed;
    return nebula::generateNebula(p);
}

nebula::CloudStats statsOf(const nebula::GridSet& grids)
{
    return nebula::cloudStatistics(grids, nebula::StatsOptions{});
}

struct Range
{
    double lo, hi;
};

/// What docs/presets.md documents at 64^3 (seed 1, along z), per preset.
struct Documented
{
    NebulaPreset preset;
    Range pdfSigma, highSideSlope, spectrumSlope, dimension;
    bool highSide = true; ///< the PDF's high side has 3 bins (not the globule's small map)
};

const Documented DOCUMENTED_64[] = {
    {NebulaPreset::Reflection, {0.3, 0.62}, {-4.5, -2.5}, {-3.2, -2.5}, {1.25, 1.45}},
    {NebulaPreset::External, {0.3, 0.65}, {-6.0, -2.5}, {-3.3, -2.5}, {1.2, 1.45}},
    {NebulaPreset::Pillars, {0.8, 1.3}, {-2.0, -0.5}, {-3.2, -1.9}, {1.25, 1.45}},
    {NebulaPreset::Bubble, {1.0, 2.0}, {-2.0, -0.5}, {-3.2, -2.4}, {1.2, 1.45}},
    {NebulaPreset::Globule, {0.7, 1.4}, {-5.0, -2.0}, {-3.8, -2.4}, {0.75, 1.2}, false},
    {NebulaPreset::Bipolar, {0.8, 1.4}, {-3.5, -1.5}, {-3.2, -2.3}, {1.05, 1.45}},
    {NebulaPreset::Hii, {0.4, 0.8}, {-4.5, -2.0}, {-3.2, -2.4}, {1.25, 1.45}},
};

void expectIn(double value, Range r, const std::string& what)
{
    EXPECT_GE(value, r.lo) << what;
    EXPECT_LE(value, r.hi) << what;
}

} // namespace

TEST(Presets, EveryPresetIsDeterministicAndStaysOffTheCubeFaces)
{
    for (const auto& info : nebula::nebulaPresets()) {
        if (info.id == NebulaPreset::Fbm) continue;
        const auto a = generate(info.id, 48), b = generate(info.id, 48);
        const auto density = a.floatGrid("density", "--grid");
        EXPECT_GT(density->activeVoxelCount(), 1000u) << info.name;
        for (std::size_t g = 0; g < a.grids.size(); ++g) {
            EXPECT_EQ(nebula::gridChecksum(*a.grids[g]), nebula::gridChecksum(*b.grids[g]))
                << info.name << " " << a.grids[g]->getName();
        }
        if (info.id == NebulaPreset::Box) continue; // the periodic box fills the cube
        // No clipped envelope: nothing on the cube's faces, in any grid.
        for (const auto& grid : a.grids) {
            const auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(grid);
            if (!fg) continue;
            for (auto it = fg->cbeginValueOn(); it; ++it) {
                const auto c = it.getCoord();
                const bool face = c.x() == 0 || c.y() == 0 || c.z() == 0 || c.x() == 47 ||
                                  c.y() == 47 || c.z() == 47;
                ASSERT_FALSE(face) << info.name << " " << grid->getName() << " at " << c;
            }
        }
    }
}

TEST(Presets, StatisticsInTheDocumentedRangesAt64)
{
    for (const auto& d : DOCUMENTED_64) {
        const std::string name = nebula::presetName(d.preset);
        const auto st = statsOf(generate(d.preset, 64));
        ASSERT_TRUE(st.pdf.fitted && st.spectrum.fitted && st.contours.fitted) << name;
        expectIn(st.pdf.sigma, d.pdfSigma, name + " sigma(ln N)");
        EXPECT_EQ(st.pdf.highSide, d.highSide) << name;
        if (d.highSide) expectIn(st.pdf.tailSlope, d.highSideSlope, name + " high side");
        expectIn(st.spectrum.slope, d.spectrumSlope, name + " spectrum");
        expectIn(st.contours.dimension, d.dimension, name + " perimeter-area");
    }
}

TEST(Presets, ObservedTargetsAt128)
{
    // The observed targets, where docs/presets.md says a preset meets them at 128^3: sigma(ln N)
    // 0.3-0.6 for reflection and external; every preset's spectrum -2.5 to -3.2 over a decade
    // of k; the contours' dimension 1.25-1.45 for reflection, external, pillars and bubble
    // (bipolar reaches it at 256^3; the globule's few, round contours stay near 1); a
    // power-law high side in the pillars' PDF (their heads' cores).
    for (const auto& info : nebula::nebulaPresets()) {
        if (info.id == NebulaPreset::Fbm || info.id == NebulaPreset::Box) continue;
        const auto st = statsOf(generate(info.id, 128));
        expectIn(st.spectrum.slope, {-3.2, -2.5}, std::string(info.name) + " spectrum");
        if (info.id == NebulaPreset::Reflection || info.id == NebulaPreset::External) {
            expectIn(st.pdf.sigma, {0.3, 0.6}, std::string(info.name) + " sigma(ln N)");
        }
        if (info.id == NebulaPreset::Reflection || info.id == NebulaPreset::External ||
            info.id == NebulaPreset::Pillars || info.id == NebulaPreset::Bubble) {
            expectIn(st.contours.dimension, {1.25, 1.45}, std::string(info.name) + " D");
        }
        if (info.id == NebulaPreset::Pillars) {
            // The heads' cores: a high side falling as a power law shallower than N^-2 (the
            // cavity's far wall widens the lognormal, so it holds no 2x excess: no tail).
            EXPECT_TRUE(st.pdf.highSide);
            expectIn(st.pdf.tailSlope, {-2.0, -1.0}, "pillars' high side");
        }
    }
}

TEST(Presets, AFinerGridIsTheSameCloud)
{
    // The 128^3 reflection's column map, binned 2 x 2, against the 64^3 one over the box they
    // share: correlated above 0.8 (the same large-scale modes), not a new cloud.
    nebula::StatsOptions opts;
    opts.bbox = "0,0,0,63,63,63";
    const auto coarse = nebula::cloudStatistics(generate(NebulaPreset::Reflection, 64), opts);
    opts.bbox = "0,0,0,127,127,127";
    const auto fine = nebula::cloudStatistics(generate(NebulaPreset::Reflection, 128), opts);
    double sab = 0.0, saa = 0.0, sbb = 0.0, ma = 0.0, mb = 0.0;
    for (int v = 0; v < 64; ++v) {
        for (int u = 0; u < 64; ++u) {
            ma += coarse.map.at(u, v);
            mb += fine.map.at(2 * u, 2 * v) + fine.map.at(2 * u + 1, 2 * v) +
                  fine.map.at(2 * u, 2 * v + 1) + fine.map.at(2 * u + 1, 2 * v + 1);
        }
    }
    ma /= 4096.0;
    mb /= 4096.0;
    for (int v = 0; v < 64; ++v) {
        for (int u = 0; u < 64; ++u) {
            const double a = coarse.map.at(u, v) - ma;
            const double b = fine.map.at(2 * u, 2 * v) + fine.map.at(2 * u + 1, 2 * v) +
                             fine.map.at(2 * u, 2 * v + 1) + fine.map.at(2 * u + 1, 2 * v + 1) - mb;
            sab += a * b;
            saa += a * a;
            sbb += b * b;
        }
    }
    EXPECT_GT(sab / std::sqrt(saa * sbb), 0.8);
}

TEST(Presets, MachAndForcingSetTheDensityPdf)
{
    // The box (no geometry): sigma of ln n over its voxels, as nebstats measures it on the
    // written grid, against sqrt(ln(1 + b^2 M^2)) within 10 %, for M = 2-10 and b = 1/3-1.
    for (double b : {1.0 / 3.0, 0.5, 1.0}) {
        for (double mach : {2.0, 4.0, 6.0, 10.0}) {
            nebula::NebulaParams p = nebula::presetParams(NebulaPreset::Box);
            p.res = 32;
            p.turbulence.mach = mach;
            p.turbulence.forcingB = b;
            const auto st = statsOf(nebula::generateNebula(p));
            const double predicted = std::sqrt(std::log(1.0 + b * b * mach * mach));
            EXPECT_NEAR(st.volume.sigma(), predicted, 0.1 * predicted)
                << "M " << mach << " b " << b;
            EXPECT_EQ(st.volume.count(), 32u * 32u * 32u);
        }
    }
}

TEST(Presets, AnisotropyShowsInTheSpectrum)
{
    // The box with --anisotropy 2 along x, projected along z: the column's power across x over
    // the power along x (k = 1.6-16 per edge) above 2; isotropic, within 25 % of 1.
    nebula::NebulaParams p = nebula::presetParams(NebulaPreset::Box);
    p.res = 64;
    p.turbulence.anisotropy = 2.0;
    p.turbulence.axis = {1.0, 0.0, 0.0};
    const auto striated = statsOf(nebula::generateNebula(p));
    EXPECT_GT(striated.spectrum.anisotropy, 2.0);
    p.turbulence.anisotropy = 0.0;
    const auto isotropic = statsOf(nebula::generateNebula(p));
    EXPECT_NEAR(isotropic.spectrum.anisotropy, 1.0, 0.25);
}

TEST(Presets, NamesStarsAndErrors)
{
    EXPECT_EQ(nebula::parsePreset("pillars"), NebulaPreset::Pillars);
    const std::string message = nebula::test::errorMessage([] { nebula::parsePreset("m42"); });
    EXPECT_NE(message.find("unknown preset 'm42'"), std::string::npos) << message;
    for (const auto& info : nebula::nebulaPresets())
        EXPECT_NE(message.find(info.name), std::string::npos) << info.name;
    // Stars scale with the cube: the same place in the picture at any --size.
    const auto at10 = nebula::presetStars(NebulaPreset::Reflection, 10.0);
    const auto at20 = nebula::presetStars(NebulaPreset::Reflection, 20.0);
    ASSERT_EQ(at10.size(), 1u);
    for (int d = 0; d < 3; ++d)
        EXPECT_DOUBLE_EQ(at20[0].position[d], 2.0 * at10[0].position[d]);
    // The turbulence's options are checked with the rest.
    nebula::NebulaParams p = nebula::presetParams(NebulaPreset::External);
    p.turbulence.mach = -1.0;
    EXPECT_THROW(nebula::generateNebula(p), nebula::UsageError);
    p = nebula::presetParams(NebulaPreset::External);
    p.edgeCut = -1.0;
    EXPECT_THROW(nebula::generateNebula(p), nebula::UsageError);
}
