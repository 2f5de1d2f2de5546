// SPDX-License-Identifier: Apache-2.0
/// @file test_cube_io.cpp
/// io/cube_io.h: the .npy header parser (versions, byte orders, memory orders, bad headers),
/// .npy cubes read plane by plane in both orders and byte orders, RADMC-3D grids and density
/// files (ASCII and binary, a second species, cell counts that disagree, unequal cells
/// resampled), FITS cubes and their WCS (written here through cfitsio), density units against
/// hand-computed values, and the writers read back.

#include "nebula/io/cube_io.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/io/fits.h"

#include "test_util.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

using nebula::CubeFormat;
using nebula::CubeSelect;
using nebula::DensityUnit;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

class CubeIo : public nebula::test::TempFolder
{
protected:
    void write(const std::string& name, const std::string& bytes) const
    {
        std::ofstream(path(name), std::ios::binary) << bytes;
    }
};

/// A .npy file: @p dict as the header (version @p major), then @p data.
std::string npyBytes(const std::string& dict, const std::string& data, int major = 1)
{
    std::string header = dict;
    const std::size_t prefix = major == 1 ? 10 : 12;
    while ((prefix + header.size() + 1) % 64 != 0)
        header += ' ';
    header += '\n';
    std::string out = std::string("\x93NUMPY", 6) + char(major) + char(0);
    const std::size_t n = header.size();
    out += char(n & 0xff);
    out += char(n >> 8 & 0xff);
    if (major > 1) out += std::string(2, '\0');
    return out + header + data;
}

/// The values v(x, y, z) = 100 x + 10 y + z of a 2 x 3 x 4 cube, in C or Fortran order, as
/// @p T in big- or little-endian bytes.
template <typename T> std::string cubeData(bool fortran, bool bigEndian)
{
    std::string out;
    const auto put = [&](int x, int y, int z) {
        const T v = T(100 * x + 10 * y + z);
        char b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        if (bigEndian) std::reverse(b, b + sizeof(T));
        out.append(b, sizeof(T));
    };
    if (fortran) {
        for (int z = 0; z < 4; ++z)
            for (int y = 0; y < 3; ++y)
                for (int x = 0; x < 2; ++x)
                    put(x, y, z);
    } else {
        for (int x = 0; x < 2; ++x)
            for (int y = 0; y < 3; ++y)
                for (int z = 0; z < 4; ++z)
                    put(x, y, z);
    }
    return out;
}

/// Every voxel of @p cube, checked against 100 x + 10 y + z (times @p scale).
void expectCube(nebula::CubeSource& cube, double scale = 1.0)
{
    const auto& info = cube.info();
    ASSERT_EQ(info.dims, (std::array<std::int64_t, 3>{2, 3, 4}));
    std::vector<double> plane(std::size_t(info.planeSize()));
    for (std::int64_t k = 0; k < info.planeCount(); ++k) {
        cube.readPlane(k, plane.data());
        for (std::size_t i = 0; i < plane.size(); ++i) {
            std::array<std::int64_t, 3> c{};
            c[std::size_t(info.planeAxis)] = k;
            c[std::size_t(info.fastAxis)] = std::int64_t(i) % info.dims[std::size_t(info.fastAxis)];
            c[std::size_t(info.slowAxis)] = std::int64_t(i) / info.dims[std::size_t(info.fastAxis)];
            ASSERT_DOUBLE_EQ(plane[i], scale * double(100 * c[0] + 10 * c[1] + c[2]))
                << c[0] << " " << c[1] << " " << c[2];
        }
    }
}

} // namespace

TEST(NpyHeader, ParsesVersionsOrdersAndTypes)
{
    auto h = nebula::parseNpyHeader(
        npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4), }", ""), "a.npy");
    EXPECT_EQ(h.major, 1);
    EXPECT_EQ(h.byteOrder, '<');
    EXPECT_EQ(h.kind, 'f');
    EXPECT_EQ(h.itemSize, 4);
    EXPECT_FALSE(h.fortranOrder);
    EXPECT_EQ(h.shape, (std::vector<std::int64_t>{2, 3, 4}));
    EXPECT_EQ(h.dataOffset % 64, 0u);

    h = nebula::parseNpyHeader(
        npyBytes("{\"shape\": (5,), \"fortran_order\": True, \"descr\": \">i2\"}", "", 2), "b");
    EXPECT_EQ(h.major, 2);
    EXPECT_EQ(h.byteOrder, '>');
    EXPECT_EQ(h.kind, 'i');
    EXPECT_EQ(h.itemSize, 2);
    EXPECT_TRUE(h.fortranOrder);
    EXPECT_EQ(h.shape, (std::vector<std::int64_t>{5}));
    h = nebula::parseNpyHeader(
        npyBytes("{'descr': '|u1', 'fortran_order': False, 'shape': ()}", "", 3), "c");
    EXPECT_EQ(h.major, 3);
    EXPECT_TRUE(h.shape.empty());
}

