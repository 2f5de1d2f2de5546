// SPDX-License-Identifier: Apache-2.0
// HDF5 cubes (DESIGN §10), through the C API: a dataset read in x planes as h5py indexes it
// (f[path][x, y, z], C order), its attributes units/unit, voxel_size_pc and origin_pc; cubes
// written in memory (the core driver) and handed to AtomicFile.
#include "cube_raw.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/memory.h"

#include <fmt/format.h>
#include <hdf5.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <functional>
#include <iostream>
#include <string_view>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

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

/// Throws Error "<where>: <what>", HDF5's error stack cleared (its text is the library's, not
/// a message for the user: every caller says what failed in its own words).
[[noreturn]] void fail(const std::string& where, const std::string& what)
{
    H5Eclear2(H5E_DEFAULT);
    throw Error(where + ": " + what);
}

void quietErrors()
{
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); // errors become exceptions, not stderr text
}

/// @p text as it may appear in a message: printable ASCII only, at most 80 characters (names
/// inside a file are the file's, not ours).
std::string printable(std::string_view text)
{
    std::string s;
    for (char c : text.substr(0, 80))
        s += (c >= ' ' && c <= '~') ? c : '?';
    return text.size() > 80 ? s + "..." : s;
}

/// A string attribute @p name of @p obj (fixed or variable length), or nullopt; printable
/// ASCII (it is shown in messages).
std::optional<std::string> stringAttribute(hid_t obj, const char* name, const std::string& where)
{
    if (H5Aexists(obj, name) <= 0) return std::nullopt;
    Hid attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
    Hid type(H5Aget_type(attr.get()), H5Tclose);
    if (!attr.ok() || !type.ok())
        fail(where, std::string("cannot read attribute ") + name + " (damaged?)");
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
            fail(where, std::string("cannot read attribute ") + name + " (damaged?)");
        std::string s = text ? text : "";
        H5free_memory(text);
        return printable(s);
    }
    const std::size_t size = H5Tget_size(type.get());
    if (size < 1 || size > 4096) throw Error(where + ": attribute \"" + name + "\" is too long");
    // One byte more than the file's size: a NULLPAD or SPACEPAD string of N characters fills
    // all N bytes, and a NULLTERM memory type of N bytes would keep only N - 1 of them.
    std::string s(size + 1, '\0');
    Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), size + 1);
    H5Tset_strpad(mem.get(), H5T_STR_NULLTERM);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
    if (H5Aread(attr.get(), mem.get(), s.data()) < 0) {
        fail(where, std::string("cannot read attribute ") + name + " (damaged?)");
    }
    s.resize(std::strlen(s.c_str()));
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    return printable(s);
}

/// A numeric attribute of @p count (1 or 3) values, or nullopt.
std::optional<std::vector<double>> numberAttribute(hid_t obj, const char* name,
                                                   const std::string& where)
{
    if (H5Aexists(obj, name) <= 0) return std::nullopt;
    Hid attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
    Hid type(H5Aget_type(attr.get()), H5Tclose);
    Hid space(H5Aget_space(attr.get()), H5Sclose);
    if (!attr.ok() || !type.ok() || !space.ok()) {
        fail(where, std::string("cannot read attribute ") + name + " (damaged?)");
    }
    const auto cls = H5Tget_class(type.get());
    if (cls != H5T_FLOAT && cls != H5T_INTEGER) {
        throw Error(where + ": attribute \"" + name + "\" is not a number");
    }
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (n < 1 || n > 3)
        throw Error(where + ": attribute \"" + name + "\" has " + std::to_string(n) +
                    " values, expected 1 or 3");
    std::vector<double> v(static_cast<std::size_t>(n));
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()) < 0) {
        fail(where, std::string("cannot read attribute ") + name + " as numbers (damaged?)");
    }
    return v;
}

/// Link access that never opens another file: an external link's traversal fails (the links
/// on a dataset's path are refused by name before, in checkLinks(); this is the backstop).
Hid linkAccess(hid_t cls)
{
    Hid plist(H5Pcreate(cls), H5Pclose);
    const auto refuse = [](const char*, const char*, const char*, const char*, unsigned*, hid_t,
                           void*) -> herr_t { return -1; };
    if (!plist.ok() || H5Pset_elink_cb(plist.get(), refuse, nullptr) < 0) {
        fail("HDF5", "cannot set up the link access");
    }
    return plist;
}

/// What a link that is not a hard link points to, for messages: "a soft link to \"/x\"",
/// "an external link to \"b.h5\" (object \"/x\")", "a user-defined link".
std::string linkText(hid_t file, const char* path, const H5L_info_t& info, hid_t lapl)
{
    std::string value(std::min<std::size_t>(info.u.val_size, 4096), '\0');
    const bool got =
        !value.empty() && H5Lget_val(file, path, value.data(), value.size(), lapl) >= 0;
    H5Eclear2(H5E_DEFAULT);
    if (info.type == H5L_TYPE_SOFT) {
        return "a soft link" + (got ? " to \"" + printable(value.c_str()) + "\"" : std::string());
    }
    if (info.type == H5L_TYPE_EXTERNAL) {
        const char *other = nullptr, *object = nullptr;
        if (got && H5Lunpack_elink_val(value.data(), value.size(), nullptr, &other, &object) >= 0 &&
            other && object) {
            return "an external link to \"" + printable(other) + "\" (object \"" +
                   printable(object) + "\")";
        }
        H5Eclear2(H5E_DEFAULT);
        return "an external link to another file";
    }
    return "a user-defined link";
}

/// The most links listDatasets() visits: a file is not a database.
constexpr int MAX_LISTED_LINKS = 100000;

