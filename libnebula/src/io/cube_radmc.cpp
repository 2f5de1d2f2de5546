// SPDX-License-Identifier: Apache-2.0
// RADMC-3D regular grids (DESIGN §10): amr_grid.inp (style 0, cartesian) with
// dust_density.inp (ASCII) or dust_density.binp (binary, 4- or 8-byte values), one dust
// species, dust mass density [g cm^-3] in cells whose walls are in cm. Cells of unequal
// widths are resampled to the finest width (each voxel takes the cell its centre lies in).
#include "cube_raw.h"

#include "nebula/core/error.h"
#include "nebula/core/input.h"
#include "nebula/core/memory.h"
#include "nebula/core/units.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sys/stat.h>

namespace nebula {

namespace {

/// Numbers in RADMC-3D's ASCII files: white space between them, Fortran's 1.0d-3 allowed.
class NumberReader
{
public:
    NumberReader(std::string_view text, std::string name) : mText(text), mName(std::move(name)) {}

    bool next(double& value)
    {
        while (mPos < mText.size() && std::strchr(" \t\r\n", mText[mPos]))
            ++mPos;
        if (mPos >= mText.size()) return false;
        std::size_t end = mPos;
        while (end < mText.size() && !std::strchr(" \t\r\n", mText[end]))
            ++end;
        std::string word(mText.substr(mPos, end - mPos));
        for (auto& c : word) {
            if (c == 'd' || c == 'D') c = 'e';
        }
        const char* b = word.data() + (word[0] == '+' ? 1 : 0);
        const char* e = word.data() + word.size();
        const auto r = std::from_chars(b, e, value);
        if (r.ec != std::errc() || r.ptr != e) {
            throw Error(mName + ": \"" + word.substr(0, 40) + "\" at byte " + std::to_string(mPos) +
                        " is not a number");
        }
        mPos = end;
        return true;
    }
    double number(const char* what)
    {
        double v = 0.0;
        if (!next(v)) throw Error(mName + ": ends before " + what);
        return v;
    }
    std::int64_t integer(const char* what, std::int64_t lo, std::int64_t hi)
    {
        const double v = number(what);
        if (!(v >= double(lo) && v <= double(hi)) || v != std::floor(v)) {
            throw Error(mName + ": " + what +
                        fmt::format(" is {}, expected an integer in [{}, {}]", v, lo, hi));
        }
        return std::int64_t(v);
    }
    std::size_t pos() const { return mPos; }
    void seek(std::size_t pos) { mPos = pos; }

private:
    std::string_view mText;
    std::string mName;
    std::size_t mPos = 0;
};

constexpr std::int64_t MAX_CELLS = std::int64_t(1) << 31;

} // namespace

RadmcGrid parseRadmcGrid(std::string_view text, const std::string& name)
{
    NumberReader r(text, name);
    RadmcGrid g;
    const auto iformat = r.integer("the format number", 0, 1000000);
    if (iformat != 1) {
        throw Error(name + ": format number " + std::to_string(iformat) + ", expected 1");
    }
    const auto style = r.integer("the grid style", 0, 1000000);
    if (style != 0) {
        throw Error(name + ": grid style " + std::to_string(style) +
                    " (an AMR or octree grid), expected 0 (a regular grid)");
    }
    const auto coord = r.integer("the coordinate system", 0, 1000000);
    if (coord >= 100) {
        throw Error(name + ": coordinate system " + std::to_string(coord) +
                    " is spherical or cylindrical; only cartesian grids (< 100) are cubes");
    }
    r.integer("gridinfo", 0, 1000000);
    for (int i = 0; i < 3; ++i)
        r.integer("the incl_x, incl_y, incl_z flags", 0, 1);
    for (std::size_t i = 0; i < 3; ++i)
        g.cells[i] = r.integer("the cell counts", 1, MAX_CELLS - 1);
    if (double(g.cells[0]) * double(g.cells[1]) * double(g.cells[2]) > 9e15) {
        throw Error(name + ": too many cells");
    }
    static const char* const WALLS[3] = {"the x walls", "the y walls", "the z walls"};
    for (std::size_t i = 0; i < 3; ++i) {
        // Walls are read one by one: a count larger than the text is not allocated.
        auto& w = g.walls[i];
        for (std::int64_t k = 0; k <= g.cells[i]; ++k) {
            const double v = r.number(WALLS[i]);
            if (!std::isfinite(v) || (!w.empty() && !(v > w.back()))) {
                throw Error(name + ": " + WALLS[i] + " must be finite and increase (wall " +
                            std::to_string(k) + " is " + fmt::format("{}", v) + ")");
            }
            w.push_back(v);
        }
    }
    return g;
}

RadmcDataHeader parseRadmcDataHeader(std::string_view bytes, bool binary, const std::string& name)
{
    RadmcDataHeader h;
    if (binary) {
        if (bytes.size() < 32) throw Error(name + ": truncated: no 32-byte header");
        std::int64_t v[4];
        std::memcpy(v, bytes.data(), 32);
        if (v[0] != 1)
            throw Error(name + ": format number " + std::to_string(v[0]) + ", expected 1");
        if (v[1] != 4 && v[1] != 8) {
            throw Error(name + ": precision " + std::to_string(v[1]) + ", expected 4 or 8 bytes");
        }
        if (v[2] < 1 || v[2] >= (std::int64_t(1) << 50) || v[3] < 1 || v[3] > 100000) {
            throw Error(name + fmt::format(": {} cells of {} species: bad counts", v[2], v[3]));
        }
        h.precision = int(v[1]);
        h.cells = v[2];
        h.species = v[3];
        h.dataOffset = 32;
        const double need = 32.0 + double(h.cells) * double(h.species) * double(h.precision);
        if (need > double(bytes.size())) {
            throw Error(name + fmt::format(": truncated: the header says {} cells of {} species "
                                           "({} bytes), the file has {} bytes",
                                           h.cells, h.species, need, bytes.size()));
        }
        return h;
    }
    NumberReader r(bytes, name);
    const auto iformat = r.integer("the format number", 0, 1000000);
    if (iformat != 1)
        throw Error(name + ": format number " + std::to_string(iformat) + ", expected 1");
    h.cells = r.integer("the cell count", 1, (std::int64_t(1) << 50) - 1);
    h.species = r.integer("the species count", 1, 100000);
    h.precision = 0;
    h.dataOffset = r.pos();
    // Each value takes a character and a separator at least: a header that promises more
    // than the text can hold is truncated (and its counts cannot overflow a later product).
    const double values = double(h.cells) * double(h.species);
    if (2.0 * values - 1.0 > double(bytes.size() - h.dataOffset)) {
        throw Error(name + fmt::format(": truncated: the header says {} cells of {} species, "
                                       "more values than the {} bytes after it can hold",
                                       h.cells, h.species, bytes.size() - h.dataOffset));
    }
    return h;
}

namespace detail {

namespace {

/// Reads an optional file's bytes (mapped).
InputBytes mapFile(const std::string& path, const std::string& option)
{
    InputSpec spec;
    spec.option = option;
    spec.format = "a RADMC-3D file";
    spec.limit = MAX_GRID_INPUT_BYTES;
    return mapInput(path, spec);
}

bool exists(const std::string& path)
{
    struct stat st
    {
    };
    return ::stat(path.c_str(), &st) == 0;
}

class RadmcCube final : public CubeSource
{
public:
    RadmcCube(RadmcGrid grid, InputBytes data, RadmcDataHeader h, bool binary, int species,
              std::string name)
        : mGrid(std::move(grid)), mData(std::move(data)), mH(h), mBinary(binary),
          mReader(mData.view(), name)
    {
        mInfo.name = name;
        mInfo.unit = "g/cm3-dust"; // RADMC-3D's dust_density is a dust mass density
        const std::int64_t cells = mGrid.cells[0] * mGrid.cells[1] * mGrid.cells[2];
        if (h.cells != cells) {
            throw Error(name + fmt::format(": {} cells, but amr_grid.inp has {} x {} x {} = {}",
                                           h.cells, mGrid.cells[0], mGrid.cells[1], mGrid.cells[2],
                                           cells));
        }
        if (species < 1 || species > h.species) {
            throw UsageError(fmt::format("--species {}: {} has {} dust species (1 to {})", species,
                                         name, h.species, h.species));
        }
        mSpecies = species;
        geometry();
        mInfo.planeAxis = 2;
        mInfo.fastAxis = 0;
        mInfo.slowAxis = 1;
        requireMemory(double(mGrid.cells[0] * mGrid.cells[1]) * 8.0 +
                          double(mInfo.planeSize()) * 8.0,
                      name + ": a plane of the cube");
        mCellPlane.resize(std::size_t(mGrid.cells[0] * mGrid.cells[1]));
        if (!mBinary) {
            // Skip the species before ours.
            mReader.seek(mH.dataOffset);
            double v;
            for (std::int64_t i = 0; i < cells * (species - 1); ++i) {
                if (!mReader.next(v)) truncated(i);
            }
        }
    }

