// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file fits.h
/// A small RAII wrapper of cfitsio for nebula's FITS inputs and outputs (nebimport's cubes,
/// nebexport's cubes, images): files opened read-only from disk or from bytes in memory, files
/// created in memory and written out through AtomicFile, every cfitsio status checked and
/// turned into an Error that names the file and the HDU. cfitsio itself stays out of this
/// header (it is a private dependency of the io layer).

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace nebula {

class FitsFile
{
public:
    /// Opens @p path read-only at its primary HDU; @p name names it in messages. A gzipped
    /// file is inflated first, into memory, and refused as soon as it inflates to more than its
    /// headers declare (plus a small margin). Throws Error (missing, not FITS, a damaged header,
    /// naming the card at fault).
    static FitsFile open(const std::string& path, const std::string& name);
    /// Opens a copy of @p bytes (a whole FITS file, or one gzipped, inflated as open() does)
    /// read-only (fuzzers, tests).
    static FitsFile openMemory(std::string_view bytes, const std::string& name);
    /// Creates an empty FITS file in memory; add HDUs with createImage(), then take the bytes
    /// with finishBytes() or write them with writeFile().
    static FitsFile createMemory(const std::string& name);

    FitsFile(FitsFile&& other) noexcept;
    FitsFile& operator=(FitsFile&& other) noexcept;
    FitsFile(const FitsFile&) = delete;
    FitsFile& operator=(const FitsFile&) = delete;
    ~FitsFile();

    const std::string& name() const { return mName; }
    /// The number of HDUs (the primary is HDU 0).
    int hduCount() const;
    /// Makes HDU @p index (0 = primary, as astropy counts) the current one.
    void moveTo(int index);
    /// Makes the extension whose EXTNAME (or HDUNAME) is @p extname the current one.
    void moveTo(const std::string& extname);
    /// The current HDU's index (0 = primary).
    int hdu() const;
    /// "HDU 2 (EXTNAME)" or "HDU 0", for messages.
    std::string hduLabel() const;
    /// True if the current HDU is an image (the primary is one, possibly with NAXIS = 0).
    bool isImage() const;

    /// The current image HDU's axis lengths in FITS order (NAXIS1 first); empty for NAXIS = 0.
    std::vector<std::int64_t> imageShape() const;
    /// The current image's BITPIX (8, 16, 32, 64, -32, -64).
    int bitpix() const;
    /// Byte offsets of the current HDU's data and of its end in the file (header checks: a
    /// file shorter than its data end is truncated).
    std::pair<std::int64_t, std::int64_t> dataSpan() const;
    /// The file's size in bytes (for memory files: the bytes written so far).
    std::int64_t fileSize() const;

    /// A keyword's value, or nullopt if the current header lacks it; throws Error if present
    /// with a value of another type.
    std::optional<std::string> keyString(const std::string& key) const;
    std::optional<double> keyDouble(const std::string& key) const;
    std::optional<std::int64_t> keyInt(const std::string& key) const;
    /// A numeric keyword's value as written ([+-]digits[.digits][E|D[+-]digits], so +-inf
    /// beyond double's range), or nullopt if the header lacks it; throws Error naming the
    /// keyword if its value is anything else (a string such as 'NaN', a logical, blank), which
    /// cfitsio would convert or take as a default.
    std::optional<double> keyNumber(const std::string& key) const;

    /// Writes (or updates) a keyword with its comment in the current header; a string longer
    /// than a card holds continues over several (the CONTINUE convention).
    void writeKey(const std::string& key, const std::string& value, const std::string& comment);
    void writeKey(const std::string& key, double value, const std::string& comment);
    void writeKey(const std::string& key, std::int64_t value, const std::string& comment);
    /// Appends HISTORY (COMMENT) cards; long text continues over several cards.
    void writeHistory(const std::string& text);
    void writeComment(const std::string& text);

    /// Appends a float32 image HDU with @p shape (FITS order, any number of axes) and makes
    /// it current: the first is the primary HDU, later ones extensions. @p extname sets EXTNAME
    /// ("" none).
    void createImage(const std::vector<std::int64_t>& shape, const std::string& extname = "");
    /// Appends a binary table HDU of one row and one column @p column of @p values (doubles,
    /// TDIM @p tdim, TUNIT @p unit) and makes it current: e.g. a -TAB coordinate array.
    void createDoubleTable(const std::string& extname, const std::string& column,
                           const std::vector<std::int64_t>& tdim, const std::vector<double>& values,
                           const std::string& unit);
    /// A column of a table: its name, unit (TUNIT) and one double per row.
    struct Column
    {
        std::string name;
        std::string unit;
        std::vector<double> values;
    };
    /// Appends a binary table HDU whose rows are the columns' values (all of one length) and
    /// makes it current.
    void createTable(const std::string& extname, const std::vector<Column>& columns);
    /// Writes @p count floats at element @p first (0-based, FITS order) of the current image.
    void writeFloats(std::int64_t first, std::int64_t count, const float* values);
    /// Reads @p count elements from element @p first (0-based) of the current image as
    /// doubles, BSCALE/BZERO applied; undefined integer pixels (BLANK) become NaN.
    void readDoubles(std::int64_t first, std::int64_t count, double* out) const;

    /// Closes a file made by createMemory() and returns its bytes.
    std::string finishBytes();
    /// Closes a file made by createMemory() and writes its bytes to @p out (no copy).
    void finishTo(std::ostream& out);
    /// finishBytes() written to @p path ("-" = stdout) through AtomicFile (committed).
    void writeFile(const std::string& path);

    /// Throws Error naming the card if the current HDU's header breaks the FITS rules that
    /// cfitsio lets pass: a byte that is not printable ASCII, SIMPLE = F, a keyword with a
    /// character other than letters, digits, - and _, a string with no closing quote, an END
    /// card or last record that is not blank after END.
    void checkHeaderText() const;
    /// What is wrong with an HDU after the last one cfitsio can read ("HDU 2: card 2 (BITPIX):
    /// ..."), "" if none follows (trailing bytes that do not start an HDU are not one).
    /// Leaves the last readable HDU current.
    std::string unreadHduFault();

    /// Throws Error "<file>: <HDU>: <what>: <what the status means>" if @p status is not 0:
    /// the status in nebula's words, never cfitsio's message stack (its routine names, raw
    /// header bytes).
    void check(int status, const std::string& what) const;

private:
    FitsFile() = default;
    static FitsFile openOwned(std::string bytes, const std::string& name);
    /// check() for a header that failed to parse: the message names its first card at fault
    /// (the header of HDU @p index starts at byte @p headerStart), else the status.
    void checkHeader(int status, std::int64_t headerStart, int index,
                     const std::string& what) const;
    /// Up to @p count bytes of the file from @p offset ("" if there are none).
    std::string bytesAt(std::int64_t offset, std::size_t count) const;
    struct Impl;
    std::unique_ptr<Impl> mImpl;
    std::string mName;
};

} // namespace nebula
