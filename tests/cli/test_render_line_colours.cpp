// SPDX-License-Identifier: Apache-2.0
// RGB mode's emission in the true colour of its lines (DESIGN §3.4), end to end: pixels
// follow the local line mix, RGB and spectral renders agree in chromaticity, an explicit
// --emission-color paints as before, and the path tracer and nebscatter say what they draw.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/image.h"
#include "nebula/physics/colour.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

using namespace nebula::clitest;

namespace {

constexpr const char* HALPHA = "H-alpha:1";
constexpr const char* OIII = "[O III]5007:1,[O III]4959:0.336";

class LineColours : public Cli
{
protected:
    /// A thin cloud (nebgen's at @p densityScale of its density: 1e-3, tau_V about 1e-3
    /// across) lit by
    /// nebillum, named @p out, with the emission grids asked for: "emission" (H-alpha) in
    /// the lower x half of the grid if @p halpha, "emission.oiii" ([O III]) in the upper x
    /// half, overlapping the H-alpha by a quarter of the width, if @p oiii; each 1 per voxel
    /// over the whole depth.
    void makeScene(const std::string& out, bool halpha, bool oiii, float densityScale = 1e-3f)
    {
        if (!fs::exists(path("base.vdb"))) {
            ASSERT_EQ(run("nebgen --res 24 --seed 3 -o base.vdb").code, 0);
        }
        nebula::GridSet g = read(path("base.vdb"));
        auto density = g.floatGrid("density", "")->deepCopy();
        for (auto it = density->beginValueOn(); it; ++it)
            it.setValue(*it * densityScale);
        const openvdb::CoordBBox box = density->evalActiveVoxelBoundingBox();
        const int x0 = box.min().x(), x1 = box.max().x(), w = x1 - x0 + 1;
        openvdb::GridPtrVec grids{density};
        const auto slab = [&](const std::string& name, const char* lines, int lo, int hi) {
            auto e = openvdb::FloatGrid::create(0.0f);
            e->setTransform(density->transform().copy());
            e->setName(name);
            e->setGridClass(openvdb::GRID_FOG_VOLUME);
            openvdb::CoordBBox b = box;
            b.min().x() = lo;
            b.max().x() = hi;
            e->tree().fill(b, 1.0f, true);
            e->tree().voxelizeActiveTiles();
            e->insertMeta(nebula::META_LINES, openvdb::StringMetadata(lines));
            grids.push_back(e);
        };
        if (halpha) slab("emission", HALPHA, x0, x0 + w / 2 - 1);
        if (oiii) slab("emission.oiii", OIII, x0 + w / 4, x1);
        writeVdb(path("raw_" + out), grids, g.meta);
        ASSERT_EQ(run("nebillum -i raw_" + out + " -o " + out).code, 0);
    }

    /// Renders @p scene (RGB, or with @p extra) to @p exr at 32x32 without star sprites.
    nebula::Image render(const std::string& scene, const std::string& exr,
                         const std::string& extra = "")
    {
        const Result r =
            run("nebrender -i " + scene + " --res 32x32 --no-stars " + extra + " -o " + exr);
        EXPECT_EQ(r.code, 0) << r.err;
        lastErr = r.err;
        return nebula::readExr(path(exr), nullptr);
    }

    /// An H-alpha-only and an [O III]-only scene rendered with @p extra (ha.exr, o3.exr): their
    /// summed linear R, G, B.
    std::array<std::array<double, 3>, 2> renderEachLine(const std::string& extra)
    {
        makeScene("ha.vdb", true, false);
        makeScene("o3.vdb", false, true);
        return {sum(render("ha.vdb", "ha.exr", extra)), sum(render("o3.vdb", "o3.exr", extra))};
    }

    /// The beauty's summed linear R, G, B.
    static std::array<double, 3> sum(const nebula::Image& img)
    {
        std::array<double, 3> s{0, 0, 0};
        for (std::size_t p = 0; p < img.rgba.size() / 4; ++p)
            for (std::size_t c = 0; c < 3; ++c)
                s[c] += img.rgba[4 * p + c];
        return s;
    }

    std::string lastErr;
};

} // namespace

