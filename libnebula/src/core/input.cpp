// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/input.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <mutex>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <utility>
#include <vector>

namespace nebula {

std::string inputName(const std::string& path)
{
    return path == "-" ? std::string("<stdin>") : path;
}

namespace {

/// Closes a descriptor it opened on every way out.
struct Fd
{
    int fd = -1;
    bool owned = false;
    ~Fd()
    {
        if (owned && fd >= 0) ::close(fd);
    }
};

} // namespace

namespace {

/// An input opened for reading: its descriptor, status and name in messages.
struct Opened
{
    Fd in;
    struct stat st = {};
    std::string where;
};

void openInput(const std::string& path, const InputSpec& spec, Opened& o)
{
    // The main input is named by its path alone, as every later message about it is.
    o.where = spec.option == "-i" ? inputName(path) : inputName(path) + " (" + spec.option + ")";
    if (path == "-") {
        if (::isatty(STDIN_FILENO)) {
            throw UsageError(spec.option + " -: stdin is a terminal; pipe " + spec.format +
                             " in or give a file");
        }
        o.in.fd = STDIN_FILENO;
    } else {
        o.in.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (o.in.fd < 0) {
            throw Error(o.where + ": cannot open file (" + std::strerror(errno) + ")");
        }
        o.in.owned = true;
    }
    if (::fstat(o.in.fd, &o.st) != 0) {
        throw Error(o.where + ": cannot read file (" + std::strerror(errno) + ")");
    }
    if (S_ISDIR(o.st.st_mode)) throw Error(o.where + ": is a folder, not " + spec.format);
    if (S_ISREG(o.st.st_mode) && o.st.st_size > 0) {
        const auto size = std::uint64_t(o.st.st_size);
        if (size > spec.limit) {
            throw Error(fmt::format("{}: the file has {}, more than the {} nebula reads of {} "
                                    "(README, Failure behaviour)",
                                    o.where, bytesText(double(size)), bytesText(double(spec.limit)),
                                    spec.format));
        }
    }
}

/// Reads all of an opened input (see readInput()).
std::string readOpened(const Opened& o, const InputSpec& spec)
{
    const std::string& where = o.where;
    const struct stat& st = o.st;
    const int fd = o.in.fd;
    const bool regular = S_ISREG(st.st_mode);
    std::string bytes;
    if (regular && st.st_size > 0 && spec.checkMemory) {
        requireMemory(double(st.st_size), where + ": reading the file");
    }
    bool headKnown = !spec.head;
    // Small reads until the head is known, so that a wrong stream is refused at once.
    std::vector<char> chunk(std::size_t(64) << 10);
    for (;;) {
        const ssize_t n = ::read(fd, chunk.data(), chunk.size());
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw Error(where + ": read failed (" + std::strerror(errno) + ")");
        if (n == 0) break;
        if (std::uint64_t(bytes.size()) + std::uint64_t(n) > spec.limit) {
            throw Error(fmt::format("{}: more than {} arrived, the most nebula reads of {} "
                                    "(README, Failure behaviour)",
                                    where, bytesText(double(spec.limit)), spec.format));
        }
        if (regular && bytes.empty() && st.st_size > 0) bytes.reserve(std::size_t(st.st_size));
        if (spec.checkMemory && !regular && bytes.size() + std::size_t(n) > bytes.capacity()) {
            // A stream that would outgrow the machine is refused before the string grows.
            requireMemory(2.0 * double(bytes.size() + std::size_t(n)),
                          where + ": reading the stream");
        }
        bytes.append(chunk.data(), std::size_t(n));
        if (!headKnown) {
            headKnown = spec.head(bytes, false, where);
            if (headKnown) chunk.resize(std::size_t(1) << 20);
        }
    }
    if (!headKnown) spec.head(bytes, true, where);
    return bytes;
}

} // namespace

std::string readInput(const std::string& path, const InputSpec& spec)
{
    Opened o;
    openInput(path, spec, o);
    return readOpened(o, spec);
}

namespace {

// ---- A mapped file that shrinks while it is read ---------------------------------------------
//
// Reading a page of a mapping past the end of its file raises SIGBUS: another program truncated
// or rewrote the file in place while a tool read it. The handler names the file and exits 1,
// as any other read error does, instead of dying of the signal. It makes async-signal-safe
// calls only: it scans a fixed table (no allocation, no locks) and writes to stderr.

constexpr int MAX_MAPPINGS = 16;
constexpr int MAP_FREE = 0, MAP_BUSY = 1, MAP_READY = 2;
std::atomic<int> gMapState[MAX_MAPPINGS];
const char* gMapBegin[MAX_MAPPINGS];
std::size_t gMapSize[MAX_MAPPINGS];
char gMapName[MAX_MAPPINGS][512];
struct sigaction gOldBus; ///< the handler before ours (a sanitizer's), for other addresses

void writeAll(const char* text)
{
    std::size_t left = std::strlen(text);
    while (left > 0) {
        const ssize_t n = ::write(STDERR_FILENO, text, left);
        if (n <= 0) return;
        text += n;
        left -= std::size_t(n);
    }
}

extern "C" void mappedFileShrank(int sig, siginfo_t* info, void* context)
{
    const char* at = static_cast<const char*>(info->si_addr);
    for (int i = 0; i < MAX_MAPPINGS; ++i) {
        if (gMapState[i].load() != MAP_READY) continue;
        if (at >= gMapBegin[i] && at < gMapBegin[i] + gMapSize[i]) {
            writeAll(program_invocation_short_name);
            writeAll(": error: ");
            writeAll(gMapName[i]);
            writeAll(": the file shrank while it was read (another program truncated or "
                     "rewrote it in place); run again once it is complete\n");
            ::_exit(1);
        }
    }
    // Not a mapped input's page: what would have happened without this handler.
    if ((gOldBus.sa_flags & SA_SIGINFO) != 0 && gOldBus.sa_sigaction != nullptr) {
        gOldBus.sa_sigaction(sig, info, context);
        return;
    }
    if (gOldBus.sa_handler != SIG_DFL && gOldBus.sa_handler != SIG_IGN &&
        gOldBus.sa_handler != nullptr) {
        gOldBus.sa_handler(sig);
        return;
    }
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

/// Registers a mapping for the handler; its slot, or -1 if the table is full.
int registerMapping(const char* begin, std::size_t size, const std::string& name)
{
    static std::once_flag once;
    std::call_once(once, [] {
        struct sigaction act;
        std::memset(&act, 0, sizeof act);
        act.sa_sigaction = mappedFileShrank;
        act.sa_flags = SA_SIGINFO;
        sigemptyset(&act.sa_mask);
        ::sigaction(SIGBUS, &act, &gOldBus);
    });
    for (int i = 0; i < MAX_MAPPINGS; ++i) {
        int expected = MAP_FREE;
        if (gMapState[i].compare_exchange_strong(expected, MAP_BUSY)) {
            gMapBegin[i] = begin;
            gMapSize[i] = size;
            const std::size_t n = std::min(name.size(), sizeof gMapName[i] - 1);
            std::memcpy(gMapName[i], name.data(), n);
            gMapName[i][n] = '\0';
            gMapState[i].store(MAP_READY);
            return i;
        }
    }
    return -1;
}

} // namespace

InputBytes InputBytes::borrow(std::string_view bytes)
{
    InputBytes in;
    in.mData = bytes.data() ? bytes.data() : "";
    in.mSize = bytes.size();
    return in;
}

InputBytes::InputBytes(InputBytes&& other) noexcept
    : mData(std::exchange(other.mData, nullptr)), mSize(std::exchange(other.mSize, 0)),
      mMapped(std::exchange(other.mMapped, false)), mSlot(std::exchange(other.mSlot, -1)),
      mBytes(std::move(other.mBytes))
{}

InputBytes& InputBytes::operator=(InputBytes&& other) noexcept
{
    if (this != &other) {
        unmap();
        mData = std::exchange(other.mData, nullptr);
        mSize = std::exchange(other.mSize, 0);
        mMapped = std::exchange(other.mMapped, false);
        mSlot = std::exchange(other.mSlot, -1);
        mBytes = std::move(other.mBytes);
    }
    return *this;
}

InputBytes::~InputBytes()
{
    unmap();
}

void InputBytes::unmap() noexcept
{
    if (mSlot >= 0) gMapState[mSlot].store(MAP_FREE);
    mSlot = -1;
    if (mMapped) ::munmap(const_cast<char*>(mData), mSize);
    mMapped = false;
}

void InputBytes::release(std::size_t begin, std::size_t end) const
{
    if (!mMapped) return;
    const auto page = std::size_t(::sysconf(_SC_PAGESIZE));
    end = std::min(end, mSize);
    const std::size_t first = (begin + page - 1) / page * page; // whole pages only
    const std::size_t last = end == mSize ? end : end / page * page;
    if (last <= first) return;
    // Advice only: a failure leaves the pages mapped, which costs memory, not correctness.
    (void)::madvise(const_cast<char*>(mData) + first, last - first, MADV_DONTNEED);
}

InputBytes mapInput(const std::string& path, const InputSpec& spec)
{
    Opened o;
    openInput(path, spec, o);
    if (!S_ISREG(o.st.st_mode) || o.st.st_size <= 0) return InputBytes(readOpened(o, spec));
    const auto size = std::size_t(o.st.st_size);
    void* p = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, o.in.fd, 0);
    if (p == MAP_FAILED) {
        throw Error(o.where + ": cannot map file (" + std::strerror(errno) + ")");
    }
    (void)::madvise(p, size, MADV_SEQUENTIAL);
    InputBytes bytes;
    bytes.mData = static_cast<const char*>(p);
    bytes.mSize = size;
    bytes.mMapped = true;
    bytes.mSlot = registerMapping(bytes.mData, size, o.where);
    if (spec.head) spec.head(bytes.view(), true, o.where);
    return bytes;
}

std::function<bool(std::string_view, bool, const std::string&)> jsonHead(const std::string& opens,
                                                                         const std::string& what)
{
    return [opens, what](std::string_view head, bool atEnd, const std::string& source) {
        for (const char c : head) {
            if (c == ' ' || c == '\t' || c == '\r' || c == '\n') continue;
            if (opens.find(c) != std::string::npos) return true;
            const auto byte = static_cast<unsigned char>(c);
            const std::string shown = (byte >= 32 && byte < 127)
                                          ? fmt::format("'{}'", c)
                                          : fmt::format("byte 0x{:02X}", unsigned(byte));
            throw Error(
                fmt::format("{}: not {}: it starts with {}, expected {}", source, what, shown,
                            opens.size() == 1 ? "'" + opens + "'" : "one of \"" + opens + "\""));
        }
        if (atEnd) throw Error(source + ": empty: expected " + what);
        // All blank so far: refuse a stream of nothing but white space at 1 MiB.
        if (head.size() > (std::size_t(1) << 20)) {
            throw Error(source + ": more than 1 MiB of white space; expected " + what);
        }
        return false;
    };
}

std::function<bool(std::string_view, bool, const std::string&)> textHead(const std::string& name)
{
    return [name](std::string_view head, bool atEnd, const std::string& source) {
        std::size_t line = 1, column = 0;
        for (const char c : head.substr(0, 4096)) {
            ++column;
            const auto byte = static_cast<unsigned char>(c);
            if (byte == '\n') {
                ++line;
                column = 0;
                continue;
            }
            if ((byte < 0x20 && byte != '\t' && byte != '\r') || byte == 0x7f) {
                throw Error(fmt::format("{}, line {}: byte 0x{:02X} at column {} is not text; a "
                                        "config file holds lines \"key = value\"",
                                        name.empty() ? source : name, line, unsigned(byte),
                                        column));
            }
        }
        return atEnd || head.size() >= 4096;
    };
}

} // namespace nebula