/// What a file holds: its datasets (path and number of dimensions; -1 for a virtual dataset,
/// whose shape is not asked for: HDF5 may open its source files to find it) and the links
/// that are not followed (soft, external, user-defined).
struct Listing
{
    std::vector<std::pair<std::string, int>> datasets;
    std::vector<std::string> links; ///< "/x (a soft link to \"/y\")"
    int visited = 0;
    hid_t file = -1, lapl = -1;
};

Listing listDatasets(hid_t file, hid_t lapl)
{
    Listing found;
    found.file = file;
    found.lapl = lapl;
    H5Lvisit(
        file, H5_INDEX_NAME, H5_ITER_INC,
        [](hid_t group, const char* name, const H5L_info_t* info, void* data) -> herr_t {
            auto& list = *static_cast<Listing*>(data);
            if (++list.visited > MAX_LISTED_LINKS) return 1;
            const std::string path = "/" + std::string(name);
            if (info->type != H5L_TYPE_HARD) {
                list.links.push_back(printable(path) + " (" +
                                     linkText(group, name, *info, list.lapl) + ", not followed)");
                return 0;
            }
            Hid obj(H5Oopen(group, name, list.lapl), H5Oclose);
            if (!obj.ok() || H5Iget_type(obj.get()) != H5I_DATASET) return 0;
            Hid dcpl(H5Dget_create_plist(obj.get()), H5Pclose);
            if (dcpl.ok() && H5Pget_layout(dcpl.get()) == H5D_VIRTUAL) {
                list.datasets.emplace_back(path, -1);
                return 0;
            }
            Hid space(H5Dget_space(obj.get()), H5Sclose);
            const int nd = space.ok() ? H5Sget_simple_extent_ndims(space.get()) : -2;
            list.datasets.emplace_back(path, nd);
            return 0;
        },
        &found);
    H5Eclear2(H5E_DEFAULT);
    return found;
}

std::string datasetList(const Listing& list)
{
    std::string s;
    for (const auto& [path, nd] : list.datasets) {
        s += (s.empty() ? "" : ", ") + printable(path) +
             (nd == -1 ? " (virtual)"
              : nd < 0 ? " (unreadable)"
                       : " (" + std::to_string(nd) + "-D)");
    }
    for (const auto& link : list.links)
        s += (s.empty() ? "" : ", ") + link;
    return s.empty() ? "none" : s;
}

/// @p dataset as a path from the root ("/a/b/c": empty and "." parts dropped).
std::string canonicalPath(const std::string& dataset)
{
    std::string path;
    std::size_t pos = 0;
    while (pos <= dataset.size()) {
        std::size_t next = dataset.find('/', pos);
        if (next == std::string::npos) next = dataset.size();
        const std::string part = dataset.substr(pos, next - pos);
        if (!part.empty() && part != ".") path += "/" + part;
        pos = next + 1;
    }
    return path.empty() ? "/" : path;
}

/// Throws unless every part of @p path (from the root down) is a hard link: a soft link is
/// refused naming its target, an external link naming the other file, so that a --dataset
/// path cannot lead out of the file. Each part is looked up only after its parent was found
/// to be a hard link, so no lookup here traverses anything else.
void checkLinks(hid_t file, const std::string& path, hid_t lapl, const std::string& fileName,
                const std::function<std::string()>& datasets)
{
    for (std::size_t pos = 0;;) {
        pos = path.find('/', pos + 1);
        const std::string prefix = path.substr(0, pos);
        H5L_info_t info{};
        if (H5Lexists(file, prefix.c_str(), lapl) <= 0 ||
            H5Lget_info(file, prefix.c_str(), &info, lapl) < 0) {
            H5Eclear2(H5E_DEFAULT);
            throw Error(fileName + ": no dataset \"" + printable(path) +
                        "\" (datasets: " + datasets() + ")");
        }
        if (info.type != H5L_TYPE_HARD) {
            const std::string what = linkText(file, prefix.c_str(), info, lapl);
            throw Error(fileName + ": dataset " + printable(path) + ": " + printable(prefix) +
                        " is " + what +
                        "; nebimport follows no links (an external one would read a file you "
                        "did not name): give --dataset the path where the data are stored");
        }
        if (pos == std::string::npos) return;
    }
}

/// Filters whose names users know (HDF5's and h5py's registered ids).
std::string filterName(H5Z_filter_t id)
{
    switch (id) {
    case H5Z_FILTER_DEFLATE: return "gzip";
    case H5Z_FILTER_SHUFFLE: return "shuffle";
    case H5Z_FILTER_FLETCHER32: return "fletcher32";
    case H5Z_FILTER_SZIP: return "szip";
    case H5Z_FILTER_NBIT: return "nbit";
    case H5Z_FILTER_SCALEOFFSET: return "scaleoffset";
    case 307: return "bzip2";
    case 32000: return "lzf";
    case 32001: return "blosc";
    case 32004: return "lz4";
    case 32008: return "bitshuffle";
    case 32013: return "zfp";
    case 32015: return "zstd";
    case 32026: return "blosc2";
    default: return "";
    }
}

/// A filter of a dataset's pipeline, as stored.
struct Filter
{
    H5Z_filter_t id = 0;
    std::vector<unsigned> params; ///< its cd_values
};