TEST(NpyHeader, RefusesBadHeaders)
{
    const auto msg = [](const std::string& bytes) {
        return errorMessage([&] { nebula::parseNpyHeader(bytes, "bad.npy"); });
    };
    EXPECT_TRUE(contains(msg("PK\3\4 not numpy"), "not a .npy file"));
    std::string v4 = npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (1,)}", "");
    v4[6] = 4;
    EXPECT_TRUE(contains(msg(v4), "version 4.0"));
    EXPECT_TRUE(
        contains(msg(npyBytes("{'descr': '|O', 'fortran_order': False, 'shape': (3,)}", "")),
                 "object array"));
    EXPECT_TRUE(contains(
        msg(npyBytes("{'descr': [('a', '<f4')], 'fortran_order': False, 'shape': (3,)}", "")),
        "structured"));
    EXPECT_TRUE(
        contains(msg(npyBytes("{'descr': '<c8', 'fortran_order': False, 'shape': (3,)}", "")),
                 "not a number type"));
    EXPECT_TRUE(
        contains(msg(npyBytes("{'descr': '<f4', 'fortran_order': maybe, 'shape': (3,)}", "")),
                 "True or False"));
    EXPECT_TRUE(contains(msg(npyBytes("{'descr': '<f4', 'shape': (3,)}", "")), "missing"));
    EXPECT_TRUE(
        contains(msg(npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (-3,)}", "")),
                 "non-negative integer"));
    EXPECT_TRUE(contains(msg(npyBytes("{'descr': '<f4', 'descr': '<f4', 'shape': (3,)}", "")),
                         "repeated key"));
    // A header length past the bytes, and past the bound.
    std::string shortHeader =
        npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (3,)}", "");
    EXPECT_TRUE(contains(msg(shortHeader.substr(0, 40)), "truncated"));
    std::string huge = std::string("\x93NUMPY\x02\x00", 8) + std::string("\x00\x00\x10\x00", 4);
    EXPECT_TRUE(contains(msg(huge), "more than the 65536 read"));
}

TEST(NpyHeader, WritesWhatItReads)
{
    for (bool fortran : {false, true}) {
        const std::string h = nebula::npyHeader({7, 8, 9}, fortran);
        EXPECT_EQ(h.size() % 64, 0u);
        const auto p = nebula::parseNpyHeader(h, "w.npy");
        EXPECT_EQ(p.shape, (std::vector<std::int64_t>{7, 8, 9}));
        EXPECT_EQ(p.fortranOrder, fortran);
        EXPECT_EQ(p.dataOffset, h.size());
    }
}

TEST_F(CubeIo, NpyCubesInEveryOrderAndByteOrder)
{
    for (bool fortran : {false, true}) {
        for (bool big : {false, true}) {
            const std::string order = fortran ? "True" : "False";
            const std::string e = big ? ">" : "<";
            write("f4.npy", npyBytes("{'descr': '" + e + "f4', 'fortran_order': " + order +
                                         ", 'shape': (2, 3, 4), }",
                                     cubeData<float>(fortran, big)));
            write("f8.npy", npyBytes("{'descr': '" + e + "f8', 'fortran_order': " + order +
                                         ", 'shape': (2, 3, 4), }",
                                     cubeData<double>(fortran, big), 2));
            write("i2.npy", npyBytes("{'descr': '" + e + "i2', 'fortran_order': " + order +
                                         ", 'shape': (2, 3, 4), }",
                                     cubeData<std::int16_t>(fortran, big)));
            for (const char* name : {"f4.npy", "f8.npy", "i2.npy"}) {
                SCOPED_TRACE(std::string(name) + (fortran ? " F" : " C") + (big ? " BE" : " LE"));
                auto cube = nebula::openCube(path(name), CubeSelect{});
                EXPECT_EQ(cube->info().planeAxis, fortran ? 2 : 0);
                EXPECT_TRUE(cube->info().unit.empty());
                EXPECT_FALSE(cube->info().geometry);
                expectCube(*cube);
            }
        }
    }
}

