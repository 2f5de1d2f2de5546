// HDF5 cubes (DESIGN §10), through the C API: a dataset read in x planes as h5py indexes it
// (f[path][x, y, z], C order), its attributes units/unit, voxel_size_pc and origin_pc; cubes
// written in memory (the core driver) and handed to AtomicFile.
#include "cube_raw.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"

#include <hdf5.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <sys/stat.h>

namespace nebula::detail {

namespace {

/// An HDF5 identifier closed by its own function.
class Hid
{
public:
    Hid() = default;
    Hid(hid_t id, herr_t (*close)(hid_t)) : mId(id), mClose(close) {}
    Hid(Hid&& o) noexcept : mId(o.mId), mClose(o.mClose) { o.mId = -1; }
    Hid& operator=(Hid&& o) noexcept
    {
        std::swap(mId, o.mId);
        std::swap(mClose, o.mClose);
        return *this;
    }
    Hid(const Hid&) = delete;
    Hid& operator=(const Hid&) = delete;
    ~Hid()
    {
        if (mId >= 0 && mClose) mClose(mId);
    }
    hid_t get() const { return mId; }
    bool ok() const { return mId >= 0; }

private:
    hid_t mId = -1;
    herr_t (*mClose)(hid_t) = nullptr;
};

/// The innermost message of HDF5's error stack ("" if none), the stack then cleared.
std::string hdf5Message()
{
    std::string msg;
    H5Ewalk2(
        H5E_DEFAULT, H5E_WALK_UPWARD,
        [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
            auto* m = static_cast<std::string*>(data);
            if (n == 0 && e->desc) *m = e->desc;
            return 0;
        },
        &msg);
    H5Eclear2(H5E_DEFAULT);
    return msg;
}

[[noreturn]] void fail(const std::string& where, const std::string& what)
{
    const std::string detail = hdf5Message();
    throw Error(where + ": " + what + (detail.empty() ? "" : " (HDF5: " + detail + ")"));
}

void quietErrors()
{
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); // errors become exceptions, not stderr text
}

/// The datasets of @p file (paths) and their number of dimensions.
std::vector<std::pair<std::string, int>> listDatasets(hid_t file)
{
    std::vector<std::pair<std::string, int>> found;
    H5Lvisit(
        file, H5_INDEX_NAME, H5_ITER_INC,
        [](hid_t group, const char* name, const H5L_info_t* info, void* data) -> herr_t {
            if (info->type != H5L_TYPE_HARD) return 0;
            Hid obj(H5Oopen(group, name, H5P_DEFAULT), H5Oclose);
            if (!obj.ok() || H5Iget_type(obj.get()) != H5I_DATASET) return 0;
            Hid space(H5Dget_space(obj.get()), H5Sclose);
            const int nd = space.ok() ? H5Sget_simple_extent_ndims(space.get()) : -1;
            static_cast<std::vector<std::pair<std::string, int>>*>(data)->emplace_back(
                "/" + std::string(name), nd);
            return 0;
        },
        &found);
    H5Eclear2(H5E_DEFAULT);
    return found;
}

std::string datasetList(const std::vector<std::pair<std::string, int>>& sets)
{
    std::string s;
    for (const auto& [path, nd] : sets)
        s += (s.empty() ? "" : ", ") + path + " (" + std::to_string(nd) + "-D)";
    return s.empty() ? "none" : s;
}

/// A string attribute @p name of @p obj (fixed or variable length), or nullopt.
std::optional<std::string> stringAttribute(hid_t obj, const char* name, const std::string& where)
{
    if (H5Aexists(obj, name) <= 0) return std::nullopt;
    Hid attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
    Hid type(H5Aget_type(attr.get()), H5Tclose);
    if (!attr.ok() || !type.ok()) fail(where, std::string("cannot read attribute ") + name);
    if (H5Tget_class(type.get()) != H5T_STRING) {
        throw Error(where + ": attribute \"" + name + "\" is not a string");
    }
    Hid space(H5Aget_space(attr.get()), H5Sclose);
    if (H5Sget_simple_extent_npoints(space.get()) != 1) {
        throw Error(where + ": attribute \"" + name + "\" is not a single string");
    }
    if (H5Tis_variable_str(type.get()) > 0) {
        Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(mem.get(), H5T_VARIABLE);
        H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
        char* text = nullptr;
        if (H5Aread(attr.get(), mem.get(), &text) < 0)
            fail(where, std::string("attribute ") + name);
        std::string s = text ? text : "";
        H5free_memory(text);
        return s;
    }
    const std::size_t size = H5Tget_size(type.get());
    if (size > 4096) throw Error(where + ": attribute \"" + name + "\" is too long");
    std::string s(size, '\0');
    Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), size);
    if (H5Aread(attr.get(), mem.get(), s.data()) < 0) fail(where, std::string("attribute ") + name);
    s.resize(std::strlen(s.c_str()));
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    return s;
}