/// The dataset's filters, each one that nebimport decodes itself: gzip (inflated into exactly
/// the chunk's size, so a chunk cannot inflate past it), shuffle and fletcher32 (both keep
/// the size). Anything else is refused, naming it: a filter this build lacks cannot be read
/// at all, and the others (szip, nbit, scaleoffset, plugins) size their output from numbers
/// in the file.
std::vector<Filter> readFilters(hid_t dcpl, const std::string& where)
{
    std::vector<Filter> filters;
    const int n = H5Pget_nfilters(dcpl);
    if (n < 0 || n > 32) throw Error(where + ": cannot read its filters (damaged?)");
    for (int i = 0; i < n; ++i) {
        Filter f;
        unsigned flags = 0, config = 0;
        std::size_t count = 8;
        f.params.resize(count);
        char name[64] = {};
        f.id = H5Pget_filter2(dcpl, unsigned(i), &flags, &count, f.params.data(), sizeof(name),
                              name, &config);
        if (f.id < 0) throw Error(where + ": cannot read its filters (damaged?)");
        f.params.resize(std::min<std::size_t>(count, 8));
        const std::string known = filterName(f.id);
        const std::string label =
            "filter " + std::to_string(f.id) + (known.empty() ? "" : " (" + known + ")");
        const bool ours = f.id == H5Z_FILTER_DEFLATE || f.id == H5Z_FILTER_SHUFFLE ||
                          f.id == H5Z_FILTER_FLETCHER32;
        if (!ours && H5Zfilter_avail(f.id) <= 0) {
            H5Eclear2(H5E_DEFAULT);
            throw Error(where + " is compressed with " + label +
                        ", which this build cannot read; save it with gzip or without "
                        "compression");
        }
        if (!ours) {
            throw Error(where + " is stored with " + label +
                        ", which nebimport does not read (it decodes gzip, shuffle and "
                        "fletcher32, whose output size it can bound); save it with gzip or "
                        "without compression");
        }
        filters.push_back(std::move(f));
    }
    return filters;
}

/// Throws unless the dataset's values lie in the file itself: external raw-data storage
/// (values in other files, by any path the file names) and virtual datasets (values mapped
/// from other datasets and files) are refused naming the feature, before any value is read.
void checkStoredInFile(hid_t dcpl, const std::string& where)
{
    if (H5Pget_layout(dcpl) == H5D_VIRTUAL) {
        throw Error(where +
                    " is a virtual dataset (its values are mapped from other datasets, which "
                    "may lie in other files); nebimport reads only values stored in the file "
                    "it is given: save the values themselves");
    }
    const int external = H5Pget_external_count(dcpl);
    if (external != 0) {
        char other[256] = {};
        off_t offset = 0;
        hsize_t size = 0;
        const bool named =
            external > 0 && H5Pget_external(dcpl, 0, sizeof(other), other, &offset, &size) >= 0;
        H5Eclear2(H5E_DEFAULT);
        throw Error(where + " keeps its values in another file" +
                    (named ? " (\"" + printable(other) + "\")" : std::string()) +
                    " (HDF5 external storage); nebimport reads only the file it is given: save "
                    "the values inside the .h5 file");
    }
}

/// HDF5's Fletcher-32 of @p n bytes (16-bit big-endian words, as H5Z_FILTER_FLETCHER32).
std::uint32_t fletcher32(const unsigned char* data, std::size_t n)
{
    std::uint32_t sum1 = 0, sum2 = 0;
    std::size_t words = n / 2;
    while (words) {
        std::size_t block = std::min<std::size_t>(words, 360);
        words -= block;
        for (; block; --block, data += 2) {
            sum1 += (std::uint32_t(data[0]) << 8) | data[1];
            sum2 += sum1;
        }
        sum1 = (sum1 & 0xffff) + (sum1 >> 16);
        sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    }
    if (n % 2) {
        sum1 += std::uint32_t(*data) << 8;
        sum2 += sum1;
        sum1 = (sum1 & 0xffff) + (sum1 >> 16);
        sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    }
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    return (sum2 << 16) | sum1;
}

/// The most chunks a dataset may have: each costs a lookup in the file's chunk index.
constexpr double MAX_CHUNKS = double(1 << 24);

/// A chunked dataset, read by nebula itself chunk by chunk (H5Dread_chunk) so that every
/// allocation is bounded by the dataset's declared size: the stored bytes of a chunk at most
/// its size plus a margin, gzip inflated into exactly the chunk's size. The chunks under one
/// block (a row of chunks across the fixed axes) are decoded once and kept for the next blocks.
class Hdf5ChunkedArray final : public RawArray
{
public:
    Hdf5ChunkedArray(Hid file, Hid dataset, Hid type, std::vector<std::int64_t> shape,
                     std::vector<std::int64_t> chunk, std::vector<Filter> filters,
                     std::vector<unsigned char> fill, std::string where)
        : mFile(std::move(file)), mSet(std::move(dataset)), mType(std::move(type)),
          mShape(std::move(shape)), mChunk(std::move(chunk)), mFilters(std::move(filters)),
          mFill(std::move(fill)), mWhere(std::move(where))
    {
        mTypeSize = mFill.size();
        mChunkBytes = mTypeSize;
        for (auto c : mChunk)
            mChunkBytes *= std::size_t(c);
    }
    std::vector<std::int64_t> shape() const override { return mShape; }
    bool firstFastest() const override { return false; }
    void readBlock(const std::vector<std::int64_t>& fixed, double* out) override;

private:
    void loadRow(const std::vector<std::int64_t>& key);
    void decode(std::size_t stored, std::uint32_t skipped, unsigned char* out);
    /// Inflates mA's first @p n bytes into @p out, exactly the chunk's size, unshuffling
    /// elements of @p shuffle bytes (1: none) on the way. Throws if it inflates to more.
    void inflateInto(std::size_t n, unsigned char* out, std::size_t shuffle);

    Hid mFile, mSet, mType;
    std::vector<std::int64_t> mShape, mChunk;
    std::vector<Filter> mFilters;
    std::vector<unsigned char> mFill; ///< the fill value, in the file's type
    std::string mWhere;
    std::size_t mTypeSize = 0, mChunkBytes = 0;
    std::vector<std::int64_t> mKey;    ///< the row of chunks held in mRow
    std::vector<unsigned char> mRow;   ///< its chunks, decoded, C order over the free axes
    std::vector<unsigned char> mA, mB; ///< a chunk's stored bytes and the decoding's steps
};

