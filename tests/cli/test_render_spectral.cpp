// SPDX-License-Identifier: Apache-2.0
// End-to-end tests of nebrender --spectral: the pipeline from nebgen --spectral, its outputs,
// and its bad inputs (DESIGN §7).
#include "cli_fixture.h"

#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"
#include "nebula/physics/colour.h"
#include "nebula/physics/lines.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

using namespace nebula::clitest;

namespace {

class RenderSpectral : public Cli
{
protected:
    /// spec.vdb: a small spectral nebula (rotating shell) through nebillum.
    void makeSpectral()
    {
        ASSERT_EQ(run("nebgen --res 20 --seed 3 --spectral --rotation 40 --emission-shape shell "
                      "--oiii 0.5 -o s.vdb")
                      .code,
                  0);
        ASSERT_EQ(run("nebillum -i s.vdb -o spec.vdb").code, 0);
    }

    /// Copies spec.vdb to @p out with an absorption grid "absorption.nai" (1 wherever the
    /// density is active) whose nebula:absorption-lines is @p lines (none if empty).
    void withAbsorber(const std::string& out, const std::string& lines)
    {
        nebula::GridSet g = read(path("spec.vdb"));
        auto a = openvdb::gridPtrCast<openvdb::FloatGrid>(g.find("density"))->deepCopy();
        a->clearMetadata(); // the density's, and its name
        a->setName("absorption.nai");
        for (auto it = a->beginValueOn(); it; ++it)
            it.setValue(1.0f);
        if (!lines.empty()) {
            a->insertMeta(nebula::META_ABSORPTION_LINES, openvdb::StringMetadata(lines));
        }
        g.grids.push_back(a);
        writeVdb(path(out), g.grids, g.meta);
    }

    /// Copies spec.vdb to @p out with grid @p name replaced by @p grid.
    void replaceGrid(const std::string& out, openvdb::GridBase::Ptr grid)
    {
        nebula::GridSet g = read(path("spec.vdb"));
        g.replace(grid);
        writeVdb(path(out), g.grids, g.meta);
    }
};

double sumY(const nebula::Image& img)
{
    double s = 0.0;
    for (std::size_t i = 0; i < img.rgba.size() / 4; ++i) {
        s +=
            nebula::linearSRGBToXYZ({img.rgba[i * 4], img.rgba[i * 4 + 1], img.rgba[i * 4 + 2]})[1];
    }
    return s;
}

} // namespace

TEST_F(RenderSpectral, RendersSpectraWithLayersAndProvenance)
{
    makeSpectral();
    const Result r = run("nebrender -i spec.vdb --spectral --res 16x16 --spectral-layers 47 "
                         "--exaggerate-velocity 100 -o f.exr -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("piecewise-linear, 2 emission grid(s)"), std::string::npos) << r.err;
    std::map<std::string, std::string> attrs;
    const nebula::Image img = nebula::readExr(path("f.exr"), &attrs);
    EXPECT_NE(attrs["nebula:integrator"].find("spectral, piecewise-linear"), std::string::npos);
    ASSERT_EQ(img.channels.size(), 47u);
    EXPECT_EQ(img.channels.front().name, "S0.365,00nm");
    EXPECT_EQ(img.channels.back().name, "S0.825,00nm");
    // The layers hold the spectrum: their integral against the CMFs (10 nm box bands) is the
    // pixel's XYZ to the bands' resolution; check Y of the whole frame within 3 %.
    double Ylayers = 0.0;
    for (std::size_t b = 0; b < img.channels.size(); ++b) {
        const double centre = 365.0 + 10.0 * double(b);
        double s = 0.0;
        for (float v : img.channels[b].values)
            s += v;
        Ylayers += s * 10.0 * nebula::cmfAt(centre)[1];
    }
    const double Y = sumY(img);
    EXPECT_GT(Y, 0.0);
    EXPECT_NEAR(Ylayers, Y, 0.03 * Y);
    EXPECT_TRUE(std::filesystem::exists(path("f.png")));
}

TEST_F(RenderSpectral, FixedBandsApproachPiecewiseLinear)
{
    makeSpectral();
    ASSERT_EQ(run("nebrender -i spec.vdb --spectral --res 12x12 --exaggerate-velocity 50 --no-png "
                  "-o pl.exr")
                  .code,
              0);
    ASSERT_EQ(run("nebrender -i spec.vdb --bands 20 --res 12x12 --exaggerate-velocity 50 --no-png "
                  "-o b20.exr")
                  .code,
              0);
    ASSERT_EQ(run("nebrender -i spec.vdb --bands 2000 --res 12x12 --exaggerate-velocity 50 "
                  "--no-png -o b2000.exr")
                  .code,
              0);
    const double pl = sumY(nebula::readExr(path("pl.exr"), nullptr));
    const double b20 = sumY(nebula::readExr(path("b20.exr"), nullptr));
    const double b2000 = sumY(nebula::readExr(path("b2000.exr"), nullptr));
    EXPECT_LT(std::abs(b2000 - pl), std::abs(b20 - pl));
    EXPECT_NEAR(b2000, pl, 0.01 * pl);
}

// An absorption grid dims the spectrum around its lines (here Na I D, the lines 100 times
// wider and faster, so reaching 579-600 nm) and nowhere else; its bad forms are refused.
TEST_F(RenderSpectral, AbsorptionGridDimsItsLinesOnly)
{
    makeSpectral();
    withAbsorber("abs.vdb", "Na I D2:20,Na I D1:10");
    const std::string common =
        " --spectral --res 12x12 --spectral-layers 470 --exaggerate-velocity 100 --no-png ";
    ASSERT_EQ(run("nebrender -i spec.vdb" + common + "-o plain.exr").code, 0);
    const Result r = run("nebrender -i abs.vdb" + common + "-o dim.exr -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("absorption grid \"absorption.nai\" absorbs Na I D2:20,Na I D1:10"),
              std::string::npos)
        << r.err;
    std::map<std::string, std::string> attrs;
    const nebula::Image plain = nebula::readExr(path("plain.exr"), nullptr);
    const nebula::Image dim = nebula::readExr(path("dim.exr"), &attrs);
    EXPECT_NE(attrs["nebula:integrator"].find("absorption lines of 1 grid(s)"), std::string::npos)
        << attrs["nebula:integrator"];
    const auto band = [](const nebula::Image& img, std::size_t b) {
        double s = 0.0;
        for (float v : img.channels[b].values)
            s += v;
        return s;
    };
    // Layer b covers [360 + b, 361 + b] nm.
    EXPECT_LT(band(dim, 229), 0.9 * band(plain, 229)); // 589-590 nm
    for (const std::size_t b : {100u, 200u, 250u, 400u})
        EXPECT_EQ(band(dim, b), band(plain, b)) << b;
    EXPECT_LT(sumY(dim), sumY(plain));

    // RGB mode cannot draw lines; fixed bands cannot resolve them.
    expectFailure("nebrender -i abs.vdb -o f.exr", 2, "\"absorption.nai\"");
    expectFailure("nebrender -i abs.vdb -o f.exr", 2, "--spectral");
    expectFailure("nebrender -i abs.vdb --bands 20 -o f.exr", 2, "absorption.nai");
    // No line list, or one that does not parse: refused, naming file and grid.
    withAbsorber("bare.vdb", "");
    expectFailure("nebrender -i bare.vdb --spectral -o f.exr", 1,
                  "bare.vdb: absorption grid \"absorption.nai\" has no nebula:absorption-lines");
    withAbsorber("bad.vdb", "Na I D2:-1");
    expectFailure("nebrender -i bad.vdb --spectral -o f.exr", 1,
                  "absorption grid \"absorption.nai\" metadata nebula:absorption-lines");
}