TEST_F(LineColours, PixelsFollowTheLocalLineMix)
{
    // Only H-alpha: deep red, beyond the sRGB red primary (G < 0 in the EXR, clipped in the
    // PNG); only [O III]: teal-green (R < 0, G > B > 0).
    // (--emission-scale 100: the starlight the thin dust scatters is 1e-3 of the glow.)
    const auto [ha, o3] = renderEachLine("--emission-scale 100");
    EXPECT_GT(ha[0], 0.0);
    EXPECT_LT(ha[1], 0.0);
    EXPECT_LT(o3[0], 0.0);
    EXPECT_GT(o3[1], o3[2]);
    EXPECT_GT(o3[2], 0.0);
    // In the PNG, the glowing pixels: red where H-alpha glows, green (R clipped to 0) where
    // [O III] does.
    for (const auto& [png, red] : {std::pair{"ha.png", true}, std::pair{"o3.png", false}}) {
        const auto px = pngPixels(path(png));
        ASSERT_FALSE(px.empty()) << png;
        int lit = 0;
        for (std::size_t p = 0; p < px.size() / 4; ++p) {
            const int r = px[4 * p], g = px[4 * p + 1], b = px[4 * p + 2];
            if (std::max({r, g, b}) < 64) continue;
            ++lit;
            if (red) {
                EXPECT_GT(r, 4 * std::max(g, b)) << png << " pixel " << p;
            } else {
                EXPECT_GT(g, 4 * r) << png << " pixel " << p;
                EXPECT_GT(g, b) << png << " pixel " << p;
            }
        }
        EXPECT_GT(lit, 50) << png;
    }
}

namespace {

/// The largest difference in chromaticity x or y between @p a and @p b over the pixels
/// brighter (in @p b) than 1 % of @p b's brightest, and how many those are.
std::pair<double, int> chromaticityDifference(const nebula::Image& a, const nebula::Image& b)
{
    const std::size_t n = a.rgba.size() / 4;
    const auto xyzOf = [](const nebula::Image& img, std::size_t p) {
        return nebula::linearSRGBToXYZ({img.rgba[4 * p], img.rgba[4 * p + 1], img.rgba[4 * p + 2]});
    };
    double brightest = 0.0, worst = 0.0;
    for (std::size_t p = 0; p < n; ++p)
        brightest = std::max(brightest, xyzOf(b, p)[1]);
    int compared = 0;
    for (std::size_t p = 0; p < n; ++p) {
        const auto xa = xyzOf(a, p), xb = xyzOf(b, p);
        if (!(xb[1] > 0.01 * brightest) || !(xa[0] + xa[1] + xa[2] > 0.0)) continue;
        ++compared;
        const auto ca = nebula::chromaticity(xa), cb = nebula::chromaticity(xb);
        worst = std::max({worst, std::abs(ca[0] - cb[0]), std::abs(ca[1] - cb[1])});
    }
    return {worst, compared};
}

} // namespace

TEST_F(LineColours, RgbAgreesWithSpectralThroughDust)
{
    // The same grids in nebgen's dust at a tenth of its density (measured 0.0038):
    // each line group is dimmed at its own wavelength, as in the spectral render, so the
    // colours still agree, within 0.01 in x and y (the starlight the dust scatters, dimmed per
    // channel in RGB mode, makes the rest).
    // Both grids (a channel each), and [O III] alone (channel 1 itself, DESIGN §3.4).
    for (const bool both : {true, false}) {
        const std::string name = both ? "dusty" : "dusty_o3";
        makeScene(name + ".vdb", both, true, 0.1f);
        const nebula::Image rgb = render(name + ".vdb", name + "_rgb.exr", "--lod 0");
        const nebula::Image spec = render(name + ".vdb", name + "_spec.exr", "--spectral");
        const auto [worst, compared] = chromaticityDifference(rgb, spec);
        EXPECT_LT(worst, 0.01) << name;
        EXPECT_GT(compared, 100) << name;
        std::cout << "RGB vs spectral through dust (" << name << "): " << compared
                  << " pixels, largest chromaticity difference " << worst << "\n";
    }
}