TEST_F(CubeIo, NpyTruncatedOrTwoDimensionalIsRefused)
{
    const std::string data = cubeData<float>(false, false);
    write("short.npy", npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4)}",
                                data.substr(0, 50)));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("short.npy"), CubeSelect{}); }),
                         "truncated: the header says 96 bytes of data, the file holds 50"));
    write("flat.npy", npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (6, 4)}", data));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("flat.npy"), CubeSelect{}); }),
                         "a 2-D image (6 x 4), expected a 3-D cube"));
    write("huge.npy",
          npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (1000000, 1000000, 1)}", ""));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("huge.npy"), CubeSelect{}); }),
                         "at most 2^36"));
}

TEST_F(CubeIo, VectorComponentsOfAFourDimensionalArray)
{
    // a[c, x, y, z] = c * 1000 + 100 x + 10 y + z, C order.
    std::string data;
    for (int c = 0; c < 3; ++c)
        for (int x = 0; x < 2; ++x)
            for (int y = 0; y < 3; ++y)
                for (int z = 0; z < 4; ++z) {
                    const float v = float(c * 1000 + 100 * x + 10 * y + z);
                    data.append(reinterpret_cast<const char*>(&v), 4);
                }
    write("v.npy",
          npyBytes("{'descr': '<f4', 'fortran_order': False, 'shape': (3, 2, 3, 4)}", data));
    for (int c = 0; c < 3; ++c) {
        CubeSelect sel;
        sel.component = c;
        auto cube = nebula::openCube(path("v.npy"), sel);
        std::vector<double> plane(12);
        cube->readPlane(1, plane.data()); // x = 1: (y, z), z fastest
        EXPECT_DOUBLE_EQ(plane[0], c * 1000 + 100);
        EXPECT_DOUBLE_EQ(plane[11], c * 1000 + 100 + 23);
    }
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("v.npy"), CubeSelect{}); }),
                         "expected a 3-D cube"));
}

namespace {

const double AU = nebula::AU_CM;

std::string radmcGrid(const std::array<std::vector<double>, 3>& walls, int coord = 0, int style = 0)
{
    std::string s = "1\n" + std::to_string(style) + "\n" + std::to_string(coord) + "\n0\n1 1 1\n";
    for (const auto& w : walls)
        s += std::to_string(w.size() - 1) + " ";
    s += "\n";
    for (const auto& w : walls)
        for (double v : w)
            s += fmt::format("{:.17e}\n", v);
    return s;
}

std::vector<double> walls(int n, double step)
{
    std::vector<double> w;
    for (int i = 0; i <= n; ++i)
        w.push_back(i * step);
    return w;
}

} // namespace

TEST_F(CubeIo, RadmcAsciiAndBinary)
{
    const double cell = 1000 * AU;
    write("amr_grid.inp", radmcGrid({walls(2, cell), walls(3, cell), walls(4, cell)}));
    // Two species; the second is twice the first, written Fortran-style (1.0d0).
    std::string ascii = "1\n24\n2\n";
    std::string binary;
    const std::int64_t head[4] = {1, 8, 24, 2};
    binary.append(reinterpret_cast<const char*>(head), 32);
    for (int s = 1; s <= 2; ++s)
        for (int z = 0; z < 4; ++z)
            for (int y = 0; y < 3; ++y)
                for (int x = 0; x < 2; ++x) {
                    const double v = s * double(100 * x + 10 * y + z);
                    ascii += fmt::format("{}d0\n", v);
                    binary.append(reinterpret_cast<const char*>(&v), 8);
                }
    write("dust_density.inp", ascii);
    for (int species : {1, 2}) {
        CubeSelect sel;
        sel.species = species;
        auto cube = nebula::openCube(path("dust_density.inp"), sel);
        EXPECT_EQ(cube->info().unit, "g/cm3-dust");
        ASSERT_TRUE(cube->info().geometry);
        EXPECT_NEAR(cube->info().geometry->spacing[0], cell / nebula::PC_CM, 1e-15);
        EXPECT_NEAR((*cube->info().geometry->origin)[2], 0.5 * cell / nebula::PC_CM, 1e-15);
        expectCube(*cube, species);
    }
    write("dust_density.binp", binary);
    CubeSelect sel;
    sel.species = 2;
    auto cube = nebula::openCube(dir.string(), sel); // the folder: .binp first
    EXPECT_TRUE(contains(cube->info().name, "dust_density.binp"));
    expectCube(*cube, 2);
    sel.species = 3;
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::openCube(dir.string(), sel); }), "has 2 dust species"));
}

