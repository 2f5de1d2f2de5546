// SPDX-License-Identifier: Apache-2.0
// Hardening at the mechanisms (README "Failure behaviour"): bounded, early reading of every
// input (VDB, JSON, config; files, pipes, /dev/stdin, endless devices); bounded JSON; unique
// names; finite physics; work bounds checked before any work; nebtone's all-or-nothing
// sequences; and messages that never show a library's or the compiler's internals.
#include "cli_fixture.h"

#include "nebula/io/grid_names.h"
#include "nebula/io/image.h"
#include "nebula/physics/stars.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

/// A JSON array nested @p depth levels deep.
std::string deepArray(std::size_t depth)
{
    return std::string(depth, '[') + std::string(depth, ']');
}

void writeText(const std::string& p, const std::string& text)
{
    std::ofstream(p, std::ios::binary | std::ios::trunc) << text;
}

/// What no error message may show: a library's exception text, an internal name, a raw
/// integer overflow.
const std::vector<std::string> INTERNALS = {
    "json.exception", "std::vector", "bad_alloc", "basic_string", "max_size",    "what()",
    "terminate",      "2147483647",  "nebula::",  "Assertion",    "Segmentation"};

} // namespace

class Hardening : public Cli
{
protected:
    /// expectFailure(), and stderr is one line that names @p mention and no internals.
    void expectClean(const std::string& cmd, int code, const std::string& mention)
    {
        const auto before = entries();
        const Result r = run("timeout 60 " + cmd);
        EXPECT_EQ(r.code, code) << cmd << "\n" << r.err;
        EXPECT_NE(r.err.find(mention), std::string::npos)
            << cmd << ": expected \"" << mention << "\" in: " << r.err;
        for (const auto& bad : INTERNALS) {
            EXPECT_EQ(r.err.find(bad), std::string::npos)
                << cmd << " shows \"" << bad << "\": " << r.err;
        }
        EXPECT_EQ(entries(), before) << "output or temporary left behind by: " << cmd;
    }

    /// lit.vdb with metadata @p key set to @p value, written as another program would
    /// (without nebula:checksums, unless @p key is that).
    void litWithMeta(const std::string& out, const std::string& key, const std::string& value)
    {
        auto grids = read(path("lit.vdb"));
        grids.meta.removeMeta(nebula::META_CHECKSUMS);
        grids.setMetaString(key, value);
        openvdb::io::File f(path(out));
        f.write(grids.grids, grids.meta);
        f.close();
    }
};

// Endless and huge inputs are refused after their first bytes, naming file and option.
TEST_F(Hardening, EndlessInputsAreRefusedAfterTheirFirstBytes)
{
    makeLit();
    expectClean("nebillum -i /dev/zero -o x.vdb", 1, "/dev/zero: not a VDB file");
    expectClean("head -c 3000000000 /dev/zero | nebillum -i - -o x.vdb", 1,
                "<stdin>: not a VDB file");
    expectClean("nebillum -i small.vdb --stars /dev/zero -o x.vdb", 1,
                "/dev/zero (--stars): not a JSON array of stars: it starts with byte 0x00");
    expectClean("nebrender -i lit.vdb --camera-path /dev/zero --res 8x8 -o 'f.####.exr'", 1,
                "/dev/zero (--camera-path): not a camera path");
    expectClean("nebgen --config /dev/zero -o x.vdb", 2,
                "--config: /dev/zero, line 1: byte 0x00 at column 1 is not text");
    expectClean("nebillum -i small.vdb --stars /dev/null -o x.vdb", 1,
                "/dev/null (--stars): empty");
    // Past the size limit: a regular file is refused by its size, a pipe as it passes it;
    // both sizes in the message.
    {
        std::ofstream f(path("big.json"), std::ios::binary);
        f << '[';
        f << std::string((std::size_t(16) << 20) + 10, ' ');
        f << ']';
    }
    expectClean("nebillum -i small.vdb --stars big.json -o x.vdb", 1,
                "big.json (--stars): the file has 16 MiB, more than the 16 MiB nebula reads of "
                "a JSON file");
    fs::remove(path("big.json"));
    expectClean("nebillum -i small.vdb --stars <({ printf '['; head -c 20000000 /dev/zero | tr "
                "'\\0' ' '; }) -o x.vdb",
                1, "more than 16 MiB arrived, the most nebula reads of a JSON file");
}

