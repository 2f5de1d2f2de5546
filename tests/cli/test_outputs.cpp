// SPDX-License-Identifier: Apache-2.0
// The one output check (docs/failures.md, "Outputs that are inputs, or another format"):
// every tool compares every output it will write (each option marked an output, and the
// outputs it derives, such as nebrender's PNG) with every other output and every input (each
// option marked an input, and the files inside nebimport's FILE:HDU and FX,FY,FZ values), by
// inode and by normalised name, before any work; and each output's name must end as its
// format's names do.
#include "cli_fixture.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

using namespace nebula::clitest;

class Outputs : public Cli
{
protected:
    /// expectFailure(), and the files @p kept keep their bytes.
    void expectRefused(const std::string& cmd, int code, const std::string& mention,
                       const std::vector<std::string>& kept)
    {
        std::vector<std::string> before;
        for (const auto& f : kept)
            before.push_back(fileBytes(f));
        expectFailure(cmd, code, mention);
        for (std::size_t i = 0; i < kept.size(); ++i)
            EXPECT_EQ(fileBytes(kept[i]), before[i]) << kept[i] << " changed by: " << cmd;
    }
};

// nebrender's --fits and --sed joined the check: naming the scene, another output or the
// filter file is refused before the render, and the file keeps its bytes.
TEST_F(Outputs, NebrenderComparesEveryOutputWithEveryInput)
{
    makeLit();
    const std::string render = "nebrender -i lit.vdb --res 8x8 -o a.exr ";
    expectRefused(render + "--sed lit.vdb", 2, "--sed lit.vdb is the input -i lit.vdb",
                  {"lit.vdb"});
    expectRefused(render + "--fits lit.vdb", 2, "--fits lit.vdb is the input -i lit.vdb",
                  {"lit.vdb"});
    expectRefused(render + "--fits ./a.exr", 2, "are the same file", {});
    expectRefused(render + "--png b.png --sed b.png", 2, "are the same file", {});
    // The PNG the EXR's name gives is an output too.
    expectRefused(render + "--sed s.csv --fits a.png", 2, "--fits a.png", {});
    run("ln -s a.png link.fits"); // dangling: a.png is yet to be written
    expectRefused(render + "--fits link.fits", 2, "are the same file", {});
    std::ofstream(path("band.csv")) << "500,0\n550,1\n600,0\n";
    expectRefused(render + "--filter-file band.csv --sed band.csv", 2,
                  "--sed band.csv is the input --filter-file band.csv", {"band.csv"});
    std::ofstream(path("path.json")) << "{}";
    expectRefused(render + "--camera-path path.json --sed path.json", 2,
                  "--sed path.json is the input --camera-path path.json", {"path.json"});
    // A hard link is the same file under another name.
    run("ln lit.vdb hard.csv");
    expectRefused(render + "--sed hard.csv", 2, "--sed hard.csv is the input -i lit.vdb",
                  {"lit.vdb"});
}

// nebimport's -o against the files inside --emission FILE[:HDU], --temperature and each of
// --velocity FX,FY,FZ (a hard link gives the output name a .vdb ending).
TEST_F(Outputs, NebimportComparesTheOutputWithEveryCube)
{
    // Debian's python3, which has numpy (a version manager's may come first on PATH).
    ASSERT_EQ(run("/usr/bin/python3 -c 'import numpy as np; "
                  "[np.save(n, np.ones((4, 4, 4), np.float32)) for n in "
                  "(\"d.npy\", \"e.npy\", \"t.npy\", \"vx.npy\", \"vy.npy\", \"vz.npy\")]'")
                  .code,
              0);
    run("ln e.npy e.vdb && ln t.npy t.vdb && ln vz.npy vz.vdb");
    const std::string import = "nebimport -i d.npy --voxel-size 0.1pc --unit cm-3 ";
    expectRefused(import + "--emission e.npy -o e.vdb", 2, "is the input --emission e.npy",
                  {"e.npy"});
    expectRefused(import + "--temperature t.npy -o t.vdb", 2, "is the input --temperature t.npy",
                  {"t.npy"});
    expectRefused(import + "--velocity vx.npy,vy.npy,vz.npy -o vz.vdb", 2,
                  "is the input --velocity vz.npy", {"vz.npy"});
    // The input is checked too, and a good run still works.
    run("ln d.npy d.vdb");
    expectRefused(import + "-o d.vdb", 2, "is the input -i d.npy", {"d.npy"});
    EXPECT_EQ(run(import + "--emission e.npy --emission-unit Lsun/pc3/sr -o ok.vdb").code, 0);
}