    void readPlane(std::int64_t k, double* out) override
    {
        const std::int64_t iz = mMap[2][std::size_t(k)];
        while (mPlane < iz)
            loadCellPlane();
        const std::int64_t nx = mInfo.dims[0], ny = mInfo.dims[1], cx = mGrid.cells[0];
        for (std::int64_t y = 0; y < ny; ++y) {
            const std::int64_t iy = mMap[1][std::size_t(y)];
            for (std::int64_t x = 0; x < nx; ++x)
                out[y * nx + x] = mCellPlane[std::size_t(iy * cx + mMap[0][std::size_t(x)])];
        }
    }

private:
    /// Spacing and origin; the voxel -> cell maps, resampled where the widths differ.
    void geometry()
    {
        double finest = HUGE_VAL;
        bool uniform = true;
        std::array<double, 3> width{};
        for (std::size_t a = 0; a < 3; ++a) {
            const auto& w = mGrid.walls[a];
            width[a] = (w.back() - w.front()) / double(mGrid.cells[a]);
            for (std::size_t i = 1; i < w.size(); ++i) {
                const double d = w[i] - w[i - 1];
                finest = std::min(finest, d);
                if (std::abs(d - width[a]) > 1e-6 * width[a]) uniform = false;
            }
        }
        for (std::size_t a = 1; a < 3; ++a) {
            if (std::abs(width[a] - width[0]) > 1e-6 * width[0]) uniform = false;
        }
        const double h = uniform ? width[0] : finest; // [cm]
        CubeGeometry g;
        std::array<double, 3> origin{};
        for (std::size_t a = 0; a < 3; ++a) {
            const auto& w = mGrid.walls[a];
            const double n = uniform ? double(mGrid.cells[a])
                                     : std::max(1.0, std::round((w.back() - w.front()) / h));
            if (n > double(MAX_CELLS - 1)) {
                throw Error(mInfo.name + ": resampling to the finest cell width would need " +
                            fmt::format("{}", n) + " voxels along an axis");
            }
            mInfo.dims[a] = std::int64_t(n);
            g.spacing[a] = h / PC_CM;
            origin[a] = (w.front() + 0.5 * h) / PC_CM;
            mMap[a].resize(std::size_t(n));
            for (std::int64_t i = 0; i < std::int64_t(n); ++i) {
                if (uniform) {
                    mMap[a][std::size_t(i)] = i;
                    continue;
                }
                const double c = w.front() + (double(i) + 0.5) * h;
                const auto it = std::upper_bound(w.begin(), w.end(), c);
                const std::int64_t cell = std::int64_t(it - w.begin()) - 1;
                mMap[a][std::size_t(i)] = std::clamp<std::int64_t>(cell, 0, mGrid.cells[a] - 1);
            }
        }
        g.origin = origin;
        mInfo.geometry = g;
        if (!uniform) {
            mInfo.warnings.push_back(fmt::format(
                "{}: the cells are not equal cubes ({} x {} x {} cells); resampled to {} x {} x "
                "{} voxels of the finest width, {} pc (each voxel takes the cell its centre is in)",
                mInfo.name, mGrid.cells[0], mGrid.cells[1], mGrid.cells[2], mInfo.dims[0],
                mInfo.dims[1], mInfo.dims[2], h / PC_CM));
        }
        const double voxels = double(mInfo.dims[0]) * double(mInfo.dims[1]) * double(mInfo.dims[2]);
        if (voxels > 9e15) throw Error(mInfo.name + ": too many voxels");
    }