// A config file from a pipe, /dev/stdin or a process substitution is the text that is checked
// and applied; a key given twice names both lines.
TEST_F(Hardening, ConfigFilesFromPipesAreApplied)
{
    ASSERT_EQ(run("nebgen --config <(printf 'res = 16\\nseed = 4\\n') -o a.vdb").code, 0);
    ASSERT_EQ(run("printf 'res = 16\\nseed = 4\\n' | nebgen --config /dev/stdin -o b.vdb").code, 0);
    ASSERT_EQ(run("nebgen --res 16 --seed 4 -o c.vdb").code, 0);
    ASSERT_EQ(run("nebgen -o d.vdb --res 24").code, 0);
    const auto box = [&](const std::string& f) {
        return read(path(f)).floatGrid("density", "")->evalActiveVoxelBoundingBox();
    };
    EXPECT_EQ(box("a.vdb"), box("c.vdb"));
    EXPECT_EQ(box("b.vdb"), box("c.vdb"));
    EXPECT_NE(box("a.vdb"), box("d.vdb")); // not the defaults
    EXPECT_LE(box("a.vdb").dim().x(), 16);
    // The command line still wins over the config file.
    ASSERT_EQ(run("nebgen --config <(printf 'res = 16\\n') --res 24 -o e.vdb").code, 0);
    EXPECT_EQ(box("e.vdb"), box("d.vdb"));
    expectClean("nebgen --config <(printf 'res = 16\\nquiet\\nres = 20\\n') -o x.vdb", 2,
                "line 3: --res is set again (line 1 set it first)");
    expectClean("nebgen --config <(printf 'res = 16\\n') --config <(printf 'seed = 2\\n') "
                "-o x.vdb",
                2, "--config is given twice");
    expectClean("nebgen --config missing.toml -o x.vdb", 2,
                "missing.toml (--config): cannot open file");
}

// No JSON deeper than 64 levels reaches the parser: from a file, from metadata, in every tool.
TEST_F(Hardening, DeepJsonIsRefusedInEveryConsumer)
{
    makeLit();
    writeText(path("deep.json"), deepArray(100000));
    expectClean("nebillum -i small.vdb --stars deep.json -o x.vdb", 1,
                "deep.json: JSON nested deeper than 64 levels");
    writeText(path("deeppath.json"), "{\"fps\": " + deepArray(100000) + "}");
    expectClean("nebrender -i lit.vdb --camera-path deeppath.json --res 8x8 -o 'f.####.exr'", 1,
                "deeppath.json: the camera path is JSON nested deeper than 64 levels");
    // Depth 64 is parsed (and refused for what it is, not for its depth).
    writeText(path("ok.json"), deepArray(64));
    expectClean("nebillum -i small.vdb --stars ok.json -o x.vdb", 1, "ok.json: star 1");
    litWithMeta("deepstars.vdb", nebula::META_STARS, deepArray(100000));
    litWithMeta("deepdust.vdb", nebula::META_DUST, "{\"kappa_V\":" + deepArray(100000) + "}");
    litWithMeta("deephistory.vdb", nebula::META_HISTORY, deepArray(100000));
    for (const std::string tool :
         {"nebillum -i %s -o x.vdb", "nebscatter --packets 100 -i %s -o x.vdb",
          "nebrender --res 8x8 -i %s -o x.exr", "nebpyramid -i %s -o x.vdb"}) {
        for (const std::string file : {"deepstars.vdb", "deepdust.vdb"}) {
            std::string cmd = tool;
            cmd.replace(cmd.find("%s"), 2, file);
            expectClean(cmd, 1, "nested deeper than 64 levels");
        }
    }
    expectClean("nebphase --t-count 2 --mu-bins 2 --photons 100 -i deepdust.vdb -o x.vdb", 1,
                "nested deeper than 64 levels");
    expectClean("nebillum -i deephistory.vdb -o x.vdb", 1,
                "metadata nebula:history is JSON nested deeper than 64 levels");
}