/// Undoes the shuffle filter as bytes stream in: byte p of a shuffled block of @p count
/// elements of @p size bytes is byte p / count of element p % count (bytes past the last
/// whole element stay where they are).
class Unshuffler
{
public:
    Unshuffler(std::size_t size, std::size_t bytes)
        : mSize(size > 1 ? size : 1), mCount(bytes / mSize)
    {}
    void put(const unsigned char* in, std::size_t n, unsigned char* out)
    {
        for (std::size_t j = 0; j < n; ++j) {
            if (mByte < mSize && mCount > 0) { // element mElement's byte mByte
                out[mElement * mSize + mByte] = in[j];
                if (++mElement == mCount) {
                    mElement = 0;
                    ++mByte;
                }
            } else { // past the last whole element
                out[mCount * mSize + mElement++] = in[j];
            }
        }
    }

private:
    std::size_t mSize, mCount, mByte = 0, mElement = 0;
};

void Hdf5ChunkedArray::inflateInto(std::size_t n, unsigned char* out, std::size_t shuffle)
{
    if (n > UINT_MAX) throw Error(mWhere + ": damaged: a chunk is too large");
    z_stream z{};
    if (inflateInit(&z) != Z_OK) throw Error(mWhere + ": cannot start inflating");
    z.next_in = mA.data();
    z.avail_in = uInt(n);
    std::size_t got = 0;
    int status = Z_OK;
    if (shuffle <= 1) {
        // Straight into the chunk: a stream longer than the chunk stops at its end.
        z.next_out = out;
        z.avail_out = uInt(mChunkBytes);
        status = inflate(&z, Z_FINISH);
        got = z.total_out;
    } else {
        // Through a window, unshuffled into the chunk as the bytes come.
        Unshuffler unshuffle(shuffle, mChunkBytes);
        std::vector<unsigned char> window(std::min<std::size_t>(mChunkBytes + 1, 1 << 18));
        while (status == Z_OK && got <= mChunkBytes) {
            z.next_out = window.data();
            z.avail_out = uInt(window.size());
            status = inflate(&z, Z_NO_FLUSH);
            const std::size_t produced = window.size() - z.avail_out;
            if (got + produced <= mChunkBytes) unshuffle.put(window.data(), produced, out);
            got += produced;
            if (status == Z_OK && produced == 0) status = Z_BUF_ERROR; // input ran out
        }
    }
    inflateEnd(&z);
    if (got > mChunkBytes || (got == mChunkBytes && status != Z_STREAM_END)) {
        throw Error(mWhere + fmt::format(": a chunk inflates to more than its {} bytes (a "
                                         "decompression bomb, or damaged)",
                                         mChunkBytes));
    }
    if (status != Z_STREAM_END) {
        throw Error(mWhere + ": damaged: a gzip-compressed chunk does not inflate");
    }
    if (got != mChunkBytes) {
        throw Error(mWhere + fmt::format(": damaged: a chunk inflates to {} bytes, expected {}",
                                         got, mChunkBytes));
    }
}

void Hdf5ChunkedArray::decode(std::size_t stored, std::uint32_t skipped, unsigned char* out)
{
    const auto damaged = [&](const std::string& why) { throw Error(mWhere + ": damaged: " + why); };
    // The filters to undo, last applied first.
    std::vector<const Filter*> steps;
    for (std::size_t i = mFilters.size(); i-- > 0;) {
        if (i >= 32 || !((skipped >> i) & 1u)) steps.push_back(&mFilters[i]);
    }
    const auto shuffleSize = [&](const Filter& f) {
        return f.params.empty() ? mTypeSize : std::size_t(f.params[0]);
    };
    std::size_t n = stored;
    for (std::size_t i = 0;; ++i) {
        // The usual tails (gzip, then shuffle) go straight into the chunk: no copy of it.
        const std::size_t left = steps.size() - i;
        const auto is = [&](std::size_t j, H5Z_filter_t id) { return steps[i + j]->id == id; };
        if (left == 0 || (left == 1 && is(0, H5Z_FILTER_SHUFFLE))) {
            if (n != mChunkBytes) {
                damaged(fmt::format("a chunk holds {} bytes, expected {}", n, mChunkBytes));
            }
            if (left == 0) {
                std::memcpy(out, mA.data(), n);
            } else {
                Unshuffler(shuffleSize(*steps[i]), n).put(mA.data(), n, out);
            }
            return;
        }
        if (is(0, H5Z_FILTER_DEFLATE) && (left == 1 || (left == 2 && is(1, H5Z_FILTER_SHUFFLE)))) {
            inflateInto(n, out, left == 2 ? shuffleSize(*steps[i + 1]) : 1);
            return;
        }
        const Filter& f = *steps[i];
        if (f.id == H5Z_FILTER_FLETCHER32) {
            if (n < 4) damaged("a chunk is too short for its checksum");
            n -= 4;
            const unsigned char* c = mA.data() + n;
            const std::uint32_t want = std::uint32_t(c[0]) | std::uint32_t(c[1]) << 8 |
                                       std::uint32_t(c[2]) << 16 | std::uint32_t(c[3]) << 24;
            const std::uint32_t sum = fletcher32(mA.data(), n);
            // Files from HDF5 before 1.6.3 hold the sum with its bytes swapped in pairs.
            const std::uint32_t swapped = ((sum & 0x00ff00ffu) << 8) | ((sum >> 8) & 0x00ff00ffu);
            if (want != sum && want != swapped) damaged("a chunk does not match its checksum");
        } else if (f.id == H5Z_FILTER_DEFLATE) {
            // Another order of filters (rare): through a buffer of the chunk's size.
            mB.resize(mChunkBytes);
            inflateInto(n, mB.data(), 1);
            mA.swap(mB);
            n = mChunkBytes;
        } else if (f.id == H5Z_FILTER_SHUFFLE) {
            mB.resize(n);
            Unshuffler(shuffleSize(f), n).put(mA.data(), n, mB.data());
            mA.swap(mB);
        }
    }
}