/// A numeric attribute of @p count (1 or 3) values, or nullopt.
std::optional<std::vector<double>> numberAttribute(hid_t obj, const char* name,
                                                   const std::string& where)
{
    if (H5Aexists(obj, name) <= 0) return std::nullopt;
    Hid attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
    Hid type(H5Aget_type(attr.get()), H5Tclose);
    Hid space(H5Aget_space(attr.get()), H5Sclose);
    if (!attr.ok() || !type.ok() || !space.ok()) fail(where, std::string("attribute ") + name);
    const auto cls = H5Tget_class(type.get());
    if (cls != H5T_FLOAT && cls != H5T_INTEGER) {
        throw Error(where + ": attribute \"" + name + "\" is not a number");
    }
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (n < 1 || n > 3)
        throw Error(where + ": attribute \"" + name + "\" has " + std::to_string(n) +
                    " values, expected 1 or 3");
    std::vector<double> v(static_cast<std::size_t>(n));
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()) < 0) fail(where, name);
    return v;
}

class Hdf5Array final : public RawArray
{
public:
    Hdf5Array(Hid file, Hid dataset, std::vector<std::int64_t> shape, std::string where)
        : mFile(std::move(file)), mSet(std::move(dataset)), mShape(std::move(shape)),
          mWhere(std::move(where))
    {}
    std::vector<std::int64_t> shape() const override { return mShape; }
    bool firstFastest() const override { return false; }
    void readBlock(const std::vector<std::int64_t>& fixed, double* out) override
    {
        const std::size_t nd = mShape.size();
        std::vector<hsize_t> start(nd, 0), count(nd);
        hsize_t total = 1;
        for (std::size_t i = 0; i < nd; ++i) {
            if (i < fixed.size()) {
                start[i] = hsize_t(fixed[i]);
                count[i] = 1;
            } else {
                count[i] = hsize_t(mShape[i]);
                total *= count[i];
            }
        }
        Hid space(H5Dget_space(mSet.get()), H5Sclose);
        Hid mem(H5Screate_simple(1, &total, nullptr), H5Sclose);
        if (!space.ok() || !mem.ok() ||
            H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                                nullptr) < 0 ||
            H5Dread(mSet.get(), H5T_NATIVE_DOUBLE, mem.get(), space.get(), H5P_DEFAULT, out) < 0) {
            fail(mWhere, "cannot read the data (truncated or damaged?)");
        }
    }

private:
    Hid mFile, mSet;
    std::vector<std::int64_t> mShape;
    std::string mWhere;
};

} // namespace

