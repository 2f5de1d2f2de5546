// SPDX-License-Identifier: Apache-2.0
// Tests for nebula/image.h: EXR round trip, atomic failure behaviour, PNG encoding and the
// automatic tone curve (DESIGN §8).

#include "nebula/core/error.h"
#include "nebula/io/image.h"

#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <sys/resource.h>

namespace fs = std::filesystem;

namespace {

/// A fresh empty folder per test, removed afterwards.
class ImageTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        std::string pattern = (fs::temp_directory_path() / "nebula_image_XXXXXX").string();
        ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
        mDir = pattern;
    }
    void TearDown() override
    {
        std::error_code ec;
        fs::remove_all(mDir, ec);
    }

    std::string file(const std::string& name) const { return (mDir / name).string(); }

    /// Names of everything in the folder (to find leftovers such as temporary files).
    std::vector<std::string> listing() const
    {
        std::vector<std::string> names;
        for (const auto& entry : fs::directory_iterator(mDir)) {
            names.push_back(entry.path().filename().string());
        }
        std::sort(names.begin(), names.end());
        return names;
    }

    fs::path mDir;
};

/// Expects @p fn to throw nebula::Error whose message contains @p needle.
template <class Fn> void expectErrorContaining(Fn&& fn, const std::string& needle)
{
    try {
        fn();
        ADD_FAILURE() << "expected nebula::Error containing \"" << needle << "\"";
    } catch (const nebula::Error& e) {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
            << "message: " << e.what() << "\nexpected to contain: " << needle;
    }
}

nebula::Image sampleImage()
{
    nebula::Image image(5, 3);
    for (std::size_t i = 0; i < image.rgba.size(); ++i) {
        // Values that a lossy or half-float path would change.
        image.rgba[i] = float(i) * 0.1234567f - 1.5f + (i % 7 == 0 ? 1e-30f : 0.0f);
    }
    image.rgba[7] = 65504.0f * 3.0f;
    image.rgba[11] = std::numeric_limits<float>::denorm_min();
    for (const char* name : {"level.L1", "star.alpha"}) {
        nebula::ImageLayer layer{name, std::vector<float>(5 * 3 * 3)};
        for (std::size_t i = 0; i < layer.rgb.size(); ++i) {
            layer.rgb[i] = std::sqrt(float(i + 1)) * (name[0] == 'l' ? 1.0f : -3.0f);
        }
        image.layers.push_back(layer);
    }
    return image;
}

// ---- libpng reader for the tests ------------------------------------------------------------

struct PngReadback
{
    int width = 0;
    int height = 0;
    int colorType = -1;
    int bitDepth = 0;
    bool hasSrgb = false;
    int srgbIntent = -1;
    bool hasGama = false;
    std::vector<unsigned char> rgba; ///< only filled for 8-bit RGBA
    std::map<std::string, std::string> text;

    int at(int x, int y, int c) const { return rgba[(std::size_t(y) * width + x) * 4 + c]; }
};

/// The only function with setjmp: trivially destructible locals only.
bool pngReadAll(png_structp png, png_infop info, std::FILE* fp)
{
    if (setjmp(png_jmpbuf(png))) return false;
    png_init_io(png, fp);
    png_read_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
    return true;
}

bool readPng(const std::string& path, PngReadback* out)
{
    std::FILE* fp = std::fopen(path.c_str(), "rb");
    if (!fp) return false;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    const bool ok = png && info && pngReadAll(png, info, fp);
    if (ok) {
        out->width = int(png_get_image_width(png, info));
        out->height = int(png_get_image_height(png, info));
        out->colorType = png_get_color_type(png, info);
        out->bitDepth = png_get_bit_depth(png, info);
        int intent = -1;
        out->hasSrgb = png_get_sRGB(png, info, &intent) != 0;
        out->srgbIntent = intent;
        double gamma = 0.0;
        out->hasGama = png_get_gAMA(png, info, &gamma) != 0;
        png_textp text = nullptr;
        const int numText = png_get_text(png, info, &text, nullptr);
        for (int i = 0; i < numText; ++i) {
            const std::size_t len = text[i].compression == PNG_ITXT_COMPRESSION_NONE
                                        ? text[i].itxt_length
                                        : text[i].text_length;
            out->text[text[i].key] = std::string(text[i].text, len);
        }
        if (out->colorType == PNG_COLOR_TYPE_RGB_ALPHA && out->bitDepth == 8) {
            png_bytepp rows = png_get_rows(png, info);
            out->rgba.resize(std::size_t(out->width) * out->height * 4);
            for (int y = 0; y < out->height; ++y) {
                std::copy(rows[y], rows[y] + std::size_t(out->width) * 4,
                          out->rgba.begin() + std::ptrdiff_t(y) * out->width * 4);
            }
        }
    }
    if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    std::fclose(fp);
    return ok;
}

