// SPDX-License-Identifier: Apache-2.0
/// @file test_fits.cpp
/// io/fits.h: a FITS file made in memory and read back (keys with their types, HISTORY, image
/// HDUs of any dimension and extension names), HDU navigation by number and name, errors that
/// name the file, HDU and card in nebula's words (no cfitsio routine names, no raw bytes),
/// numeric keywords read strictly, and gzipped files inflated within their declared size.

#include "nebula/io/fits.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <vector>

using nebula::FitsFile;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

std::string twoHdus()
{
    auto f = FitsFile::createMemory("mem.fits");
    f.createImage({4, 3});
    f.writeKey("OBJECT", std::string("a test"), "a string");
    f.writeKey("EXPTIME", 0.1, "a double");
    f.writeKey("NCOMBINE", std::int64_t(7), "an integer");
    f.writeHistory("made by test_fits.cpp, a line long enough to go on over a second card of "
                   "eighty characters");
    const std::vector<float> image = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    f.writeFloats(0, 12, image.data());
    f.createImage({2, 2, 2, 3}, "VEL");
    std::vector<float> vel(24);
    for (std::size_t i = 0; i < vel.size(); ++i)
        vel[i] = float(i) * 0.5f;
    f.writeFloats(0, 24, vel.data());
    return f.finishBytes();
}

} // namespace

TEST(Fits, WritesAndReadsKeysImagesAndExtensions)
{
    const std::string bytes = twoHdus();
    EXPECT_EQ(bytes.size() % 2880, 0u);
    auto f = FitsFile::openMemory(bytes, "mem.fits");
    EXPECT_EQ(f.hduCount(), 2);
    EXPECT_EQ(f.hdu(), 0);
    EXPECT_TRUE(f.isImage());
    EXPECT_EQ(f.imageShape(), (std::vector<std::int64_t>{4, 3}));
    EXPECT_EQ(f.bitpix(), -32);
    EXPECT_EQ(f.keyString("OBJECT"), "a test");
    EXPECT_EQ(f.keyDouble("EXPTIME"), 0.1); // the shortest text, read back bit for bit
    EXPECT_EQ(f.keyInt("NCOMBINE"), 7);
    EXPECT_FALSE(f.keyDouble("MISSING"));
    EXPECT_TRUE(contains(errorMessage([&] { f.keyDouble("OBJECT"); }), "keyword OBJECT"));
    std::vector<double> row(4);
    f.readDoubles(4, 4, row.data());
    EXPECT_EQ(row, (std::vector<double>{4, 5, 6, 7}));

    f.moveTo("VEL");
    EXPECT_EQ(f.hdu(), 1);
    EXPECT_EQ(f.hduLabel(), "HDU 1 (VEL)");
    EXPECT_EQ(f.imageShape(), (std::vector<std::int64_t>{2, 2, 2, 3}));
    std::vector<double> last(2);
    f.readDoubles(22, 2, last.data());
    EXPECT_EQ(last, (std::vector<double>{11, 11.5}));
    f.moveTo(0);
    EXPECT_EQ(f.hduLabel(), "HDU 0");
    EXPECT_TRUE(contains(errorMessage([&] { f.moveTo(2); }), "no HDU 2 (the file has 2"));
    EXPECT_TRUE(contains(errorMessage([&] { f.moveTo("NOPE"); }), "mem.fits: no HDU named"));
}

TEST(Fits, ErrorsNameTheFileAndHdu)
{
    EXPECT_TRUE(contains(errorMessage([] { FitsFile::openMemory("not a FITS file", "junk.fits"); }),
                         "junk.fits: cannot open it as a FITS file"));
    EXPECT_TRUE(
        contains(errorMessage([] { FitsFile::open("/nonexistent/x.fits", "/nonexistent/x.fits"); }),
                 "/nonexistent/x.fits: cannot open it"));
    auto f = FitsFile::openMemory(twoHdus(), "mem.fits");
    std::vector<double> out(100);
    EXPECT_TRUE(contains(errorMessage([&] { f.readDoubles(0, 100, out.data()); }),
                         "mem.fits: HDU 0: cannot read the image data"));
    auto w = FitsFile::createMemory("new.fits");
    w.createImage({1, 1, 1});
    EXPECT_TRUE(contains(errorMessage([&] { w.writeKey("BAD", NAN, ""); }), "not a finite"));
}