void Hdf5ChunkedArray::loadRow(const std::vector<std::int64_t>& key)
{
    const std::size_t nd = mShape.size(), k = key.size();
    std::vector<std::int64_t> count(nd, 1), index(nd, 0);
    std::size_t chunks = 1;
    for (std::size_t a = k; a < nd; ++a) {
        count[a] = (mShape[a] + mChunk[a] - 1) / mChunk[a];
        chunks *= std::size_t(count[a]);
    }
    mRow.resize(chunks * mChunkBytes);
    // A stored chunk is its size or, compressed, less; a margin for gzip's worst case.
    const std::size_t maxStored =
        mFilters.empty() ? mChunkBytes : mChunkBytes + mChunkBytes / 64 + 1024;
    for (std::size_t c = 0; c < chunks; ++c) {
        // index: the chunk's position over the free axes, C order.
        std::size_t rest = c;
        for (std::size_t a = nd; a-- > k;) {
            index[a] = std::int64_t(rest % std::size_t(count[a]));
            rest /= std::size_t(count[a]);
        }
        std::vector<hsize_t> offset(nd);
        for (std::size_t a = 0; a < nd; ++a)
            offset[a] = hsize_t((a < k ? key[a] : index[a]) * mChunk[a]);
        unsigned char* out = mRow.data() + c * mChunkBytes;
        hsize_t stored = 0;
        if (H5Dget_chunk_storage_size(mSet.get(), offset.data(), &stored) < 0 || stored == 0) {
            H5Eclear2(H5E_DEFAULT); // never written: the fill value, as HDF5 reads it
            for (std::size_t i = 0; i < mChunkBytes; i += mTypeSize)
                std::memcpy(out + i, mFill.data(), mTypeSize);
            continue;
        }
        if (stored > maxStored) {
            throw Error(mWhere + fmt::format(": damaged: a chunk is stored in {} bytes, more "
                                             "than its {} bytes of values",
                                             stored, mChunkBytes));
        }
        mA.resize(std::size_t(stored));
        std::uint32_t skipped = 0;
        if (H5Dread_chunk(mSet.get(), H5P_DEFAULT, offset.data(), &skipped, mA.data()) < 0) {
            H5Eclear2(H5E_DEFAULT);
            throw Error(mWhere + ": cannot read the data (truncated or damaged?)");
        }
        decode(std::size_t(stored), skipped, out);
    }
    mKey = key;
    // Large chunks' stored bytes are not kept beside the row (the tree grows next).
    if (mA.capacity() > (std::size_t(16) << 20)) std::vector<unsigned char>().swap(mA);
    if (mB.capacity() > (std::size_t(16) << 20)) std::vector<unsigned char>().swap(mB);
}

void Hdf5ChunkedArray::readBlock(const std::vector<std::int64_t>& fixed, double* out)
{
    const std::size_t nd = mShape.size(), k = fixed.size();
    std::vector<std::int64_t> key(k);
    for (std::size_t a = 0; a < k; ++a)
        key[a] = fixed[a] / mChunk[a];
    if (key != mKey) loadRow(key);
    // Within a chunk, C order; the offset of the fixed axes' voxel in every chunk of the row.
    std::vector<std::size_t> stride(nd, 1);
    for (std::size_t a = nd - 1; a-- > 0;)
        stride[a] = stride[a + 1] * std::size_t(mChunk[a + 1]);
    std::size_t base = 0;
    for (std::size_t a = 0; a < k; ++a)
        base += std::size_t(fixed[a] % mChunk[a]) * stride[a];
    std::vector<std::int64_t> count(nd, 1);
    for (std::size_t a = k; a < nd; ++a)
        count[a] = (mShape[a] + mChunk[a] - 1) / mChunk[a];
    // Gather the block in the file's type into out's bytes (a value is at most 8 bytes), then
    // convert in place.
    auto* bytes = reinterpret_cast<unsigned char*>(out);
    std::vector<std::int64_t> u(nd, 0); // the position over the free axes but the last
    const std::size_t last = nd - 1;
    std::size_t written = 0;
    for (bool more = true; more;) {
        std::size_t chunkIndex = 0, within = base;
        for (std::size_t a = k; a < last; ++a) {
            chunkIndex = chunkIndex * std::size_t(count[a]) + std::size_t(u[a] / mChunk[a]);
            within += std::size_t(u[a] % mChunk[a]) * stride[a];
        }
        for (std::int64_t q = 0; q < count[last]; ++q) {
            const std::size_t run =
                std::size_t(std::min(mChunk[last], mShape[last] - q * mChunk[last]));
            const unsigned char* from =
                mRow.data() +
                (chunkIndex * std::size_t(count[last]) + std::size_t(q)) * mChunkBytes +
                within * mTypeSize;
            std::memcpy(bytes + written * mTypeSize, from, run * mTypeSize);
            written += run;
        }
        more = false;
        for (std::size_t a = last; a-- > k;) {
            if (++u[a] < mShape[a]) {
                more = true;
                break;
            }
            u[a] = 0;
        }
    }
    if (H5Tconvert(mType.get(), H5T_NATIVE_DOUBLE, written, out, nullptr, H5P_DEFAULT) < 0) {
        H5Eclear2(H5E_DEFAULT);
        throw Error(mWhere + ": cannot convert its values to numbers");
    }
}

/// A contiguous or compact dataset, read by HDF5 (H5Dread of exactly the block).
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

