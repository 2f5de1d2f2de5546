// SPDX-License-Identifier: Apache-2.0
// FITS headers read by nebula itself (fits_header.h): the declared size of a file, the first
// card that breaks the standard, and gzipped files inflated within their declared size.
#include "fits_header.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <unistd.h>
#include <vector>

namespace nebula::detail {

namespace {

constexpr std::size_t CARD = 80;

std::string_view trim(std::string_view s)
{
    while (!s.empty() && s.back() == ' ')
        s.remove_suffix(1);
    while (!s.empty() && s.front() == ' ')
        s.remove_prefix(1);
    return s;
}

/// A header card: its keyword (blanks trimmed) and, after "= ", its value field without the
/// comment (a string with its quotes).
struct Card
{
    std::string_view keyword, value;
    bool valued = false;
    bool unclosedQuote = false;
};

Card readCard(std::string_view c)
{
    Card card;
    card.keyword = trim(c.substr(0, 8));
    card.valued = c.substr(8, 2) == "= ";
    if (!card.valued) return card;
    std::string_view v = c.substr(10);
    std::size_t start = v.find_first_not_of(' ');
    if (start == std::string_view::npos) return card;
    if (v[start] == '\'') {
        // A string: '' is a quote inside it.
        std::size_t i = start + 1;
        while (i < v.size()) {
            if (v[i] == '\'') {
                if (i + 1 < v.size() && v[i + 1] == '\'') {
                    i += 2;
                    continue;
                }
                break;
            }
            ++i;
        }
        card.unclosedQuote = i >= v.size();
        card.value = v.substr(start, std::min(v.size(), i + 1) - start);
        return card;
    }
    card.value = trim(v.substr(start, v.find('/', start) - start));
    return card;
}

/// An integer value: [+-]digits, at most 18 of them.
bool parseInt(std::string_view v, long long& out)
{
    std::size_t i = 0;
    bool negative = false;
    if (i < v.size() && (v[i] == '+' || v[i] == '-')) negative = v[i++] == '-';
    if (i == v.size() || v.size() - i > 18) return false;
    long long n = 0;
    for (; i < v.size(); ++i) {
        if (v[i] < '0' || v[i] > '9') return false;
        n = n * 10 + (v[i] - '0');
    }
    out = negative ? -n : n;
    return true;
}

std::uint64_t roundUp(double bytes)
{
    const double b = std::ceil(bytes / double(FITS_BLOCK)) * double(FITS_BLOCK);
    return b >= 9e18 ? std::uint64_t(9e18) : std::uint64_t(b);
}

bool legalBitpix(long long b)
{
    return b == 8 || b == 16 || b == 32 || b == 64 || b == -32 || b == -64;
}

} // namespace

bool parseFitsNumber(std::string_view value, double& out)
{
    std::string text(value);
    std::size_t i = 0, digits = 0;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    for (; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i)
        ++digits;
    if (i < text.size() && text[i] == '.') {
        for (++i; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i)
            ++digits;
    }
    if (digits == 0) return false;
    if (i < text.size() && (text[i] == 'E' || text[i] == 'e' || text[i] == 'D' || text[i] == 'd')) {
        text[i] = 'E';
        ++i;
        if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
        std::size_t exp = 0;
        for (; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i)
            ++exp;
        if (exp == 0) return false;
    }
    if (i != text.size()) return false;
    out = std::strtod(text.c_str(), nullptr); // +-inf beyond double range: the caller refuses it
    return true;
}

void FitsLayout::startHdu(std::string_view bytes)
{
    const Card first = readCard(bytes.substr(mDeclared, CARD));
    if (first.keyword != (mPrimary ? "SIMPLE" : "XTENSION")) {
        mEnded = true; // not an HDU: what follows is not declared
        return;
    }
    mStarted = true;
    mCursor = mDeclared;
    mBitpix = 0;
    mNaxis = -1;
    mPcount = 0;
    mGcount = 1;
    mGroups = false;
    std::fill(std::begin(mAxes), std::end(mAxes), -1);
}

void FitsLayout::endHeader()
{
    const std::uint64_t headerEnd = mDeclared + roundUp(double(mCursor - mDeclared));
    mStarted = false;
    mPrimary = false;
    bool ok = legalBitpix(mBitpix) && mNaxis >= 0 && mNaxis <= 999 && mPcount >= 0 && mGcount >= 0;
    double count = mNaxis > 0 ? 1.0 : 0.0;
    for (long long i = 0; ok && i < mNaxis; ++i) {
        if (mAxes[i] < 0) ok = false;
        if (!(i == 0 && mGroups && mAxes[0] == 0)) count *= double(mAxes[i]);
    }
    if (!ok) { // cfitsio refuses this header: no size can be trusted after it
        mDeclared = headerEnd;
        mEnded = true;
        return;
    }
    const double data =
        double(std::llabs(mBitpix) / 8) * double(mGcount) * (double(mPcount) + count);
    mDeclared = headerEnd + roundUp(data);
    mCursor = mDeclared;
}

void FitsLayout::advance(std::string_view bytes)
{
    while (!mEnded) {
        if (!mStarted) {
            if (bytes.size() < mDeclared + CARD) return;
            startHdu(bytes);
            if (mEnded) return;
        }
        bool headerDone = false;
        while (mCursor + CARD <= bytes.size()) {
            const Card card = readCard(bytes.substr(mCursor, CARD));
            mCursor += CARD;
            if (card.keyword == "END") {
                headerDone = true;
                break;
            }
            long long v = 0;
            const bool isInt = card.valued && parseInt(card.value, v);
            if (card.keyword == "BITPIX") {
                mBitpix = isInt ? v : 0;
            } else if (card.keyword == "NAXIS") {
                mNaxis = isInt ? v : -1;
            } else if (card.keyword.size() > 5 && card.keyword.substr(0, 5) == "NAXIS") {
                long long n = 0;
                if (parseInt(card.keyword.substr(5), n) && n >= 1 && n <= 999)
                    mAxes[n - 1] = isInt ? v : -1;
            } else if (card.keyword == "PCOUNT") {
                mPcount = isInt ? v : -1;
            } else if (card.keyword == "GCOUNT") {
                mGcount = isInt ? v : -1;
            } else if (card.keyword == "GROUPS") {
                mGroups = card.value == "T";
            }
            if (mCursor - mDeclared >= MAX_FITS_HEADER_BYTES) {
                mEnded = true; // no END in sight: nothing after it is declared
                return;
            }
        }
        if (!headerDone) return;
        endHeader();
    }
}

std::uint64_t FitsLayout::bound() const
{
    return mDeclared + (mEnded ? 0 : MAX_FITS_HEADER_BYTES) + FITS_GZIP_MARGIN;
}

std::string headerFault(std::string_view bytes, bool primary)
{
    long long naxis = -1;
    const std::size_t cards = bytes.size() / CARD;
    bool hasEnd = false;
    for (std::size_t i = 0; i < cards && !hasEnd; ++i)
        hasEnd = readCard(bytes.substr(i * CARD, CARD)).keyword == "END";
    for (std::size_t i = 0; i < cards; ++i) {
        const std::string_view raw = bytes.substr(i * CARD, CARD);
        const Card card = readCard(raw);
        const std::string kw = printable(std::string(card.keyword), 16);
        const std::string label = "card " + std::to_string(i + 1) + " (" + kw + ")";
        const std::string value = printable(std::string(card.value), 40);
        for (std::size_t j = 0; j < CARD; ++j) {
            const auto c = static_cast<unsigned char>(raw[j]);
            if (c < 32 || c > 126) {
                if (!hasEnd && i > 0) { // cards, then bytes that are not: no END between
                    return "no END card in the first " + std::to_string(i * CARD) +
                           " bytes of the header (card " + std::to_string(i + 1) +
                           " is not header text)";
                }
                const bool keywordText = kw.find("\\x") == std::string::npos;
                return "card " + std::to_string(i + 1) +
                       (card.keyword.empty() || !keywordText ? std::string() : " (" + kw + ")") +
                       fmt::format(": byte \\x{:02x} in column {} is not printable ASCII", c,
                                   j + 1);
            }
        }
        long long v = 0;
        const bool isInt = card.valued && parseInt(card.value, v);
        if (i == 0) {
            const char* want = primary ? "SIMPLE" : "XTENSION";
            if (card.keyword != want) {
                return "card 1 is " + (kw.empty() ? std::string("blank") : kw) + ", expected " +
                       want + (primary ? " (is it a FITS file?)" : " (the start of an HDU)");
            }
            if (primary && card.value != "T") {
                return label + ": SIMPLE = " + value + ", expected T (a standard FITS file)";
            }
            continue;
        }
        if (i == 1 && (card.keyword != "BITPIX" || !isInt || !legalBitpix(v))) {
            return card.keyword != "BITPIX"
                       ? label + ": expected BITPIX as the second keyword"
                       : label + ": BITPIX = " + value + ", expected 8, 16, 32, 64, -32 or -64";
        }
        if (i == 2) {
            if (card.keyword != "NAXIS" || !isInt || v < 0 || v > 999) {
                return card.keyword != "NAXIS"
                           ? label + ": expected NAXIS as the third keyword"
                           : label + ": NAXIS = " + value + ", expected an integer 0 to 999";
            }
            naxis = v;
            continue;
        }
        if (i >= 3 && (long long)(i) < 3 + naxis) {
            const std::string want = "NAXIS" + std::to_string(i - 2);
            if (card.keyword != want) return label + ": expected " + want;
            if (!isInt || v < 0) {
                return label + ": " + want + " = " + value + ", expected an integer >= 0";
            }
            continue;
        }
        if (card.keyword == "END") {
            if (trim(raw.substr(3)).size() > 0)
                return label + ": the END card is not blank after END";
            const std::size_t fill = std::min(bytes.size(), (i / 36 + 1) * 36 * CARD);
            for (std::size_t j = (i + 1) * CARD; j < fill; ++j) {
                if (bytes[j] != ' ') {
                    return "the header's last record is not blank after its END card (card " +
                           std::to_string(j / CARD + 1) + ")";
                }
            }
            return "";
        }
        const bool commentary = card.keyword == "COMMENT" || card.keyword == "HISTORY" ||
                                card.keyword == "HIERARCH" || card.keyword.empty();
        if (!commentary) {
            for (char c : card.keyword) {
                // Lower case is against the standard, but cfitsio and astropy read it as upper.
                if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) {
                    return label + ": the keyword has a character other than A-Z, 0-9, - and _";
                }
            }
        }
        if (card.unclosedQuote) return label + ": a string value with no closing quote";
    }
    return "no END card in the first " + std::to_string(cards * CARD) + " bytes of the header";
}