class FitsFileTest : public nebula::test::TempFolder
{
};

TEST_F(FitsFileTest, WriteFileGoesThroughAtomicFile)
{
    auto f = FitsFile::createMemory(path("a.fits"));
    f.createImage({2, 2, 2});
    const std::vector<float> v(8, 1.5f);
    f.writeFloats(0, 8, v.data());
    f.writeFile(path("a.fits"));
    auto r = FitsFile::open(path("a.fits"), "a.fits");
    EXPECT_EQ(r.imageShape(), (std::vector<std::int64_t>{2, 2, 2}));
    EXPECT_EQ(r.fileSize(), 2 * 2880);
    std::size_t files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        (void)e;
        ++files;
    }
    EXPECT_EQ(files, 1u); // no temporary left
}

TEST(Fits, FuzzRegressionsAreRefusedOrRead)
{
    // tests/fuzz/regressions/fits: FITS bytes fuzz_fits once failed on, read as it reads them.
    const auto folder =
        std::filesystem::path(NEBULA_SOURCE_DIR) / "tests" / "fuzz" / "regressions" / "fits";
    int files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
        std::ifstream in(entry.path(), std::ios::binary);
        const std::string bytes{std::istreambuf_iterator<char>(in),
                                std::istreambuf_iterator<char>()};
        try {
            auto f = FitsFile::openMemory(bytes, entry.path().filename().string());
            for (int i = 0; i < f.hduCount() && i < 8; ++i) {
                f.moveTo(i);
                const auto shape = f.imageShape();
                double count = shape.empty() ? 0.0 : 1.0;
                for (auto a : shape)
                    count *= double(a);
                if (count > 0 && count <= 4096) {
                    std::vector<double> v(static_cast<std::size_t>(count));
                    f.readDoubles(0, std::int64_t(count), v.data());
                }
            }
        } catch (const nebula::Error&) {
        }
        ++files;
    }
    EXPECT_GT(files, 0);
}

TEST(Fits, AFileCutInsideARecordIsAnError)
{
    // cfitsio reads whole 2880-byte records; a file cut short of one must not be read past.
    const std::string bytes = twoHdus();
    auto f = FitsFile::openMemory(bytes.substr(0, 2880 + 20), "cut.fits");
    std::vector<double> v(12);
    try {
        f.readDoubles(0, 12, v.data()); // zeros past the cut, or an error: never a crash
    } catch (const nebula::Error&) {
    }
    EXPECT_EQ(f.fileSize(), 2900);
}