// Grid names are unique; star names have a limit and every name derived from one stays within
// its format's limits (tested at the limit).
TEST_F(Hardening, NamesAreAContract)
{
    makeLit();
    {
        auto grids = read(path("small.vdb"));
        auto copy = grids.floatGrid("density", "")->deepCopy();
        grids.grids.push_back(copy);
        writeVdb(path("two.vdb"), grids.grids, grids.meta);
    }
    expectClean("nebillum -i two.vdb -o x.vdb", 1,
                "two.vdb: grids 1 and 3 are both named \"density\"");
    const std::string longest(nebula::MAX_STAR_NAME_LENGTH, 'a');
    const std::string tooLong(nebula::MAX_STAR_NAME_LENGTH + 1, 'b');
    writeText(path("long.json"),
              "[{\"name\": \"" + tooLong +
                  "\", \"position\": [0, 0, 0], \"luminosity\": 10, \"class\": \"B3V\"}]");
    expectClean("nebillum -i small.vdb --stars long.json -o x.vdb", 1,
                "\"name\" must be a string of 1 to 64 letters");
    expectClean("nebillum -i small.vdb --star " + std::string(10000, 'c') +
                    ":0,0,0:10:B3V -o x.vdb",
                2, "(10000 characters)");
    writeText(path("two.json"),
              "[{\"name\": \"" + longest +
                  "\", \"position\": [0.5, 0, 0], \"luminosity\": 100, \"class\": \"B3V\"},"
                  "{\"name\": \"" +
                  longest.substr(1) + "z" +
                  "\", \"position\": [-0.5, 0, 0], \"luminosity\": 100, \"class\": \"G2V\"}]");
    ASSERT_EQ(run("nebillum -i small.vdb --stars two.json -o longlit.vdb").code, 0);
    ASSERT_TRUE(read(path("longlit.vdb")).find("tau." + longest));
    const Result r = run("nebrender -i longlit.vdb --res 12x12 --no-png -o long.exr");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto img = nebula::readExr(path("long.exr"), nullptr);
    std::vector<std::string> layers;
    for (const auto& l : img.layers)
        layers.push_back(l.name);
    EXPECT_NE(std::find(layers.begin(), layers.end(), "star." + longest), layers.end());
    EXPECT_NE(std::find(layers.begin(), layers.end(), "star." + longest.substr(1) + "z"),
              layers.end());
}

// Every value that scales the physics is refused where its product would overflow, naming
// it; no tool writes a non-finite voxel or pixel.
TEST_F(Hardening, PhysicsOverflowNamesItsCause)
{
    makeLit();
    litWithMeta("kappa.vdb", nebula::META_DUST,
                R"({"kappa_V":1e308,"albedo":0.6,"g":0.6,"phase":"hg","curve":"CCM89","R_V":3.1})");
    expectClean("nebillum -i kappa.vdb -o x.vdb", 1,
                "kappa.vdb: metadata nebula:dust: dust "
                "parameter kappa_V must be > 0 and at most");
    expectClean("nebillum -i small.vdb --kappa-v 1e308 -o x.vdb", 2, "--kappa-v");
    // Within the range, a density whose optical depth overflows a float names kappa_V.
    {
        auto grids = read(path("small.vdb"));
        auto density =
            openvdb::gridPtrCast<openvdb::FloatGrid>(grids.floatGrid("density", "")->deepCopy());
        for (auto it = density->beginValueOn(); it; ++it)
            it.setValue(3e38f);
        grids.replace(density);
        writeVdb(path("dense.vdb"), grids.grids, grids.meta);
    }
    expectClean("nebillum -i dense.vdb --kappa-v 1e6 -o x.vdb", 1,
                "overflows: kappa_V = 1e+06 [pc^-1 cm^3]");
    expectClean("nebrender -i lit.vdb --rv 1e-300 --res 8x8 -o x.exr", 2, "--rv");
    expectClean("nebrender -i lit.vdb --emission-scale 1e300 --res 8x8 -o x.exr", 2,
                "--emission-scale 1e+300 times the emission grid");
    ASSERT_EQ(run("nebgen --res 16 --spectral -o spec.vdb && nebillum -i spec.vdb -o "
                  "spec-lit.vdb")
                  .code,
              0);
    expectClean("nebrender -i spec-lit.vdb --spectral --temperature-scale 1e300 --res 8x8 -o "
                "x.exr",
                2, "--temperature-scale 1e+300 times grid \"temperature\"'s hottest voxel");
    expectClean("nebrender -i spec-lit.vdb --spectral --blackbody-scale 1e300 --res 8x8 -o "
                "x.exr",
                2, "--blackbody-scale");
}