/// Luminance as image.h defines it.
double lum(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

void setGrey(nebula::Image& image, std::size_t pixel, float v)
{
    for (int c = 0; c < 3; ++c)
        image.rgba[4 * pixel + c] = v;
    image.rgba[4 * pixel + 3] = 1.0f;
}

} // namespace

// ---- EXR ------------------------------------------------------------------------------------

TEST_F(ImageTest, ExrRoundTripIsExact)
{
    const nebula::Image image = sampleImage();
    const std::map<std::string, std::string> attrs = {
        {"nebula:command", "nebrender -i cloud.vdb -o frame.0001.exr --exposure 2"},
        {"nebula:version", "0.1.0"},
        {"nebula:exposure", "2"},
        {"comments", "reflection nebula, unit test"},
        {"nebula:utf8", "\xce\xbb = 550 nm"},
    };
    const std::string path = file("frame.exr");
    nebula::writeExr(path, image, attrs);
    EXPECT_EQ(listing(), std::vector<std::string>{"frame.exr"});

    std::map<std::string, std::string> readAttrs = {{"stale", "entry"}};
    const nebula::Image back = nebula::readExr(path, &readAttrs);
    EXPECT_EQ(back.width, image.width);
    EXPECT_EQ(back.height, image.height);
    EXPECT_EQ(back.rgba, image.rgba); // float ==: exact
    ASSERT_EQ(back.layers.size(), image.layers.size());
    for (std::size_t i = 0; i < image.layers.size(); ++i) {
        EXPECT_EQ(back.layers[i].name, image.layers[i].name);
        EXPECT_EQ(back.layers[i].rgb, image.layers[i].rgb);
    }
    EXPECT_EQ(readAttrs, attrs);
    EXPECT_TRUE(back.channels.empty());

    // Null attribute map is allowed.
    EXPECT_EQ(nebula::readExr(path, nullptr).rgba, image.rgba);
}

TEST_F(ImageTest, ExrOverwritesExistingFile)
{
    const std::string path = file("frame.exr");
    nebula::Image a(2, 2);
    nebula::writeExr(path, a, {});
    nebula::Image b(3, 1);
    b.rgba[0] = 42.0f;
    nebula::writeExr(path, b, {});
    const nebula::Image back = nebula::readExr(path, nullptr);
    EXPECT_EQ(back.width, 3);
    EXPECT_EQ(back.rgba, b.rgba);
    EXPECT_TRUE(back.layers.empty());
    EXPECT_EQ(listing(), std::vector<std::string>{"frame.exr"});
}

TEST_F(ImageTest, ExrIntoMissingFolderThrowsAndLeavesNothing)
{
    const std::string path = file("missing/frame.exr");
    expectErrorContaining([&] { nebula::writeExr(path, sampleImage(), {}); }, path);
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(listing().empty());
}

TEST_F(ImageTest, ExrBadSizesThrowAndLeaveNothing)
{
    const std::string path = file("frame.exr");

    nebula::Image badLayer = sampleImage();
    badLayer.layers[1].rgb.pop_back();
    expectErrorContaining([&] { nebula::writeExr(path, badLayer, {}); }, path);
    expectErrorContaining([&] { nebula::writeExr(path, badLayer, {}); }, "star.alpha");

    nebula::Image badRgba = sampleImage();
    badRgba.rgba.push_back(0.0f);
    expectErrorContaining([&] { nebula::writeExr(path, badRgba, {}); }, path);

    nebula::Image empty;
    expectErrorContaining([&] { nebula::writeExr(path, empty, {}); }, path);

    nebula::Image duplicate = sampleImage();
    duplicate.layers[1].name = duplicate.layers[0].name;
    expectErrorContaining([&] { nebula::writeExr(path, duplicate, {}); }, "twice");

    EXPECT_TRUE(listing().empty());
}

