// SPDX-License-Identifier: Apache-2.0
// What an adversarial user tries: negative and oversized integers, nan and inf, absurd
// sizes, steps and distances, two "-" inputs, broken transforms and config files, empty or
// overflowing star lists, partial dust metadata. Each is refused with a usage error (exit 2)
// that names the option and says the limit, or an error (exit 1) naming the file; nothing
// dies with a bare std::bad_alloc, hangs, or writes non-finite pixels.
#include "cli_fixture.h"

#include "nebula/core/memory.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/image.h"
#include "nebula/stages/generate.h"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

/// Occurrences of @p part in @p text.
int count(const std::string& text, const std::string& part)
{
    int n = 0;
    for (auto at = text.find(part); at != std::string::npos; at = text.find(part, at + 1))
        ++n;
    return n;
}

/// @p grids written to @p path with OpenVDB directly (no checksums, nothing checked), for
/// files the tools would not write.
void writeRaw(const std::string& path, nebula::GridSet grids)
{
    grids.meta.removeMeta("nebula:checksums"); // recomputed by nobody: the file is doctored
    writeVdb(path, grids.grids, grids.meta);
}

/// Replaces every occurrence of the bytes of double @p from in file @p path by those of @p to;
/// returns how many it replaced.
int patchDouble(const std::string& path, double from, double to)
{
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    char a[sizeof(double)], b[sizeof(double)];
    std::memcpy(a, &from, sizeof a);
    std::memcpy(b, &to, sizeof b);
    const std::string needle(a, sizeof a);
    int n = 0;
    for (auto at = bytes.find(needle); at != std::string::npos; at = bytes.find(needle, at + 1)) {
        bytes.replace(at, sizeof b, b, sizeof b);
        ++n;
    }
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    return n;
}

} // namespace