// Work that would not finish is refused before it starts, with the bound (and, where it is
// an estimate, the estimate) in the message.
TEST_F(Hardening, WorkThatWouldNotFinishIsRefusedAtOnce)
{
    makeLit();
    expectClean("nebscatter -i lit.vdb --packets 1099511627776 -o x.vdb", 2,
                "--packets must be in [1, 1e+09] per source, got 1099511627776");
    expectClean("nebrender -i lit.vdb --integrator path --spp 1073741824 --res 32x32 -o x.exr", 2,
                "is 1.1e+12 random walks per frame; at most 1e+10");
    expectClean("nebrender -i lit.vdb --bands 1000000 --res 8x8 -o x.exr", 2,
                "--bands: expected an integer in [1, 4700]");
    expectClean("nebrender -i lit.vdb --spectral --continuum-step 1e-3 --res 8x8 -o x.exr", 2,
                "--continuum-step: expected a number in [0.1, 50]");
    expectClean("nebrender -i lit.vdb --spectral --continuum-step 1e-7 --res 8x8 -o x.exr", 2,
                "--continuum-step: expected a number in [0.1, 50]");
    writeText(path("path.json"), R"({"fps": 1, "keyframes": [
        {"time": 0, "eye": [0, 0, -6], "look_at": [0, 0, 0]},
        {"time": 4, "eye": [0, 1, -6], "look_at": [0, 0, 0]}]})");
    expectClean("nebrender -i lit.vdb --camera-path path.json --frames 1-1000000000 --res 8x8 "
                "-o 'f.####.exr'",
                2, "1000000000 frames; at most 1000000 frames in one range");
    expectClean("nebrender -i lit.vdb --camera-path path.json --frames 2-9:2 --res 8x8 "
                "-o 'f.####.exr'",
                2, "frame 6 is beyond the end of path.json, which has 5 frames");
    expectClean("nebphase --photons 10000000000 -o x.vdb", 2,
                "10000000000 photons per t; at most 1e+09");
    expectClean("nebphase --t-count 1000 --photons 1000000000 -o x.vdb", 2,
                "--t-count 1000 x 1000000000 photons per t is 1e+12 photons; at most 1e+11");
    expectClean("nebphase --slab --tau 1 --photons 100000000000", 2,
                "--photons must be in [1, 1e10] for --slab");
    expectClean("nebtone -i 'f.####.exr' --frames 1-1000000000 -o 'f.####.png'", 2,
                "at most 1000000 frames in one range");
}