TEST_F(ImageTest, ExrReservedAttributeThrowsAndLeavesNothing)
{
    const std::string path = file("frame.exr");
    for (const char* key : {"compression", "channels", "dataWindow", "type", ""}) {
        expectErrorContaining([&] { nebula::writeExr(path, sampleImage(), {{key, "x"}}); }, path);
    }
    EXPECT_TRUE(listing().empty());
}

TEST_F(ImageTest, ReadExrErrorsNameThePath)
{
    const std::string missing = file("nope.exr");
    expectErrorContaining([&] { nebula::readExr(missing, nullptr); }, missing);

    const std::string notExr = file("text.exr");
    std::ofstream(notExr) << "this is not an EXR file\n";
    expectErrorContaining([&] { nebula::readExr(notExr, nullptr); }, notExr);
}

// ---- sRGB -----------------------------------------------------------------------------------

TEST(Srgb, KnownValues)
{
    EXPECT_EQ(nebula::srgbEncode(0.0), 0.0);
    EXPECT_EQ(nebula::srgbEncode(1.0), 1.0);
    EXPECT_NEAR(nebula::srgbEncode(0.0031308), 0.04045, 1e-5);
    EXPECT_NEAR(nebula::srgbEncode(0.5), 0.7353569830524495, 1e-9);
    // Clamped outside [0, 1]; NaN encodes as black.
    EXPECT_EQ(nebula::srgbEncode(-0.5), 0.0);
    EXPECT_EQ(nebula::srgbEncode(7.0), 1.0);
    EXPECT_EQ(nebula::srgbEncode(std::nan("")), 0.0);
    // Continuous at the linear/power junction (within 1e-7) and monotonic.
    EXPECT_NEAR(nebula::srgbEncode(0.0031308 * (1 - 1e-12)),
                nebula::srgbEncode(0.0031308 * (1 + 1e-12)), 1e-7);
    double prev = -1.0;
    for (int i = 0; i <= 10000; ++i) {
        const double v = nebula::srgbEncode(i / 10000.0);
        EXPECT_GE(v, prev);
        prev = v;
    }
}

// ---- Tone curve -----------------------------------------------------------------------------

TEST(ToneCurve, AutomaticWhiteIsThePercentile)
{
    // 1000 lit grey pixels with Y = k (k = 1..1000) in a scrambled order plus 200 black ones,
    // which the percentile ignores.
    nebula::Image image(40, 30);
    for (std::size_t i = 0; i < 1000; ++i) {
        const std::size_t pixel = (i * 373) % 1000; // 373 is coprime to 1000
        setGrey(image, pixel, float(i + 1));
    }
    nebula::ToneParams params;
    const double y995 = lum(995, 995, 995); // nearest rank: ceil(0.995 * 1000) = 995th
    nebula::ToneCurve curve = nebula::computeToneCurve(image, params);
    EXPECT_NEAR(curve.white, y995, 1e-12 * y995);
    EXPECT_GE(curve.gamma, nebula::TONE_MIN_GAMMA);
    EXPECT_LE(curve.gamma, 1.0);

    params.percentile = 50.0;
    curve = nebula::computeToneCurve(image, params);
    EXPECT_NEAR(curve.white, lum(500, 500, 500), 1e-12 * 500);

    params.percentile = 100.0;
    curve = nebula::computeToneCurve(image, params);
    EXPECT_NEAR(curve.white, lum(1000, 1000, 1000), 1e-12 * 1000);

    // Deterministic.
    const nebula::ToneCurve again = nebula::computeToneCurve(image, params);
    EXPECT_EQ(again.white, curve.white);
    EXPECT_EQ(again.gamma, curve.gamma);
}

