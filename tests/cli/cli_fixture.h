// SPDX-License-Identifier: Apache-2.0
#pragma once
// The end-to-end test fixture shared by the CLI test files: a fresh folder per test, the
// built tools on PATH, and helpers to run them and to check failures (exit code,
// message, no output left).
#include "nebula/io/grid_io.h"

#include <openvdb/openvdb.h>
#include <png.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace nebula::clitest {

namespace fs = std::filesystem;

inline const std::string TOOLS = NEBULA_TOOLS_DIR;

struct Result
{
    int code = -1;
    std::string err; ///< stderr
};

class Cli : public ::testing::Test
{
protected:
    void SetUp() override
    {
        openvdb::initialize();
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir = fs::path(::testing::TempDir()) /
              (std::string("nebula_cli_") + info->test_suite_name() + "_" + info->name());
        fs::remove_all(dir);
        fs::create_directories(dir);
    }
    void TearDown() override
    {
        if (!HasFailure()) fs::remove_all(dir);
    }

    std::string path(const std::string& name) const { return (dir / name).string(); }

    /// Runs a shell command line in the test folder; tool names are resolved to the build.
    Result run(const std::string& cmd) const
    {
        const std::string errFile = path("stderr.txt");
        const std::string full = "cd '" + dir.string() + "' && export PATH='" + TOOLS +
                                 "':$PATH && { " + cmd + " ; } 2> '" + errFile + "' < /dev/null";
        const int status = std::system(("bash -c \"" + escape(full) + "\"").c_str());
        Result r;
        r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        std::ifstream in(errFile);
        std::stringstream s;
        s << in.rdbuf();
        r.err = s.str();
        fs::remove(errFile);
        return r;
    }

    /// The folder's entries, sorted (to find leftovers such as temporaries).
    std::vector<std::string> entries() const
    {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir))
            names.push_back(e.path().filename());
        std::sort(names.begin(), names.end());
        return names;
    }

    /// The bytes of file @p name in the test folder ("" if it cannot be read).
    std::string fileBytes(const std::string& name) const
    {
        std::ifstream in(path(name), std::ios::binary);
        std::stringstream s;
        s << in.rdbuf();
        return s.str();
    }

    /// Small nebula + illumination used by many tests: small.vdb and lit.vdb.
    void makeLit()
    {
        ASSERT_EQ(run("nebgen --res 24 --seed 3 -o small.vdb").code, 0);
        ASSERT_EQ(run("nebillum -i small.vdb -o lit.vdb").code, 0);
    }

    /// Expects a failure with exit code @p code, a single "tool: error: " line mentioning
    /// @p mention, and no new file in the folder.
    void expectFailure(const std::string& cmd, int code, const std::string& mention)
    {
        const auto before = entries();
        const Result r = run(cmd);
        EXPECT_EQ(r.code, code) << cmd << "\n" << r.err;
        EXPECT_NE(r.err.find("error: "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(mention), std::string::npos)
            << "expected \"" << mention << "\" in: " << r.err;
        EXPECT_EQ(entries(), before) << "output or temporary left behind by: " << cmd;
    }

    static std::string escape(const std::string& s)
    {
        std::string o;
        for (char c : s) {
            if (c == '"' || c == '\\' || c == '$' || c == '`') o += '\\';
            o += c;
        }
        return o;
    }

    fs::path dir;
};

inline nebula::GridSet read(const std::string& p)
{
    return nebula::readGrids(p);
}

inline double maxValue(const openvdb::FloatGrid& g)
{
    double m = -1e300;
    for (auto it = g.cbeginValueOn(); it; ++it)
        m = std::max(m, double(*it));
    return m;
}

/// The RGBA pixels of an 8-bit or 16-bit PNG, as 8-bit RGBA (libpng's simplified API), and
/// its size; empty on failure.
inline std::vector<unsigned char> pngPixels(const std::string& p, int* width = nullptr,
                                            int* height = nullptr)
{
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    std::vector<unsigned char> pixels;
    if (!png_image_begin_read_from_file(&image, p.c_str())) return pixels;
    image.format = PNG_FORMAT_RGBA;
    pixels.resize(PNG_IMAGE_SIZE(image));
    if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) pixels.clear();
    if (width) *width = int(image.width);
    if (height) *height = int(image.height);
    return pixels;
}

/// Writes @p grids as another program would: with OpenVDB, and without nebula's checksums of
/// the contents it changed (README "Failure behaviour": a program that keeps them is refused).
inline void writeVdb(const std::string& p, openvdb::GridPtrVec grids, openvdb::MetaMap meta)
{
    meta.removeMeta(nebula::META_CHECKSUMS);
    openvdb::io::File f(p);
    f.write(grids, meta);
    f.close();
}

} // namespace nebula::clitest