TEST_F(LineColours, RgbAgreesWithSpectralInChromaticity)
{
    // Both grids, overlapping: per pixel, the RGB render's chromaticity is the spectral
    // render's (its linear sRGB, which the PNG clips alike) within 0.001 in x and y (measured
    // 6e-4), in every pixel brighter than 1 % of the brightest, and so is its luminance
    // within 1 %. What differs: the starlight scattered by the cloud (tau_V ~ 1e-3), dimmed
    // per channel in RGB mode. --lod 0: the spectral renderer has no level of detail, whose
    // coarser copies would blur the slabs' edges in the RGB render only.
    makeScene("mix.vdb", true, true);
    const nebula::Image rgb = render("mix.vdb", "rgb.exr", "-v --lod 0");
    EXPECT_NE(lastErr.find("emission grid \"emission.oiii\": linear sRGB"), std::string::npos)
        << lastErr;
    EXPECT_EQ(lastErr.find("warning"), std::string::npos) << lastErr;
    const nebula::Image spec = render("mix.vdb", "spec.exr", "--spectral");
    ASSERT_EQ(rgb.rgba.size(), spec.rgba.size());
    const std::size_t n = rgb.rgba.size() / 4;
    double brightest = 0.0;
    for (std::size_t p = 0; p < n; ++p) {
        brightest = std::max(brightest, double(spec.rgba[4 * p + 1]) + spec.rgba[4 * p]);
    }
    int compared = 0, red = 0, green = 0;
    double worst = 0.0;
    for (std::size_t p = 0; p < n; ++p) {
        const auto xyzOf = [&](const nebula::Image& img) {
            return nebula::linearSRGBToXYZ(
                {img.rgba[4 * p], img.rgba[4 * p + 1], img.rgba[4 * p + 2]});
        };
        const auto a = xyzOf(rgb), b = xyzOf(spec);
        if (!(b[1] > 0.01 * nebula::linearSRGBToXYZ({brightest, brightest, brightest})[1]))
            continue;
        ++compared;
        const auto xa = nebula::chromaticity(a), xb = nebula::chromaticity(b);
        const double d = std::max(std::abs(xa[0] - xb[0]), std::abs(xa[1] - xb[1]));
        worst = std::max(worst, d);
        EXPECT_LT(d, 0.001) << "pixel " << p << ": RGB " << rgb.rgba[4 * p] << ", "
                            << rgb.rgba[4 * p + 1] << ", " << rgb.rgba[4 * p + 2] << ", spectral "
                            << spec.rgba[4 * p] << ", " << spec.rgba[4 * p + 1] << ", "
                            << spec.rgba[4 * p + 2];
        red += xb[0] > 0.6;   // H-alpha alone
        green += xb[1] > 0.5; // [O III] alone
        // Equally bright: a unit of a line grid has --emission-color's luminance in both.
        EXPECT_NEAR(a[1] / b[1], 1.0, 0.01) << "pixel " << p;
    }
    EXPECT_GT(compared, 200);
    EXPECT_GT(red, 20);
    EXPECT_GT(green, 20);
    std::cout << "RGB vs spectral: " << compared << " pixels, largest chromaticity difference "
              << worst << "\n";
}

TEST_F(LineColours, EmissionColorPaintsTheEmissionGridAsBefore)
{
    makeScene("mix.vdb", true, true);
    const auto painted = sum(render("mix.vdb", "p.exr", "--emission-color 1,0.15,0.2"));
    EXPECT_NE(lastErr.find("--emission-color paints only the emission grid \"emission\"; the "
                           "lines of \"emission.oiii\" are drawn in their colours without "
                           "--emission-color"),
              std::string::npos)
        << lastErr;
    // Pink: G/R and B/R as given (the starlight scattered by the thin dust adds under 2 %).
    EXPECT_NEAR(painted[1] / painted[0], 0.15, 0.15 * 0.05);
    EXPECT_NEAR(painted[2] / painted[0], 0.2, 0.2 * 0.05);
}

TEST_F(LineColours, PathTracerDrawsLineColours)
{
    const auto [ha, o3] = renderEachLine("--integrator path --spp 4");
    EXPECT_GT(ha[0], 0.0);
    EXPECT_LT(ha[1], 0.0);
    EXPECT_LT(o3[0], 0.0);
    EXPECT_GT(o3[1], o3[2]);
    // Both grids, per channel: the ray caster's image within 5 % of the total (the
    // path tracer's noise at 8 walks per pixel, fixed seed).
    makeScene("mix.vdb", true, true);
    const auto path = sum(render("mix.vdb", "mp.exr", "--integrator path --spp 8"));
    const auto fast = sum(render("mix.vdb", "mf.exr"));
    for (std::size_t c = 0; c < 3; ++c)
        EXPECT_NEAR(path[c], fast[c], 0.05 * std::abs(fast[c]) + 1e-12) << c;
}

TEST_F(LineColours, ScatterFieldSaysWhatItLeavesOut)
{
    makeScene("mix.vdb", true, true);
    const Result s = run("nebscatter -i mix.vdb --packets 2000 -o s.vdb");
    ASSERT_EQ(s.code, 0) << s.err;
    EXPECT_NE(s.err.find("the field scatters the glow of the emission grid \"emission\" only; "
                         "that of \"emission.oiii\" is left out"),
              std::string::npos)
        << s.err;
    render("s.vdb", "f.exr");
    EXPECT_NE(lastErr.find("the scattered-light field (nebscatter) holds the scattered glow of "
                           "\"emission\" only; that of \"emission.oiii\" is left out"),
              std::string::npos)
        << lastErr;
}

TEST_F(LineColours, RefusesALineGridOnOtherVoxels)
{
    makeScene("mix.vdb", true, true);
    nebula::GridSet g = read(path("mix.vdb"));
    auto moved = g.floatGrid("emission.oiii", "")->deepCopy();
    moved->setTransform(openvdb::math::Transform::createLinearTransform(0.37));
    g.replace(moved);
    writeVdb(path("moved.vdb"), g.grids, g.meta);
    expectFailure("nebrender -i moved.vdb --res 8x8 -o f.exr", 1,
                  "moved.vdb: grid \"emission.oiii\" does not share the transform of grid "
                  "\"density\"");
}
