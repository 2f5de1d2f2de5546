// SPDX-License-Identifier: Apache-2.0
// Cubes from and to other programs: formats, units, the plane reader over an N-D array
// (DESIGN §10). The formats themselves: cube_fits.cpp, cube_hdf5.cpp, cube_npy.cpp,
// cube_radmc.cpp.
#include "cube_raw.h"

#include "nebula/core/error.h"
#include "nebula/core/file_format.h"
#include "nebula/core/memory.h"
#include "nebula/core/units.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <climits>
#include <sys/stat.h>

namespace nebula {

namespace {

std::string lower(std::string s)
{
    for (auto& c : s)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool endsWith(const std::string& s, const std::string& tail)
{
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

} // namespace

namespace detail {
// The formats, each defined in its own file. A new format: a line here and its entry below.
const CubeFormat& fitsCubeFormat();  // cube_fits.cpp
const CubeFormat& hdf5CubeFormat();  // cube_hdf5.cpp
const CubeFormat& npyCubeFormat();   // cube_npy.cpp
const CubeFormat& radmcCubeFormat(); // cube_radmc.cpp
} // namespace detail

const std::vector<const CubeFormat*>& cubeFormats()
{
    static const std::vector<const CubeFormat*> formats{
        &detail::fitsCubeFormat(), &detail::hdf5CubeFormat(), &detail::npyCubeFormat(),
        &detail::radmcCubeFormat()};
    return formats;
}

std::vector<std::string> cubeFormatNames(bool written)
{
    std::vector<std::string> names;
    for (const CubeFormat* f : cubeFormats())
        if (!written || f->write) names.push_back(f->name);
    return names;
}

std::string cubeFormatList(bool written)
{
    const auto names = cubeFormatNames(written);
    std::string list;
    for (std::size_t i = 0; i < names.size(); ++i)
        list += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
    return list;
}

std::string cubeFileNamesDoc()
{
    const auto& formats = cubeFormats();
    std::string doc;
    for (std::size_t i = 0; i < formats.size(); ++i)
        doc += (i == 0 ? "" : i + 1 == formats.size() ? ", or " : ", ") + formats[i]->doc;
    return doc;
}

const CubeFormat& cubeFormat(const std::string& name, const std::string& option)
{
    for (const CubeFormat* f : cubeFormats())
        if (f->name == name) return *f;
    throw UsageError(option + ": unknown format \"" + name + "\" (expected " +
                     cubeFormatList(false) + ")");
}

const CubeFormat* cubeFormatOf(const std::string& path)
{
    const std::string p = lower(path);
    const std::string base =
        p.substr(p.find_last_of('/') == std::string::npos ? 0 : p.find_last_of('/') + 1);
    for (const CubeFormat* f : cubeFormats()) {
        for (const auto& ending : f->endings)
            if (endsWith(p, ending)) return f;
        for (const auto& name : f->fileNames)
            if (base == name) return f;
    }
    struct stat st
    {
    };
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
        for (const CubeFormat* f : cubeFormats())
            if (f->folder) return f;
    }
    return nullptr;
}

std::optional<double> lengthUnitPc(const std::string& unit)
{
    const std::string u = lower(unit);
    if (u == "pc" || u == "parsec") return 1.0;
    if (u == "kpc") return KPC_CM / PC_CM;
    if (u == "au") return AU_CM / PC_CM;
    if (u == "cm") return 1.0 / PC_CM;
    if (u == "m") return 1e2 / PC_CM;
    if (u == "km") return 1e5 / PC_CM;
    return std::nullopt;
}

std::optional<DensityUnit> parseDensityUnit(const std::string& text)
{
    // Spelling does not matter: case, blanks, '^', '**', '.' and '*' (products) go.
    std::string u;
    const std::string l = lower(text);
    for (std::size_t i = 0; i < l.size(); ++i) {
        const char c = l[i];
        if (c == ' ' || c == '\t' || c == '^' || c == '*' || c == '.' || c == '(' || c == ')') {
            continue;
        }
        u += c;
    }
    if (u.empty()) return std::nullopt;
    for (const char* s : {"cm-3", "1/cm3", "/cm3", "cm-3h", "h/cm3", "n_h/cm3", "ncm-3"}) {
        if (u == s) return DensityUnit::NumberDensity;
    }
    for (const char* s : {"g/cm3", "gcm-3"}) {
        if (u == s) return DensityUnit::GasMass;
    }
    for (const char* s : {"g/cm3-dust", "gcm-3-dust", "g/cm3dust", "gcm-3dust"}) {
        if (u == s) return DensityUnit::DustMass;
    }
    for (const char* s : {"msun/pc3", "msunpc-3", "solmass/pc3", "solmasspc-3", "m_sun/pc3"}) {
        if (u == s) return DensityUnit::SolarMass;
    }
    return std::nullopt;
}

std::string densityUnitName(DensityUnit unit)
{
    switch (unit) {
    case DensityUnit::NumberDensity: return "cm-3";
    case DensityUnit::GasMass: return "g/cm3";
    case DensityUnit::DustMass: return "g/cm3-dust";
    case DensityUnit::SolarMass: return "Msun/pc3";
    }
    return "?";
}

double densityToNH(DensityUnit unit, double mu, double dustToGas)
{
    switch (unit) {
    case DensityUnit::NumberDensity: return 1.0;
    case DensityUnit::GasMass: return 1.0 / (mu * M_H_G);
    case DensityUnit::DustMass: return 1.0 / (dustToGas * mu * M_H_G);
    case DensityUnit::SolarMass: return MSUN_PC3_G_CM3 / (mu * M_H_G);
    }
    return 0.0;
}

namespace detail {

void checkCubeShape(const std::vector<std::int64_t>& shape, int component, const std::string& name)
{
    std::string text;
    for (std::size_t i = 0; i < shape.size(); ++i)
        text += (i ? " x " : "") + std::to_string(shape[i]);
    const std::size_t want = component >= 0 ? 4 : 3;
    if (shape.size() != want && !(component >= 0 && shape.size() == 3)) {
        std::string what = shape.size() == 2 ? "a 2-D image (" + text + ")"
                           : shape.empty()   ? "no data"
                                             : std::to_string(shape.size()) + "-D (" + text + ")";
        throw Error(name + ": is " + what + ", expected a 3-D cube" +
                    (component >= 0 ? " (or 4-D with a first or last axis of 3)" : ""));
    }
    double voxels = shape.size() == 4 ? 1.0 / 3.0 : 1.0; // a vector's 3 components
    for (auto n : shape)
        voxels *= double(n);
    if (voxels > double(MAX_CUBE_VOXELS)) {
        throw Error(name + ": " + text +
                    fmt::format(" is {:.3g} voxels; a cube may have at most 2^36 ({:.3g}, "
                                "4096^3): reading more would take hours",
                                voxels, double(MAX_CUBE_VOXELS)));
    }
    for (auto n : shape) {
        if (n < 1 || n > INT_MAX) {
            throw Error(name + ": axis lengths " + text + ": each must be 1 to " +
                        std::to_string(INT_MAX));
        }
    }
}

namespace {

class ArrayCube final : public CubeSource
{
public:
    ArrayCube(std::unique_ptr<RawArray> array, CubeInfo info, int component)
        : mArray(std::move(array))
    {
        mInfo = std::move(info);
        const auto shape = mArray->shape();
        const int nd = int(shape.size());
        checkCubeShape(shape, component, mInfo.name);
        mComp = -1;
        if (nd == 4) {
            const bool first = shape[0] == 3, last = shape[3] == 3;
            if (first == last) {
                throw Error(
                    mInfo.name + ": a 4-D array needs exactly one end axis of length 3 " +
                    "(the vector's components); it has " +
                    fmt::format("{} x {} x {} x {}", shape[0], shape[1], shape[2], shape[3]));
            }
            mComp = first ? 0 : 3;
            mComponent = component;
        } else if (component >= 0) {
            throw Error(mInfo.name +
                        ": a 3-D array, expected a 4-D vector field (or give three files)");
        }
        // Spatial axes of the array and nebula's axis each is.
        std::vector<int> storage(static_cast<std::size_t>(nd));
        for (int i = 0; i < nd; ++i)
            storage[std::size_t(i)] = mArray->firstFastest() ? nd - 1 - i : i;
        const auto spatial = [&](int a) { return a - (mComp == 0 ? 1 : 0); };
        for (int a = 0, s = 0; a < nd; ++a) {
            if (a != mComp) mInfo.dims[std::size_t(s++)] = shape[std::size_t(a)];
        }
        // The plane axis: the slowest spatial axis in the file.
        std::size_t p = 0;
        while (storage[p] == mComp)
            ++p;
        mFixedAxes.assign(storage.begin(), storage.begin() + std::ptrdiff_t(p) + 1);
        std::vector<int> rest(storage.begin() + std::ptrdiff_t(p) + 1, storage.end());
        mStride = 1;
        if (!rest.empty() && rest.back() == mComp) {
            mStride = 3;
            rest.pop_back();
        }
        mInfo.planeAxis = spatial(storage[p]);
        mInfo.slowAxis = spatial(rest[0]);
        mInfo.fastAxis = spatial(rest[1]);
        requireMemory(double(mInfo.planeSize()) * double(mStride) * 8.0 * 2.0,
                      mInfo.name + ": a plane of the cube");
        if (mStride > 1) mBlock.resize(std::size_t(mInfo.planeSize()) * 3);
    }

