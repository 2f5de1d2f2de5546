#include "nebula/io/fits.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"

#include <fitsio.h>
#include <fmt/format.h>

#include <algorithm>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
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

/// cfitsio's message for @p status and the messages it stacked, one line.
std::string fitsMessage(int status)
{
    char text[FLEN_STATUS] = {0};
    fits_get_errstatus(status, text);
    std::string msg = text;
    char line[FLEN_ERRMSG];
    std::string detail;
    while (fits_read_errmsg(line)) {
        std::string l = line;
        while (!l.empty() && (l.back() == ' ' || l.back() == '\n'))
            l.pop_back();
        if (!l.empty() && detail.find(l) == std::string::npos) {
            detail += (detail.empty() ? "" : "; ") + l;
        }
    }
    return detail.empty() ? msg : msg + " (" + detail + ")";
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
    const std::string msg = fitsMessage(status);
    fits_clear_errmsg();
    throw Error(where + ": " + what + ": " + msg);
}

FitsFile FitsFile::open(const std::string& path, const std::string& name)
{
    FitsFile f;
    f.mName = name;
    f.mImpl = std::make_unique<Impl>();
    f.mImpl->path = path;
    int status = 0;
    // The disk driver: the name is a file name, never cfitsio's extended syntax.
    fits_open_diskfile(&f.mImpl->fptr, path.c_str(), READONLY, &status);
    if (status) {
        f.mImpl->fptr = nullptr;
        f.check(status, "cannot open it as a FITS file");
    }
    return f;
}

FitsFile FitsFile::openMemory(std::string_view bytes, const std::string& name)
{
    FitsFile f;
    f.mName = name;
    f.mImpl = std::make_unique<Impl>();
    // cfitsio's memory driver reads whole 2880-byte records: pad the copy with zeros so that
    // it never reads past a file whose length is not a multiple of 2880 (a truncated one).
    f.mImpl->bytes.assign(bytes.data(), bytes.size());
    f.mImpl->fileSize = bytes.size();
    f.mImpl->bytes.resize((bytes.size() + 2879) / 2880 * 2880 + 2880, '\0');
    f.mImpl->bytesPtr = f.mImpl->bytes.data();
    f.mImpl->bytesSize = f.mImpl->bytes.size();
    int status = 0;
    fits_open_memfile(&f.mImpl->fptr, name.c_str(), READONLY, &f.mImpl->bytesPtr,
                      &f.mImpl->bytesSize, 0, nullptr, &status);
    if (status) {
        f.mImpl->fptr = nullptr;
        f.check(status, "cannot open it as a FITS file");
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
    int status = 0, type = 0;
    fits_movabs_hdu(mImpl->fptr, index + 1, &type, &status);
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
    if (status == 0 && value[0]) label += " (" + std::string(value) + ")";
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
