// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/file_format.h"

#include "nebula/core/error.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <sys/stat.h>

namespace nebula {

namespace {

struct FormatInfo
{
    FileFormat format;
    const char* name;
    std::vector<std::string> extensions;
};

const std::array<FormatInfo, 8>& formats()
{
    static const std::array<FormatInfo, 8> table{{
        {FileFormat::Vdb, "VDB", {".vdb"}},
        {FileFormat::Exr, "EXR", {".exr"}},
        {FileFormat::Png, "PNG", {".png"}},
        {FileFormat::Fits, "FITS", {".fits", ".fit", ".fts"}},
        {FileFormat::Npy, "NumPy .npy", {".npy"}},
        {FileFormat::Hdf5, "HDF5", {".h5", ".hdf5", ".he5"}},
        {FileFormat::Csv, "CSV", {".csv"}},
        {FileFormat::Json, "JSON", {".json"}},
    }};
    return table;
}

const FormatInfo& info(FileFormat format)
{
    for (const auto& f : formats())
        if (f.format == format) return f;
    throw Error("unknown file format");
}

std::string lower(std::string s)
{
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

bool endsWith(const std::string& s, const std::string& tail)
{
    return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

/// The name's last component.
std::string baseName(const std::string& path)
{
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

} // namespace

const char* formatName(FileFormat format)
{
    return info(format).name;
}

const std::vector<std::string>& formatExtensions(FileFormat format)
{
    return info(format).extensions;
}

std::optional<FileFormat> formatOfName(const std::string& path)
{
    const std::string name = lower(baseName(path));
    // The longest ending that matches: ".fits.gz" is FITS, whatever ".gz" alone would be.
    std::optional<FileFormat> found;
    std::size_t longest = 0;
    for (const auto& f : formats()) {
        for (const auto& e : f.extensions) {
            if (e.size() > longest && endsWith(name, e)) {
                found = f.format;
                longest = e.size();
            }
        }
    }
    return found;
}

void checkOutputName(const std::string& path, const std::string& option, FileFormat format)
{
    if (path.empty() || path == "-") return;
    struct stat st;
    if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) return;
    const auto& f = info(format);
    const auto named = formatOfName(path);
    if (named == format) return;
    std::string endings;
    for (const auto& e : f.extensions)
        endings += (endings.empty() ? "*" : ", *") + e;
    const std::string base = baseName(path);
    const auto dot = base.find('.');
    const std::string says =
        named ? std::string("the name says ") + formatName(*named)
              : (dot == std::string::npos || dot == 0
                     ? std::string("the name has no ending")
                     : "the name ends in \"" + base.substr(base.rfind('.')) + "\"");
    throw UsageError(option + " " + path + ": " + says + ", but this output is " + f.name +
                     "; name it " + endings);
}

} // namespace nebula