TEST_F(CubeIo, RadmcBadFilesAreRefused)
{
    const double cell = 1000 * AU;
    write("amr_grid.inp", radmcGrid({walls(2, cell), walls(3, cell), walls(4, cell)}));
    write("dust_density.inp", "1\n25\n1\n" + std::string(25 * 2, ' '));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(dir.string(), CubeSelect{}); }),
                         "25 cells, but amr_grid.inp has 2 x 3 x 4 = 24"));
    write("dust_density.inp", "1\n24\n1\n1 2 3\n");
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(dir.string(), CubeSelect{}); }),
                         "more values than the 7 bytes after it can hold"));
    write("dust_density.inp", "1\n24\n1\n1 2 3\n" + std::string(60, ' '));
    auto cube = nebula::openCube(dir.string(), CubeSelect{});
    std::vector<double> plane(6);
    EXPECT_TRUE(contains(errorMessage([&] { cube->readPlane(0, plane.data()); }),
                         "truncated: expected 24 values"));
    write("dust_density.inp", "1\n24\n1\n1 2 x3\n" + std::string(60, ' '));
    cube = nebula::openCube(dir.string(), CubeSelect{});
    EXPECT_TRUE(
        contains(errorMessage([&] { cube->readPlane(0, plane.data()); }), "\"x3\" at byte"));
    EXPECT_TRUE(contains(
        errorMessage([&] {
            nebula::parseRadmcGrid(radmcGrid({walls(2, 1), walls(2, 1), walls(2, 1)}, 100), "g");
        }),
        "spherical"));
    EXPECT_TRUE(contains(
        errorMessage([&] {
            nebula::parseRadmcGrid(radmcGrid({walls(2, 1), walls(2, 1), walls(2, 1)}, 0, 1), "g");
        }),
        "grid style 1"));
    EXPECT_TRUE(
        contains(errorMessage([&] {
                     nebula::parseRadmcGrid(
                         radmcGrid({std::vector<double>{0, 2, 1}, walls(2, 1), walls(2, 1)}), "g");
                 }),
                 "must be finite and increase"));
    std::string bin(32, '\0');
    const std::int64_t head[4] = {1, 8, 24, 1};
    std::memcpy(bin.data(), head, 32);
    EXPECT_TRUE(contains(errorMessage([&] { nebula::parseRadmcDataHeader(bin, true, "d.binp"); }),
                         "truncated"));
    const std::int64_t badPrecision[4] = {1, 3, 24, 1};
    std::memcpy(bin.data(), badPrecision, 32);
    EXPECT_TRUE(contains(errorMessage([&] { nebula::parseRadmcDataHeader(bin, true, "d.binp"); }),
                         "precision 3"));
}

TEST_F(CubeIo, RadmcUnequalCellsAreResampledToTheFinest)
{
    // x walls at 0, 1, 3, 4 (widths 1, 2, 1), y and z of width 1 [units of 1000 au].
    const double u = 1000 * AU;
    write("amr_grid.inp",
          radmcGrid({std::vector<double>{0, u, 3 * u, 4 * u}, walls(1, u), walls(1, u)}));
    std::string bin(32, '\0');
    const std::int64_t head[4] = {1, 4, 3, 1};
    std::memcpy(bin.data(), head, 32);
    for (float v : {1.0f, 2.0f, 3.0f})
        bin.append(reinterpret_cast<const char*>(&v), 4);
    write("dust_density.binp", bin);
    auto cube = nebula::openCube(path("amr_grid.inp"), CubeSelect{});
    EXPECT_EQ(cube->info().dims, (std::array<std::int64_t, 3>{4, 1, 1}));
    ASSERT_EQ(cube->info().warnings.size(), 1u);
    EXPECT_TRUE(contains(cube->info().warnings[0], "resampled to 4 x 1 x 1"));
    std::vector<double> plane(4);
    cube->readPlane(0, plane.data());
    EXPECT_EQ(plane, (std::vector<double>{1, 2, 2, 3}));
}