// Pixels that are mostly a star's sprite (Image::starPixel) do not set the automatic white
// point: an ODS frame's nebula fills a few per cent of the pixels and the sprites the top
// half per cent, so the 99.5th percentile would land on a sprite. --tone-stars counts them.
// The mask round-trips through the EXR as its own channel, not as an image channel.
TEST_F(ImageTest, StarPixelsDoNotSetTheWhitePoint)
{
    nebula::Image image(100, 100); // 10000 pixels: 400 of nebula, 60 of star sprites
    for (std::size_t i = 0; i < 400; ++i)
        setGrey(image, i * 11, float(1 + i % 4)); // the nebula: Y 1..4
    image.starPixel.assign(10000, 0);
    for (std::size_t i = 0; i < 60; ++i) {
        const std::size_t p = 5000 + i * 7;
        setGrey(image, p, 1000.0f);
        image.starPixel[p] = 1;
    }
    nebula::ToneParams params;
    const double nebula4 = lum(4, 4, 4);
    EXPECT_NEAR(nebula::computeToneCurve(image, params).white, nebula4, 1e-9 * nebula4);
    params.stars = true; // 460 lit: rank ceil(0.995 * 460) = 458 is a star
    EXPECT_NEAR(nebula::computeToneCurve(image, params).white, lum(1000, 1000, 1000), 1e-6);
    const auto stats = nebula::luminanceStats(image, 99.5);
    EXPECT_EQ(stats.lit, 400u);

    const std::string path = file("stars.exr");
    nebula::writeExr(path, image, {});
    const nebula::Image back = nebula::readExr(path, nullptr);
    EXPECT_TRUE(back.channels.empty());
    EXPECT_EQ(back.starPixel, image.starPixel);
    EXPECT_NEAR(nebula::luminanceStats(back, 99.5).white, nebula4, 1e-9 * nebula4);
    // A mask of the wrong size is refused before anything is written.
    image.starPixel.pop_back();
    EXPECT_THROW(nebula::writeExr(file("bad-stars.exr"), image, {}), nebula::Error);
    EXPECT_FALSE(std::filesystem::exists(file("bad-stars.exr")));
}

TEST(ToneCurve, AutomaticGammaMapsLogMeanToKey)
{
    const double k = nebula::TONE_KEY;
    // Half the pixels at 1, half at k^2: log-mean k of white, so gamma 1.
    nebula::Image image(10, 10);
    for (std::size_t i = 0; i < 100; ++i)
        setGrey(image, i, i % 2 ? 1.0f : float(k * k));
    nebula::ToneCurve curve = nebula::computeToneCurve(image, {});
    EXPECT_NEAR(curve.white, lum(1, 1, 1), 1e-15);
    EXPECT_NEAR(curve.gamma, 1.0, 1e-6);

    // Half at 1, half at k^4: log-mean k^2, gamma = ln(k) / ln(k^2) = 0.5.
    for (std::size_t i = 0; i < 100; ++i)
        setGrey(image, i, i % 2 ? 1.0f : float(std::pow(k, 4)));
    curve = nebula::computeToneCurve(image, {});
    EXPECT_NEAR(curve.gamma, 0.5, 1e-6);
    EXPECT_NEAR(std::pow(k * k, curve.gamma), k, 1e-6);

    // A very dark mean would ask for gamma 0.15: clamped to TONE_MIN_GAMMA.
    for (std::size_t i = 0; i < 100; ++i)
        setGrey(image, i, i % 2 ? 1.0f : 1e-5f);
    curve = nebula::computeToneCurve(image, {});
    EXPECT_EQ(curve.gamma, nebula::TONE_MIN_GAMMA);

    // A flat image: log-mean equals white, gamma 1.
    for (std::size_t i = 0; i < 100; ++i)
        setGrey(image, i, 3.0f);
    curve = nebula::computeToneCurve(image, {});
    EXPECT_NEAR(curve.white, lum(3, 3, 3), 1e-14);
    EXPECT_EQ(curve.gamma, 1.0);
}

TEST(ToneCurve, FixedGammaKeepsTheAutomaticWhite)
{
    // Half the pixels at 1, half at k^4: the automatic curve fits gamma 0.5; a fixed gamma of
    // 0.8 keeps the same white (the 99.5th percentile) and its own gamma.
    const double k = nebula::TONE_KEY;
    nebula::Image image(10, 10);
    for (std::size_t i = 0; i < 100; ++i)
        setGrey(image, i, i % 2 ? 1.0f : float(std::pow(k, 4)));
    nebula::ToneParams params;
    params.fixedGamma = true;
    params.gamma = 0.8;
    const nebula::ToneCurve fitted = nebula::computeToneCurve(image, {});
    const nebula::ToneCurve fixed = nebula::computeToneCurve(image, params);
    EXPECT_NEAR(fitted.gamma, 0.5, 1e-6);
    EXPECT_EQ(fixed.white, fitted.white);
    EXPECT_EQ(fixed.gamma, 0.8);
    params.gamma = -1.0;
    EXPECT_THROW(nebula::computeToneCurve(image, params), nebula::Error);
}