TEST_F(RenderSpectral, BadInputIsAClearErrorWithNoOutput)
{
    makeSpectral();
    expectFailure("nebrender -i spec.vdb --bands 0 -o f.exr", 2, "--bands");
    expectFailure("nebrender -i spec.vdb --exaggerate-velocity 5 -o f.exr", 2,
                  "--exaggerate-velocity is for --spectral (here: --integrator fast)");
    expectFailure("nebrender -i spec.vdb --spectral --lines 'H-alfa:1' -o f.exr", 2, "H-alfa");
    expectFailure("nebrender -i spec.vdb --spectral --lines 'H-alpha:-1' -o f.exr", 2, "H-alpha");
    expectFailure("nebrender -i spec.vdb --spectral --lines '0:1' -o f.exr", 2, "--lines");
    expectFailure("nebrender -i spec.vdb --spectral --line-width 0 -o f.exr", 2, "--line-width");
    expectFailure("nebrender -i spec.vdb --spectral --exaggerate-velocity 0 -o f.exr", 2,
                  "--exaggerate-velocity");
    expectFailure("nebrender -i spec.vdb --spectral --integrator path -o f.exr", 2, "--spectral");
    // nebgen's 40 km/s times 1e5 is faster than light.
    expectFailure("nebrender -i spec.vdb --spectral --exaggerate-velocity 1e5 -o f.exr", 2,
                  "not slower than light");

    // A temperature grid with a negative value, one with a NaN.
    for (const float bad : {-5.0f, std::nanf("")}) {
        auto t = openvdb::FloatGrid::create(0.0f);
        t->setName("temperature");
        t->setTransform(read(path("spec.vdb")).find("density")->transform().copy());
        t->tree().setValue(openvdb::Coord(3, 3, 3), 100.0f);
        t->tree().setValue(openvdb::Coord(4, 3, 3), bad);
        replaceGrid("badT.vdb", t);
        expectFailure("nebrender -i badT.vdb --spectral -o f.exr", 1, "temperature");
        std::filesystem::remove(path("badT.vdb"));
    }
    // A velocity grid of the wrong type.
    {
        auto v = openvdb::FloatGrid::create(0.0f);
        v->setName("velocity");
        v->setTransform(read(path("spec.vdb")).find("density")->transform().copy());
        v->tree().setValue(openvdb::Coord(3, 3, 3), 1.0f);
        replaceGrid("badV.vdb", v);
        expectFailure("nebrender -i badV.vdb --spectral -o f.exr", 1, "velocity");
        std::filesystem::remove(path("badV.vdb"));
    }
    // An emission grid whose nebula:lines names an unknown line.
    {
        nebula::GridSet g = read(path("spec.vdb"));
        g.find("emission")
            ->insertMeta(nebula::META_LINES, openvdb::StringMetadata("H-alpha:1,Foo:2"));
        writeVdb(path("badL.vdb"), g.grids, g.meta);
        expectFailure("nebrender -i badL.vdb --spectral -o f.exr", 1, "Foo");
    }
}
