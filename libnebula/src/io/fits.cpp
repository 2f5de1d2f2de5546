// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/fits.h"

#include "fits_header.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"

#include <fitsio.h>
#include <fmt/format.h>

#include <algorithm>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <iostream>
#include <limits>
#include <malloc.h>
#include <sys/stat.h>
#include <unistd.h>

namespace nebula {

struct FitsFile::Impl
{
    fitsfile* fptr = nullptr;
    std::string bytes;        ///< the copy a memory file was opened from (openMemory())
    void* bytesPtr = nullptr; ///< cfitsio keeps the addresses of these two (openMemory())
    std::size_t bytesSize = 0;
    std::size_t fileSize = 0; ///< the bytes given to openMemory(), before the padding
    void* buffer = nullptr;   ///< a created memory file's buffer (cfitsio reallocates it)
    std::size_t bufferSize = 0;
    std::string path; ///< the disk file (fileSize())

    ~Impl()
    {
        if (fptr) {
            int status = 0;
            fits_close_file(fptr, &status);
        }
        std::free(buffer);
    }
};

namespace {

/// What cfitsio's status @p status means, in nebula's words: the common codes from a table,
/// any other from cfitsio's own short text (never its message stack, which names its internal
/// routines and quotes raw header bytes), routine names taken out and bytes made printable.
std::string statusText(int status)
{
    switch (status) {
    case FILE_NOT_OPENED: return "the file cannot be opened";
    case END_OF_FILE: return "the file ends before the header or data it declares (truncated?)";
    case READ_ERROR: return "a read failed (the file truncated or unreadable?)";
    case MEMORY_ALLOCATION: return "out of memory";
    case KEY_NO_EXIST: return "the keyword is missing";
    case VALUE_UNDEFINED: return "the keyword has no value";
    case NO_QUOTE: return "a string value has no closing quote";
    case BAD_KEYCHAR: return "a card holds a character that FITS does not allow";
    case BAD_ORDER: return "the required keywords are out of order";
    case NOT_POS_INT: return "a value that must be a positive integer is not";
    case NO_END: return "the header has no END card";
    case BAD_BITPIX:
    case NO_BITPIX: return "BITPIX is missing or not 8, 16, 32, 64, -32 or -64";
    case BAD_NAXIS:
    case NO_NAXIS: return "NAXIS is missing or not an integer 0 to 999";
    case BAD_NAXES:
    case NO_NAXES: return "an NAXISn keyword is missing or not an integer >= 0";
    case NEG_AXIS: return "an axis length is below 1";
    case BAD_PCOUNT:
    case NO_PCOUNT: return "PCOUNT is missing or not an integer >= 0";
    case BAD_GCOUNT:
    case NO_GCOUNT: return "GCOUNT is missing or not an integer >= 0";
    case BAD_TFIELDS:
    case NO_TFIELDS: return "TFIELDS is missing or not an integer 0 to 999";
    case NEG_WIDTH: return "a table's row width (NAXIS1) is negative";
    case NEG_ROWS: return "a table's row count (NAXIS2) is negative";
    case NO_TBCOL:
    case BAD_TBCOL: return "a table column's position (TBCOLn) is missing or out of range";
    case NO_TFORM:
    case BAD_TFORM:
    case BAD_TFORM_DTYPE: return "a table column's format (TFORMn) is missing or not valid";
    case BAD_TDIM: return "a table column's TDIMn is not valid";
    case BAD_ROW_WIDTH: return "a table's column widths do not add up to its NAXIS1";
    case BAD_SIMPLE: return "SIMPLE is not T (not a standard FITS file)";
    case NO_SIMPLE: return "it does not start with SIMPLE (not a FITS file?)";
    case NO_XTENSION: return "an extension does not start with XTENSION";
    case NOT_IMAGE: return "the HDU is not an image";
    case UNKNOWN_EXT: return "an extension of a type FITS does not define";
    case UNKNOWN_REC: return "a record that is neither a header nor data (not a FITS file?)";
    case END_JUNK: return "the END card is not blank after END";
    case BAD_HEADER_FILL: return "the header's last record is not blank after its END card";
    case BAD_DATA_FILL: return "the data's last record is not padded with zeros";
    case BAD_HDU_NUM: return "no such HDU";
    case BAD_INTKEY:
    case BAD_C2I: return "the value is not an integer";
    case BAD_LOGICALKEY: return "the value is not T or F";
    case BAD_FLOATKEY:
    case BAD_DOUBLEKEY:
    case BAD_C2F:
    case BAD_C2D: return "the value is not a number";
    case NUM_OVERFLOW: return "a value is beyond the range of its type";
    case ZERO_SCALE: return "BSCALE is 0";
    case BAD_DIMEN: return "the number of axes is not valid";
    case BAD_HEAP_PTR: return "a table's heap address is not valid";
    default: break;
    }
    char text[FLEN_STATUS] = {0};
    fits_get_errstatus(status, text);
    std::string t = text;
    // cfitsio's routines are ff plus letters: none of them reaches a user.
    std::string clean;
    for (std::size_t i = 0; i < t.size();) {
        const bool wordStart = i == 0 || !std::isalnum(static_cast<unsigned char>(t[i - 1]));
        if (wordStart && t.compare(i, 2, "ff") == 0) {
            std::size_t j = i + 2;
            while (j < t.size() && std::islower(static_cast<unsigned char>(t[j])))
                ++j;
            if (j - i >= 5) {
                i = j;
                continue;
            }
        }
        clean += t[i++];
    }
    return detail::printable(clean, 80) + " (FITS status " + std::to_string(status) + ")";
}

/// realloc() for cfitsio's memory files that zeroes every byte it adds: cfitsio reads parts of
/// its buffer it has not written yet (looking for the END card), which must not be garbage.
void* zeroingRealloc(void* p, std::size_t size)
{
    const std::size_t old = p ? malloc_usable_size(p) : 0;
    void* q = std::realloc(p, size);
    if (!q) return nullptr;
    const std::size_t now = malloc_usable_size(q);
    if (now > old) std::memset(static_cast<char*>(q) + old, 0, now - old);
    return q;
}

} // namespace

FitsFile::FitsFile(FitsFile&& other) noexcept = default;
FitsFile& FitsFile::operator=(FitsFile&& other) noexcept = default;
FitsFile::~FitsFile() = default;

void FitsFile::check(int status, const std::string& what) const
{
    if (status == 0) return;
    std::string where = mName;
    if (mImpl && mImpl->fptr) {
        int num = 0;
        fits_get_hdu_num(mImpl->fptr, &num);
        if (num > 0) where += ": " + hduLabel();
    }
    fits_clear_errmsg();
    throw Error(where + ": " + what + ": " + statusText(status));
}

void FitsFile::checkHeaderText() const
{
    LONGLONG head = 0, data = 0, stop = 0;
    int status = 0;
    fits_get_hduaddrll(mImpl->fptr, &head, &data, &stop, &status);
    check(status, "cannot locate the header");
    const std::size_t length =
        std::size_t(std::min<LONGLONG>(data - head, LONGLONG(detail::MAX_FITS_HEADER_BYTES)));
    const std::string fault = detail::headerFault(bytesAt(head, length), hdu() == 0);
    if (!fault.empty()) throw Error(mName + ": " + hduLabel() + ": " + fault);
}

std::string FitsFile::unreadHduFault()
{
    const int n = hduCount();
    moveTo(n - 1);
    const std::int64_t end = dataSpan().second;
    const std::string next = bytesAt(end, detail::MAX_FITS_HEADER_BYTES);
    if (next.compare(0, 8, "XTENSION") != 0) return ""; // no HDU there: trailing bytes
    const std::string fault = detail::headerFault(next, false);
    return fault.empty() ? "" : "HDU " + std::to_string(n) + ": " + fault;
}

std::string FitsFile::bytesAt(std::int64_t offset, std::size_t count) const
{
    if (mImpl->path.empty()) {
        const auto size = std::int64_t(mImpl->fileSize);
        if (offset < 0 || offset >= size) return {};
        return mImpl->bytes.substr(std::size_t(offset), count);
    }
    std::string out(count, '\0');
    const int fd = ::open(mImpl->path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return {};
    const ssize_t n = ::pread(fd, out.data(), count, off_t(offset));
    ::close(fd);
    out.resize(n > 0 ? std::size_t(n) : 0);
    return out;
}

void FitsFile::checkHeader(int status, std::int64_t headerStart, int index,
                           const std::string& what) const
{
    if (status == 0) return;
    fits_clear_errmsg();
    // The header's own first fault names the card; cfitsio's code alone does not.
    const std::string fault =
        detail::headerFault(bytesAt(headerStart, detail::MAX_FITS_HEADER_BYTES), index == 0);
    throw Error(mName + ": " + what + ": HDU " + std::to_string(index) + ": " +
                (fault.empty() ? statusText(status) : fault));
}

FitsFile FitsFile::open(const std::string& path, const std::string& name)
{
    // A gzipped file is inflated here, bounded by what its headers declare (cfitsio would
    // inflate all of it into memory first, whatever its size). Opening it here also names a
    // missing or unreadable file in the system's words.
    if (detail::isGzipFile(path, name)) return openOwned(detail::inflateFitsGzip(path, name), name);
    FitsFile f;
    f.mName = name;
    f.mImpl = std::make_unique<Impl>();
    f.mImpl->path = path;
    int status = 0;
    // The disk driver: the name is a file name, never cfitsio's extended syntax.
    fits_open_diskfile(&f.mImpl->fptr, path.c_str(), READONLY, &status);
    if (status) {
        f.mImpl->fptr = nullptr;
        f.checkHeader(status, 0, 0, "cannot open it as a FITS file");
    }
    return f;
}

FitsFile FitsFile::openMemory(std::string_view bytes, const std::string& name)
{
    if (detail::isGzip(bytes)) return openOwned(detail::inflateFitsGzip(bytes, name), name);
    return openOwned(std::string(bytes), name);
}

FitsFile FitsFile::openOwned(std::string bytes, const std::string& name)
{
    FitsFile f;
    f.mName = name;
    f.mImpl = std::make_unique<Impl>();
    // cfitsio's memory driver reads whole 2880-byte records: pad the bytes with zeros so that
    // it never reads past a file whose length is not a multiple of 2880 (a truncated one).
    f.mImpl->fileSize = bytes.size();
    f.mImpl->bytes = std::move(bytes);
    f.mImpl->bytes.resize((f.mImpl->fileSize + 2879) / 2880 * 2880 + 2880, '\0');
    f.mImpl->bytesPtr = f.mImpl->bytes.data();
    f.mImpl->bytesSize = f.mImpl->bytes.size();
    int status = 0;
    fits_open_memfile(&f.mImpl->fptr, name.c_str(), READONLY, &f.mImpl->bytesPtr,
                      &f.mImpl->bytesSize, 0, nullptr, &status);
    if (status) {
        f.mImpl->fptr = nullptr;
        f.checkHeader(status, 0, 0, "cannot open it as a FITS file");
    }
    return f;
}

FitsFile FitsFile::createMemory(const std::string& name)
{
    FitsFile f;
    f.mName = name;
    f.mImpl = std::make_unique<Impl>();
    f.mImpl->bufferSize = 2880;
    f.mImpl->buffer = zeroingRealloc(nullptr, f.mImpl->bufferSize);
    if (!f.mImpl->buffer) throw Error(name + ": out of memory");
    int status = 0;
    fits_create_memfile(&f.mImpl->fptr, &f.mImpl->buffer, &f.mImpl->bufferSize,
                        std::size_t(1) << 24, zeroingRealloc, &status);
    if (status) {
        f.mImpl->fptr = nullptr;
        f.check(status, "cannot create a FITS file in memory");
    }
    return f;
}

int FitsFile::hduCount() const
{
    int n = 0, status = 0;
    fits_get_num_hdus(mImpl->fptr, &n, &status);
    check(status, "cannot count its HDUs");
    return n;
}

void FitsFile::moveTo(int index)
{
    const int n = hduCount();
    if (index < 0 || index >= n) {
        throw Error(mName + ": no HDU " + std::to_string(index) + " (the file has " +
                    std::to_string(n) + ", numbered from 0)");
    }
    // The next HDU's header starts where this one's data end (for naming a damaged card).
    const std::int64_t next = index == hdu() + 1 ? dataSpan().second : -1;
    int status = 0, type = 0;
    fits_movabs_hdu(mImpl->fptr, index + 1, &type, &status);
    if (status && next >= 0) checkHeader(status, next, index, "cannot read it");
    check(status, "cannot read HDU " + std::to_string(index));
}

void FitsFile::moveTo(const std::string& extname)
{
    int status = 0;
    std::string copy = extname;
    fits_movnam_hdu(mImpl->fptr, ANY_HDU, copy.data(), 0, &status);
    if (status == BAD_HDU_NUM) {
        fits_clear_errmsg();
        throw Error(mName + ": no HDU named \"" + extname + "\"");
    }
    check(status, "cannot read HDU \"" + extname + "\"");
}

int FitsFile::hdu() const
{
    int num = 0;
    fits_get_hdu_num(mImpl->fptr, &num);
    return num - 1;
}

std::string FitsFile::hduLabel() const
{
    std::string label = "HDU " + std::to_string(hdu());
    char value[FLEN_VALUE] = {0};
    int status = 0;
    fits_read_key(mImpl->fptr, TSTRING, "EXTNAME", value, nullptr, &status);
    if (status == 0 && value[0]) label += " (" + detail::printable(value, 40) + ")";
    fits_clear_errmsg();
    return label;
}

bool FitsFile::isImage() const
{
    int type = 0, status = 0;
    fits_get_hdu_type(mImpl->fptr, &type, &status);
    check(status, "cannot read the HDU type");
    return type == IMAGE_HDU;
}

std::vector<std::int64_t> FitsFile::imageShape() const
{
    int naxis = 0, status = 0;
    fits_get_img_dim(mImpl->fptr, &naxis, &status);
    check(status, "cannot read NAXIS");
    if (naxis < 0 || naxis > 999) throw Error(mName + ": " + hduLabel() + ": bad NAXIS");
    std::vector<LONGLONG> axes(std::size_t(naxis), 0);
    if (naxis > 0) fits_get_img_sizell(mImpl->fptr, naxis, axes.data(), &status);
    check(status, "cannot read the NAXISn keywords");
    return std::vector<std::int64_t>(axes.begin(), axes.end());
}

int FitsFile::bitpix() const
{
    int bitpix = 0, status = 0;
    fits_get_img_type(mImpl->fptr, &bitpix, &status);
    check(status, "cannot read BITPIX");
    return bitpix;
}

std::pair<std::int64_t, std::int64_t> FitsFile::dataSpan() const
{
    LONGLONG head = 0, start = 0, end = 0;
    int status = 0;
    fits_get_hduaddrll(mImpl->fptr, &head, &start, &end, &status);
    check(status, "cannot locate the HDU's data");
    return {std::int64_t(start), std::int64_t(end)};
}

std::int64_t FitsFile::fileSize() const
{
    if (!mImpl->bytes.empty()) return std::int64_t(mImpl->fileSize);
    if (!mImpl->path.empty()) {
        struct stat st
        {
        };
        if (::stat(mImpl->path.c_str(), &st) != 0) {
            throw Error(mName + ": cannot stat it (" + std::strerror(errno) + ")");
        }
        return std::int64_t(st.st_size);
    }
    return std::int64_t(mImpl->bufferSize);
}

namespace {

/// Reads keyword @p key as @p type into @p value; false if the header lacks it.
bool readKey(const FitsFile& f, fitsfile* fptr, const std::string& key, int type, void* value)
{
    int status = 0;
    fits_read_key(fptr, type, key.c_str(), value, nullptr, &status);
    if (status == KEY_NO_EXIST) {
        fits_clear_errmsg();
        return false;
    }
    f.check(status, "keyword " + key);
    return true;
}

} // namespace

std::optional<std::string> FitsFile::keyString(const std::string& key) const
{
    char value[FLEN_VALUE] = {0};
    if (!readKey(*this, mImpl->fptr, key, TSTRING, value)) return std::nullopt;
    std::string s = value;
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    return s;
}

std::optional<double> FitsFile::keyDouble(const std::string& key) const
{
    double value = 0.0;
    if (!readKey(*this, mImpl->fptr, key, TDOUBLE, &value)) return std::nullopt;
    return value;
}

std::optional<double> FitsFile::keyNumber(const std::string& key) const
{
    char value[FLEN_VALUE] = {0};
    int status = 0;
    fits_read_keyword(mImpl->fptr, key.c_str(), value, nullptr, &status);
    if (status == KEY_NO_EXIST) {
        fits_clear_errmsg();
        return std::nullopt;
    }
    check(status, "keyword " + key);
    std::string_view text(value);
    while (!text.empty() && text.back() == ' ')
        text.remove_suffix(1);
    while (!text.empty() && text.front() == ' ')
        text.remove_prefix(1);
    double number = 0.0;
    if (!detail::parseFitsNumber(text, number)) {
        throw Error(
            mName + ": " + hduLabel() + ": " + key + " = " +
            (text.empty() ? std::string("(no value)") : detail::printable(std::string(text), 40)) +
            " is not a number");
    }
    return number;
}

std::optional<std::int64_t> FitsFile::keyInt(const std::string& key) const
{
    LONGLONG value = 0;
    if (!readKey(*this, mImpl->fptr, key, TLONGLONG, &value)) return std::nullopt;
    return std::int64_t(value);
}

void FitsFile::writeKey(const std::string& key, const std::string& value,
                        const std::string& comment)
{
    int status = 0;
    if (value.size() > 68) {
        fits_write_key_longwarn(mImpl->fptr, &status);
        fits_update_key_longstr(mImpl->fptr, key.c_str(), value.c_str(), comment.c_str(), &status);
    } else {
        fits_update_key_str(mImpl->fptr, key.c_str(), value.c_str(), comment.c_str(), &status);
    }
    check(status, "cannot write keyword " + key);
}

void FitsFile::writeKey(const std::string& key, double value, const std::string& comment)
{
    if (!std::isfinite(value)) throw Error(mName + ": keyword " + key + ": not a finite number");
    // The shortest text that reads back as the same double, in FITS's spelling (1.0, 1E-20).
    std::string text = fmt::format("{}", value);
    for (auto& c : text) {
        if (c == 'e') c = 'E';
    }
    if (text.find_first_of(".E") == std::string::npos) text += ".0";
    std::string card = fmt::format("{:<8}= {:>20} / {}", key, text, comment);
    card.resize(std::min<std::size_t>(card.size(), 80));
    int status = 0;
    fits_update_card(mImpl->fptr, key.c_str(), card.c_str(), &status);
    check(status, "cannot write keyword " + key);
}

void FitsFile::writeKey(const std::string& key, std::int64_t value, const std::string& comment)
{
    int status = 0;
    fits_update_key_lng(mImpl->fptr, key.c_str(), LONGLONG(value), comment.c_str(), &status);
    check(status, "cannot write keyword " + key);
}

void FitsFile::writeHistory(const std::string& text)
{
    int status = 0;
    fits_write_history(mImpl->fptr, text.c_str(), &status);
    check(status, "cannot write HISTORY");
}

void FitsFile::writeComment(const std::string& text)
{
    int status = 0;
    fits_write_comment(mImpl->fptr, text.c_str(), &status);
    check(status, "cannot write COMMENT");
}

void FitsFile::createImage(const std::vector<std::int64_t>& shape, const std::string& extname)
{
    std::vector<LONGLONG> axes(shape.begin(), shape.end());
    int status = 0;
    fits_create_imgll(mImpl->fptr, FLOAT_IMG, int(axes.size()), axes.data(), &status);
    check(status, "cannot create an image HDU");
    if (!extname.empty()) writeKey("EXTNAME", extname, "name of this HDU");
}

void FitsFile::createDoubleTable(const std::string& extname, const std::string& column,
                                 const std::vector<std::int64_t>& tdim,
                                 const std::vector<double>& values, const std::string& unit)
{
    int status = 0;
    std::string form = std::to_string(values.size()) + "D";
    char* ttype[] = {const_cast<char*>(column.c_str())};
    char* tform[] = {const_cast<char*>(form.c_str())};
    char* tunit[] = {const_cast<char*>(unit.c_str())};
    fits_create_tbl(mImpl->fptr, BINARY_TBL, 1, 1, ttype, tform, tunit, extname.c_str(), &status);
    check(status, "cannot create the table " + extname);
    std::vector<long> dims(tdim.begin(), tdim.end());
    fits_write_tdim(mImpl->fptr, 1, int(dims.size()), dims.data(), &status);
    fits_write_col(mImpl->fptr, TDOUBLE, 1, 1, 1, LONGLONG(values.size()),
                   const_cast<double*>(values.data()), &status);
    check(status, "cannot write the table " + extname);
}

void FitsFile::createTable(const std::string& extname, const std::vector<Column>& columns)
{
    if (columns.empty()) throw Error(mName + ": table " + extname + ": no columns");
    const std::size_t rows = columns.front().values.size();
    std::vector<char*> ttype, tform, tunit;
    std::string form = "1D";
    for (const auto& c : columns) {
        if (c.values.size() != rows) {
            throw Error(mName + ": table " + extname + ": column " + c.name + " has " +
                        std::to_string(c.values.size()) + " rows, not " + std::to_string(rows));
        }
        ttype.push_back(const_cast<char*>(c.name.c_str()));
        tform.push_back(form.data());
        tunit.push_back(const_cast<char*>(c.unit.c_str()));
    }
    int status = 0;
    fits_create_tbl(mImpl->fptr, BINARY_TBL, LONGLONG(rows), int(columns.size()), ttype.data(),
                    tform.data(), tunit.data(), extname.c_str(), &status);
    check(status, "cannot create the table " + extname);
    for (std::size_t i = 0; i < columns.size(); ++i) {
        fits_write_col(mImpl->fptr, TDOUBLE, int(i) + 1, 1, 1, LONGLONG(rows),
                       const_cast<double*>(columns[i].values.data()), &status);
    }
    check(status, "cannot write the table " + extname);
}

void FitsFile::writeFloats(std::int64_t first, std::int64_t count, const float* values)
{
    int status = 0;
    fits_write_img(mImpl->fptr, TFLOAT, LONGLONG(first) + 1, LONGLONG(count),
                   const_cast<float*>(values), &status);
    check(status, "cannot write the image data");
}

void FitsFile::readDoubles(std::int64_t first, std::int64_t count, double* out) const
{
    int status = 0, anynul = 0;
    double nul = std::numeric_limits<double>::quiet_NaN();
    fits_read_img(mImpl->fptr, TDOUBLE, LONGLONG(first) + 1, LONGLONG(count), &nul, out, &anynul,
                  &status);
    check(status, "cannot read the image data");
}

std::string FitsFile::finishBytes()
{
    int status = 0;
    fits_close_file(mImpl->fptr, &status);
    mImpl->fptr = nullptr;
    check(status, "cannot finish the FITS file");
    return std::string(static_cast<const char*>(mImpl->buffer), mImpl->bufferSize);
}

void FitsFile::finishTo(std::ostream& out)
{
    int status = 0;
    fits_close_file(mImpl->fptr, &status);
    mImpl->fptr = nullptr;
    check(status, "cannot finish the FITS file");
    out.write(static_cast<const char*>(mImpl->buffer), std::streamsize(mImpl->bufferSize));
}

void FitsFile::writeFile(const std::string& path)
{
    int status = 0;
    fits_close_file(mImpl->fptr, &status);
    mImpl->fptr = nullptr;
    check(status, "cannot finish the FITS file");
    const char* data = static_cast<const char*>(mImpl->buffer);
    if (path == "-") {
        std::cout.write(data, std::streamsize(mImpl->bufferSize));
        std::cout.flush();
        if (!std::cout)
            throw Error("<stdout>: write failed (" + std::string(std::strerror(errno)) + ")");
        return;
    }
    AtomicFile file(path);
    file.stream().write(data, std::streamsize(mImpl->bufferSize));
    file.commit();
}

} // namespace nebula