TEST(DensityUnits, ParseAndConvert)
{
    EXPECT_EQ(nebula::parseDensityUnit("cm-3"), DensityUnit::NumberDensity);
    EXPECT_EQ(nebula::parseDensityUnit("cm^-3"), DensityUnit::NumberDensity);
    EXPECT_EQ(nebula::parseDensityUnit("1 / cm3"), DensityUnit::NumberDensity);
    EXPECT_EQ(nebula::parseDensityUnit("g/cm3"), DensityUnit::GasMass);
    EXPECT_EQ(nebula::parseDensityUnit("g cm**-3"), DensityUnit::GasMass);
    EXPECT_EQ(nebula::parseDensityUnit("g/cm3-dust"), DensityUnit::DustMass);
    EXPECT_EQ(nebula::parseDensityUnit("Msun/pc3"), DensityUnit::SolarMass);
    EXPECT_EQ(nebula::parseDensityUnit("solMass / pc3"), DensityUnit::SolarMass);
    EXPECT_FALSE(nebula::parseDensityUnit("furlongs"));
    EXPECT_FALSE(nebula::parseDensityUnit(""));

    // Hand-computed: 1 M_sun pc^-3 = 1.98841e33 g / (3.0857e18 cm)^3 = 6.768e-23 g cm^-3;
    // m_H = 1.6735e-24 g, so 1.4 m_H = 2.3429e-24 g.
    EXPECT_NEAR(nebula::MSUN_PC3_G_CM3, 6.768e-23, 0.001e-23);
    EXPECT_NEAR(nebula::M_H_G, 1.6735e-24, 0.0001e-24);
    EXPECT_DOUBLE_EQ(nebula::densityToNH(DensityUnit::NumberDensity, 1.4, 0.01), 1.0);
    EXPECT_NEAR(nebula::densityToNH(DensityUnit::GasMass, 1.4, 0.01) * 2.3429e-24, 1.0, 1e-4);
    EXPECT_NEAR(nebula::densityToNH(DensityUnit::DustMass, 1.4, 0.01) * 2.3429e-26, 1.0, 1e-4);
    // 1 M_sun pc^-3 of gas at mu = 1.4: 6.768e-23 / 2.3429e-24 = 28.89 H atoms per cm^3.
    EXPECT_NEAR(nebula::densityToNH(DensityUnit::SolarMass, 1.4, 0.01), 28.89, 0.01);
    EXPECT_NEAR(*nebula::lengthUnitPc("au"), 4.8481e-6, 0.0001e-6);
    EXPECT_DOUBLE_EQ(*nebula::lengthUnitPc("kpc"), 1000.0);
    EXPECT_FALSE(nebula::lengthUnitPc("deg"));
}

namespace {

/// A FITS file with a 2 x 3 x 4 float cube (100 x + 10 y + z) and @p keys.
std::string fitsCube(const std::vector<std::pair<std::string, std::string>>& keys,
                     const std::vector<std::pair<std::string, double>>& numbers)
{
    auto f = nebula::FitsFile::createMemory("t.fits");
    f.createImage({2, 3, 4});
    for (const auto& [k, v] : keys)
        f.writeKey(k, v, "");
    for (const auto& [k, v] : numbers)
        f.writeKey(k, v, "");
    std::vector<float> data;
    for (int z = 0; z < 4; ++z)
        for (int y = 0; y < 3; ++y)
            for (int x = 0; x < 2; ++x)
                data.push_back(float(100 * x + 10 * y + z));
    f.writeFloats(0, 24, data.data());
    return f.finishBytes();
}

} // namespace

