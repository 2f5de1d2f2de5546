#include "nebula/core/atomic_file.h"

#include "nebula/core/error.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

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

void checkOutputWritable(const std::string& path, const std::string& what)
{
    const std::string folder = folderOf(path);
    if (::access(folder.c_str(), W_OK | X_OK) != 0) {
        throw Error(path + ": cannot write " + what + ": folder \"" + folder +
                    "\" is not writable (" + std::strerror(errno) + ")");
    }
}

AtomicFile::AtomicFile(const std::string& path) : mPath(path)
{
    checkOutputWritable(path, "output");
    // mkstemp gives a unique name in the target's folder, so rename() stays on one filesystem.
    std::string pattern = path + ".tmp.XXXXXX";
    std::vector<char> buf(pattern.begin(), pattern.end());
    buf.push_back('\0');
    const int fd = ::mkstemp(buf.data());
    if (fd < 0) {
        throw Error(path + ": cannot create temporary output file (" + std::strerror(errno) + ")");
    }
    // mkstemp creates the file 0600; give it the permissions an ordinary open() would.
    const mode_t mask = ::umask(0);
    ::umask(mask);
    ::fchmod(fd, 0666 & ~mask);
    ::close(fd);
    mTmpPath = buf.data();
}

AtomicFile::~AtomicFile()
{
    if (!mCommitted && !mTmpPath.empty()) std::remove(mTmpPath.c_str());
}

void AtomicFile::commit()
{
    if (std::rename(mTmpPath.c_str(), mPath.c_str()) != 0) {
        throw Error(mPath + ": cannot move finished output into place (" + std::strerror(errno) +
                    ")");
    }
    mCommitted = true;
}

} // namespace nebula
