#include "nebula/core/input.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
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

std::string readInput(const std::string& path, const InputSpec& spec)
{
    // The main input is named by its path alone, as every later message about it is.
    const std::string where =
        spec.option == "-i" ? inputName(path) : inputName(path) + " (" + spec.option + ")";
    Fd in;
    if (path == "-") {
        if (::isatty(STDIN_FILENO)) {
            throw UsageError(spec.option + " -: stdin is a terminal; pipe " + spec.format +
                             " in or give a file");
        }
        in.fd = STDIN_FILENO;
    } else {
        in.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (in.fd < 0) {
            throw Error(where + ": cannot open file (" + std::strerror(errno) + ")");
        }
        in.owned = true;
    }
    struct stat st;
    if (::fstat(in.fd, &st) != 0) {
        throw Error(where + ": cannot read file (" + std::strerror(errno) + ")");
    }
    if (S_ISDIR(st.st_mode)) throw Error(where + ": is a folder, not " + spec.format);
    const bool regular = S_ISREG(st.st_mode);
    std::string bytes;
    if (regular && st.st_size > 0) {
        const auto size = std::uint64_t(st.st_size);
        if (size > spec.limit) {
            throw Error(fmt::format("{}: the file has {}, more than the {} nebula reads of {} "
                                    "(README, Failure behaviour)",
                                    where, bytesText(double(size)), bytesText(double(spec.limit)),
                                    spec.format));
        }
        if (spec.checkMemory) requireMemory(double(size), where + ": reading the file");
    }
    bool headKnown = !spec.head;
    // Small reads until the head is known, so that a wrong stream is refused at once.
    std::vector<char> chunk(std::size_t(64) << 10);
    for (;;) {
        const ssize_t n = ::read(in.fd, chunk.data(), chunk.size());
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