TEST(ToneCurve, BlackAndNonFiniteImagesGiveAValidCurve)
{
    nebula::Image black(8, 8);
    nebula::ToneCurve curve = nebula::computeToneCurve(black, {});
    EXPECT_EQ(curve.white, 1.0);
    EXPECT_EQ(curve.gamma, 1.0);

    // NaN, infinite and negative pixels are ignored.
    nebula::Image odd(4, 1);
    setGrey(odd, 0, std::numeric_limits<float>::quiet_NaN());
    setGrey(odd, 1, std::numeric_limits<float>::infinity());
    setGrey(odd, 2, -5.0f);
    setGrey(odd, 3, 2.0f);
    curve = nebula::computeToneCurve(odd, {});
    EXPECT_TRUE(std::isfinite(curve.white));
    EXPECT_NEAR(curve.white, lum(2, 2, 2), 1e-14);
    EXPECT_EQ(curve.gamma, 1.0);
}

TEST(ToneCurve, ManualExposure)
{
    nebula::ToneParams params;
    params.automatic = false;
    params.exposure = 2.0;
    params.gamma = 0.7;
    nebula::Image image(2, 2);
    setGrey(image, 0, 100.0f); // ignored in manual mode
    nebula::ToneCurve curve = nebula::computeToneCurve(image, params);
    EXPECT_EQ(curve.white, 0.25);
    EXPECT_EQ(curve.gamma, 0.7);

    params.exposure = -3.0;
    params.gamma = 1.0;
    curve = nebula::computeToneCurve(image, params);
    EXPECT_EQ(curve.white, 8.0);

    params.gamma = 0.0;
    EXPECT_THROW(nebula::computeToneCurve(image, params), nebula::Error);
    params.gamma = 1.0;
    params.exposure = std::nan("");
    EXPECT_THROW(nebula::computeToneCurve(image, params), nebula::Error);

    nebula::ToneParams bad;
    bad.percentile = 101.0;
    EXPECT_THROW(nebula::computeToneCurve(image, bad), nebula::Error);
}

// ---- PNG ------------------------------------------------------------------------------------

TEST_F(ImageTest, PngGradient)
{
    // Row 0: a grey ramp from 0 to white. Row 1: above white, negative, NaN, and one colour.
    const int W = 64;
    const nebula::ToneCurve curve{2.0, 0.5};
    nebula::Image image(W, 2);
    for (int x = 0; x < W; ++x)
        setGrey(image, std::size_t(x), float(2.0 * x / (W - 1)));
    setGrey(image, W + 0, 50.0f);
    setGrey(image, W + 1, -1.0f);
    setGrey(image, W + 2, std::numeric_limits<float>::quiet_NaN());
    image.rgba[4 * (W + 3) + 0] = 0.5f; // R only, premultiplied alpha 0.3: not divided
    image.rgba[4 * (W + 3) + 3] = 0.3f;
    const std::map<std::string, std::string> text = {
        {"Software", "nebula 0.1.0"},
        {"Comment", "nebrender -i cloud.vdb -o frame.png"},
        {"Title", "\xce\xbb-ramp"}, // UTF-8: written as iTXt
    };
    const std::string path = file("frame.png");
    nebula::writePng(path, image, curve, text);
    EXPECT_EQ(listing(), std::vector<std::string>{"frame.png"});

    PngReadback png;
    ASSERT_TRUE(readPng(path, &png));
    EXPECT_EQ(png.width, W);
    EXPECT_EQ(png.height, 2);
    EXPECT_EQ(png.colorType, PNG_COLOR_TYPE_RGB_ALPHA);
    EXPECT_EQ(png.bitDepth, 8);
    ASSERT_EQ(png.rgba.size(), std::size_t(W) * 2 * 4);
    EXPECT_TRUE(png.hasSrgb);
    EXPECT_EQ(png.srgbIntent, PNG_sRGB_INTENT_PERCEPTUAL);
    EXPECT_TRUE(png.hasGama);
    EXPECT_EQ(png.text, text);

    EXPECT_EQ(png.at(0, 0, 0), 0);
    EXPECT_EQ(png.at(W - 1, 0, 0), 255); // at the white point
    for (int x = 1; x < W; ++x) {
        EXPECT_GT(png.at(x, 0, 0), png.at(x - 1, 0, 0)) << "x = " << x;
    }
    for (int x = 0; x < W; ++x) {
        EXPECT_EQ(png.at(x, 0, 1), png.at(x, 0, 0));
        EXPECT_EQ(png.at(x, 0, 2), png.at(x, 0, 0));
        EXPECT_EQ(png.at(x, 0, 3), 255);
        // display = sRGB((c / white)^gamma), rounded to 8 bits.
        const double c = double(image.rgba[4 * std::size_t(x)]);
        const double expected = 255.0 * nebula::srgbEncode(std::pow(c / 2.0, 0.5));
        EXPECT_NEAR(png.at(x, 0, 0), expected, 0.5 + 1e-9);
    }
    EXPECT_EQ(png.at(0, 1, 0), 255); // clamped above white
    EXPECT_EQ(png.at(1, 1, 0), 0);   // negative
    EXPECT_EQ(png.at(2, 1, 0), 0);   // NaN
    // Pure red: the luminance curve lifts it above display white, so the colour is scaled
    // down as a whole and stays pure red instead of clipping towards white.
    EXPECT_EQ(png.at(3, 1, 0), 255);
    EXPECT_EQ(png.at(3, 1, 1), 0);
    EXPECT_EQ(png.at(3, 1, 2), 0);
    EXPECT_EQ(png.at(3, 1, 3), 255); // alpha always opaque
}