    void readPlane(std::int64_t k, double* out) override
    {
        std::vector<std::int64_t> fixed;
        for (int a : mFixedAxes)
            fixed.push_back(a == mComp ? mComponent : k);
        if (mStride == 1) {
            mArray->readBlock(fixed, out);
            return;
        }
        mArray->readBlock(fixed, mBlock.data());
        const std::size_t n = std::size_t(mInfo.planeSize());
        for (std::size_t i = 0; i < n; ++i)
            out[i] = mBlock[i * 3 + std::size_t(mComponent)];
    }

private:
    std::unique_ptr<RawArray> mArray;
    int mComp = -1, mComponent = 0;
    std::vector<int> mFixedAxes;
    int mStride = 1;
    std::vector<double> mBlock;
};

} // namespace

std::unique_ptr<CubeSource> arrayCube(std::unique_ptr<RawArray> array, CubeInfo info, int component)
{
    return std::make_unique<ArrayCube>(std::move(array), std::move(info), component);
}

} // namespace detail

std::unique_ptr<CubeSource> openCube(const std::string& path, const CubeSelect& select)
{
    const CubeFormat* format = select.format ? select.format : cubeFormatOf(path);
    if (!format) {
        std::string hints;
        for (const CubeFormat* f : cubeFormats())
            hints += (hints.empty() ? "" : ", ") + f->hint;
        throw UsageError(select.option + ": " + path + ": cannot tell the format from the name (" +
                         hints + ")" + (select.option == "-i" ? "; give --format" : ""));
    }
    return format->open(path, select);
}

void writeCube(const CubeFormat& format, const std::string& path, const CubeHeader& header,
               const std::string& dataset, const PlaneFunction& plane)
{
    if (!format.write)
        throw UsageError(path + ": nebexport does not write " + format.title + " files");
    checkOutputName(path, "-o", *format.fileFormat);
    format.write(path, header, dataset, plane);
}

} // namespace nebula