std::string shapeText(const std::vector<std::int64_t>& shape)
{
    std::string text;
    for (std::size_t i = 0; i < shape.size(); ++i)
        text += (i ? " x " : "") + std::to_string(shape[i]);
    return text;
}

/// Throws unless the dataset holds stored values: a dataset declared but never written is
/// read by HDF5 as its fill value (a 4096^3 one for minutes, from a file of a few hundred
/// bytes). A contiguous dataset must also lie inside the file.
void checkAllocated(hid_t file, hid_t set, H5D_layout_t layout, double bytes,
                    const std::vector<std::int64_t>& shape, const std::string& where)
{
    H5D_space_status_t status = H5D_SPACE_STATUS_ERROR;
    const bool known = H5Dget_space_status(set, &status) >= 0;
    const hsize_t stored = H5Dget_storage_size(set);
    H5Eclear2(H5E_DEFAULT);
    if (!known || status == H5D_SPACE_STATUS_NOT_ALLOCATED || stored == 0) {
        throw Error(where + " has no stored values: its " + shapeText(shape) +
                    " voxels were declared but never written (HDF5 would read them all as "
                    "its fill value)");
    }
    if (layout == H5D_CONTIGUOUS) {
        const haddr_t offset = H5Dget_offset(set);
        hsize_t fileSize = 0;
        H5Fget_filesize(file, &fileSize);
        H5Eclear2(H5E_DEFAULT);
        if (double(stored) < bytes || offset == HADDR_UNDEF ||
            double(offset) + bytes > double(fileSize)) {
            throw Error(where + fmt::format(": truncated: its {} bytes of values do not lie "
                                            "inside the file's {} bytes",
                                            bytes, fileSize));
        }
    }
}

/// The chunk dimensions of a chunked dataset, checked: the chunks that one plane crosses are
/// decoded and kept together, so they may hold at most twice the dataset's values (one plane
/// of chunks of 1 x N x N is a plane; chunks of the whole cube are the cube), and there are at
/// most MAX_CHUNKS chunks.
std::vector<std::int64_t> chunkShape(hid_t dcpl, const std::vector<std::int64_t>& shape,
                                     std::size_t typeSize, const std::string& where)
{
    const std::size_t nd = shape.size();
    std::vector<hsize_t> dims(nd, 0);
    if (H5Pget_chunk(dcpl, int(nd), dims.data()) != int(nd)) {
        H5Eclear2(H5E_DEFAULT);
        throw Error(where + ": cannot read its chunk shape (damaged?)");
    }
    std::vector<std::int64_t> chunk(dims.begin(), dims.end());
    double row = double(typeSize), data = double(typeSize), chunks = 1.0, chunkBytes = 1.0;
    for (std::size_t a = 0; a < nd; ++a) {
        if (chunk[a] < 1 || chunk[a] > (std::int64_t(1) << 32)) {
            throw Error(where + ": damaged: chunks of " + shapeText(chunk));
        }
        const double n = std::ceil(double(shape[a]) / double(chunk[a]));
        row *= a == 0 ? double(chunk[a]) : n * double(chunk[a]);
        data *= double(shape[a]);
        chunks *= n;
        chunkBytes *= double(chunk[a]);
    }
    chunkBytes *= double(typeSize);
    if (row > 2.0 * data + double(1 << 20) || chunkBytes > 4294967295.0) {
        throw Error(where + ": its chunks of " + shapeText(chunk) + " (" + bytesText(chunkBytes) +
                    " each) would take " + bytesText(row) +
                    " of memory to read one plane, more than twice its " + bytesText(data) +
                    " of values; save it with smaller chunks");
    }
    if (chunks > MAX_CHUNKS) {
        throw Error(where + fmt::format(": is stored in {:.0f} chunks of {}; nebimport reads at "
                                        "most 2^24 ({:.0f}): save it with larger chunks",
                                        chunks, shapeText(chunk), MAX_CHUNKS));
    }
    requireMemory(row, where + ": the chunks under one plane");
    return chunk;
}

/// The fill value of @p set's dcpl in the dataset's type (zeros where the file has none).
std::vector<unsigned char> fillValue(hid_t dcpl, hid_t type, std::size_t size)
{
    std::vector<unsigned char> fill(size, 0);
    H5D_fill_value_t defined = H5D_FILL_VALUE_UNDEFINED;
    if (H5Pfill_value_defined(dcpl, &defined) >= 0 && defined != H5D_FILL_VALUE_UNDEFINED) {
        if (H5Pget_fill_value(dcpl, type, fill.data()) < 0) std::fill(fill.begin(), fill.end(), 0);
    }
    H5Eclear2(H5E_DEFAULT);
    return fill;
}

/// The cube's geometry attributes, checked: voxel_size_pc is one finite positive number or
/// three equal ones (cubic voxels, not mirrored), origin_pc three finite numbers.
void readGeometry(const std::optional<std::vector<double>>& voxel,
                  const std::optional<std::vector<double>>& origin, const std::string& where,
                  CubeInfo& info)
{
    const auto values = [](const std::vector<double>& v) {
        return v.size() == 1 ? fmt::format("{}", v[0]) : fmt::format("[{}]", fmt::join(v, ", "));
    };
    if (origin) {
        bool finite = origin->size() == 3;
        for (double o : *origin)
            finite = finite && std::isfinite(o);
        if (!finite) {
            throw Error(where + ": attribute origin_pc is " + values(*origin) +
                        ", expected 3 finite numbers (x, y, z) [pc]");
        }
    }
    if (!voxel) return;
    bool ok = true;
    for (double s : *voxel)
        ok = ok && std::isfinite(s) && s > 0.0 && s == (*voxel)[0];
    if (!ok) {
        throw Error(where + ": attribute voxel_size_pc is " + values(*voxel) +
                    ", expected one finite positive number [pc] or three equal ones (cubic "
                    "voxels)");
    }
    CubeGeometry g;
    g.spacing = {(*voxel)[0], (*voxel)[0], (*voxel)[0]};
    if (origin) g.origin = std::array<double, 3>{(*origin)[0], (*origin)[1], (*origin)[2]};
    info.geometry = g;
}

