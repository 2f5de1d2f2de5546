// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file input.h
/// Every input's way in, the counterpart of atomic_file.h: a file, "-" (stdin), /dev/stdin,
/// /dev/fd/N, a FIFO or a process substitution is read once, as the stream it is, with a size
/// limit, and the format's first bytes are checked as soon as they arrive, before the rest is
/// read. So an endless or huge input (/dev/zero, gigabytes of anything on a pipe) is refused
/// after its first bytes or at the limit, naming the file and the option, never read whole
/// first; and a config file from a pipe is the same text that is checked and applied.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace nebula {

/// The largest JSON document (stars, dust, camera paths, metadata) or config file read [bytes].
inline constexpr std::uint64_t MAX_TEXT_INPUT_BYTES = std::uint64_t(16) << 20;
/// The largest VDB file or stream read [bytes] (also refused beyond the machine's memory).
inline constexpr std::uint64_t MAX_GRID_INPUT_BYTES = std::uint64_t(64) << 30;

/// What readInput() reads and how it recognises it.
struct InputSpec
{
    /// Names the input in messages with its option, e.g. "--stars", "-i", "--config".
    std::string option;
    /// The format in words, for messages: "a JSON file", "a VDB file", "a config file".
    std::string format;
    std::uint64_t limit = MAX_TEXT_INPUT_BYTES;
    /// Checks the first bytes: returns true once @p head (everything read so far) is known
    /// to start as this format, false while it needs more bytes (it is called again with
    /// more, and with @p atEnd true at the end of the input), and throws Error naming
    /// @p source when the bytes cannot be this format. Empty: no check.
    std::function<bool(std::string_view head, bool atEnd, const std::string& source)> head;
    /// Also refuse an input larger than the machine's memory (requireMemory()).
    bool checkMemory = false;
};

/// The name of @p path in messages: "<stdin>" for "-", else the path.
std::string inputName(const std::string& path);

/// Reads all of @p path ("-" = stdin) as @p spec says. Throws Error "<path> (<option>): ..."
/// ("<path>: ..." for -i, the tool's main input, as every later message about it reads)
/// when it cannot be opened or read, is a folder, is larger than spec.limit (a regular
/// file's size is checked before reading; a stream is refused as soon as it passes the
/// limit; both sizes in the message), or its head is not the format. A terminal on stdin is
/// a UsageError.
std::string readInput(const std::string& path, const InputSpec& spec);

/// An input's bytes without a second copy in memory: a regular file is mapped read-only (its
/// pages are the kernel's page cache, shared, dropped under memory pressure), a stream's bytes
/// are held as read. Move-only.
class InputBytes
{
public:
    InputBytes() = default;
    /// Bytes read into memory (a stream).
    explicit InputBytes(std::string bytes) : mBytes(std::move(bytes)) {}
    /// Bytes someone else holds, for as long as this lives (a test's or a fuzzer's buffer).
    static InputBytes borrow(std::string_view bytes);
    InputBytes(InputBytes&& other) noexcept;
    InputBytes& operator=(InputBytes&& other) noexcept;
    InputBytes(const InputBytes&) = delete;
    InputBytes& operator=(const InputBytes&) = delete;
    ~InputBytes();

    std::string_view view() const
    {
        return mData ? std::string_view(mData, mSize) : std::string_view(mBytes);
    }
    /// True when the bytes are a mapped file (release() then frees memory).
    bool mapped() const { return mMapped; }
    /// Drops the whole pages of [begin, end) from this process's memory: a mapped file's pages
    /// are read back from the page cache if touched again, so a reader that has parsed them
    /// stops paying for them (a 4 GiB file parsed into grids does not count twice). Nothing
    /// for bytes in memory.
    void release(std::size_t begin, std::size_t end) const;

private:
    friend InputBytes mapInput(const std::string& path, const InputSpec& spec);
    void unmap() noexcept;
    const char* mData = nullptr; ///< a mapping or borrowed bytes; else mBytes
    std::size_t mSize = 0;
    bool mMapped = false;
    int mSlot = -1; ///< the mapping's entry in the SIGBUS handler's table (mapInput())
    std::string mBytes;
};

/// readInput(), except that a non-empty regular file is mapped, not read: the same checks
/// (size limit, head), no copy. If another program truncates the file while it is mapped,
/// reading past its new end ends the tool with "<tool>: error: <file>: the file shrank while
/// it was read ..." and exit status 1 (a SIGBUS handler), not a crash. Streams (stdin, FIFOs,
/// process substitutions) are read as readInput() reads them. spec.checkMemory applies to streams
/// only: a mapped file takes no memory of its own.
InputBytes mapInput(const std::string& path, const InputSpec& spec);

/// A head check for JSON: the first byte that is not white space must open an object or an
/// array (@p opens, e.g. "[" or "{["). An empty or all-blank input is refused too.
std::function<bool(std::string_view, bool, const std::string&)> jsonHead(const std::string& opens,
                                                                         const std::string& what);

/// A head check for text (config files): no NUL or other control byte except tab, CR and LF
/// in the first 4 KiB. Messages start with @p name ("--config: c.toml"), or with readInput()'s
/// name of the input if @p name is empty.
std::function<bool(std::string_view, bool, const std::string&)>
textHead(const std::string& name = "");

} // namespace nebula
