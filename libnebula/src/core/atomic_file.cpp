// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/atomic_file.h"

#include "nebula/core/error.h"

#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <dirent.h>
#include <fcntl.h>
#include <fstream>
#include <mutex>
#include <ostream>
#include <sstream>
#include <streambuf>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

namespace nebula {

namespace {

std::atomic<bool> gWriteThrough{false};

std::string folderOf(const std::string& path)
{
    const auto slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    if (slash == 0) return "/";
    return path.substr(0, slash);
}

std::string baseOf(const std::string& path)
{
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string osError(int err)
{
    return std::strerror(err != 0 ? err : EIO);
}

// ---- Temporaries removed on SIGINT, SIGTERM and SIGHUP ---------------------------------------
//
// The handler may only make async-signal-safe calls: it unlinks the paths of a fixed table
// (no allocation, no locks) and re-raises the signal with its default action, so the exit
// status still says which signal stopped the tool.

constexpr int MAX_TEMPORARIES = 32;
constexpr int SLOT_FREE = 0, SLOT_BUSY = 1, SLOT_READY = 2;
std::atomic<int> gSlotState[MAX_TEMPORARIES];
char gSlotPath[MAX_TEMPORARIES][PATH_MAX];

extern "C" void removeTemporariesAndDie(int sig)
{
    for (int i = 0; i < MAX_TEMPORARIES; ++i) {
        if (gSlotState[i].load() == SLOT_READY) ::unlink(gSlotPath[i]);
    }
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

void installSignalHandlers()
{
    static std::once_flag once;
    std::call_once(once, [] {
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
            struct sigaction old;
            if (::sigaction(sig, nullptr, &old) != 0) continue;
            if (old.sa_handler != SIG_DFL) continue; // ignored, or someone else's handler
            struct sigaction act;
            std::memset(&act, 0, sizeof act);
            act.sa_handler = removeTemporariesAndDie;
            sigemptyset(&act.sa_mask);
            ::sigaction(sig, &act, nullptr);
        }
    });
}

/// Registers @p path for removal on a signal; returns its slot, or -1 if the table is full
/// or the path too long (the file is then still removed by the destructor or the next run).
int registerTemporary(const std::string& path)
{
    if (path.size() + 1 > PATH_MAX) return -1;
    installSignalHandlers();
    for (int i = 0; i < MAX_TEMPORARIES; ++i) {
        int expected = SLOT_FREE;
        if (gSlotState[i].compare_exchange_strong(expected, SLOT_BUSY)) {
            std::memcpy(gSlotPath[i], path.c_str(), path.size() + 1);
            gSlotState[i].store(SLOT_READY);
            return i;
        }
    }
    return -1;
}

void unregisterTemporary(int slot)
{
    if (slot >= 0) gSlotState[slot].store(SLOT_FREE);
}

// ---- Stale temporaries -------------------------------------------------------------------------

/// Seconds since the epoch at which process @p pid started, or -1 if there is no such process.
double processStartTime(long pid)
{
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string text;
    if (!std::getline(stat, text)) {
        // No /proc (or no such process): fall back on kill(pid, 0).
        if (::kill(pid_t(pid), 0) == 0 || errno == EPERM) return 0.0;
        return -1.0;
    }
    // Field 22 (starttime, clock ticks since boot) comes after the ")" that ends the name.
    const auto close = text.rfind(')');
    if (close == std::string::npos) return 0.0;
    std::istringstream fields(text.substr(close + 2));
    std::string field;
    for (int i = 3; i <= 22 && fields >> field; ++i) {
    }
    const double ticks = std::strtod(field.c_str(), nullptr);
    std::ifstream procStat("/proc/stat");
    double bootTime = 0.0;
    for (std::string key; procStat >> key;) {
        if (key == "btime") {
            procStat >> bootTime;
            break;
        }
    }
    return bootTime + ticks / double(::sysconf(_SC_CLK_TCK));
}

/// The pid in "<pid>.XXXXXX[...]", or -1.
long pidOfTemporary(const std::string& rest)
{
    const auto dot = rest.find('.');
    if (dot == std::string::npos || dot == 0 || dot > 10) return -1;
    long pid = 0;
    for (std::size_t i = 0; i < dot; ++i) {
        if (rest[i] < '0' || rest[i] > '9') return -1;
        pid = pid * 10 + (rest[i] - '0');
    }
    return pid;
}

// ---- A checked, seekable stream buffer over a file descriptor ---------------------------------

class FdStreamBuf : public std::streambuf
{
public:
    explicit FdStreamBuf(int fd) : mFd(fd), mBuffer(1 << 20)
    {
        setp(mBuffer.data(), mBuffer.data() + mBuffer.size());
    }

    /// errno of the first failure, 0 if none.
    int error() const { return mError; }

    bool flushBuffer()
    {
        const char* p = pbase();
        std::size_t left = std::size_t(pptr() - pbase());
        while (left > 0 && mError == 0) {
            const ssize_t n = ::write(mFd, p, left);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                mError = n < 0 ? errno : EIO;
                break;
            }
            p += n;
            left -= std::size_t(n);
        }
        setp(mBuffer.data(), mBuffer.data() + mBuffer.size());
        return mError == 0;
    }

protected:
    int_type overflow(int_type c) override
    {
        if (!flushBuffer()) return traits_type::eof();
        if (!traits_type::eq_int_type(c, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(c);
            pbump(1);
        }
        return traits_type::not_eof(c);
    }
    int sync() override { return flushBuffer() ? 0 : -1; }
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override
    {
        if (!flushBuffer()) return pos_type(off_type(-1));
        const int whence = dir == std::ios_base::beg   ? SEEK_SET
                           : dir == std::ios_base::cur ? SEEK_CUR
                                                       : SEEK_END;
        const off_t pos = ::lseek(mFd, off_t(off), whence);
        if (pos < 0) {
            if (mError == 0) mError = errno;
            return pos_type(off_type(-1));
        }
        return pos_type(off_type(pos));
    }
    pos_type seekpos(pos_type pos, std::ios_base::openmode mode) override
    {
        return seekoff(off_type(pos), std::ios_base::beg, mode);
    }

private:
    int mFd;
    std::vector<char> mBuffer;
    int mError = 0;
};

void fsyncFolder(const std::string& path)
{
    const int fd = ::open(folderOf(path).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    ::fsync(fd); // EINVAL on filesystems without directory sync: nothing more to do
    ::close(fd);
}

const char* kindOf(mode_t mode)
{
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    if (S_ISLNK(mode)) return "a symbolic link";
    if (S_ISDIR(mode)) return "a folder";
    return "not a regular file";
}

} // namespace

void setWriteThrough(bool enabled)
{
    gWriteThrough = enabled;
}

void checkOutputWritable(const std::string& path, const std::string& what)
{
    const std::string folder = folderOf(path);
    if (::access(folder.c_str(), W_OK | X_OK) != 0) {
        throw Error(path + ": cannot write " + what + ": folder \"" + folder +
                    "\" is not writable (" + std::strerror(errno) + ")");
    }
    struct stat st;
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
        throw Error(path + ": cannot write " + what + ": it is a folder");
    }
}

void checkOutputTarget(const std::string& path, const std::string& what)
{
    struct stat st;
    if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
        if (S_ISDIR(st.st_mode)) throw Error(path + ": cannot write " + what + ": it is a folder");
        if (!gWriteThrough) {
            throw UsageError(what + " " + path + ": output is " + kindOf(st.st_mode) +
                             ", not a regular file; nebula replaces outputs atomically and "
                             "refuses to replace it (give --write-through to write through it)");
        }
        return; // written through as it is, as AtomicFile does
    }
    checkOutputWritable(path, what);
}

std::string AtomicFile::tmpPrefix(const std::string& path)
{
    return path + ".tmp." + std::to_string(long(::getpid())) + ".";
}

int removeStaleTemporaries(const std::string& path)
{
    const std::string folder = folderOf(path);
    const std::string prefix = baseOf(path) + ".tmp.";
    DIR* dir = ::opendir(folder.c_str());
    if (!dir) return 0;
    int removed = 0;
    while (const dirent* entry = ::readdir(dir)) {
        const std::string name = entry->d_name;
        if (name.compare(0, prefix.size(), prefix) != 0) continue;
        const long pid = pidOfTemporary(name.substr(prefix.size()));
        if (pid <= 0 || pid == long(::getpid())) continue;
        const std::string full = folder + "/" + name;
        struct stat st;
        if (::lstat(full.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
        const double started = processStartTime(pid);
        // A live writer started before it last wrote its temporary (1 s of slack for the
        // clock-tick resolution of the start time).
        const bool writerAlive = started >= 0.0 && started <= double(st.st_mtime) + 1.0;
        if (!writerAlive && ::unlink(full.c_str()) == 0) ++removed;
    }
    ::closedir(dir);
    return removed;
}

struct AtomicFile::Impl
{
    int fd = -1;
    int slot = -1;
    std::unique_ptr<FdStreamBuf> fileBuf;      ///< temporary file
    std::unique_ptr<std::stringbuf> directBuf; ///< write-through: the whole output in memory
    std::ostream stream{nullptr};
};

AtomicFile::AtomicFile(const std::string& path)
    : mImpl(std::make_unique<Impl>()), mPath(path), mTarget(path)
{
    struct stat st;
    bool direct = false;
    if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
        if (S_ISDIR(st.st_mode)) throw Error(path + ": cannot write: it is a folder");
        if (!gWriteThrough) {
            throw UsageError(path + ": output is " + kindOf(st.st_mode) +
                             ", not a regular file; nebula replaces outputs atomically and "
                             "refuses to replace it (give --write-through to write through it)");
        }
        if (S_ISLNK(st.st_mode)) {
            char* resolved = ::realpath(path.c_str(), nullptr);
            if (!resolved) {
                // A dangling link: create the file it points to.
                std::vector<char> buf(PATH_MAX + 1);
                const ssize_t n = ::readlink(path.c_str(), buf.data(), PATH_MAX);
                if (n <= 0)
                    throw Error(path + ": cannot resolve symbolic link (" + osError(errno) + ")");
                const std::string link(buf.data(), std::size_t(n));
                mTarget = link.front() == '/' ? link : folderOf(path) + "/" + link;
            } else {
                mTarget = resolved;
                std::free(resolved);
            }
            if (::stat(mTarget.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) direct = true;
        } else {
            direct = true;
        }
    }

    if (direct) {
        mImpl->fd = ::open(mTarget.c_str(), O_WRONLY | O_CLOEXEC);
        if (mImpl->fd < 0) throw Error(path + ": cannot open for writing (" + osError(errno) + ")");
        mImpl->directBuf = std::make_unique<std::stringbuf>(std::ios::out | std::ios::binary);
        mImpl->stream.rdbuf(mImpl->directBuf.get());
        return;
    }

    checkOutputWritable(mTarget, "output");
    removeStaleTemporaries(mTarget);
    // mkstemp gives a unique name in the target's folder, so rename() stays on one filesystem;
    // the pid in the name lets a later run tell a dead writer's temporary from a live one's.
    std::string pattern = tmpPrefix(mTarget) + "XXXXXX";
    std::vector<char> buf(pattern.begin(), pattern.end());
    buf.push_back('\0');
    const int fd = ::mkostemp(buf.data(), O_CLOEXEC);
    if (fd < 0) {
        throw Error(path + ": cannot create temporary output file (" + osError(errno) + ")");
    }
    mTmpPath = buf.data();
    mImpl->fd = fd;
    mImpl->slot = registerTemporary(mTmpPath);
    // mkstemp creates the file 0600; give it the permissions an ordinary open() would.
    const mode_t mask = ::umask(0);
    ::umask(mask);
    ::fchmod(fd, 0666 & ~mask);
    mImpl->fileBuf = std::make_unique<FdStreamBuf>(fd);
    mImpl->stream.rdbuf(mImpl->fileBuf.get());
}

AtomicFile::~AtomicFile()
{
    if (mImpl->fd >= 0) ::close(mImpl->fd);
    if (!mCommitted && !mTmpPath.empty()) ::unlink(mTmpPath.c_str());
    unregisterTemporary(mImpl->slot);
}

std::ostream& AtomicFile::stream()
{
    return mImpl->stream;
}

void AtomicFile::fail(const std::string& what, int err)
{
    throw Error(mPath + ": cannot write: " + what + " failed (" + osError(err) + ")");
}

void AtomicFile::finish()
{
    if (mFinished) return;
    Impl& d = *mImpl;
    if (d.fileBuf) {
        d.fileBuf->flushBuffer();
        if (d.fileBuf->error() != 0) fail("write", d.fileBuf->error());
        if (!d.stream) fail("write", EIO); // a writer's own error (it set badbit)
        if (::fsync(d.fd) != 0) fail("fsync", errno);
    } else {
        const std::string data = d.directBuf->str();
        if (!d.stream) fail("write", EIO);
        const char* p = data.data();
        std::size_t left = data.size();
        while (left > 0) {
            const ssize_t n = ::write(d.fd, p, left);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) fail("write", n < 0 ? errno : EIO);
            p += n;
            left -= std::size_t(n);
        }
    }
    const int fd = d.fd;
    d.fd = -1;
    if (::close(fd) != 0) fail("close", errno);
    mFinished = true;
}

void AtomicFile::rename()
{
    if (mTmpPath.empty()) { // written through
        mCommitted = true;
        return;
    }
    if (::rename(mTmpPath.c_str(), mTarget.c_str()) != 0) {
        throw Error(mPath + ": cannot move finished output into place (" + osError(errno) + ")");
    }
    mCommitted = true;
    unregisterTemporary(mImpl->slot);
    mImpl->slot = -1;
    fsyncFolder(mTarget);
}

void AtomicFile::commit()
{
    finish();
    rename();
}

void commitAll(const std::vector<AtomicFile*>& files)
{
    for (AtomicFile* f : files)
        f->finish();
    // Hard links to the old contents, so that a failed rename can put them back.
    std::vector<std::string> backups(files.size());
    for (std::size_t i = 0; i < files.size(); ++i) {
        if (files[i]->mTmpPath.empty()) continue;
        const std::string backup = files[i]->mTmpPath + ".old";
        if (::link(files[i]->mTarget.c_str(), backup.c_str()) == 0) backups[i] = backup;
    }
    std::size_t done = 0;
    try {
        for (; done < files.size(); ++done)
            files[done]->rename();
    } catch (...) {
        for (std::size_t j = 0; j < done; ++j) {
            if (files[j]->mTmpPath.empty()) continue;
            if (!backups[j].empty()) {
                ::rename(backups[j].c_str(), files[j]->mTarget.c_str());
                backups[j].clear();
            } else {
                ::unlink(files[j]->mTarget.c_str()); // it did not exist before
            }
        }
        for (const auto& b : backups)
            if (!b.empty()) ::unlink(b.c_str());
        throw;
    }
    for (const auto& b : backups)
        if (!b.empty()) ::unlink(b.c_str());
}

} // namespace nebula