/// An open file, from a path or from bytes in memory.
Hid openFile(const std::string& path, std::optional<std::string_view> image)
{
    Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    if (!fapl.ok()) fail(path, "cannot set up the HDF5 library");
    if (image) {
        // The core driver over a copy of the bytes, no file behind it.
        if (H5Pset_fapl_core(fapl.get(), std::size_t(1) << 16, 0) < 0 ||
            H5Pset_file_image(fapl.get(), const_cast<char*>(image->data()), image->size()) <
                0) { // HDF5 copies the bytes
            fail(path, "cannot set up an HDF5 file in memory");
        }
        // The core driver refuses an image whose name is an existing file: a name no file has.
        Hid file(H5Fopen("\x01nebula-hdf5-image", H5F_ACC_RDONLY, fapl.get()), H5Fclose);
        if (!file.ok()) fail(path, "not an HDF5 file, or damaged");
        return file;
    }
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
    Hid file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
    if (!file.ok()) fail(path, "cannot open it as an HDF5 file (damaged?)");
    return file;
}

/// The dataset @p select names, or the file's only 3-D (4-D) one, as a path from the root.
std::string chooseDataset(hid_t file, hid_t lapl, const std::string& name, const CubeSelect& select)
{
    if (!select.dataset.empty()) return canonicalPath(select.dataset);
    const Listing list = listDatasets(file, lapl);
    std::vector<std::string> cubes;
    for (const auto& [p, nd] : list.datasets) {
        // A virtual dataset is a candidate: it is refused by name once chosen.
        if (nd == (select.component >= 0 ? 4 : 3) || nd == -1) cubes.push_back(p);
    }
    if (cubes.size() != 1) {
        throw UsageError(name + ": " + (cubes.empty() ? "no 3-D dataset" : "several 3-D datasets") +
                         " (datasets: " + datasetList(list) + "); name one with --dataset");
    }
    return cubes[0];
}

std::unique_ptr<CubeSource> openDataset(Hid file, const std::string& name, const CubeSelect& select)
{
    const Hid lapl = linkAccess(H5P_LINK_ACCESS);
    const Hid dapl = linkAccess(H5P_DATASET_ACCESS);
    const std::string dsPath = chooseDataset(file.get(), lapl.get(), name, select);
    checkLinks(file.get(), dsPath, lapl.get(), name,
               [&] { return datasetList(listDatasets(file.get(), lapl.get())); });
    const std::string where = name + ": dataset " + printable(dsPath);
    Hid set(H5Dopen2(file.get(), dsPath.c_str(), dapl.get()), H5Dclose);
    if (!set.ok()) fail(where, "cannot open it as a dataset (is it a group?)");

    // What the file's metadata say, checked before the dataset's shape or any value is read.
    Hid dcpl(H5Dget_create_plist(set.get()), H5Pclose);
    if (!dcpl.ok()) fail(where, "cannot read how it is stored (damaged?)");
    checkStoredInFile(dcpl.get(), where);
    const H5D_layout_t layout = H5Pget_layout(dcpl.get());
    if (layout != H5D_CONTIGUOUS && layout != H5D_CHUNKED && layout != H5D_COMPACT) {
        fail(where, "cannot read how it is stored (damaged?)");
    }
    auto filters = readFilters(dcpl.get(), where);
    Hid type(H5Dget_type(set.get()), H5Tclose);
    const auto cls = type.ok() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
    if (cls != H5T_FLOAT && cls != H5T_INTEGER) {
        H5Eclear2(H5E_DEFAULT);
        throw Error(where + ": its values are not numbers (HDF5 type class " +
                    std::to_string(int(cls)) + "), expected floats or integers");
    }
    const std::size_t typeSize = H5Tget_size(type.get());
    if (typeSize < 1 || typeSize > 8) {
        throw Error(where + ": its values are " + std::to_string(typeSize) +
                    "-byte numbers, expected at most 8 bytes (float64, int64)");
    }
    Hid space(H5Dget_space(set.get()), H5Sclose);
    const int nd = space.ok() ? H5Sget_simple_extent_ndims(space.get()) : -1;
    if (nd < 0 || nd > 32) fail(where, "cannot read its shape (damaged?)");
    std::vector<hsize_t> dims(static_cast<std::size_t>(nd));
    H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    std::vector<std::int64_t> shape(dims.begin(), dims.end());

    CubeInfo info;
    info.name = where;
    checkCubeShape(shape, select.component, info.name);
    double bytes = double(typeSize);
    for (auto n : shape)
        bytes *= double(n);
    checkAllocated(file.get(), set.get(), layout, bytes, shape, where);

    // Attributes on the dataset, else on the file's root group.
    Hid root(H5Gopen2(file.get(), "/", H5P_DEFAULT), H5Gclose);
    const auto attr = [&](auto reader, const char* attribute) {
        auto v = reader(set.get(), attribute, where);
        if (!v && root.ok()) v = reader(root.get(), attribute, name);
        return v;
    };
    auto unit = attr(stringAttribute, "units");
    if (!unit) unit = attr(stringAttribute, "unit");
    info.unit = unit.value_or("");
    readGeometry(attr(numberAttribute, "voxel_size_pc"), attr(numberAttribute, "origin_pc"), where,
                 info);
    std::unique_ptr<RawArray> array;
    if (layout == H5D_CHUNKED) {
        auto chunk = chunkShape(dcpl.get(), shape, typeSize, where);
        auto fill = fillValue(dcpl.get(), type.get(), typeSize);
        array = std::make_unique<Hdf5ChunkedArray>(std::move(file), std::move(set), std::move(type),
                                                   shape, std::move(chunk), std::move(filters),
                                                   std::move(fill), where);
    } else {
        array = std::make_unique<Hdf5Array>(std::move(file), std::move(set), shape, where);
    }
    return arrayCube(std::move(array), std::move(info), select.component);
}