TEST_F(ImageTest, PngKeepsHueAndMapsLuminance)
{
    // A blue-ish pixel below white: the curve scales its channels alike, so the decoded
    // linear ratios stay 1:2:4, and its luminance is (Y / white)^gamma.
    nebula::Image image(1, 1);
    image.rgba = {0.1f, 0.2f, 0.4f, 1.0f};
    const std::string path = file("hue.png");
    nebula::writePng(path, image, nebula::ToneCurve{2.0, 0.5}, {});
    PngReadback png;
    ASSERT_TRUE(readPng(path, &png));
    const auto linear = [](double v) {
        v /= 255.0;
        return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
    };
    const double r = linear(png.at(0, 0, 0)), g = linear(png.at(0, 0, 1)),
                 b = linear(png.at(0, 0, 2));
    EXPECT_NEAR(g / r, 2.0, 0.05);
    EXPECT_NEAR(b / r, 4.0, 0.1);
    const double Y = lum(0.1, 0.2, 0.4) / 2.0;
    EXPECT_NEAR(lum(r, g, b), std::sqrt(Y), 0.01);
}

TEST_F(ImageTest, PngErrorsThrowAndLeaveNothing)
{
    nebula::Image image(4, 4);
    const nebula::ToneCurve curve;

    const std::string missing = file("missing/frame.png");
    expectErrorContaining([&] { nebula::writePng(missing, image, curve, {}); }, missing);

    const std::string path = file("frame.png");
    expectErrorContaining([&] { nebula::writePng(path, image, curve, {{"", "x"}}); }, path);
    expectErrorContaining(
        [&] {
            nebula::writePng(path, image, curve, {{std::string(80, 'k'), "x"}});
        },
        path);
    expectErrorContaining([&] { nebula::writePng(path, image, {0.0, 1.0}, {}); }, path);
    expectErrorContaining([&] { nebula::writePng(path, image, {1.0, -1.0}, {}); }, path);

    nebula::Image bad(4, 4);
    bad.rgba.resize(3);
    expectErrorContaining([&] { nebula::writePng(path, bad, curve, {}); }, path);

    EXPECT_TRUE(listing().empty());
}

TEST_F(ImageTest, PngLibpngErrorIsReportedAndCleanedUp)
{
    // Wider than libpng's default user limit (1,000,000): libpng itself rejects the IHDR,
    // exercising the setjmp path; the temporary file must be gone afterwards.
    nebula::Image wide(1000001, 1);
    const std::string path = file("wide.png");
    expectErrorContaining([&] { nebula::writePng(path, wide, {}, {}); }, path);
    expectErrorContaining([&] { nebula::writePng(path, wide, {}, {}); }, "exceeds user limit");
    EXPECT_TRUE(listing().empty());
}