// A name that says another format is refused before any work, naming both formats; "-",
// FIFOs and devices (--write-through) have no name to keep.
TEST_F(Outputs, NamesEndAsTheirFormat)
{
    makeLit();
    expectRefused("nebillum -i small.vdb -o out.fits", 2,
                  "-o out.fits: the name says FITS, but this output is VDB; name it *.vdb", {});
    expectRefused("nebgen --res 8 -o cloud", 2, "the name has no ending", {});
    expectRefused("nebgen --res 8 -o cloud.vdb.tmp", 2, "the name ends in \".tmp\"", {});
    expectRefused("nebrender -i lit.vdb --res 8x8 -o a.png", 2, "but this output is EXR", {});
    expectRefused("nebrender -i lit.vdb --res 8x8 -o a.exr --sed s.fits", 2,
                  "--sed s.fits: the name says FITS, but this output is CSV", {});
    expectRefused("nebrender -i lit.vdb --res 8x8 -o a.exr --fits s.npy", 2,
                  "--fits s.npy: the name says NumPy .npy, but this output is FITS", {});
    expectRefused("nebexport -i small.vdb -o d.npy --format fits", 2,
                  "-o d.npy: the name says NumPy .npy, but this output is FITS", {});
    expectRefused("nebphase -o t.vdb --t-count 2 --mu-bins 4 --photons 100 --json t.txt", 2,
                  "--json t.txt", {});
    expectRefused("nebtone -i 'f.####.exr' -o 'g.####.jpg'", 2, "but this output is PNG", {});
    // Upper case endings are the same endings; "-" and a device are no names.
    EXPECT_EQ(run("nebgen --res 8 -o CLOUD.VDB").code, 0);
    EXPECT_EQ(run("nebgen --res 8 -o - > piped.bin").code, 0);
    EXPECT_EQ(run("nebgen --res 8 --write-through -o /dev/null").code, 0);
    // nebula writes no gzip-compressed FITS: a .gz name would hold uncompressed bytes.
    expectRefused("nebexport -i small.vdb -o d.fits.gz --format fits", 2,
                  "-o d.fits.gz: the name ends in \".gz\", but this output is FITS; name it "
                  "*.fits, *.fit, *.fts",
                  {});
}

// Progress in a log (issue 47): with stderr not a terminal (here a file) and -v, a tool
// writes its progress as lines, one each time the work passes a multiple of 5 % (or 30 s
// after the last), rising, below 100 %, and one when done; without -v, none. Every tool with
// long work does: nebscatter, nebrender (its rows weighed by their work: a dome master's
// sky and cloud), nebillum, nebexport and nebimport.
TEST_F(Cli, ProgressIsWrittenAsLinesToALogUnderVerbose)
{
    makeLit();
    struct Lines
    {
        int steps = 0, done = 0;
        bool rising = true;
    };
    // The progress lines of @p tool ("tool ...: 35 % after 1 s", "tool ...: done in 2 s").
    const auto linesOf = [&](const std::string& tool) {
        std::ifstream file(path("log.txt"));
        const std::string text((std::istreambuf_iterator<char>(file)),
                               std::istreambuf_iterator<char>());
        EXPECT_EQ(text.find('\r'), std::string::npos) << tool; // no bar drawn
        std::istringstream in(text);
        std::string line;
        Lines l;
        int last = -1;
        while (std::getline(in, line)) {
            if (line.rfind(tool, 0) != 0) continue;
            const auto colon = line.find(": ");
            if (colon == std::string::npos) continue;
            const std::string rest = line.substr(colon + 2);
            if (rest.rfind("done in ", 0) == 0) {
                ++l.done;
                last = -1;
            } else if (rest.find(" % after ") != std::string::npos) {
                const int pct = std::stoi(rest);
                l.rising = l.rising && pct > last && pct < 100;
                last = pct;
                ++l.steps;
            }
        }
        return l;
    };
    ASSERT_EQ(run("nebscatter -i lit.vdb --packets 20000 -o f.vdb -v 2> log.txt").code, 0);
    Lines l = linesOf("nebscatter ");
    EXPECT_GE(l.done, 1);
    EXPECT_GE(l.steps, 10); // at least every 5 % of one source's packets, less a few skipped
    EXPECT_TRUE(l.rising);
    const Result quiet = run("nebscatter -i lit.vdb --packets 20000 -o g.vdb");
    ASSERT_EQ(quiet.code, 0);
    EXPECT_EQ(quiet.err.find(" % after "), std::string::npos) << quiet.err;
    for (const auto& [cmd, tool] : std::vector<std::pair<std::string, std::string>>{
             {"nebrender -i f.vdb --camera fisheye --dome-tilt 30 --frame-nebula --res 128x128 "
              "--no-png -o d.exr",
              "nebrender:"},
             {"nebrender -i lit.vdb --spectral --res 32x32 --no-png -o s.exr", "nebrender:"},
             {"nebrender -i lit.vdb --integrator path --spp 2 --res 32x32 --no-png -o p.exr",
              "nebrender path:"},
             {"nebillum -i small.vdb -o lit2.vdb", "nebillum "},
             {"nebexport -i small.vdb -o d.npy", "nebexport d.npy:"},
             {"nebimport -i d.npy --unit cm-3 --voxel-size 0.1pc -o back.vdb", "nebimport "}}) {
        const Result r = run(cmd + " -v 2> log.txt");
        ASSERT_EQ(r.code, 0) << cmd;
        l = linesOf(tool);
        EXPECT_GE(l.done, 1) << cmd;
        EXPECT_TRUE(l.rising) << cmd;
    }
}