/// How long libhdf5 may take over a file's structure in probeStructure() [s]: a structure
/// walk takes milliseconds; this only ends a library that loops. NEBULA_HDF5_PROBE_SECONDS
/// (1 to 3600) sets another bound (the tests' looping file).
int probeSeconds()
{
    const char* v = std::getenv("NEBULA_HDF5_PROBE_SECONDS");
    const int n = v ? std::atoi(v) : 0;
    return n >= 1 && n <= 3600 ? n : 120;
}

/// libhdf5 1.10 crashes or loops on some damaged metadata before any of its calls returns an
/// error (tests/fuzz/libhdf5). So the structure walk that opening a cube makes (links,
/// dataset, type, layout, filters, attributes) runs first in a child process: where the
/// library crashes or loops there, the file is refused with a message instead of taking the
/// tool down. A file the walk refuses cleanly is refused again here, with its own message.
void probeStructure(const std::string& path, const CubeSelect& select)
{
    std::cout.flush();
    std::cerr.flush();
    const pid_t pid = ::fork();
    if (pid < 0) return; // no process to spare: the walk runs here as it did before
    if (pid == 0) {
        const int null = ::open("/dev/null", O_WRONLY);
        if (null >= 0) ::dup2(null, STDERR_FILENO); // a sanitizer's report, not the user's
        int code = 0;
        try {
            quietErrors();
            openDataset(openFile(path, std::nullopt), path, select);
        } catch (...) {
            code = 3;
        }
        ::_exit(code);
    }
    int status = 0;
    const int seconds = probeSeconds();
    for (int waited = 0;; ++waited) {
        const pid_t done = ::waitpid(pid, &status, WNOHANG);
        if (done == pid) break;
        if (done < 0 && errno != EINTR) return;
        if (waited >= seconds * 100) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            throw Error(path +
                        ": the HDF5 library did not finish reading the file's structure in " +
                        std::to_string(seconds) +
                        " s (it loops on some damaged files): the file is damaged or hostile; "
                        "nothing was read from it");
        }
        ::usleep(10000);
    }
    if (WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 3)) return;
    throw Error(path + ": the HDF5 library failed while reading the file's structure (" +
                (WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                     : "exit " + std::to_string(WEXITSTATUS(status))) +
                "): the file is damaged or hostile; nothing was read from it");
}

} // namespace

std::unique_ptr<CubeSource> openHdf5Cube(const std::string& path, const CubeSelect& select)
{
    quietErrors();
    probeStructure(path, select);
    return openDataset(openFile(path, std::nullopt), path, select);
}

std::unique_ptr<CubeSource> openHdf5CubeImage(std::string_view bytes, const std::string& name,
                                              const CubeSelect& select)
{
    quietErrors();
    // HDF5's signature sits at 0, 512, 1024, ...; less than a superblock is not a file.
    if (bytes.size() < 48)
        throw Error(name + ": not an HDF5 file (" + std::to_string(bytes.size()) + " bytes)");
    return openDataset(openFile(name, bytes), name, select);
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
        if (!a.ok() || H5Awrite(a.get(), H5T_NATIVE_DOUBLE, v) < 0) {
            fail(where, std::string("cannot write attribute ") + name);
        }
    };
    const auto putString = [&](const char* name, const std::string& value) {
        Hid t(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(t.get(), H5T_VARIABLE);
        H5Tset_cset(t.get(), H5T_CSET_UTF8);
        Hid s(H5Screate(H5S_SCALAR), H5Sclose);
        Hid a(H5Acreate2(set.get(), name, t.get(), s.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
        const char* text = value.c_str();
        if (!a.ok() || H5Awrite(a.get(), t.get(), &text) < 0) {
            fail(where, std::string("cannot write attribute ") + name);
        }
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

const CubeFormat& hdf5CubeFormat()
{
    static const CubeFormat format = [] {
        CubeFormat f;
        f.name = "hdf5";
        f.title = "HDF5";
        f.doc = ".h5/.hdf5";
        f.hint = ".h5";
        f.endings = {".h5", ".hdf5", ".he5", ".hdf"};
        f.selector = &CubeSelect::dataset;
        f.open = openHdf5Cube;
        f.fileFormat = FileFormat::Hdf5;
        f.write = [](const std::string& path, const CubeHeader& header, const std::string& dataset,
                     const PlaneFunction& plane) {
            // The image in memory, and its copy handed to the writer.
            const double bytes =
                double(header.dims[0]) * double(header.dims[1]) * double(header.dims[2]) * 4.0;
            requireMemory(2.0 * bytes, path + ": the HDF5 file (built in memory)");
            writeHdf5Cube(path, header, dataset, plane);
        };
        f.writerMemory = [](const std::array<std::int64_t, 3>& dims, double fileBytes) {
            // The file in memory (HDF5's core driver), its copy handed to the writer, one x
            // plane.
            return WriterMemory{2.0 * fileBytes + 4.0 * double(dims[1]) * double(dims[2]),
                                "the HDF5 file is built in memory and copied out"};
        };
        return f;
    }();
    return format;
}

} // namespace nebula::detail

namespace nebula {

std::unique_ptr<CubeSource> openHdf5Memory(std::string_view bytes, const std::string& name,
                                           const CubeSelect& select)
{
    return detail::openHdf5CubeImage(bytes, name, select);
}

} // namespace nebula