// 1. Integer options refuse negative, oversized and non-decimal values, naming the option and
// its range (CLI11 alone read "--seed -1" as 18446744073709551615 and saturated
// "99999999999999999999").
TEST_F(Cli, IntegerOptionsRefuseNegativeAndOversizedValues)
{
    const std::string u64 = "[0, 18446744073709551615]";
    struct Case
    {
        std::string command; // with {} for the value
        std::string option, range;
    };
    const std::vector<Case> cases = {
        {"nebgen --seed {} -o a.vdb", "--seed", u64},
        {"nebgen --res {} -o a.vdb", "--res", "[2, 2048]"},
        {"nebgen --octaves {} -o a.vdb", "--octaves", "[1, 16]"},
        {"nebgen --threads {} -o a.vdb", "--threads", "[0, 4096]"},
        {"nebillum -i a.vdb --threads {} -o b.vdb", "--threads", "[0, 4096]"},
        {"nebpyramid -i a.vdb --levels {} -o b.vdb", "--levels", "[1, 24]"},
        {"nebpyramid -i a.vdb --threads {} -o b.vdb", "--threads", "[0, 4096]"},
        {"nebscatter -i a.vdb --seed {} -o b.vdb", "--seed", u64},
        {"nebscatter -i a.vdb --packets {} -o b.vdb", "--packets", "[1, 1099511627776]"},
        {"nebscatter -i a.vdb --order {} -o b.vdb", "--order", "[0, 4]"},
        {"nebscatter -i a.vdb --threads {} -o b.vdb", "--threads", "[0, 4096]"},
        {"nebrender -i a.vdb --seed {} -o f.exr", "--seed", u64},
        {"nebrender -i a.vdb --levels {} -o f.exr", "--levels", "[0, 16]"},
        {"nebrender -i a.vdb --spp {} -o f.exr", "--spp", "[1, 1073741824]"},
        {"nebrender -i a.vdb --bands {} -o f.exr", "--bands", "[1, 4700]"},
        {"nebrender -i a.vdb --spectral --spectral-layers {} -o f.exr", "--spectral-layers",
         "[1, 470]"},
        {"nebrender -i a.vdb --threads {} -o f.exr", "--threads", "[0, 4096]"},
        {"nebphase --seed {} -o p.vdb", "--seed", u64},
        {"nebphase --photons {} -o p.vdb", "--photons", "[1, 18446744073709551615]"},
        {"nebphase --max-photons {} -o p.vdb", "--max-photons", "[1, 18446744073709551615]"},
        {"nebphase --t-count {} -o p.vdb", "--t-count", "[2, 1000000]"},
        {"nebphase --mu-bins {} -o p.vdb", "--mu-bins", "[2, 1000000]"},
        {"nebphase --slab --tau 1 --bins {}", "--bins", "[1, 100000]"},
        {"nebphase --threads {} -o p.vdb", "--threads", "[0, 4096]"},
    };
    for (const auto& c : cases) {
        for (const std::string value : {"-1", "99999999999999999999", "1e3", "0x10"}) {
            std::string cmd = c.command;
            cmd.replace(cmd.find("{}"), 2, value);
            expectFailure(cmd, 2,
                          c.option + ": expected an integer in " + c.range + ", got " + value);
        }
    }
    // --field-level also takes "auto" (its default).
    for (const std::string value : {"-2", "99999999999999999999", "1e3", "0x10", "Auto"})
        expectFailure("nebscatter -i a.vdb --field-level " + value + " -o b.vdb", 2,
                      "--field-level: expected auto or an integer in [-1, 16], got " + value);
    // The largest seed is fine, and a leading zero is decimal (not octal as CLI11 reads it).
    const Result r = run("nebgen --res 8 --seed 18446744073709551615 -o a.vdb && "
                         "nebgen --res 8 --seed 010 -o b.vdb && nebgen --res 8 --seed 10 -o c.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto b = read(path("b.vdb")).floatGrid("density", "");
    const auto c = read(path("c.vdb")).floatGrid("density", "");
    EXPECT_EQ(maxValue(*b), maxValue(*c));
}

// 2. Ranges are printed readably: no 300-digit rendering of the largest double.
TEST_F(Cli, RangesArePrintedReadably)
{
    for (const auto& [cmd, mention] : std::vector<std::pair<std::string, std::string>>{
             {"nebillum -i a.vdb --threads -1 -o b.vdb",
              "--threads: expected an integer in [0, 4096], got -1"},
             {"nebrender -i a.vdb --step 0 -o f.exr",
              "--step: expected a finite number > 0, got 0"},
             {"nebrender -i a.vdb --emission-scale -1 -o f.exr",
              "--emission-scale: expected a finite number >= 0, got -1"},
             {"nebrender -i a.vdb --fov 400 -o f.exr",
              "--fov: expected a number in [0.01, 360], got 400"},
             {"nebrender -i a.vdb --fov 180 -o f.exr",
              "--fov must be in (0, 179] degrees for the perspective camera, got 180"},
             {"nebrender -i a.vdb --g 1 -o f.exr", "--g: expected a number in (-1, 1), got 1"},
             {"nebgen --shell-width 0 -o a.vdb",
              "--shell-width: expected a number in (0, 1], got 0"},
         }) {
        const Result r = run(cmd);
        EXPECT_EQ(r.code, 2) << cmd << "\n" << r.err;
        EXPECT_NE(r.err.find(mention), std::string::npos) << mention << " in:\n" << r.err;
        EXPECT_LT(r.err.size(), 300u) << r.err;
        EXPECT_EQ(r.err.find("0000000000"), std::string::npos) << r.err;
    }
}

// 3. A step so small that a ray would take billions of steps is refused once the grid is
// known, with the smallest step this grid allows.
TEST_F(Cli, TinyRayStepIsRefusedWithTheSmallestAllowed)
{
    makeLit();
    const Result r = run("nebrender -i lit.vdb --step 1e-9 --res 8x8 -o f.exr");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("error: --step 1e-09: a ray across this grid"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("more than the limit of 1e+06"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("the smallest step for this grid is "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(" voxels ("), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(" pc)"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(path("f.exr")));
    // The same with --spectral; a small but sane step renders.
    expectFailure("nebrender -i lit.vdb --spectral --step 1e-9 --res 8x8 -o f.exr", 2,
                  "the smallest step for this grid is ");
    const Result ok = run("nebrender -i lit.vdb --step 0.05 --res 8x8 -o f.exr");
    EXPECT_EQ(ok.code, 0) << ok.err;
    // A wavelength outside the extinction curve is the option's fault too (it was exit 1
    // without the option's name).
    expectFailure("nebrender -i lit.vdb --wavelengths 5000,546,435 --res 8x8 -o g.exr", 2,
                  "--wavelengths: CCM89 extinction: wavelength 5000 nm is outside the curve's "
                  "range 125-3333 nm");
}

// An ODS stereo base larger than the scene is refused (exit 2, nothing written); the
// camera's own checks name their options.
TEST_F(Cli, OdsStereoBaseMustSuitTheScene)
{
    makeLit();
    expectFailure("nebrender -i lit.vdb --camera ods --ipd 1000 --res 16x16 -o f.exr", 2,
                  "--ipd 1000 pc is larger than the scene, whose box is ");
    EXPECT_FALSE(fs::exists(path("f.exr")));
    expectFailure("nebrender -i lit.vdb --camera ods --res 16x16 -o f.exr", 2,
                  "--camera ods needs --ipd");
    expectFailure("nebrender -i lit.vdb --camera ods --ipd 0 --res 16x16 -o f.exr", 2,
                  "--camera ods needs --ipd, the inter-pupillary distance, a finite length > 0");
    expectFailure("nebrender -i lit.vdb --camera ods --ipd 0.1 --res 32x16 -o f.exr", 2,
                  "must be square with an even height");
    expectFailure("nebrender -i lit.vdb --ipd 0.1 --res 16x16 -o f.exr", 2,
                  "--ipd is for --camera ods");
    expectFailure("nebrender -i lit.vdb --camera ods --ipd 0.1 --pole-merge 80,70 --res 16x16 "
                  "-o f.exr",
                  2, "--pole-merge FROM,TO must have 0 <= FROM < TO <= 90 degrees, got 80,70");
    const Result ok = run("nebrender -i lit.vdb --camera ods --ipd 0.1 --res 32x32 -o f.exr");
    EXPECT_EQ(ok.code, 0) << ok.err;
}

// 4. Sizes that would not fit in memory are refused before anything is allocated, saying how
// much they need and how much the machine has; no bare std::bad_alloc.
TEST_F(Cli, AllocationsTooLargeForTheMachineAreRefused)
{
    makeLit();
    const double machine = double(nebula::physicalMemory());
    const std::string has = "of memory; this machine has " + nebula::bytesText(machine);

    expectFailure("nebrender -i lit.vdb --sprite-radius 1e9 --res 8x8 -o f.exr", 2,
                  "--sprite-radius 1e+09: the star sprite footprint (4e+09 x 4e+09 pixels) needs ");
    expectFailure("nebrender -i lit.vdb --sprite-radius 1e9 --res 8x8 -o f.exr", 2, has);
    // 470 spectral layers of 65536^2 pixels need terabytes on any machine.
    expectFailure("nebrender -i lit.vdb --spectral --spectral-layers 470 --res 65536x65536 "
                  "-o f.exr",
                  2, "--res 65536x65536: the image needs ");
    // Few photons per t, so the work bound (1e11 photons in a table) leaves the memory to fail.
    expectFailure("nebphase --t-count 1000000 --mu-bins 1000000 --photons 1000 --max-photons 1000 "
                  "-o p.vdb",
                  2, "--t-count 1000000 x --mu-bins 1000000: the phase table needs ");

    // The user's own cases, where this machine is too small for them (as most are).
    struct Case
    {
        std::string command, mention;
        double bytes; // what the tool needs
    };
    const double pixels = 65536.0 * 65536.0;
    nebula::NebulaParams big;
    big.res = 2048;
    big.spectral.enabled = true;
    big.spectral.oiii = 1.0;
    const double spectral2048 = nebula::generateBytes(big); // the grids where dust may be
    const std::vector<Case> cases = {
        // R,G,B,A + 2 stars' and the transmittance's RGB layers, tone curve and PNG buffers.
        {"nebrender -i lit.vdb --res 65536x65536 -o f.exr", "--res 65536x65536: the image needs ",
         pixels * ((4 + 3 * 3) * 4 + 20)},
        {"nebgen --res 2048 --spectral --oiii 1 -o big.vdb",
         "--res 2048: generating the grids needs ", spectral2048},
    };
    for (const auto& c : cases) {
        if (machine >= c.bytes) continue; // would run (for minutes) on this machine
        expectFailure(c.command, 2, c.mention + nebula::bytesText(c.bytes) + " " + has);
    }
}

// 5. An eye so far away that its distance squared overflows is blamed on --eye (it was
// blamed on --up); every X,Y,Z option refuses such magnitudes and non-finite numbers.
TEST_F(Cli, HugeAndNonFiniteVectorsNameTheirOption)
{
    const Result r = run("nebrender -i a.vdb --eye 1e300,0,0 -o f.exr");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--eye \"1e300,0,0\": each number must be at most 1e+150 in magnitude"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("--up"), std::string::npos) << r.err;
    for (const auto& [option, tool] : std::vector<std::pair<std::string, std::string>>{
             {"--eye", "nebrender -i a.vdb -o f.exr"},
             {"--look-at", "nebrender -i a.vdb -o f.exr"},
             {"--up", "nebrender -i a.vdb -o f.exr"},
             {"--wavelengths", "nebrender -i a.vdb -o f.exr"},
             {"--emission-color", "nebrender -i a.vdb -o f.exr"},
             {"--rotation-axis", "nebgen --spectral -o a.vdb"},
             {"--motion-centre", "nebgen --spectral -o a.vdb"},
         }) {
        expectFailure(tool + " " + option + " 0,-1e200,0", 2,
                      option + " \"0,-1e200,0\": each number must be at most 1e+150");
        for (const char* bad : {"nan,0,0", "0,inf,0", "0,0,1e999"}) {
            expectFailure(tool + " " + option + " " + bad, 2,
                          option + " \"" + bad + "\": expected X,Y,Z (three numbers)");
        }
    }
}

// 6. nan, inf and overflowing numbers are usage errors (exit 2) naming the option, for every
// floating-point option of every tool.
TEST_F(Cli, NonFiniteNumbersAreUsageErrorsForEveryOption)
{
    const std::map<std::string, std::vector<std::string>> options = {
        {"nebgen -o a.vdb",
         {"--size",
          "--density",
          "--frequency",
          "--lacunarity",
          "--gain",
          "--threshold",
          "--contrast",
          "--exponent",
          "--warp",
          "--envelope",
          "--emission",
          "--emission-radius",
          "--cavity",
          "--kappa-v",
          "--albedo",
          "--g",
          "--rv",
          "--shell-width",
          "--gas-temperature",
          "--expansion",
          "--rotation",
          "--turbulence",
          "--turbulence-frequency",
          "--motion-radius",
          "--oiii"}},
        {"nebillum -i a.vdb -o b.vdb", {"--kappa-v"}},
        {"nebrender -i a.vdb -o f.exr",
         {"--fov", "--step", "--emission-scale", "--sprite-radius", "--min-star-distance",
          "--albedo", "--g", "--rv", "--continuum-step", "--exaggerate-velocity", "--line-width",
          "--blackbody-scale", "--temperature-scale", "--merge-tolerance", "--exposure", "--gamma",
          "--percentile"}},
        {"nebphase -o p.vdb", {"--albedo", "--g", "--rv", "--t-min", "--t-max", "--error"}},
        {"nebphase --slab", {"--tau", "--mu0"}},
    };
    for (const auto& [tool, names] : options) {
        for (const auto& option : names) {
            for (const std::string value : {"nan", "-inf", "1e999"}) {
                const std::string cmd = tool + " " + option + " " + value;
                const Result r = run(cmd);
                EXPECT_EQ(r.code, 2) << cmd << "\n" << r.err;
                EXPECT_NE(r.err.find("error: " + option + ": expected a "), std::string::npos)
                    << cmd << "\n"
                    << r.err;
                EXPECT_NE(r.err.find(", got " + value + "\n"), std::string::npos) << r.err;
            }
        }
    }
    EXPECT_EQ(entries(), std::vector<std::string>{}); // nothing written
    expectFailure("nebrender -i a.vdb --exposure nan -o f.exr", 2,
                  "--exposure: expected a number in [-1000, 1000], got nan");
}

// 7. Two inputs cannot both be stdin.
TEST_F(Cli, TwoStdinInputsAreRefused)
{
    makeLit();
    expectFailure("nebrender -i - --phase - -o f.exr < lit.vdb", 2,
                  "-i - and --phase - both read stdin");
}

// 8. A transform with a zero (or NaN) voxel size is refused where the grids are first used,
// naming the file and the grid (it was "singular grid transform" without either, and
// nebpyramid's "ArithmeticError: Non-zero scale values required").
TEST_F(Cli, ZeroVoxelSizeNamesTheFileAndGrid)
{
    makeLit();
    const double voxel = 0.123456789; // a value nothing else in the file holds
    auto grids = read(path("lit.vdb"));
    for (auto& g : grids.grids)
        g->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    writeRaw(path("zero.vdb"), grids);
    writeRaw(path("nan.vdb"), grids);
    ASSERT_GE(patchDouble(path("zero.vdb"), voxel, 0.0), 6);
    ASSERT_GE(patchDouble(path("nan.vdb"), voxel, std::nan("")), 6);

    const std::string zero = "zero.vdb: grid \"density\" has voxel size 0 along its x axis";
    expectFailure("nebillum -i zero.vdb -o out.vdb", 1, zero);
    expectFailure("nebpyramid -i zero.vdb --levels 1 -o out.vdb", 1, zero);
    expectFailure("nebrender -i zero.vdb --res 8x8 -o f.exr", 1, zero);
    expectFailure("nebrender -i nan.vdb --res 8x8 -o f.exr", 1,
                  "nan.vdb: grid \"density\" has a transform with non-finite values");
}

// 9. A --stars file with an empty list is an error naming the file, not silently no stars.
TEST_F(Cli, EmptyStarsFileIsAnError)
{
    makeLit();
    std::ofstream(path("empty.json")) << "[]\n";
    expectFailure("nebillum -i small.vdb --stars empty.json -o b.vdb", 1,
                  "empty.json (--stars) holds no stars");
    expectFailure("nebgen --res 8 --stars empty.json -o b.vdb", 1,
                  "empty.json (--stars) holds no stars");
}

// 10. Non-finite star positions, luminosities and temperatures are refused naming --star.
TEST_F(Cli, NonFiniteStarsAreRefused)
{
    for (const char* star : {"a:nan,0,0:10:B2V", "a:0,inf,0:10:B2V", "a:0,0,0:nan:B2V",
                             "a:0,0,0:1e999:B2V", "a:0,0,0:10:inf", "a:0,0,0:10:1e999"}) {
        expectFailure(std::string("nebgen --res 8 --star ") + star + " -o a.vdb", 2, "--star");
        const Result r = run(std::string("nebgen --res 8 --star ") + star + " -o a.vdb");
        EXPECT_EQ(r.err.find("null"), std::string::npos) << r.err;
    }
    expectFailure("nebgen --res 8 --star a:1e200,0,0:10:B2V -o a.vdb", 2,
                  "each coordinate must be at most 1e+150 pc in magnitude");
}

// 11. A luminosity whose radiance would overflow is refused, saying the limit; an image that
// still holds non-finite pixels is never written.
TEST_F(Cli, OverflowingLuminosityAndNonFinitePixels)
{
    expectFailure("nebgen --res 8 --star a:0,0,0:1e308:B2V -o a.vdb", 2,
                  "--star: star 1 (\"a\"): \"luminosity\" 1e+308 is above the limit of 1e+30 "
                  "L_sun");
    std::ofstream(path("bright.json"))
        << R"([{"name": "a", "position": [0, 0, 0], "luminosity": 1e308, "class": "B2V"}])";
    expectFailure("nebgen --res 8 --stars bright.json -o a.vdb", 1,
                  "bright.json: star 1 (\"a\"): \"luminosity\" 1e+308 is above the limit");
    expectFailure("nebgen --res 8 --star a:0,0,0:10:1e12 -o a.vdb", 2,
                  "\"temperature\" 1e+12 is above the limit of 1e+09 K");

    // At the limit, a star 1e-5 pc from the eye overflows a float pixel.
    ASSERT_EQ(run("nebgen --res 16 --no-stars --star a:0,0,0:1e30:B2V -o s.vdb && "
                  "nebillum -i s.vdb -o l.vdb")
                  .code,
              0);
    const std::string render =
        "nebrender -i l.vdb --eye 0,0,-1e-5 --look-at 0,0,0 --res 16x16 -o f.exr";
    expectFailure(render, 1, "f.exr: pixel (");
    const Result r = run(render);
    EXPECT_NE(r.err.find("not writing an image with non-finite values"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("luminosity"), std::string::npos) << r.err;
}

// 12. Config files: unknown keys, garbage, sections, bad values and random bytes are usage
// errors naming the file and line; bytes are never echoed raw.
TEST_F(Cli, BrokenConfigFilesNameTheFileAndLine)
{
    struct Case
    {
        std::string text, mention;
    };
    const std::vector<Case> cases = {
        {"res = 16\nrez = 16\n", "--config: c.toml, line 2: unknown option \"rez\""},
        {"# fine\nres = 16\nthis is not a setting\n",
         "--config: c.toml, line 3: expected \"key = value\""},
        {"[nebgen]\nres = 16\n", "--config: c.toml, line 1: section [nebgen]"},
        {"zz\n", "--config: c.toml, line 1: expected \"key = value\""},
        {"a.b = 1\n", "--config: c.toml, line 1: unknown option \"a.b\""},
        {"res =\n", "--config: c.toml, line 1: \"res\" has no value"},
        {"seed = -1\n",
         "--config: c.toml, line 1: --seed: expected an integer in [0, 18446744073709551615], "
         "got -1"},
        {"size = nan\n", "--config: c.toml, line 1: --size: expected a finite number > 0"},
        {"res = 16\nstar = [\"a:0,0,0:1:B2V\",\n", "the array opened with '[' is not closed"},
    };
    for (const auto& c : cases) {
        std::ofstream(path("c.toml"), std::ios::trunc) << c.text;
        expectFailure("nebgen --config c.toml -o a.vdb", 2, c.mention);
    }

    // Random bytes: the first one that is not text is named by its value, none is echoed.
    std::mt19937 rng(7);
    std::string bytes = "res = 16\n";
    for (int i = 0; i < 256; ++i)
        bytes += char(rng() & 0xff);
    bytes[9] = bytes[10] = bytes[11] = 'x';
    bytes[12] = '\0';
    std::ofstream(path("c.toml"), std::ios::binary | std::ios::trunc) << bytes;
    const Result r = run("nebgen --config c.toml -o a.vdb");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--config: c.toml, line 2: byte 0x00 at column 4"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("is not text"), std::string::npos) << r.err;
    for (char ch : r.err) {
        const auto u = static_cast<unsigned char>(ch);
        EXPECT_TRUE(ch == '\n' || (u >= 0x20 && u < 0x7f)) << "raw byte " << int(u) << " echoed";
    }
    EXPECT_FALSE(fs::exists(path("a.vdb")));

    // A good file still works: comments, [default], quoted strings, flags, arrays.
    std::ofstream(path("c.toml"), std::ios::trunc)
        << "# a comment\n; another\n[default]\nres = 8\nseed = 3\nquiet = true\n"
           "star = [\"a:0,0,0:10:B2V\",\n        \"b:1,0,0:5:A0V\"]\nlines = \"H-alpha\"\n";
    const Result ok = run("nebgen --config c.toml -o a.vdb");
    ASSERT_EQ(ok.code, 0) << ok.err;
    EXPECT_EQ(read(path("a.vdb")).stars().size(), 2u);
}

// 13. A nebula:dust that lacks fields uses the defaults for them and warns once, naming them.
TEST_F(Cli, PartialDustMetadataUsesTheDefaultsAndWarnsOnce)
{
    makeLit();
    auto grids = read(path("lit.vdb"));
    grids.setMetaString(nebula::META_DUST, R"({"albedo": 0.3, "kappa_V": 0.0015})");
    writeRaw(path("partial.vdb"), grids);

    const std::string warning = "warning: partial.vdb: metadata nebula:dust lacks 4 fields; using "
                                "the defaults g = 0.6, phase = hg, curve = CCM89, R_V = 3.1";
    for (const std::string cmd :
         {"nebrender -i partial.vdb --res 8x8 -o f.exr", "nebillum -i partial.vdb -o b.vdb",
          "nebpyramid -i partial.vdb --levels 1 -o p.vdb",
          "nebphase -i partial.vdb --t-count 2 --mu-bins 2 --error 1 "
          "--photons 64 --max-photons 64 -o t.vdb"}) {
        const Result r = run(cmd);
        ASSERT_EQ(r.code, 0) << cmd << "\n" << r.err;
        EXPECT_EQ(count(r.err, warning), 1) << cmd << "\n" << r.err;
        EXPECT_EQ(count(r.err, "nebula:dust lacks"), 1) << cmd << "\n" << r.err;
    }
    std::map<std::string, std::string> attrs;
    nebula::readExr(path("f.exr"), &attrs);
    const auto dust = nlohmann::json::parse(attrs.at("nebula:dust"));
    EXPECT_EQ(dust.at("albedo").get<double>(), 0.3);
    EXPECT_EQ(dust.at("g").get<double>(), 0.6);
    // -q silences the warning; a complete nebula:dust gives none.
    EXPECT_EQ(run("nebrender -i partial.vdb --res 8x8 -q -o g.exr").err, "");
    EXPECT_EQ(run("nebrender -i lit.vdb --res 8x8 -o h.exr").err.find("lacks"), std::string::npos);
    // A field of the wrong type is still an error.
    grids.setMetaString(nebula::META_DUST, R"({"albedo": "high"})");
    writeRaw(path("wrong.vdb"), grids);
    expectFailure("nebrender -i wrong.vdb --res 8x8 -o f2.exr", 1,
                  "wrong.vdb: metadata nebula:dust: dust parameters: \"albedo\" must be a number");
}