    [[noreturn]] void truncated(std::int64_t read) const
    {
        throw Error(mInfo.name + fmt::format(": truncated: expected {} values ({} cells x {} "
                                             "species), the file ends after {}",
                                             double(mH.cells) * double(mH.species), mH.cells,
                                             mH.species, read));
    }

    /// The next z plane of cells into mCellPlane.
    void loadCellPlane()
    {
        ++mPlane;
        const std::int64_t n = mGrid.cells[0] * mGrid.cells[1];
        if (mBinary) {
            const std::size_t first =
                mH.dataOffset +
                std::size_t(((mSpecies - 1) * mH.cells + mPlane * n) * mH.precision);
            const char* p = mData.view().data() + first;
            for (std::int64_t i = 0; i < n; ++i) {
                if (mH.precision == 4) {
                    float f;
                    std::memcpy(&f, p + 4 * i, 4);
                    mCellPlane[std::size_t(i)] = f;
                } else {
                    std::memcpy(&mCellPlane[std::size_t(i)], p + 8 * i, 8);
                }
            }
            mData.release(first, first + std::size_t(n * mH.precision));
            return;
        }
        for (std::int64_t i = 0; i < n; ++i) {
            if (!mReader.next(mCellPlane[std::size_t(i)])) {
                truncated((mSpecies - 1) * mH.cells + mPlane * n + i);
            }
        }
    }