// nebtone reads and checks every frame before it writes a PNG; an absurd white point in one
// frame's metadata does not darken the sequence; names end in .png; --skip-existing keeps
// only PNGs that decode.
TEST_F(Hardening, NebtoneSequencesAreAllOrNothing)
{
    makeLit();
    writeText(path("path.json"), R"({"fps": 4, "keyframes": [
        {"time": 0, "eye": [0, 0, -6], "look_at": [0, 0, 0]},
        {"time": 1, "eye": [0.5, 0, -6], "look_at": [0, 0, 0]}]})");
    ASSERT_EQ(run("mkdir e good d && nebrender -i lit.vdb --camera-path path.json --res 16x16 "
                  "--no-png -o 'e/f.####.exr'")
                  .code,
              0);
    ASSERT_EQ(run("nebtone -i 'e/f.####.exr' -o 'good/f.####.png'").code, 0);
    // An absurd white point in frame 3's metadata: a warning, the same PNGs.
    {
        std::map<std::string, std::string> attrs;
        const auto img = nebula::readExr(path("e/f.0003.exr"), &attrs);
        attrs["nebula:luminance"] = R"({"percentile":99.5,"white":1e308,"log_mean":1e308})";
        nebula::writeExr(path("e/f.0003.exr"), img, attrs);
    }
    Result r = run("nebtone -i 'e/f.####.exr' -o 'd/f.####.png'");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("e/f.0003.exr (frame 3): attribute nebula:luminance disagrees with "
                         "the pixels"),
              std::string::npos)
        << r.err;
    for (int f = 1; f <= 5; ++f) {
        const std::string name = "f.000" + std::to_string(f) + ".png";
        const auto good = pngPixels(path("good/" + name));
        ASSERT_FALSE(good.empty()) << name;
        EXPECT_EQ(pngPixels(path("d/" + name)), good) << name;
    }
    // A damaged frame 3: nothing written at all.
    fs::resize_file(path("e/f.0003.exr"), fs::file_size(path("e/f.0003.exr")) / 2);
    expectClean("nebtone -i 'e/f.####.exr' -o 'fresh.####.png'", 1, "f.0003.exr");
    // Output names end in .png.
    expectClean("nebtone -i 'good/f.####.exr' -o 'x.####.exr'", 2,
                "the name says EXR, but this output is PNG; name it *.png");
    // --skip-existing rewrites a truncated or empty PNG, keeps a whole one.
    ASSERT_EQ(run("rm e/f.0003.exr && mkdir k && nebtone -i 'e/f.####.exr' -o 'k/f.####.png'").code,
              0);
    fs::resize_file(path("k/f.0001.png"), fs::file_size(path("k/f.0001.png")) / 2);
    writeText(path("k/f.0002.png"), "");
    EXPECT_FALSE(nebula::pngReadsBack(path("k/f.0001.png")));
    EXPECT_FALSE(nebula::pngReadsBack(path("k/f.0002.png")));
    const auto whole = fs::last_write_time(path("k/f.0004.png"));
    r = run("nebtone -i 'e/f.####.exr' --skip-existing -o 'k/f.####.png' -v");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(nebula::pngReadsBack(path("k/f.0001.png")));
    EXPECT_TRUE(nebula::pngReadsBack(path("k/f.0002.png")));
    EXPECT_EQ(fs::last_write_time(path("k/f.0004.png")), whole);
    EXPECT_NE(r.err.find("wrote 2 frames"), std::string::npos) << r.err;
    // nebrender's --skip-existing re-renders a frame whose PNG does not decode whole.
    ASSERT_EQ(run("mkdir r && nebrender -i lit.vdb --camera-path path.json --res 16x16 "
                  "-o 'r/f.####.exr'")
                  .code,
              0);
    fs::resize_file(path("r/f.0002.png"), fs::file_size(path("r/f.0002.png")) - 20);
    r = run("nebrender -i lit.vdb --camera-path path.json --res 16x16 --skip-existing -v "
            "-o 'r/f.####.exr'");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(nebula::pngReadsBack(path("r/f.0002.png")));
    EXPECT_NE(r.err.find("4 of 5 frames existed and were skipped"), std::string::npos) << r.err;
}

// Two voxels a million voxels apart: a clear refusal naming the file, the grid and both
// sizes, before anything is allocated.
TEST_F(Hardening, FarApartVoxelsNameTheFileAndGrid)
{
    makeLit();
    {
        auto grids = read(path("small.vdb"));
        auto density = openvdb::FloatGrid::create(0.0f);
        density->setName("density");
        density->setTransform(grids.floatGrid("density", "")->transform().copy());
        density->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
        density->tree().setValue(openvdb::Coord(1000000, 1000000, 0), 1.0f);
        grids.replace(density);
        writeVdb(path("far.vdb"), grids.grids, grids.meta);
    }
    expectClean("nebillum -i far.vdb -o x.vdb", 1,
                "far.vdb: grid \"density\": the active voxels span 1000003 x 1000003 x 3 voxels");
    const Result r = run("nebillum -i far.vdb -o x.vdb");
    EXPECT_NE(r.err.find("of memory; this machine has"), std::string::npos) << r.err;
}

