// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to io/: FITS headers read by nebula itself, beside cfitsio. Two jobs cfitsio cannot
// do for us: the size a file's headers declare, as its bytes arrive (the bound on what a
// gzipped file may inflate to, checked before the rest is inflated), and the first card that
// breaks the standard, named in the project's words (cfitsio's status code does not say which
// card, and its message stack speaks of its own routines and quotes raw bytes).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace nebula::detail {

/// A FITS record [bytes]: headers and data come in whole records.
inline constexpr std::size_t FITS_BLOCK = 2880;
/// The longest header followed while its END card has not come [bytes] (36,000 cards).
inline constexpr std::size_t MAX_FITS_HEADER_BYTES = 1000 * FITS_BLOCK;
/// What a gzipped FITS file may inflate to beyond what its headers declare [bytes]: trailing
/// padding some writers add.
inline constexpr std::size_t FITS_GZIP_MARGIN = std::size_t(1) << 20;

/// Follows a FITS file's HDUs through its first bytes and adds up what their headers declare
/// (header records plus NAXIS1 x ... x NAXISn x |BITPIX| / 8, GCOUNT and PCOUNT included,
/// rounded up to whole records). Bytes that do not start an HDU where one would start end the
/// walk: what follows is not declared.
class FitsLayout
{
public:
    /// Reads on through @p bytes, the file's first bytes (all of them so far; each call passes
    /// at least the bytes of the last).
    void advance(std::string_view bytes);
    /// The end of the last HDU whose header has been read [bytes].
    std::uint64_t declared() const { return mDeclared; }
    /// True when the walk is over: no further HDU can start (bytes that are not a header, a
    /// header longer than MAX_FITS_HEADER_BYTES, a size that does not parse).
    bool ended() const { return mEnded; }
    /// The most bytes the file may hold as far as its headers say: the declared HDUs, a header
    /// still being read (MAX_FITS_HEADER_BYTES) unless the walk has ended, and
    /// FITS_GZIP_MARGIN.
    std::uint64_t bound() const;

private:
    void startHdu(std::string_view bytes);
    void endHeader();

    std::uint64_t mDeclared = 0; ///< where the current HDU starts
    std::uint64_t mCursor = 0;   ///< the next card to read
    bool mPrimary = true, mStarted = false, mEnded = false, mGroups = false;
    long long mBitpix = 0, mNaxis = -1, mPcount = 0, mGcount = 1;
    long long mAxes[1000] = {};
};

/// The first card of the header at @p bytes (which start at the header) that breaks the FITS
/// rules cfitsio enforces, in words that name the card and the keyword ("card 5 (NAXIS1):
/// 'abc' is not an integer >= 0"), with bytes that are not printable shown as \xNN; "" if none
/// is found. @p primary: the header must start with SIMPLE, else with XTENSION.
std::string headerFault(std::string_view bytes, bool primary);

/// The FITS number @p value (a card's value field, blanks trimmed: [+-]digits[.digits]
/// [E|D[+-]digits]) as a double; false if it is not one (a string, a logical, blank, NaN).
bool parseFitsNumber(std::string_view value, double& out);

/// The bytes of the gzipped FITS file @p path inflated, the output bounded as it grows by what
/// the headers inflated so far declare (FitsLayout::bound()): a file that would inflate to more
/// is refused as soon as it passes the bound, so a decompression bomb costs at most its
/// declared size. Throws Error naming @p name (and both sizes, for a bomb), also for a damaged
/// or truncated gzip stream.
std::string inflateFitsGzip(const std::string& path, const std::string& name);
/// The same for gzipped bytes in memory.
std::string inflateFitsGzip(std::string_view gz, const std::string& name);

/// True if the file @p path starts with the gzip magic bytes; throws Error naming @p name if
/// it cannot be opened or read.
bool isGzipFile(const std::string& path, const std::string& name);
/// True if @p bytes start with the gzip magic bytes.
inline bool isGzip(std::string_view bytes)
{
    return bytes.size() >= 2 && bytes[0] == '\x1f' && bytes[1] == '\x8b';
}

} // namespace nebula::detail