TEST_F(ImageTest, WriteErrorsLeaveNothing)
{
    // A file-size limit makes writes fail part-way (EFBIG), as a full disk would. The limit is
    // lifted again before any assertion runs, so test output cannot be affected.
    nebula::Image noise(64, 64);
    std::uint32_t state = 12345u;
    for (float& v : noise.rgba) {
        state = state * 1664525u + 1013904223u; // LCG: incompressible data
        v = float(state >> 8) / float(1u << 24);
    }
    const std::string exr = file("frame.exr");
    const std::string png = file("frame.png");
    std::string exrMessage, pngMessage;

    rlimit old{};
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
    void (*oldHandler)(int) = std::signal(SIGXFSZ, SIG_IGN);
    rlimit small = old;
    small.rlim_cur = 2000;
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
    try {
        nebula::writeExr(exr, noise, {});
    } catch (const nebula::Error& e) {
        exrMessage = e.what();
    }
    try {
        nebula::writePng(png, noise, {}, {});
    } catch (const nebula::Error& e) {
        pngMessage = e.what();
    }
    ::setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, oldHandler);

    EXPECT_NE(exrMessage.find(exr), std::string::npos) << exrMessage;
    EXPECT_NE(pngMessage.find(png), std::string::npos) << pngMessage;
    EXPECT_NE(exrMessage.find("File too large"), std::string::npos) << exrMessage;
    EXPECT_NE(pngMessage.find("File too large"), std::string::npos) << pngMessage;
    EXPECT_TRUE(listing().empty());
}

TEST_F(ImageTest, ExrSingleChannelsRoundTrip)
{
    nebula::Image image = sampleImage();
    for (const char* name : {"S0.550,00nm", "S0.365,00nm"}) {
        nebula::ImageChannel ch{name, std::vector<float>(std::size_t(image.width) * image.height)};
        for (std::size_t i = 0; i < ch.values.size(); ++i)
            ch.values[i] = float(i) * 0.25f + name[4];
        image.channels.push_back(ch);
    }
    const std::string path = file("spectral.exr");
    nebula::writeExr(path, image, {});
    const nebula::Image back = nebula::readExr(path, nullptr);
    ASSERT_EQ(back.layers.size(), image.layers.size()); // layers are not taken for channels
    ASSERT_EQ(back.channels.size(), 2u);
    EXPECT_EQ(back.channels[0].name, "S0.365,00nm"); // channel-name order
    EXPECT_EQ(back.channels[0].values, image.channels[1].values);
    EXPECT_EQ(back.channels[1].values, image.channels[0].values);
    // A channel of the wrong size, or named twice, is refused before anything is written.
    image.channels[1].values.pop_back();
    EXPECT_THROW(nebula::writeExr(file("bad.exr"), image, {}), nebula::Error);
    image.channels[1] = image.channels[0];
    EXPECT_THROW(nebula::writeExr(file("bad.exr"), image, {}), nebula::Error);
    EXPECT_FALSE(std::filesystem::exists(file("bad.exr")));
}

// A single channel named like a layer's but not R, G or B ("variance.Y" beside the path
// tracer's variance.R/G/B) is read back as a channel, not dropped as part of the layer.
TEST_F(ImageTest, ExrChannelBesideALayerRoundTrips)
{
    nebula::Image image = sampleImage();
    ASSERT_FALSE(image.layers.empty());
    const std::string name = image.layers[0].name + ".Y";
    image.channels.push_back({name, std::vector<float>(std::size_t(image.width) * image.height)});
    for (std::size_t i = 0; i < image.channels[0].values.size(); ++i)
        image.channels[0].values[i] = float(i) + 0.5f;
    nebula::writeExr(file("y.exr"), image, {});
    const nebula::Image back = nebula::readExr(file("y.exr"), nullptr);
    ASSERT_EQ(back.layers.size(), image.layers.size());
    EXPECT_EQ(back.layers[0].rgb, image.layers[0].rgb);
    ASSERT_EQ(back.channels.size(), 1u);
    EXPECT_EQ(back.channels[0].name, name);
    EXPECT_EQ(back.channels[0].values, image.channels[0].values);
}