    RadmcGrid mGrid;
    InputBytes mData;
    RadmcDataHeader mH;
    bool mBinary;
    NumberReader mReader;
    int mSpecies = 1;
    std::int64_t mPlane = -1; ///< the cell plane in mCellPlane
    std::vector<double> mCellPlane;
    std::array<std::vector<std::int64_t>, 3> mMap; ///< voxel -> cell per axis
};

} // namespace

std::unique_ptr<CubeSource> openRadmcCube(const std::string& path, const CubeSelect& select)
{
    if (select.component >= 0) {
        throw UsageError(select.option + ": " + path + ": RADMC-3D velocities are not read");
    }
    struct stat st
    {
    };
    const bool folder = ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
    const std::string dir = folder ? path
                            : path.find('/') == std::string::npos
                                ? std::string(".")
                                : path.substr(0, path.find_last_of('/'));
    const std::string base = folder ? "" : path.substr(path.find_last_of('/') + 1);
    std::string data;
    if (base == "dust_density.inp" || base == "dust_density.binp") {
        data = path;
    } else if (exists(dir + "/dust_density.binp")) {
        data = dir + "/dust_density.binp";
    } else if (exists(dir + "/dust_density.inp")) {
        data = dir + "/dust_density.inp";
    } else {
        throw Error(path + ": no dust_density.binp or dust_density.inp in " + dir);
    }
    const std::string gridPath = dir + "/amr_grid.inp";
    InputSpec spec;
    spec.option = select.option;
    spec.format = "a RADMC-3D amr_grid.inp";
    spec.limit = MAX_TEXT_INPUT_BYTES * 64;
    spec.head = textHead();
    RadmcGrid grid = parseRadmcGrid(readInput(gridPath, spec), gridPath);
    const bool binary = data.size() > 5 && data.compare(data.size() - 5, 5, ".binp") == 0;
    InputBytes bytes = mapFile(data, select.option);
    const RadmcDataHeader h = parseRadmcDataHeader(bytes.view(), binary, data);
    return std::make_unique<RadmcCube>(std::move(grid), std::move(bytes), h, binary, select.species,
                                       data);
}

const CubeFormat& radmcCubeFormat()
{
    static const CubeFormat format = [] {
        CubeFormat f;
        f.name = "radmc";
        f.title = "RADMC-3D";
        f.doc = "a RADMC-3D folder or its amr_grid.inp";
        f.hint = "a RADMC-3D folder or amr_grid.inp";
        f.fileNames = {"amr_grid.inp", "dust_density.inp", "dust_density.binp"};
        f.folder = true;
        f.open = openRadmcCube;
        return f;
    }();
    return format;
}

} // namespace detail
} // namespace nebula