bool isGzipFile(const std::string& path, const std::string& name)
{
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw Error(name + ": cannot open it (" + std::strerror(errno) + ")");
    unsigned char magic[2] = {0, 0};
    const ssize_t n = ::read(fd, magic, 2);
    const int err = errno;
    ::close(fd);
    if (n < 0) throw Error(name + ": cannot read it (" + std::strerror(err) + ")");
    return n == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
}

namespace {

/// Ends a zlib stream on every way out.
struct ZStream
{
    z_stream z{};
    bool init = false;
    ~ZStream()
    {
        if (init) inflateEnd(&z);
    }
};

/// Grows @p out's capacity to hold @p need bytes, never past @p cap (+ the padding
/// FitsFile::openMemory adds): doubling, so that a reallocation holds at most twice the bytes.
void reserveFor(std::string& out, std::size_t need, std::size_t cap)
{
    if (need <= out.capacity()) return;
    const std::size_t grown = std::max(need, std::min(cap, 2 * out.capacity()));
    out.reserve(grown + 2 * FITS_BLOCK);
}

/// inflateFitsGzip() over any source: @p read(buffer, size) returns the bytes it put there, 0 at
/// the end (it throws on an error).
template <typename ReadFn> std::string inflateBounded(const std::string& name, ReadFn&& read)
{
    ZStream in;
    if (inflateInit2(&in.z, 16 + MAX_WBITS) != Z_OK) {
        throw Error(name + ": cannot start inflating it (out of memory?)");
    }
    in.init = true;
    std::vector<unsigned char> input(std::size_t(1) << 16);
    std::vector<unsigned char> chunk(std::size_t(1) << 18);
    std::string out;
    FitsLayout layout;
    std::uint64_t reading = 0; // compressed bytes read
    bool eof = false, streamEnd = false;
    while (true) {
        if (in.z.avail_in == 0 && !eof) {
            const std::size_t n = read(input.data(), input.size());
            eof = n == 0;
            reading += n;
            in.z.next_in = input.data();
            in.z.avail_in = uInt(n);
        }
        if (streamEnd) {
            // Another gzip member (files concatenated by cat) goes on; anything else ends it.
            if (in.z.avail_in == 0 && eof) break;
            if (in.z.avail_in == 0) continue;
            if (in.z.avail_in < 2 || in.z.next_in[0] != 0x1f || in.z.next_in[1] != 0x8b) break;
            inflateReset(&in.z);
            streamEnd = false;
        }
        in.z.next_out = chunk.data();
        in.z.avail_out = uInt(chunk.size());
        const int rc = inflate(&in.z, Z_NO_FLUSH);
        const std::size_t got = chunk.size() - in.z.avail_out;
        if (rc == Z_DATA_ERROR || rc == Z_NEED_DICT || rc == Z_MEM_ERROR || rc == Z_STREAM_ERROR) {
            throw Error(name + fmt::format(": the gzip data is damaged (after {} bytes inflated "
                                           "from the first {} bytes of the file)",
                                           out.size() + got, reading));
        }
        if (rc == Z_BUF_ERROR && got == 0 && eof && in.z.avail_in == 0) {
            throw Error(name + fmt::format(": truncated: the gzip data stops in the middle, after "
                                           "{} bytes inflated",
                                           out.size()));
        }
        if (got > 0) {
            const std::uint64_t bound = layout.bound();
            if (out.size() + got > bound) {
                throw Error(name + fmt::format(": inflates to at least {} bytes, but its FITS "
                                               "headers declare {} bytes (a margin of {} "
                                               "allowed); refused before inflating the rest",
                                               out.size() + got, layout.declared(),
                                               FITS_GZIP_MARGIN));
            }
            reserveFor(out, out.size() + got, std::size_t(bound));
            out.append(reinterpret_cast<const char*>(chunk.data()), got);
            const std::uint64_t before = layout.declared();
            layout.advance(out);
            if (layout.declared() > before) {
                try {
                    requireMemory(double(layout.declared()), name + ": its inflated bytes");
                } catch (const UsageError& e) {
                    throw Error(e.what()); // the file's size, not an option's
                }
            }
        }
        if (rc == Z_STREAM_END) streamEnd = true;
    }
    return out;
}

} // namespace

std::string inflateFitsGzip(const std::string& path, const std::string& name)
{
    struct Fd
    {
        int fd;
        ~Fd()
        {
            if (fd >= 0) ::close(fd);
        }
    } file{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
    if (file.fd < 0) throw Error(name + ": cannot open it (" + std::strerror(errno) + ")");
    return inflateBounded(name, [&](unsigned char* buffer, std::size_t size) {
        while (true) {
            const ssize_t n = ::read(file.fd, buffer, size);
            if (n >= 0) return std::size_t(n);
            if (errno != EINTR) {
                throw Error(name + ": cannot read it (" + std::strerror(errno) + ")");
            }
        }
    });
}

std::string inflateFitsGzip(std::string_view gz, const std::string& name)
{
    std::size_t at = 0;
    return inflateBounded(name, [&](unsigned char* buffer, std::size_t size) {
        const std::size_t n = std::min(size, gz.size() - at);
        std::memcpy(buffer, gz.data() + at, n);
        at += n;
        return n;
    });
}

} // namespace nebula::detail