// Pixels outside the camera's view (Image::inView, a dome master's corners) are transparent
// black in the PNG, whatever their values; every other pixel is opaque.
TEST_F(ImageTest, PixelsOutOfViewAreTransparentInThePng)
{
    nebula::Image image(3, 1);
    for (std::size_t i = 0; i < 3; ++i)
        setGrey(image, i, 0.5f);
    image.inView = {1, 0, 1};
    const std::string path = file("dome.png");
    nebula::writePng(path, image, nebula::ToneCurve{}, {});
    PngReadback png;
    ASSERT_TRUE(readPng(path, &png));
    ASSERT_EQ(png.rgba.size(), 12u);
    EXPECT_EQ(png.rgba[3], 255);
    EXPECT_GT(png.rgba[0], 0);
    for (int c = 4; c < 8; ++c)
        EXPECT_EQ(png.rgba[std::size_t(c)], 0) << c;
    EXPECT_EQ(png.rgba[11], 255);
}

// Channel names OpenEXR would truncate are refused (so that <layer>.R, .G and .B never
// collide), at the limit: a layer name of 253 characters is written and read back whole.
TEST_F(ImageTest, ChannelNamesBeyondOpenExrsLimitAreRefused)
{
    nebula::Image img(2, 2);
    nebula::ImageLayer layer;
    layer.name = std::string(nebula::EXR_MAX_CHANNEL_NAME - 2, 'x');
    layer.rgb.assign(2 * 2 * 3, 0.5f);
    img.layers.push_back(layer);
    nebula::writeExr(file("ok.exr"), img, {});
    const auto back = nebula::readExr(file("ok.exr"), nullptr);
    ASSERT_EQ(back.layers.size(), 1u);
    EXPECT_EQ(back.layers[0].name, layer.name);
    img.layers[0].name += "y";
    expectErrorContaining([&] { nebula::writeExr(file("long.exr"), img, {}); },
                          "has 256 characters; OpenEXR keeps 255");
    EXPECT_FALSE(fs::exists(file("long.exr")));
}

// Named layers and channels: handles in the order added, found by name, names unique.
TEST(ImageLayers, AddedLayersAreFoundByNameInTheirOrder)
{
    nebula::Image img(3, 2);
    const nebula::LayerId a = img.addLayer("star.a");
    const nebula::LayerId t = img.addLayer("transmittance", 1.0f);
    const nebula::ChannelId v = img.addChannel("variance.Y");
    ASSERT_EQ(img.layers.size(), 2u);
    EXPECT_EQ(img.layers[0].name, "star.a");
    EXPECT_EQ(img.layers[1].name, "transmittance");
    EXPECT_EQ(img.rgb(a).size(), 3u * 2u * 3u);
    EXPECT_EQ(img.rgb(t), std::vector<float>(18, 1.0f)); // filled as asked
    EXPECT_EQ(img.values(v).size(), 6u);
    EXPECT_EQ(img.layerId("transmittance").index, t.index);
    EXPECT_EQ(img.channelId("variance.Y").index, v.index);
    EXPECT_FALSE(img.findLayer("variance"));
    EXPECT_FALSE(img.findChannel("transmittance")); // layers and channels apart
    img.rgb(t)[4] = 0.5f;
    EXPECT_EQ(img.rgb("transmittance")[4], 0.5f);
}

TEST(ImageLayers, DuplicateOrMissingNamesAreRefusedNamingThem)
{
    nebula::Image img(2, 2);
    img.addLayer("field");
    img.addChannel("S0.400,00nm");
    const auto message = [](const auto& f) {
        try {
            f();
        } catch (const nebula::Error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message([&] { img.addLayer("field"); }).find("\"field\""), std::string::npos);
    EXPECT_NE(message([&] { img.addChannel("S0.400,00nm"); }).find("S0.400,00nm"),
              std::string::npos);
    EXPECT_NE(message([&] { img.layerId("direct"); }).find("no layer \"direct\""),
              std::string::npos);
    EXPECT_NE(message([&] { img.channelId("x"); }).find("no channel \"x\""), std::string::npos);
}

TEST(ImageLayers, RemovedLayersLeaveTheOthersInOrder)
{
    nebula::Image img(1, 1);
    for (const char* name : {"star.a", "transmittance", "field", "emission", "direct"})
        img.addLayer(name);
    img.removeLayers({"field", "direct", "absent"});
    ASSERT_EQ(img.layers.size(), 3u);
    EXPECT_EQ(img.layers[0].name, "star.a");
    EXPECT_EQ(img.layers[1].name, "transmittance");
    EXPECT_EQ(img.layers[2].name, "emission");
    EXPECT_EQ(img.layerId("emission").index, 2u);
}