TEST_F(CubeIo, FitsCubeAndItsWcs)
{
    write("c.fits",
          fitsCube({{"BUNIT", "cm-3"}, {"CUNIT1", "au"}, {"CUNIT2", "au"}, {"CUNIT3", "au"}},
                   {{"CDELT1", 100},
                    {"CDELT2", 100},
                    {"CDELT3", -100},
                    {"CRPIX1", 1},
                    {"CRPIX2", 2},
                    {"CRPIX3", 1},
                    {"CRVAL1", 0},
                    {"CRVAL2", 0},
                    {"CRVAL3", 50}}));
    auto cube = nebula::openCube(path("c.fits"), CubeSelect{});
    EXPECT_EQ(cube->info().unit, "cm-3");
    EXPECT_EQ(cube->info().planeAxis, 2);
    ASSERT_TRUE(cube->info().geometry);
    const auto& g = *cube->info().geometry;
    const double au = nebula::AU_CM / nebula::PC_CM;
    EXPECT_NEAR(g.spacing[0], 100 * au, 1e-18);
    EXPECT_NEAR(g.spacing[2], -100 * au, 1e-18);
    ASSERT_TRUE(g.origin);
    EXPECT_NEAR((*g.origin)[1], -100 * au, 1e-18); // CRVAL + CDELT (1 - CRPIX)
    EXPECT_NEAR((*g.origin)[2], 50 * au, 1e-18);
    expectCube(*cube);
}

TEST_F(CubeIo, FitsWcsThatIsNotACubeIsRefused)
{
    const auto geometryError = [&](const std::vector<std::pair<std::string, std::string>>& k,
                                   const std::vector<std::pair<std::string, double>>& n) {
        write("w.fits", fitsCube(k, n));
        return nebula::openCube(path("w.fits"), CubeSelect{})->info().geometryError;
    };
    const std::vector<std::pair<std::string, std::string>> pc = {
        {"CUNIT1", "pc"}, {"CUNIT2", "pc"}, {"CUNIT3", "pc"}};
    EXPECT_TRUE(
        contains(geometryError(pc, {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 2}}), "not cubes"));
    EXPECT_TRUE(
        contains(geometryError(pc, {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 1}, {"PC1_2", 0.5}}),
                 "rotates or shears"));
    EXPECT_TRUE(contains(geometryError({{"CUNIT1", "deg"}, {"CUNIT2", "deg"}, {"CUNIT3", "deg"}},
                                       {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 1}}),
                         "is an angle"));
    EXPECT_TRUE(
        contains(geometryError(pc, {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 0}}), "not 0"));
    EXPECT_TRUE(contains(geometryError({}, {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 1}}),
                         "CUNIT1 is missing"));
    EXPECT_TRUE(geometryError({}, {}).empty()); // no WCS: --voxel-size then
    // A rotation by CROTAn, a value that is a string: refused, naming the keyword.
    EXPECT_TRUE(
        contains(geometryError(pc, {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 1}, {"CROTA2", 30}}),
                 "CROTA2 = 30 degrees"));
    auto withCrpix = pc;
    withCrpix.push_back({"CRPIX1", "NaN"});
    EXPECT_TRUE(contains(geometryError(withCrpix, {{"CDELT1", 1}, {"CDELT2", 1}, {"CDELT3", 1}}),
                         "CRPIX1 = 'NaN"));
    // Steps equal within CUBIC_STEP_TOLERANCE are not refused here (nebimport snaps them).
    EXPECT_TRUE(geometryError(pc, {{"CDELT1", 1}, {"CDELT2", 1 + 1e-9}, {"CDELT3", 1}}).empty());
}

TEST_F(CubeIo, FitsDamageIsRefused)
{
    const std::string good = fitsCube({{"BUNIT", "cm-3"}}, {});
    write("trunc.fits", good.substr(0, 2880 + 40));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("trunc.fits"), CubeSelect{}); }),
                         "truncated"));
    std::string damaged = good;
    std::memcpy(damaged.data() + 80 * 3 + 10, "   banana", 9); // NAXIS1's value
    write("damaged.fits", damaged);
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::openCube(path("damaged.fits"), CubeSelect{}); }),
                 "damaged.fits: cannot open it as a FITS file"));
    write("bscale.fits", fitsCube({{"BSCALE", "NaN"}}, {}));
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("bscale.fits"), CubeSelect{}); }),
                         "bscale.fits: HDU 0: BSCALE = 'NaN"));
    CubeSelect sel;
    sel.hdu = "NOPE";
    write("good.fits", good);
    EXPECT_TRUE(contains(errorMessage([&] { nebula::openCube(path("good.fits"), sel); }),
                         "no HDU named \"NOPE\""));
    sel.hdu = "3";
    EXPECT_TRUE(
        contains(errorMessage([&] { nebula::openCube(path("good.fits"), sel); }), "no HDU 3"));
}

