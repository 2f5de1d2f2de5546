// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/disk_space.h"

#include <cstdlib>
#include <sys/stat.h>
#include <sys/statvfs.h>

namespace nebula {

namespace {

std::string folderOf(const std::string& path)
{
    const auto slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    if (slash == 0) return "/";
    return path.substr(0, slash);
}

} // namespace

std::optional<std::uint64_t> freeDiskSpace(const std::string& path)
{
    if (path == "-") return std::nullopt;
    std::string folder = folderOf(path);
    struct stat st;
    if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
        if (!S_ISLNK(st.st_mode)) return std::nullopt; // a FIFO, a device, a folder
        char* resolved = ::realpath(path.c_str(), nullptr);
        if (!resolved) return std::nullopt;
        const std::string target = resolved;
        std::free(resolved);
        if (::stat(target.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
        folder = folderOf(target);
    }
    struct statvfs fs;
    if (::statvfs(folder.c_str(), &fs) != 0) return std::nullopt;
    return std::uint64_t(fs.f_bavail) * std::uint64_t(fs.f_frsize);
}

} // namespace nebula