std::unique_ptr<CubeSource> openHdf5Cube(const std::string& path, const CubeSelect& select)
{
    quietErrors();
    struct stat st
    {
    };
    if (::stat(path.c_str(), &st) != 0) {
        throw Error(path + ": cannot open it (" + std::strerror(errno) + ")");
    }
    if (H5Fis_hdf5(path.c_str()) <= 0) {
        H5Eclear2(H5E_DEFAULT);
        throw Error(path + ": not an HDF5 file");
    }
    Hid file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!file.ok()) fail(path, "cannot open it as an HDF5 file");
    std::string dsPath = select.dataset;
    if (dsPath.empty()) {
        const auto sets = listDatasets(file.get());
        std::vector<std::string> cubes;
        for (const auto& [p, nd] : sets) {
            if (nd == (select.component >= 0 ? 4 : 3)) cubes.push_back(p);
        }
        if (cubes.size() != 1) {
            throw UsageError(path + ": " +
                             (cubes.empty() ? "no 3-D dataset" : "several 3-D datasets") +
                             " (datasets: " + datasetList(sets) + "); name one with --dataset");
        }
        dsPath = cubes[0];
    }
    const std::string where = path + ": dataset " + dsPath;
    // H5Dopen2 of a path whose groups do not exist fails; say so without HDF5's jargon.
    const bool exists = H5Lexists(file.get(), "/", H5P_DEFAULT) > 0 && [&] {
        std::string prefix;
        std::size_t pos = 0;
        while (pos != std::string::npos) {
            const std::size_t next = dsPath.find('/', pos + 1);
            prefix = dsPath.substr(0, next);
            if (!prefix.empty() && prefix != "/" &&
                H5Lexists(file.get(), prefix.c_str(), H5P_DEFAULT) <= 0) {
                return false;
            }
            pos = next;
        }
        return true;
    }();
    H5Eclear2(H5E_DEFAULT);
    if (!exists) {
        throw Error(path + ": no dataset \"" + dsPath +
                    "\" (datasets: " + datasetList(listDatasets(file.get())) + ")");
    }
    Hid set(H5Dopen2(file.get(), dsPath.c_str(), H5P_DEFAULT), H5Dclose);
    if (!set.ok()) fail(where, "cannot open it as a dataset");
    Hid type(H5Dget_type(set.get()), H5Tclose);
    const auto cls = H5Tget_class(type.get());
    if (cls != H5T_FLOAT && cls != H5T_INTEGER) {
        throw Error(where + ": its values are not numbers (HDF5 type class " +
                    std::to_string(int(cls)) + "), expected floats or integers");
    }
    Hid space(H5Dget_space(set.get()), H5Sclose);
    const int nd = H5Sget_simple_extent_ndims(space.get());
    if (nd < 0 || nd > 32) fail(where, "cannot read its shape");
    std::vector<hsize_t> dims(static_cast<std::size_t>(nd));
    H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    std::vector<std::int64_t> shape(dims.begin(), dims.end());

    CubeInfo info;
    info.name = where;
    checkCubeShape(shape, select.component, info.name);
    // Attributes on the dataset, else on the file's root group.
    Hid root(H5Gopen2(file.get(), "/", H5P_DEFAULT), H5Gclose);
    const auto attr = [&](auto reader, const char* name) {
        auto v = reader(set.get(), name, where);
        if (!v && root.ok()) v = reader(root.get(), name, path);
        return v;
    };
    auto unit = attr(stringAttribute, "units");
    if (!unit) unit = attr(stringAttribute, "unit");
    info.unit = unit.value_or("");
    const auto voxel = attr(numberAttribute, "voxel_size_pc");
    const auto origin = attr(numberAttribute, "origin_pc");
    if (voxel) {
        CubeGeometry g;
        for (std::size_t i = 0; i < 3; ++i)
            g.spacing[i] = (*voxel)[voxel->size() == 3 ? i : 0];
        for (double s : g.spacing) {
            if (!(s != 0.0) || !std::isfinite(s)) {
                info.geometryError = where + ": attribute voxel_size_pc must be finite and not 0";
            }
        }
        if (origin) {
            if (origin->size() != 3) {
                throw Error(where + ": attribute origin_pc must hold 3 numbers (x, y, z) [pc]");
            }
            g.origin = std::array<double, 3>{(*origin)[0], (*origin)[1], (*origin)[2]};
        }
        info.geometry = g;
    }
    auto array = std::make_unique<Hdf5Array>(std::move(file), std::move(set), shape, where);
    return arrayCube(std::move(array), std::move(info), select.component);
}