TEST_F(CubeIo, WritersRoundTrip)
{
    nebula::CubeHeader h;
    h.dims = {2, 3, 4};
    h.spacing = {0.5, 0.5, 0.5};
    h.origin = {1, 2, 3};
    h.unit = "cm-3";
    h.name = "density";
    h.history = {"nebtest: a line"};
    const nebula::PlaneFunction plane = [](const nebula::PlaneOrder& o, std::int64_t k,
                                           float* out) {
        const std::array<int, 3> n{2, 3, 4};
        const int nu = n[std::size_t(o.fastAxis)], nv = n[std::size_t(o.slowAxis)];
        for (int v = 0; v < nv; ++v)
            for (int u = 0; u < nu; ++u) {
                std::array<int, 3> c{};
                c[std::size_t(o.planeAxis)] = int(k);
                c[std::size_t(o.fastAxis)] = u;
                c[std::size_t(o.slowAxis)] = v;
                out[v * nu + u] = float(100 * c[0] + 10 * c[1] + c[2]);
            }
    };
    for (const std::string& written : nebula::cubeFormatNames(true)) {
        const CubeFormat& format = nebula::cubeFormat(written, "--format");
        const std::string name = path("out." + format.name);
        nebula::writeCube(format, name, h, "/grids/density", plane);
        CubeSelect sel;
        sel.format = &format;
        auto cube = nebula::openCube(name, sel);
        SCOPED_TRACE(name);
        expectCube(*cube);
        if (format.name == "npy") continue;
        EXPECT_EQ(cube->info().unit, "cm-3");
        ASSERT_TRUE(cube->info().geometry);
        EXPECT_EQ(cube->info().geometry->spacing, h.spacing);
        EXPECT_EQ(*cube->info().geometry->origin, h.origin);
    }
}

// The formats' registry: each found by its name and its files' names, each documented;
// an unknown name refused with the known ones.
TEST(CubeFormats, EachIsFoundByNameAndDocumented)
{
    const auto& formats = nebula::cubeFormats();
    ASSERT_EQ(formats.size(), 4u);
    for (const CubeFormat* f : formats) {
        SCOPED_TRACE(f->name);
        EXPECT_EQ(&nebula::cubeFormat(f->name, "--format"), f);
        EXPECT_FALSE(f->title.empty());
        EXPECT_FALSE(f->doc.empty());
        EXPECT_FALSE(f->hint.empty());
        EXPECT_TRUE(f->open);
        EXPECT_EQ(bool(f->write), bool(f->fileFormat)); // a writer says what it writes
        EXPECT_EQ(bool(f->write), bool(f->writerMemory));
        EXPECT_TRUE(!f->endings.empty() || !f->fileNames.empty());
    }
    EXPECT_EQ(nebula::cubeFormatList(false), "fits, hdf5, npy or radmc");
    EXPECT_EQ(nebula::cubeFormatList(true), "fits, hdf5 or npy");
}

TEST(CubeFormats, AnUnknownNameIsRefusedWithTheKnownOnes)
{
    try {
        nebula::cubeFormat("vtk", "--format");
        FAIL() << "no error";
    } catch (const nebula::UsageError& e) {
        EXPECT_STREQ(e.what(),
                     "--format: unknown format \"vtk\" (expected fits, hdf5, npy or radmc)");
    }
}

TEST_F(CubeIo, TheNameOrTheFolderTellsTheFormat)
{
    const auto of = [](const std::string& p) {
        const CubeFormat* f = nebula::cubeFormatOf(p);
        return f ? f->name : std::string("none");
    };
    EXPECT_EQ(of("a/B.FITS.gz"), "fits");
    EXPECT_EQ(of("c.fts"), "fits");
    EXPECT_EQ(of("sim.hdf"), "hdf5");
    EXPECT_EQ(of("rho.npy"), "npy");
    EXPECT_EQ(of("model/amr_grid.inp"), "radmc");
    EXPECT_EQ(of("dust_density.binp"), "radmc");
    EXPECT_EQ(of("notes.txt"), "none");
    EXPECT_EQ(of(path("")), "radmc"); // a folder
}
