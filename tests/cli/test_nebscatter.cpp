// SPDX-License-Identifier: Apache-2.0
// End-to-end tests of nebscatter (DESIGN §5b): the field grids and metadata, nebrender using
// them, determinism whatever the thread count, and every bad input of the issue: no tau
// grids, no stars, --packets 0, an order outside 0..4, a field level coarser than the grid,
// field grids of the wrong type or layout, a field made for other dust or stars, and the
// field together with --phase or --levels.
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

using namespace nebula::clitest;

namespace {

class NebScatter : public Cli
{
protected:
    /// lit.vdb and its field s.vdb (cheap settings).
    void makeField()
    {
        makeLit();
        const Result r = run("nebscatter -i lit.vdb --packets 20000 -v -o s.vdb");
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_NE(r.err.find("nebscatter: stars: 20000 packets"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("noise of J"), std::string::npos) << r.err;
        // And the packets a frame without colour blotches needs: N (noise / 1.67 %)^2, up to
        // its rounding to 2 digits (upwards).
        const std::size_t at = r.err.find("noise of J ") + 11;
        const double noise = std::stod(r.err.substr(at)) / 100.0;
        const std::string needs = "needs the noise of J below about 1.7 %: --packets ";
        const std::size_t n = r.err.find(needs);
        ASSERT_NE(n, std::string::npos) << r.err;
        const double packets = std::stod(r.err.substr(n + needs.size()));
        const double expected = 20000.0 * std::pow(noise / (0.3 / 0.70 * 0.039), 2);
        EXPECT_GE(packets, expected * 0.88) << r.err; // the noise is printed to 2 digits
        EXPECT_LE(packets, expected * 1.25) << r.err;
        // The defaults: order 4, the level chosen from the grid (about 64 cells across: full
        // resolution on this small grid), and -v says why.
        EXPECT_NE(r.err.find("field level 0 chosen: about 64 cells across the grid gives level 0"),
                  std::string::npos)
            << r.err;
    }
};

double total(const nebula::Image& img, int c)
{
    double s = 0.0;
    for (std::size_t p = 0; p < img.rgba.size() / 4; ++p)
        s += img.rgba[p * 4 + std::size_t(c)];
    return s;
}

} // namespace

TEST_F(NebScatter, FieldGridsMetadataAndRendering)
{
    makeField();
    const auto s = read(path("s.vdb"));
    for (const std::string src : {"stars", "emission"}) {
        for (const std::string c : {"R", "G", "B"}) {
            const auto j = s.floatGrid("scatter." + src + ".J." + c, "");
            EXPECT_GT(j->activeVoxelCount(), 100u) << src;
            EXPECT_GT(maxValue(*j), 0.0) << src;
            EXPECT_EQ(j->metaValue<std::string>("units"), "L_sun pc^-2 sr^-1 (mean intensity J)");
            // Field level 0: the density's voxels.
            EXPECT_NEAR(j->voxelSize()[0], s.floatGrid("density", "")->voxelSize()[0], 1e-9);
            for (const std::string m : {"c1_-1", "c1_0", "c1_1", "c2_-2", "c2_2", "c4_-4", "c4_4"})
                EXPECT_TRUE(s.find("scatter." + src + "." + m + "." + c)) << m;
        }
    }
    const auto meta = nlohmann::json::parse(s.metaString(nebula::META_SCATTER));
    EXPECT_EQ(meta.at("order").get<int>(), 4);
    EXPECT_EQ(meta.at("level").get<int>(), 0);
    EXPECT_EQ(meta.at("stars").size(), 2u);

    // nebrender uses it, says so, and the picture is brighter than single scattering, more
    // so in blue (multiple scattering); --no-scatter-field gives single scattering exactly.
    Result r = run("nebrender -i s.vdb --res 24x24 --no-stars -v -o f.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("using the scattered-light field: order 4, level 0"), std::string::npos)
        << r.err;
    ASSERT_EQ(run("nebrender -i s.vdb --res 24x24 --no-stars --no-scatter-field -o n.exr").code, 0);
    ASSERT_EQ(run("nebrender -i lit.vdb --res 24x24 --no-stars -o l.exr").code, 0);
    std::map<std::string, std::string> attrs;
    const auto f = nebula::readExr(path("f.exr"), &attrs);
    const auto n = nebula::readExr(path("n.exr"), nullptr);
    const auto l = nebula::readExr(path("l.exr"), nullptr);
    EXPECT_EQ(n.rgba, l.rgba);
    for (int c = 0; c < 3; ++c)
        EXPECT_GT(total(f, c), 1.05 * total(n, c)) << c;
    EXPECT_GT(total(f, 2) / total(n, 2), total(f, 0) / total(n, 0));
    EXPECT_NE(attrs.at("nebula:integrator").find("scattered-light field"), std::string::npos);

    // The path tracer does not use it, and says so.
    r = run("nebrender -i s.vdb --res 4x4 --integrator path --spp 1 -o p.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("does not need"), std::string::npos) << r.err;
}

// Half-voxel cells (--field-level -1): grids on half the density's voxel, which nebrender
// reads and says so; the same packets as full resolution, so the picture's flux is within
// 1 % of it (only the interpolation differs), and brighter than single scattering.
TEST_F(NebScatter, HalfVoxelCellsRender)
{
    makeField();
    ASSERT_EQ(run("nebscatter -i lit.vdb --packets 20000 --field-level 0 -o s0.vdb").code, 0);
    Result r = run("nebscatter -i lit.vdb --packets 20000 --field-level -1 -v -o h.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("field level -1 (cells of 1/2^3 voxels)"), std::string::npos) << r.err;
    const auto h = read(path("h.vdb"));
    EXPECT_NEAR(h.floatGrid("scatter.stars.J.G", "")->voxelSize()[0],
                0.5 * h.floatGrid("density", "")->voxelSize()[0], 1e-9);
    EXPECT_EQ(nlohmann::json::parse(h.metaString(nebula::META_SCATTER)).at("level").get<int>(), -1);
    r = run("nebrender -i h.vdb --res 24x24 --no-stars -v -o h.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("order 4, level -1 (cells of 1/2^3 voxels)"), std::string::npos) << r.err;
    ASSERT_EQ(run("nebrender -i s0.vdb --res 24x24 --no-stars -o f0.exr").code, 0);
    ASSERT_EQ(run("nebrender -i h.vdb --res 24x24 --no-stars --no-scatter-field -o n.exr").code, 0);
    const auto fh = nebula::readExr(path("h.exr"), nullptr);
    const auto f0 = nebula::readExr(path("f0.exr"), nullptr);
    const auto n = nebula::readExr(path("n.exr"), nullptr);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(total(fh, c), total(f0, c), 0.01 * total(f0, c)) << c;
        EXPECT_GT(total(fh, c), 1.05 * total(n, c)) << c;
    }
}

TEST_F(NebScatter, SameFieldWhateverTheThreadCount)
{
    makeLit();
    ASSERT_EQ(run("nebscatter -i lit.vdb --packets 5000 --threads 1 -o one.vdb").code, 0);
    ASSERT_EQ(run("nebscatter -i lit.vdb --packets 5000 --threads 2 -o two.vdb").code, 0);
    const auto a = read(path("one.vdb")), b = read(path("two.vdb"));
    for (const auto& g : a.grids) {
        if (g->getName().rfind("scatter.", 0) != 0) continue;
        const auto ga = a.floatGrid(g->getName(), ""), gb = b.floatGrid(g->getName(), "");
        ASSERT_EQ(ga->activeVoxelCount(), gb->activeVoxelCount());
        const auto acc = gb->getConstAccessor();
        for (auto it = ga->cbeginValueOn(); it; ++it)
            ASSERT_EQ(*it, acc.getValue(it.getCoord())) << g->getName() << " " << it.getCoord();
    }
}

TEST_F(NebScatter, BadInputIsRefused)
{
    makeField();
    // No tau grids, no stars.
    expectFailure("nebscatter -i small.vdb -o x.vdb", 1, "tau.");
    {
        auto g = read(path("small.vdb"));
        g.meta.removeMeta(nebula::META_STARS);
        nebula::writeGrids(path("nostars.vdb"), g, "test", "test");
    }
    expectFailure("nebscatter -i nostars.vdb -o x.vdb", 1, "no stars");
    // Options.
    expectFailure("nebscatter -i lit.vdb --packets 0 -o x.vdb", 2, "--packets");
    expectFailure("nebscatter -i lit.vdb --order 5 -o x.vdb", 2, "--order");
    expectFailure("nebscatter -i lit.vdb --field-level 6 -o x.vdb", 2, "--field-level 6");
    expectFailure("nebscatter -i lit.vdb --field-level=-2 -o x.vdb", 2,
                  "--field-level: expected auto or an integer in [-1, 16], got -2");
    // A field of a level this renderer does not know (finer than half a voxel).
    {
        auto g = read(path("s.vdb"));
        auto meta = nlohmann::json::parse(g.metaString(nebula::META_SCATTER));
        meta["level"] = -2;
        g.meta.insertMeta(nebula::META_SCATTER, openvdb::StringMetadata(meta.dump()));
        nebula::writeGrids(path("level.vdb"), g, "test", "test");
    }
    expectFailure("nebrender -i level.vdb --res 8x8 -o x.exr", 1,
                  "has order 4 and level -2; expected 0..4 and -1..16");
    expectFailure("nebscatter -i lit.vdb --refine-tau 1000 -o x.vdb", 2, "--refine-tau");
    expectFailure("nebscatter -i lit.vdb --refine-tau -1 -o x.vdb", 2, "--refine-tau");
    // A field grid of the wrong type, or on another lattice.
    {
        auto g = read(path("s.vdb"));
        auto v = openvdb::Vec3fGrid::create();
        v->setName("scatter.stars.J.R");
        v->setTransform(g.find("scatter.stars.J.G")->transform().copy());
        g.replace(v);
        nebula::writeGrids(path("type.vdb"), g, "test", "test");
        auto h = read(path("s.vdb"));
        auto j = h.floatGrid("scatter.stars.c1_0.G", "")->deepCopy();
        j->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
        h.replace(j);
        nebula::writeGrids(path("layout.vdb"), h, "test", "test");
    }
    expectFailure("nebrender -i type.vdb --res 8x8 -o x.exr", 1, "scatter.stars.J.R");
    expectFailure("nebrender -i layout.vdb --res 8x8 -o x.exr", 1,
                  "\"scatter.stars.c1_0.G\" is not on field level 0's transform");
    // Other dust, other stars, other wavelengths.
    expectFailure("nebrender -i s.vdb --albedo 0.3 --res 8x8 -o x.exr", 1, "other dust");
    {
        auto g = read(path("s.vdb"));
        auto stars = g.stars();
        stars[0].luminosity *= 2;
        g.setStars(stars);
        nebula::writeGrids(path("brighter.vdb"), g, "test", "test");
        stars[0].position[0] += 0.5;
        g.setStars(stars);
        nebula::writeGrids(path("moved.vdb"), g, "test", "test");
    }
    expectFailure("nebrender -i brighter.vdb --res 8x8 -o x.exr", 1, "of luminosity");
    expectFailure("nebrender -i moved.vdb --res 8x8 -o x.exr", 1, "at another position");
    expectFailure("nebrender -i s.vdb --wavelengths 650,550,450 --res 8x8 -o x.exr", 1,
                  "channel wavelengths");
    // Counted twice: the field with --phase or --levels.
    ASSERT_EQ(run("nebphase -q --t-count 2 --t-max 1 --mu-bins 16 --photons 1024 "
                  "--max-photons 2048 -o phase.vdb")
                  .code,
              0);
    ASSERT_EQ(run("nebpyramid -i s.vdb --levels 1 -o p.vdb").code, 0);
    expectFailure("nebrender -i s.vdb --phase phase.vdb --phase-ignore-dust --res 8x8 -o x.exr", 2,
                  "count it twice");
    expectFailure("nebrender -i p.vdb --phase phase.vdb --phase-ignore-dust --levels 1 --res 8x8 "
                  "-o x.exr",
                  2, "count it twice");
    // With --no-scatter-field the table and levels are fine.
    EXPECT_EQ(run("nebrender -i p.vdb --phase phase.vdb --phase-ignore-dust --levels 1 "
                  "--no-scatter-field --res 8x8 -o ok.exr")
                  .code,
              0);
}

// --per-star: a field per star, which nebrender scales by the scene's luminosity (a star
// twice as bright: its collided light twice as bright).
TEST_F(NebScatter, PerStarFieldsFollowTheLuminosity)
{
    makeLit();
    ASSERT_EQ(run("nebscatter -i lit.vdb --per-star --no-emission --packets 20000 -o s.vdb").code,
              0);
    const auto s = read(path("s.vdb"));
    EXPECT_TRUE(s.find("scatter.star_alpha.J.R"));
    EXPECT_TRUE(s.find("scatter.star_beta.J.R"));
    EXPECT_FALSE(s.find("scatter.stars.J.R"));
    EXPECT_FALSE(s.find("scatter.emission.J.R"));
    {
        auto g = read(path("s.vdb"));
        auto stars = g.stars();
        for (auto& st : stars)
            st.luminosity *= 2;
        g.setStars(stars);
        nebula::writeGrids(path("bright.vdb"), g, "test", "test");
    }
    ASSERT_EQ(run("nebrender -i s.vdb --res 16x16 --no-stars --emission-scale 0 -o a.exr").code, 0);
    ASSERT_EQ(
        run("nebrender -i bright.vdb --res 16x16 --no-stars --emission-scale 0 -o b.exr").code, 0);
    const auto a = nebula::readExr(path("a.exr"), nullptr);
    const auto b = nebula::readExr(path("b.exr"), nullptr);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(total(b, c), 2.0 * total(a, c), 1e-4 * total(b, c)) << c;
}

// --spectral N: the starlight's field at N wavelengths for nebrender --spectral, beside the
// R, G, B field in the same file (each replaces only its own kind); nebrender --spectral
// uses it and says so, and the RGB render is unchanged by it; a spectral render of a file
// with only the R, G, B field warns that it is single scattering; a spectral field made
// for other stars is refused; --spectral 1 is a usage error.
TEST_F(NebScatter, SpectralFieldForTheSpectralRenderer)
{
    makeField();
    Result r = run("nebscatter -i s.vdb --spectral 6 --packets 5000 -v -o both.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("spectral: 6 wavelengths, 380-780 nm"), std::string::npos) << r.err;
    const auto b = read(path("both.vdb"));
    EXPECT_TRUE(b.find("scatter.stars.J.R")); // the R, G, B field stays
    EXPECT_TRUE(b.find("scatter.emission.J.B"));
    for (const std::string lam : {"380nm", "460nm", "540nm", "620nm", "700nm", "780nm"}) {
        const auto j = b.floatGrid("scatter.spectral.stars.J." + lam, "");
        EXPECT_GT(maxValue(*j), 0.0) << lam;
        EXPECT_EQ(j->metaValue<std::string>("units"),
                  "L_sun pc^-2 sr^-1 nm^-1 (mean intensity J per nm)");
        EXPECT_TRUE(b.find("scatter.spectral.stars.c2_-1." + lam)) << lam;
        EXPECT_FALSE(b.find("scatter.spectral.emission.J." + lam)) << lam;
    }
    const auto meta = nlohmann::json::parse(b.metaString(nebula::META_SCATTER_SPECTRAL));
    EXPECT_EQ(meta.at("wavelengths").size(), 6u);
    EXPECT_FALSE(b.metaString(nebula::META_SCATTER).empty());

    r = run("nebrender -i both.vdb --spectral --res 16x16 --no-stars -v -o f.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("using the spectral scattered-light field"), std::string::npos) << r.err;
    ASSERT_EQ(run("nebrender -i both.vdb --spectral --res 16x16 --no-stars --no-scatter-field "
                  "-o n.exr")
                  .code,
              0);
    r = run("nebrender -i s.vdb --spectral --res 16x16 --no-stars -o rgbonly.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("no spectral one"), std::string::npos) << r.err;
    const auto f = nebula::readExr(path("f.exr"), nullptr);
    const auto n = nebula::readExr(path("n.exr"), nullptr);
    EXPECT_EQ(nebula::readExr(path("rgbonly.exr"), nullptr).rgba, n.rgba);
    for (int c = 0; c < 3; ++c)
        EXPECT_GT(total(f, c), 1.05 * total(n, c)) << c;
    // The RGB render does not see the spectral field.
    ASSERT_EQ(run("nebrender -i both.vdb --res 16x16 --no-stars -o rb.exr").code, 0);
    ASSERT_EQ(run("nebrender -i s.vdb --res 16x16 --no-stars -o rs.exr").code, 0);
    EXPECT_EQ(nebula::readExr(path("rb.exr"), nullptr).rgba,
              nebula::readExr(path("rs.exr"), nullptr).rgba);
    // A spectral field made for other stars; a spectral grid missing.
    {
        auto g = read(path("both.vdb"));
        auto stars = g.stars();
        stars[1].temperature *= 1.5;
        g.setStars(stars);
        nebula::writeGrids(path("hotter.vdb"), g, "test", "test");
        auto h = read(path("both.vdb"));
        openvdb::GridPtrVec kept;
        for (auto& grid : h.grids)
            if (grid->getName() != "scatter.spectral.stars.c1_0.540nm") kept.push_back(grid);
        h.grids = kept;
        nebula::writeGrids(path("missing.vdb"), h, "test", "test");
    }
    expectFailure("nebrender -i hotter.vdb --spectral --res 8x8 -o x.exr", 1,
                  "spectral scattered-light field (nebscatter --spectral) was made for other "
                  "stars");
    expectFailure("nebrender -i missing.vdb --spectral --res 8x8 -o x.exr", 1,
                  "lacks its grid \"scatter.spectral.stars.c1_0.540nm\"");
    expectFailure("nebscatter -i lit.vdb --spectral 1 -o x.vdb", 2, "--spectral");
}

// --precision (DESIGN §5b "Stored precision"): the default 8 bits shrink the file by the
// expected factor and change the frame far less than the field's own noise (a field of
// another seed); a field from before --precision (no "stored_bits", floats) renders exactly
// as the same field with them; a damaged stored field is refused, naming the file.
TEST_F(NebScatter, StoredPrecisionShrinksTheFileNotTheFrame)
{
    makeLit();
    const std::string flags = " --packets 20000 --field-level 0 --order 2";
    ASSERT_EQ(run("nebscatter -i lit.vdb" + flags + " --precision float -o f.vdb").code, 0);
    ASSERT_EQ(run("nebscatter -i lit.vdb" + flags + " --precision float --seed 2 -o f2.vdb").code,
              0);
    const Result r = run("nebscatter -i lit.vdb" + flags + " -v -o s.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("MB, moments stored to 8 significant bits (each within 0.39 % of its "
                         "cell's c_00), noise of J"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(nlohmann::json::parse(read(path("s.vdb")).metaString(nebula::META_SCATTER))
                  .at("stored_bits"),
              8);
    // The field's grids alone (--only-new): 8 significant bits of a float's 24.
    ASSERT_EQ(run("nebscatter -i lit.vdb" + flags + " --precision float --only-new -o fo.vdb").code,
              0);
    ASSERT_EQ(run("nebscatter -i lit.vdb" + flags + " --only-new -o so.vdb").code, 0);
    const double ratio = double(fileBytes("so.vdb").size()) / double(fileBytes("fo.vdb").size());
    EXPECT_LT(ratio, 0.88) << ratio; // 0.83 measured
    EXPECT_LT(fileBytes("s.vdb").size(), fileBytes("f.vdb").size());

    for (const std::string f : {"f", "f2", "s"})
        ASSERT_EQ(run("nebrender -i " + f + ".vdb --res 24x24 --no-stars -o " + f + ".exr").code,
                  0);
    const auto a = nebula::readExr(path("f.exr"), nullptr);
    const auto b = nebula::readExr(path("s.exr"), nullptr);
    const auto c = nebula::readExr(path("f2.exr"), nullptr);
    double stored = 0.0, noise = 0.0, peak = 0.0;
    for (std::size_t p = 0; p < a.rgba.size(); ++p)
        peak = std::max(peak, double(a.rgba[p]));
    for (std::size_t p = 0; p < a.rgba.size(); ++p) {
        if (p % 4 == 3 || a.rgba[p] < 0.01 * peak) continue;
        stored += std::pow((b.rgba[p] - a.rgba[p]) / a.rgba[p], 2);
        noise += std::pow((c.rgba[p] - a.rgba[p]) / a.rgba[p], 2);
    }
    EXPECT_GT(stored, 0.0); // the values did change
    EXPECT_LT(std::sqrt(stored), 0.1 * std::sqrt(noise)) << stored << " " << noise;

    // A field from before --precision: the same floats without "stored_bits".
    nebula::GridSet old = read(path("f.vdb"));
    auto meta = nlohmann::json::parse(old.metaString(nebula::META_SCATTER));
    meta.erase("stored_bits");
    old.setMetaString(nebula::META_SCATTER, meta.dump());
    nebula::writeGrids(path("old.vdb"), old, "test", "test");
    ASSERT_EQ(run("nebrender -i old.vdb --res 24x24 --no-stars -o old.exr").code, 0);
    EXPECT_EQ(nebula::readExr(path("old.exr"), nullptr).rgba, a.rgba);

    // A damaged stored field: bytes in the middle of its grids overwritten.
    std::string bytes = fileBytes("s.vdb");
    for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 64; ++i)
        bytes[i] = char(bytes[i] ^ 0x5a);
    std::ofstream(path("damaged.vdb"), std::ios::binary) << bytes;
    expectFailure("nebrender -i damaged.vdb --res 8x8 -o d.exr", 1, "damaged.vdb");
}
