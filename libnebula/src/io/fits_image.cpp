#include "nebula/io/fits_image.h"

#include "nebula/core/error.h"

#include <fitsio.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <ostream>

namespace nebula {

namespace {

/// The FITS being built in memory: cfitsio grows the buffer with realloc().
class MemoryFits
{
public:
    explicit MemoryFits(std::string path) : mPath(std::move(path))
    {
        mSize = 2880 * 10;
        mBuffer = std::malloc(mSize);
        if (!mBuffer) throw Error(mPath + ": out of memory for the FITS file");
        int status = 0;
        fits_create_memfile(&mFits, &mBuffer, &mSize, 2880 * 10, std::realloc, &status);
        check(status, "creating the file in memory");
    }
    ~MemoryFits()
    {
        int status = 0;
        if (mFits) fits_close_file(mFits, &status);
        std::free(mBuffer);
    }
    MemoryFits(const MemoryFits&) = delete;
    MemoryFits& operator=(const MemoryFits&) = delete;

    fitsfile* get() { return mFits; }

    /// Throws Error naming the file and @p what with cfitsio's message unless @p status is 0.
    void check(int status, const std::string& what) const
    {
        if (status == 0) return;
        char text[FLEN_STATUS] = {};
        fits_get_errstatus(status, text);
        char detail[FLEN_ERRMSG] = {};
        std::string more;
        while (fits_read_errmsg(detail)) {
            if (more.empty()) more = std::string(" (") + detail + ")";
        }
        throw Error(mPath + ": FITS: " + what + ": " + text + more);
    }

    /// Closes the file and returns its bytes (valid while this object lives).
    std::pair<const char*, std::size_t> finish()
    {
        // The file ends where its last HDU's data (padded to 2880 bytes) ends; cfitsio's
        // buffer may be larger.
        int status = 0, hdus = 0;
        fits_flush_file(mFits, &status);
        fits_get_num_hdus(mFits, &hdus, &status);
        fits_movabs_hdu(mFits, hdus, nullptr, &status);
        LONGLONG headStart = 0, dataStart = 0, dataEnd = 0;
        fits_get_hduaddrll(mFits, &headStart, &dataStart, &dataEnd, &status);
        check(status, "finding the end of the file");
        fits_close_file(mFits, &status);
        mFits = nullptr;
        check(status, "closing");
        return {static_cast<const char*>(mBuffer), std::size_t(dataEnd)};
    }

private:
    std::string mPath;
    fitsfile* mFits = nullptr;
    void* mBuffer = nullptr;
    std::size_t mSize = 0;
};

void writeCard(MemoryFits& f, const FitsCard& card, const std::string& hdu)
{
    int status = 0;
    fitsfile* p = f.get();
    const char* comment = card.comment.empty() ? nullptr : card.comment.c_str();
    if (card.key == "HISTORY" || card.key == "COMMENT") {
        const auto& text = std::get<std::string>(card.value);
        if (card.key == "HISTORY") {
            fits_write_history(p, text.c_str(), &status);
        } else {
            fits_write_comment(p, text.c_str(), &status);
        }
    } else if (const auto* s = std::get_if<std::string>(&card.value)) {
        // Long strings continue over several cards (the CONTINUE convention).
        if (s->size() > 68) {
            fits_write_key_longstr(p, card.key.c_str(), s->c_str(), comment, &status);
        } else {
            fits_write_key_str(p, card.key.c_str(), s->c_str(), comment, &status);
        }
    } else if (const auto* d = std::get_if<double>(&card.value)) {
        fits_write_key_dbl(p, card.key.c_str(), *d, -15, comment, &status);
    } else if (const auto* i = std::get_if<long long>(&card.value)) {
        fits_write_key_lng(p, card.key.c_str(), LONGLONG(*i), comment, &status);
    } else {
        fits_write_key_log(p, card.key.c_str(), std::get<bool>(card.value) ? 1 : 0, comment,
                           &status);
    }
    f.check(status, hdu + ": writing keyword " + card.key);
}

} // namespace

void writeFits(AtomicFile& file, const std::vector<FitsImageHdu>& images,
               const std::vector<FitsTableHdu>& tables)
{
    if (images.empty()) throw Error(file.path() + ": FITS: no image to write");
    MemoryFits f(file.path());
    bool longstr = false;
    for (std::size_t h = 0; h < images.size(); ++h) {
        const FitsImageHdu& img = images[h];
        const std::string hdu =
            "HDU " + std::to_string(h) + (img.name.empty() ? "" : " " + img.name);
        long n = 1;
        for (const long a : img.axes)
            n *= a;
        if (img.axes.empty() || std::size_t(n) != img.data.size()) {
            throw Error(file.path() + ": FITS: " + hdu + ": " + std::to_string(img.data.size()) +
                        " values for its axes");
        }
        int status = 0;
        std::vector<long> axes = img.axes;
        fits_create_img(f.get(), FLOAT_IMG, int(axes.size()), axes.data(), &status);
        f.check(status, hdu + ": creating the image");
        if (!img.name.empty()) writeCard(f, {"EXTNAME", img.name, "component"}, hdu);
        for (const auto& card : img.cards) {
            if (!longstr && std::holds_alternative<std::string>(card.value) &&
                std::get<std::string>(card.value).size() > 68 && card.key != "HISTORY" &&
                card.key != "COMMENT") {
                fits_write_key_longwarn(f.get(), &status);
                f.check(status, hdu + ": the long-string convention");
                longstr = true;
            }
            writeCard(f, card, hdu);
        }
        std::vector<float> values(img.data);
        fits_write_img(f.get(), TFLOAT, 1, LONGLONG(values.size()), values.data(), &status);
        f.check(status, hdu + ": writing the data");
    }
    for (const auto& t : tables) {
        int status = 0;
        const std::string hdu = "table " + t.name;
        std::string form = std::to_string(t.values.size()) + "D";
        char* ttype[] = {const_cast<char*>(t.column.c_str())};
        char* tform[] = {const_cast<char*>(form.c_str())};
        char* tunit[] = {const_cast<char*>(t.unit.c_str())};
        fits_create_tbl(f.get(), BINARY_TBL, 1, 1, ttype, tform, tunit, t.name.c_str(), &status);
        f.check(status, hdu + ": creating the table");
        std::vector<long> tdim = t.tdim;
        fits_write_tdim(f.get(), 1, int(tdim.size()), tdim.data(), &status);
        std::vector<double> values = t.values;
        fits_write_col(f.get(), TDOUBLE, 1, 1, 1, LONGLONG(values.size()), values.data(), &status);
        f.check(status, hdu + ": writing the column");
    }
    const auto [bytes, size] = f.finish();
    file.stream().write(bytes, std::streamsize(size));
}

} // namespace nebula