// A sweep of error cases across the tools: each exits non-zero with "tool: error: " and
// shows no library exception text, internal name or raw overflow.
TEST_F(Hardening, ErrorMessagesShowNoInternals)
{
    makeLit();
    writeText(path("types.json"), R"([{"name": 5, "position": "here", "luminosity": []}])");
    writeText(path("pathtypes.json"), R"({"fps": "fast", "keyframes": {"a": 1}})");
    writeText(path("pathwide.json"), R"({"fps": 1e308, "keyframes": [{"time": 0, "eye": [0,
        0, -6], "look_at": [0, 0, 0]}, {"time": 1e308, "eye": [0, 1, -6], "look_at": [0,
        0, 0]}]})");
    writeText(path("text.vdb"), "not a VDB\n");
    writeText(path("bad.toml"), "res = [1, 2\nseed = x\n");
    litWithMeta("checks.vdb", nebula::META_CHECKSUMS, "{\"algorithm\": [[[[1]]]]}");
    litWithMeta("dusttypes.vdb", nebula::META_DUST, R"({"kappa_V": "much", "albedo": null})");
    ASSERT_EQ(run("mkdir e && nebrender -i lit.vdb --res 8x8 --no-png -o e/f.0001.exr").code, 0);
    {
        std::map<std::string, std::string> attrs;
        const auto img = nebula::readExr(path("e/f.0001.exr"), &attrs);
        attrs["nebula:frame"] = R"({"fps": "twelve"})";
        nebula::writeExr(path("e/f.0001.exr"), img, attrs);
    }
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"nebillum -i nowhere.vdb -o x.vdb", "nowhere.vdb: cannot open file"},
        {"nebillum -i text.vdb -o x.vdb", "text.vdb: not a VDB file"},
        {"nebillum -i . -o x.vdb", ".: is a folder"},
        {"nebillum -i small.vdb --stars types.json -o x.vdb", "types.json: star 1"},
        {"nebrender -i lit.vdb --camera-path pathtypes.json --res 8x8 -o 'f.####.exr'",
         "pathtypes.json"},
        {"nebrender -i lit.vdb --camera-path pathwide.json --res 8x8 -o 'f.####.exr'",
         "pathwide.json"},
        {"nebgen --config bad.toml -o x.vdb", "bad.toml"},
        {"nebillum -i checks.vdb -o x.vdb", "checks.vdb"},
        {"nebillum -i dusttypes.vdb -o x.vdb", "dusttypes.vdb: metadata nebula:dust"},
        {"nebtone -i 'e/f.####.exr' -o 'p.####.png'", "e/f.0001.exr (frame 1): attribute "
                                                      "nebula:frame has fps \"twelve\""},
        {"nebrender -i lit.vdb --res 0x0 -o x.exr", "--res"},
        {"nebrender -i lit.vdb --res 99999999x99999999 -o x.exr", "--res"},
        {"nebscatter -i lit.vdb --threads -1 -o x.vdb", "--threads"},
        {"nebgen --res 100000 -o x.vdb", "--res"},
        {"nebtone -i 'e/f.####.exr' --frames 0-3 -o 'p.####.png'", "--frames"},
        {"nebillum -i small.vdb --star a:0,0,0:1e308:B3V -o x.vdb", "--star"},
    };
    for (const auto& [cmd, mention] : cases) {
        SCOPED_TRACE(cmd);
        const Result r = run("timeout 120 " + cmd);
        EXPECT_TRUE(r.code == 1 || r.code == 2) << r.code << ": " << r.err;
        EXPECT_NE(r.err.find("error: "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(mention), std::string::npos)
            << "expected \"" << mention << "\" in: " << r.err;
        for (const auto& bad : INTERNALS)
            EXPECT_EQ(r.err.find(bad), std::string::npos) << "shows \"" << bad << "\": " << r.err;
    }
}