namespace {

/// @p bytes gzipped (zlib's gzip wrapper, one member).
std::string gzipped(const std::string& bytes)
{
    z_stream z{};
    EXPECT_EQ(deflateInit2(&z, 1, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
    std::string out(deflateBound(&z, uLong(bytes.size())), '\0');
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
    z.avail_in = uInt(bytes.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = uInt(out.size());
    EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
    out.resize(z.total_out);
    deflateEnd(&z);
    return out;
}

/// A message in nebula's words: no cfitsio routine (ff plus letters), no byte above 0x7e.
bool ownWords(const std::string& message)
{
    for (unsigned char c : message)
        if (c > 0x7e) return false;
    return !std::regex_search(message, std::regex("\\bff[a-z]{3,}\\b"));
}

/// @p bytes with the card that starts with @p key replaced by @p card (padded to 80).
std::string replaceCard(std::string bytes, const std::string& key, std::string card)
{
    const std::size_t at = bytes.find(key);
    card.resize(80, ' ');
    bytes.replace(at, 80, card);
    return bytes;
}

} // namespace

TEST(Fits, GzippedBytesReadAsThePlainFile)
{
    const std::string plain = twoHdus();
    auto f = FitsFile::openMemory(gzipped(plain), "mem.fits.gz");
    EXPECT_EQ(f.fileSize(), std::int64_t(plain.size()));
    EXPECT_EQ(f.hduCount(), 2);
    std::vector<double> v(12);
    f.readDoubles(0, 12, v.data());
    EXPECT_EQ(v[11], 11.0);
    f.moveTo("VEL");
    EXPECT_EQ(f.imageShape(), (std::vector<std::int64_t>{2, 2, 2, 3}));
}

TEST(Fits, AGzipBombIsRefusedAtItsDeclaredSize)
{
    // Two HDUs declare 4 records (11,520 bytes); 8 MiB of zeros follow them.
    const std::string plain = twoHdus();
    const std::string bomb = gzipped(plain + std::string(std::size_t(8) << 20, '\0'));
    const std::string m = errorMessage([&] { FitsFile::openMemory(bomb, "bomb.fits.gz"); });
    EXPECT_TRUE(contains(m, "bomb.fits.gz: inflates to at least")) << m;
    EXPECT_TRUE(contains(m, "headers declare " + std::to_string(plain.size()) + " bytes")) << m;
    // Within the margin, trailing zeros are read.
    EXPECT_NO_THROW(FitsFile::openMemory(gzipped(plain + std::string(5000, '\0')), "pad.gz"));
    // A damaged or truncated stream is refused, naming the file.
    const std::string gz = gzipped(plain);
    EXPECT_TRUE(contains(errorMessage([&] { FitsFile::openMemory(gz.substr(0, 40), "cut.gz"); }),
                         "cut.gz: truncated"));
}

TEST(Fits, DamagedHeadersAreNamedInOwnWords)
{
    const std::string good = twoHdus();
    const auto refused = [](const std::string& bytes) {
        return errorMessage([&] { FitsFile::openMemory(bytes, "bad.fits"); });
    };
    const std::vector<std::pair<std::string, std::string>> cases = {
        {replaceCard(good, "BITPIX", "BITPIX  =                   17"),
         "card 2 (BITPIX): BITPIX = 17"},
        {replaceCard(good, "NAXIS1", "NAXIS1  = 'four'"), "card 4 (NAXIS1): NAXIS1 = 'four'"},
        {replaceCard(good, "NAXIS   =", "NAXIS   =                 1000"), "NAXIS = 1000"},
        {replaceCard(good, "NAXIS2", "NAXIS2  = \xe9"), "card 5 (NAXIS2): byte \\xe9"},
        {good.substr(0, 400), "no END card"},
    };
    for (const auto& [bytes, words] : cases) {
        const std::string m = refused(bytes);
        EXPECT_TRUE(contains(m, "bad.fits: cannot open it as a FITS file: HDU 0: ")) << m;
        EXPECT_TRUE(contains(m, words)) << m;
        EXPECT_TRUE(ownWords(m)) << m;
    }
}

TEST(Fits, NumericKeywordsAreReadStrictly)
{
    auto w = FitsFile::createMemory("k.fits");
    w.createImage({1, 1, 1});
    w.writeKey("CDELT1", std::string("NaN"), "a string");
    w.writeKey("CDELT2", 2.5, "");
    const std::string bytes = replaceCard(w.finishBytes(), "CDELT2", "CDELT2  = 1.5D2");
    auto f = FitsFile::openMemory(bytes, "k.fits");
    EXPECT_EQ(f.keyNumber("CDELT2"), 150.0); // FORTRAN's D exponent
    EXPECT_FALSE(f.keyNumber("CDELT3"));
    const std::string m = errorMessage([&] { (void)f.keyNumber("CDELT1"); });
    EXPECT_TRUE(contains(m, "k.fits: HDU 0: CDELT1 = 'NaN") && contains(m, "is not a number")) << m;
    // What cfitsio lets pass, refused by checkHeaderText().
    auto simple = FitsFile::openMemory(
        replaceCard(twoHdus(), "SIMPLE", "SIMPLE  =                    F"), "f.fits");
    const std::string s = errorMessage([&] { simple.checkHeaderText(); });
    EXPECT_TRUE(contains(s, "f.fits: HDU 0: card 1 (SIMPLE): SIMPLE = F, expected T")) << s;
}