void writeHdf5Cube(const std::string& path, const CubeHeader& h, const std::string& dataset,
                   const PlaneFunction& plane)
{
    quietErrors();
    const std::string where = path;
    Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    // In memory (no backing store): the bytes go to disk through AtomicFile.
    if (!fapl.ok() || H5Pset_fapl_core(fapl.get(), std::size_t(1) << 24, 0) < 0) {
        fail(where, "cannot set up an HDF5 file in memory");
    }
    Hid file(H5Fcreate("nebexport.h5", H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
    if (!file.ok()) fail(where, "cannot create an HDF5 file in memory");
    const hsize_t dims[3] = {hsize_t(h.dims[0]), hsize_t(h.dims[1]), hsize_t(h.dims[2])};
    Hid space(H5Screate_simple(3, dims, nullptr), H5Sclose);
    Hid lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
    H5Pset_create_intermediate_group(lcpl.get(), 1);
    Hid set(H5Dcreate2(file.get(), dataset.c_str(), H5T_IEEE_F32LE, space.get(), lcpl.get(),
                       H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
    if (!set.ok()) fail(where, "cannot create dataset \"" + dataset + "\"");

    const auto putNumbers = [&](const char* name, const double* v, hsize_t n) {
        Hid s(H5Screate_simple(1, &n, nullptr), H5Sclose);
        Hid a(H5Acreate2(set.get(), name, H5T_IEEE_F64LE, s.get(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
        if (!a.ok() || H5Awrite(a.get(), H5T_NATIVE_DOUBLE, v) < 0) fail(where, name);
    };
    const auto putString = [&](const char* name, const std::string& value) {
        Hid t(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(t.get(), H5T_VARIABLE);
        H5Tset_cset(t.get(), H5T_CSET_UTF8);
        Hid s(H5Screate(H5S_SCALAR), H5Sclose);
        Hid a(H5Acreate2(set.get(), name, t.get(), s.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
        const char* text = value.c_str();
        if (!a.ok() || H5Awrite(a.get(), t.get(), &text) < 0) fail(where, name);
    };
    const bool cubic = h.spacing[0] == h.spacing[1] && h.spacing[1] == h.spacing[2];
    putNumbers("voxel_size_pc", h.spacing.data(), cubic ? 1 : 3);
    putNumbers("origin_pc", h.origin.data(), 3);
    putString("units", h.unit);
    if (!h.name.empty()) putString("grid", h.name);
    std::string history;
    for (const auto& line : h.history)
        history += line + "\n";
    if (!history.empty()) putString("history", history);

    // x planes: contiguous in C order.
    const hsize_t n = dims[1] * dims[2];
    std::vector<float> buf(static_cast<std::size_t>(n));
    Hid mem(H5Screate_simple(1, &n, nullptr), H5Sclose);
    for (hsize_t x = 0; x < dims[0]; ++x) {
        plane(PlaneOrder{0, 2, 1}, std::int64_t(x), buf.data());
        const hsize_t start[3] = {x, 0, 0}, count[3] = {1, dims[1], dims[2]};
        if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
            H5Dwrite(set.get(), H5T_NATIVE_FLOAT, mem.get(), space.get(), H5P_DEFAULT, buf.data()) <
                0) {
            fail(where, "cannot write the data");
        }
    }
    if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) fail(where, "cannot finish the file");
    const ssize_t size = H5Fget_file_image(file.get(), nullptr, 0);
    if (size < 0) fail(where, "cannot finish the file");
    std::string bytes(std::size_t(size), '\0');
    if (H5Fget_file_image(file.get(), bytes.data(), bytes.size()) != size) {
        fail(where, "cannot finish the file");
    }
    if (path == "-") {
        std::cout.write(bytes.data(), std::streamsize(bytes.size()));
        std::cout.flush();
        if (!std::cout)
            throw Error("<stdout>: write failed (" + std::string(std::strerror(errno)) + ")");
        return;
    }
    AtomicFile out(path);
    out.stream().write(bytes.data(), std::streamsize(bytes.size()));
    out.commit();
}

} // namespace nebula::detail
