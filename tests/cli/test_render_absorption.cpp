// SPDX-License-Identifier: Apache-2.0
// nebrender --spectral --fits end to end with an absorption grid (DESIGN §7.6): a uniform
// absorbing slab in front of glowing grey dust, written as a VDB here, gives the
// closed-form equivalent width 2 eps (1 - e^-tau0) in the calibrated FITS cube's planes.
#include "cli_fixture.h"

#include "nebula/io/fits.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/physics/dust.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

constexpr double H = 0.1;      // voxel [pc]
constexpr double COLUMN = 0.8; // the absorber's column: value 1 on lattice k = 1..8 [pc]

openvdb::FloatGrid::Ptr boxGrid(const std::string& name, float value, int k0, int k1)
{
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->setTransform(openvdb::math::Transform::createLinearTransform(H));
    g->denseFill(openvdb::CoordBBox(openvdb::Coord(0, 0, k0), openvdb::Coord(20, 20, k1)), value,
                 true);
    return g;
}

/// @p path: grey dust (n_H 2000) at 6000 K on k = 12..19, and with @p lines the absorber
/// absorption.caii (1 on k = 1..8) in front of it.
void writeSlab(const std::string& path, const std::string& lines, double v = 0.0)
{
    openvdb::GridPtrVec grids{boxGrid("density", 2000.0f, 12, 19),
                              boxGrid("temperature", 6000.0f, -1, 21)};
    if (!lines.empty()) {
        auto a = boxGrid(nebula::absorptionGridName("caii"), 1.0f, 1, 8);
        a->insertMeta(nebula::META_ABSORPTION_LINES, openvdb::StringMetadata(lines));
        grids.push_back(a);
    }
    if (v != 0.0) { // uniform along +z, away from the camera
        auto vel = openvdb::Vec3fGrid::create(openvdb::Vec3f(0.0f));
        vel->setName("velocity");
        vel->setTransform(openvdb::math::Transform::createLinearTransform(H));
        vel->denseFill(openvdb::CoordBBox(openvdb::Coord(-1), openvdb::Coord(21)),
                       openvdb::Vec3f(0.0f, 0.0f, float(v)), true);
        grids.push_back(vel);
    }
    nebula::DustParams dust;
    dust.curve = "grey";
    openvdb::MetaMap meta;
    meta.insertMeta(nebula::META_DUST, openvdb::StringMetadata(dust.toJson()));
    // A star nebrender needs, so faint and far that its light is nothing here: tau 0.
    meta.insertMeta(nebula::META_STARS,
                    openvdb::StringMetadata("[{\"name\": \"s\", \"position\": [1, 1, -1000], "
                                            "\"luminosity\": 1e-12, \"temperature\": 6000}]"));
    grids.push_back(boxGrid(nebula::tauGridName("s"), 0.0f, -1, 21));
    writeVdb(path, grids, meta);
}

/// The TOTAL cube's plane @p b at pixel 0.
double plane(nebula::FitsFile& f, std::int64_t b)
{
    const auto shape = f.imageShape();
    double v = 0.0;
    f.readDoubles(b * shape[0] * shape[1], 1, &v);
    return v;
}

/// The equivalent width [nm] of the dip of @p img against @p ref (TOTAL, pixel 0), over
/// the continuum at @p lambda [nm]; @p upper: the share of the dip above 394 nm.
double equivalentWidth(nebula::FitsFile& ref, nebula::FitsFile& img, double lambda, double& upper)
{
    // Plane b is the band [360 + b, 361 + b] nm; the continuum is linear between its 10 nm
    // nodes, so its value at lambda is plane 33's moved along the neighbours' slope.
    double deficit = 0.0;
    for (std::int64_t b = 0; b < 470; ++b)
        deficit += plane(ref, b) - plane(img, b);
    upper = (plane(ref, 34) - plane(img, 34)) / deficit;
    const double c = plane(ref, 33) + (lambda - 393.5) * 0.5 * (plane(ref, 34) - plane(ref, 32));
    return deficit / c;
}

} // namespace

// At rest and receding at 40 km/s (the line then placed at 394 nm / (1 + v/c), so that its
// dip straddles the planes 393-394 and 394-395 nm evenly): EW within 1 %, the dip's centre
// within 1 % of eps.
TEST_F(Cli, AbsorbingSlabHasTheClosedFormEquivalentWidthInTheFitsCube)
{
    const double c = 299792.458, tau0 = 2.0, width = 10.0;
    for (const double v : {0.0, 40.0}) {
        const double lambda0 = v == 0.0 ? 393.366 : 394.0 / (1.0 + v / c);
        const double eps = lambda0 * width / c;
        char list[64];
        std::snprintf(list, sizeof list, "%.17g:%.17g", lambda0, tau0 * 2.0 * eps / COLUMN);
        writeSlab(path("plain.vdb"), "", v);
        writeSlab(path("slab.vdb"), list, v);
        const std::string view = " --spectral --spectral-layers 470 --eye 1,1,-5 --look-at 1,1,1 "
                                 "--fov 0.5 --res 2x2 --sky 10,20 --fits-unit W/m2/sr/nm --no-png ";
        for (const char* name : {"plain", "slab"}) {
            const Result r = run(std::string("nebrender -i ") + name + ".vdb" + view + "--fits " +
                                 name + ".fits -o " + name + ".exr");
            ASSERT_EQ(r.code, 0) << r.err;
        }
        auto ref = nebula::FitsFile::open(path("plain.fits"), "plain.fits");
        auto img = nebula::FitsFile::open(path("slab.fits"), "slab.fits");
        ASSERT_EQ(ref.imageShape().size(), 3u);
        ASSERT_EQ(ref.imageShape()[2], 470);
        double upper = 0.0;
        const double centre = lambda0 * (1.0 + v / c);
        const double ew = equivalentWidth(ref, img, centre, upper);
        const double want = 2.0 * eps * -std::expm1(-tau0);
        std::printf("absorption: FITS cube, v %g km/s, tau0 %g: EW %.7g nm, closed form %.7g nm "
                    "(%+.2g %%), dip above 394 nm %.6f\n",
                    v, tau0, ew, want, 100.0 * (ew / want - 1.0), upper);
        EXPECT_NEAR(ew, want, 0.01 * want) << v;
        if (v == 0.0) {
            EXPECT_EQ(upper, 0.0);
        } else {
            EXPECT_NEAR(2.0 * upper - 1.0, 0.0, 0.01);
        }
        for (const char* f :
             {"plain.vdb", "slab.vdb", "plain.fits", "slab.fits", "plain.exr", "slab.exr"})
            std::filesystem::remove(path(f));
    }
}
