// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/image.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/file_format.h"
#include "nebula/physics/colour.h"

#include <IexBaseExc.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <ostream>
#include <set>
#include <sstream>
#include <utility>

namespace nebula {

namespace {

std::size_t pixelCount(int width, int height)
{
    return std::size_t(width) * std::size_t(height);
}

/// Throws Error (prefixed with @p where) unless the frame's sizes are consistent.
void validateImage(const std::string& where, const Image& image, bool withLayers)
{
    if (image.width <= 0 || image.height <= 0) {
        throw Error(where + ": image size must be positive, got " + std::to_string(image.width) +
                    " x " + std::to_string(image.height));
    }
    const std::size_t n = pixelCount(image.width, image.height);
    if (image.rgba.size() != n * 4) {
        throw Error(where + ": RGBA data has " + std::to_string(image.rgba.size()) +
                    " floats, expected " + std::to_string(n * 4) + " for " +
                    std::to_string(image.width) + " x " + std::to_string(image.height));
    }
    if (!image.inView.empty() && image.inView.size() != n) {
        throw Error(where + ": the image's in-view mask does not match its size");
    }
    if (!image.starPixel.empty() && image.starPixel.size() != n) {
        throw Error(where + ": the image's star-pixel mask does not match its size");
    }
    if (!withLayers) return;
    std::set<std::string> names;
    // OpenEXR keeps channel names of up to 255 characters (and truncates longer ones, so that
    // R, G and B of a long layer name would collide): "<layer>.R" must fit.
    const auto requireLength = [&](const std::string& name, std::size_t suffix) {
        if (name.size() + suffix > EXR_MAX_CHANNEL_NAME) {
            throw Error(where + ": image channel \"" + name.substr(0, 40) + "...\" has " +
                        std::to_string(name.size() + suffix) + " characters; OpenEXR keeps " +
                        std::to_string(EXR_MAX_CHANNEL_NAME));
        }
    };
    for (const ImageLayer& layer : image.layers) {
        if (layer.name.empty()) throw Error(where + ": image layer with an empty name");
        requireLength(layer.name, 2);
        if (!names.insert(layer.name).second) {
            throw Error(where + ": image layer \"" + layer.name + "\" appears twice");
        }
        if (layer.rgb.size() != n * 3) {
            throw Error(where + ": layer \"" + layer.name + "\" has " +
                        std::to_string(layer.rgb.size()) + " floats, expected " +
                        std::to_string(n * 3));
        }
    }
    for (const ImageChannel& ch : image.channels) {
        if (ch.name.empty()) throw Error(where + ": image channel with an empty name");
        requireLength(ch.name, 0);
        if (!names.insert(ch.name).second) {
            throw Error(where + ": image channel \"" + ch.name + "\" appears twice");
        }
        if (ch.values.size() != n) {
            throw Error(where + ": channel \"" + ch.name + "\" has " +
                        std::to_string(ch.values.size()) + " floats, expected " +
                        std::to_string(n));
        }
    }
}

/// An Imf::OStream over an AtomicFile's checked stream that throws on the first failure.
/// OutputFile's destructor writes the line offset table and swallows exceptions, so the
/// stream's own error state (checked by AtomicFile::finish()) is what catches a full disk.
class ExrOStream : public Imf::OStream
{
public:
    ExrOStream(std::ostream& os, const std::string& name) : Imf::OStream(name.c_str()), mOs(os) {}

    void write(const char c[], int n) override
    {
        mOs.write(c, std::streamsize(n));
        if (!mOs) throw Iex::IoExc("write failed");
        mPos += uint64_t(n);
    }
    // OutputFile's destructor calls these outside its own try block: they must not throw. A
    // failed seek leaves the stream bad, which AtomicFile::finish() reports.
    uint64_t tellp() override { return mPos; }
    void seekp(uint64_t pos) override
    {
        mOs.seekp(std::streamoff(pos));
        mPos = pos;
    }

private:
    std::ostream& mOs;
    uint64_t mPos = 0;
};

char* sliceBase(const float* p)
{
    // Imf::Slice takes a non-const pointer for both directions; OutputFile only reads it.
    return const_cast<char*>(reinterpret_cast<const char*>(p));
}

// ---- PNG ------------------------------------------------------------------------------------

/// Where the libpng callbacks leave their messages (libpng often explains an error in the
/// warning just before it, e.g. "Image width exceeds user limit" before "Invalid IHDR data").
struct PngErrorState
{
    char message[256] = {};
    char lastWarning[256] = {};
};

void pngError(png_structp png, png_const_charp msg)
{
    auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
    if (state) std::snprintf(state->message, sizeof state->message, "%s", msg ? msg : "?");
    png_longjmp(png, 1);
}

void pngWarning(png_structp png, png_const_charp msg)
{
    // libnebula never prints: keep the warning for the error message, if one follows.
    auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
    if (state) std::snprintf(state->lastWarning, sizeof state->lastWarning, "%s", msg ? msg : "");
}

/// libpng's output: an AtomicFile's checked stream; a failed write is a libpng error.
void pngWriteData(png_structp png, png_bytep data, png_size_t length)
{
    auto* os = static_cast<std::ostream*>(png_get_io_ptr(png));
    if (!os->write(reinterpret_cast<const char*>(data), std::streamsize(length))) {
        png_error(png, "write failed");
    }
}

void pngFlush(png_structp) {}

/// Every libpng call that may longjmp happens inside this function, which holds only
/// trivially destructible locals: the jump back to setjmp skips no C++ destructor.
/// Returns false after a libpng error (the message is in the error state).
bool pngWriteAll(png_structp png, png_infop info, std::ostream* os, png_uint_32 width,
                 png_uint_32 height, int bitDepth, png_bytepp rows, png_textp text, int numText)
{
    if (setjmp(png_jmpbuf(png))) return false;
    png_set_write_fn(png, os, pngWriteData, pngFlush);
    png_set_IHDR(png, info, width, height, bitDepth, PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    if (numText > 0) png_set_text(png, info, text, numText);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, info);
    return true;
}

/// PNG keywords: 1 to 79 printable Latin-1 characters without leading, trailing or double
/// spaces (PNG spec 11.3.4.3); we accept the ASCII subset.
bool validPngKeyword(const std::string& key)
{
    if (key.empty() || key.size() > 79 || key.front() == ' ' || key.back() == ' ') return false;
    for (std::size_t i = 0; i < key.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(key[i]);
        if (c < 32 || c > 126) return false;
        if (c == ' ' && key[i + 1] == ' ') return false;
    }
    return true;
}

bool isAscii(const std::string& s)
{
    return std::all_of(s.begin(), s.end(),
                       [](char c) { return static_cast<unsigned char>(c) < 128 && c != '\0'; });
}

} // namespace

// ---- EXR ------------------------------------------------------------------------------------

LayerId Image::addLayer(const std::string& name, float fill)
{
    if (findLayer(name)) throw Error("the image has two layers named \"" + name + "\"");
    layers.push_back({name, std::vector<float>(pixelCount(width, height) * 3, fill)});
    return LayerId{layers.size() - 1};
}

ChannelId Image::addChannel(const std::string& name)
{
    if (findChannel(name)) throw Error("the image has two channels named \"" + name + "\"");
    channels.push_back({name, std::vector<float>(pixelCount(width, height), 0.0f)});
    return ChannelId{channels.size() - 1};
}

std::optional<LayerId> Image::findLayer(const std::string& name) const
{
    for (std::size_t i = 0; i < layers.size(); ++i)
        if (layers[i].name == name) return LayerId{i};
    return std::nullopt;
}

std::optional<ChannelId> Image::findChannel(const std::string& name) const
{
    for (std::size_t i = 0; i < channels.size(); ++i)
        if (channels[i].name == name) return ChannelId{i};
    return std::nullopt;
}

LayerId Image::layerId(const std::string& name) const
{
    if (const auto id = findLayer(name)) return *id;
    throw Error("the image has no layer \"" + name + "\"");
}

ChannelId Image::channelId(const std::string& name) const
{
    if (const auto id = findChannel(name)) return *id;
    throw Error("the image has no channel \"" + name + "\"");
}

void Image::removeLayers(const std::vector<std::string>& names)
{
    const auto named = [&](const ImageLayer& l) {
        return std::find(names.begin(), names.end(), l.name) != names.end();
    };
    layers.erase(std::remove_if(layers.begin(), layers.end(), named), layers.end());
}

void writeExr(AtomicFile& file, const Image& image,
              const std::map<std::string, std::string>& attributes)
{
    const std::string& path = file.path();
    checkOutputName(path, "output", FileFormat::Exr);
    validateImage(path, image, true);

    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;

    // Attributes OpenEXR defines with other types (or uses to describe the file layout)
    // cannot be replaced by strings; say so instead of failing deep inside OpenEXR.
    static const char* const reserved[] = {
        "type", "tiles", "chunkCount", "version", "maxSamplesPerPixel", "name"};
    for (const auto& [key, value] : attributes) {
        if (key.empty()) throw Error(path + ": EXR attribute with an empty name");
        const bool isReserved =
            header.find(key) != header.end() ||
            std::find(std::begin(reserved), std::end(reserved), key) != std::end(reserved);
        if (isReserved) {
            throw Error(path + ": EXR attribute \"" + key +
                        "\" is reserved by OpenEXR and cannot be set as a string");
        }
    }

    try {
        const std::size_t rgbaX = 4 * sizeof(float);
        const std::size_t rgbaY = rgbaX * std::size_t(image.width);
        const std::size_t rgbX = 3 * sizeof(float);
        const std::size_t rgbY = rgbX * std::size_t(image.width);

        // Beauty pass in unprefixed R,G,B,A (ecosystem B3), layers as <name>.R/G/B.
        Imf::FrameBuffer fb;
        static const char* const rgbaNames[] = {"R", "G", "B", "A"};
        for (int c = 0; c < 4; ++c) {
            header.channels().insert(rgbaNames[c], Imf::Channel(Imf::FLOAT));
            fb.insert(rgbaNames[c],
                      Imf::Slice(Imf::FLOAT, sliceBase(image.rgba.data() + c), rgbaX, rgbaY));
        }
        for (const ImageLayer& layer : image.layers) {
            for (int c = 0; c < 3; ++c) {
                const std::string name = layer.name + "." + rgbaNames[c];
                header.channels().insert(name, Imf::Channel(Imf::FLOAT));
                fb.insert(name,
                          Imf::Slice(Imf::FLOAT, sliceBase(layer.rgb.data() + c), rgbX, rgbY));
            }
        }
        for (const ImageChannel& ch : image.channels) {
            header.channels().insert(ch.name, Imf::Channel(Imf::FLOAT));
            fb.insert(ch.name, Imf::Slice(Imf::FLOAT, sliceBase(ch.values.data()), sizeof(float),
                                          sizeof(float) * std::size_t(image.width)));
        }
        // The masks (sizes checked by validateImage()) as float channels of 0 and 1, each
        // written only where the image has one: the in-view mask (a dome master's corners)
        // and the star pixels. The floats live until the pixels are written.
        std::vector<float> maskValues[2];
        const std::pair<const char*, const std::vector<unsigned char>*> masks[2] = {
            {EXR_IN_VIEW_CHANNEL, &image.inView}, {EXR_STAR_PIXEL_CHANNEL, &image.starPixel}};
        for (int k = 0; k < 2; ++k) {
            const auto& [channel, mask] = masks[k];
            if (mask->empty()) continue;
            maskValues[k].assign(mask->begin(), mask->end());
            header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
            fb.insert(channel, Imf::Slice(Imf::FLOAT, sliceBase(maskValues[k].data()),
                                          sizeof(float), sizeof(float) * std::size_t(image.width)));
        }
        for (const auto& [key, value] : attributes) {
            header.insert(key, Imf::StringAttribute(value));
        }

        ExrOStream os(file.stream(), path);
        {
            Imf::OutputFile out(os, header);
            out.setFrameBuffer(fb);
            out.writePixels(image.height);
        } // the destructor writes the line offset table
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(path + ": cannot write EXR: " + e.what());
    }
    file.finish(); // a write the line offset table failed is reported here
}

void writeExr(const std::string& path, const Image& image,
              const std::map<std::string, std::string>& attributes)
{
    AtomicFile file(path);
    writeExr(file, image, attributes);
    file.commit();
}

std::map<std::string, std::string> readExrAttributes(const std::string& path)
{
    try {
        Imf::InputFile in(path.c_str());
        std::map<std::string, std::string> attributes;
        for (auto it = in.header().begin(); it != in.header().end(); ++it) {
            if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) {
                attributes[it.name()] = s->value();
            }
        }
        return attributes;
    } catch (const std::exception& e) {
        throw Error(path + ": cannot read EXR: " + e.what());
    }
}

Image readExr(const std::string& path, std::map<std::string, std::string>* attributes)
{
    try {
        Imf::InputFile in(path.c_str());
        const Imf::Header& header = in.header();
        const Imath::Box2i dw = header.dataWindow();
        const std::int64_t w = std::int64_t(dw.max.x) - dw.min.x + 1;
        const std::int64_t h = std::int64_t(dw.max.y) - dw.min.y + 1;
        if (w <= 0 || h <= 0 || w > INT_MAX || h > INT_MAX) {
            throw Error(path + ": EXR data window has an invalid size");
        }

        const Imf::ChannelList& channels = header.channels();
        for (const char* c : {"R", "G", "B"}) {
            if (!channels.findChannel(c)) {
                throw Error(path + ": EXR has no channel \"" + c + "\" (expected R,G,B,A)");
            }
        }

        const int width = static_cast<int>(w);
        const int height = static_cast<int>(h);
        Image image(width, height);
        const std::size_t rgbaX = 4 * sizeof(float);
        const std::size_t rgbX = 3 * sizeof(float);
        static const char* const names[] = {"R", "G", "B", "A"};

        Imf::FrameBuffer fb;
        for (int c = 0; c < 4; ++c) {
            // A missing alpha reads as opaque.
            const double fill = c == 3 ? 1.0 : 0.0;
            fb.insert(names[c], Imf::Slice::Make(Imf::FLOAT, image.rgba.data() + c, dw, rgbaX,
                                                 rgbaX * std::size_t(w), 1, 1, fill));
        }

        // Layers: every "<layer>.R" with matching ".G" and ".B", in channel-name order.
        for (auto it = channels.begin(); it != channels.end(); ++it) {
            const std::string name = it.name();
            if (name.size() < 3 || name.compare(name.size() - 2, 2, ".R") != 0) continue;
            const std::string layer = name.substr(0, name.size() - 2);
            if (!channels.findChannel(layer + ".G") || !channels.findChannel(layer + ".B")) {
                continue;
            }
            image.layers.push_back({layer, std::vector<float>(pixelCount(width, height) * 3)});
        }
        for (ImageLayer& layer : image.layers) {
            for (int c = 0; c < 3; ++c) {
                fb.insert(layer.name + "." + names[c],
                          Imf::Slice::Make(Imf::FLOAT, layer.rgb.data() + c, dw, rgbX,
                                           rgbX * std::size_t(w)));
            }
        }
        // Single channels: everything that is neither R,G,B,A nor part of a layer.
        for (auto it = channels.begin(); it != channels.end(); ++it) {
            const std::string name = it.name();
            if (name == "R" || name == "G" || name == "B" || name == "A") continue;
            bool inLayer = false;
            for (const ImageLayer& layer : image.layers) {
                if (name.size() == layer.name.size() + 2 &&
                    name.compare(0, layer.name.size(), layer.name) == 0 &&
                    name[layer.name.size()] == '.' &&
                    (name.back() == 'R' || name.back() == 'G' || name.back() == 'B')) {
                    inLayer = true;
                }
            }
            if (!inLayer)
                image.channels.push_back({name, std::vector<float>(pixelCount(width, height))});
        }
        for (ImageChannel& ch : image.channels) {
            fb.insert(ch.name, Imf::Slice::Make(Imf::FLOAT, ch.values.data(), dw, sizeof(float),
                                                sizeof(float) * std::size_t(w)));
        }

        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        // The in-view and star-pixel masks come back as Image::inView and
        // Image::starPixel, not as channels.
        for (const auto& [channel, mask] : {std::pair{EXR_IN_VIEW_CHANNEL, &image.inView},
                                            std::pair{EXR_STAR_PIXEL_CHANNEL, &image.starPixel}}) {
            for (auto it = image.channels.begin(); it != image.channels.end(); ++it) {
                if (it->name != channel) continue;
                mask->resize(it->values.size());
                for (std::size_t i = 0; i < it->values.size(); ++i)
                    (*mask)[i] = it->values[i] > 0.5f ? 1 : 0;
                image.channels.erase(it);
                break;
            }
        }

        if (attributes) {
            attributes->clear();
            for (auto it = header.begin(); it != header.end(); ++it) {
                if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) {
                    (*attributes)[it.name()] = s->value();
                }
            }
        }
        return image;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(path + ": cannot read EXR: " + e.what());
    }
}

// ---- Tone curve -----------------------------------------------------------------------------

ToneCurve computeToneCurve(const Image& image, const ToneParams& params)
{
    ToneCurve curve;
    if (!params.automatic) {
        if (!std::isfinite(params.exposure)) throw Error("tone curve: exposure must be finite");
        if (!(params.gamma > 0.0) || !std::isfinite(params.gamma)) {
            throw Error("tone curve: gamma must be positive, got " + std::to_string(params.gamma));
        }
        curve.white = std::exp2(-params.exposure);
        curve.gamma = params.gamma;
        if (!(curve.white > 0.0) || !std::isfinite(curve.white)) {
            throw Error("tone curve: exposure " + std::to_string(params.exposure) +
                        " is out of range");
        }
        return curve;
    }
    ToneCurve automatic =
        toneCurveFromStats(luminanceStats(image, params.percentile, params.stars));
    if (params.fixedGamma) {
        if (!(params.gamma > 0.0) || !std::isfinite(params.gamma)) {
            throw Error("tone curve: gamma must be positive, got " + std::to_string(params.gamma));
        }
        automatic.gamma = params.gamma;
    }
    return automatic;
}

LuminanceStats luminanceStats(const Image& image, double percentile, bool stars)
{
    if (!(percentile >= 0.0 && percentile <= 100.0)) {
        throw Error("tone curve: percentile must be in [0, 100], got " +
                    std::to_string(percentile));
    }
    validateImage("tone curve", image, false);
    LuminanceStats stats;
    stats.percentile = percentile;

    // Luminance of the lit pixels (NaN, infinity and black excluded), in pixel order.
    const std::size_t n = pixelCount(image.width, image.height);
    std::vector<double> Y;
    Y.reserve(n);
    const bool skipStars = !stars && !image.starPixel.empty();
    for (std::size_t i = 0; i < n; ++i) {
        if (skipStars && image.starPixel[i]) continue;
        const float* p = &image.rgba[4 * i];
        const double L = linearSRGBLuminance(p[0], p[1], p[2]);
        if (L > 0.0 && std::isfinite(L)) Y.push_back(L);
    }
    stats.lit = Y.size();
    if (Y.empty()) return stats; // black frame

    // White point: nearest-rank percentile, the smallest Y with at least p% of Y <= it.
    std::vector<double> sorted = Y;
    const double rank = std::ceil(percentile * double(sorted.size()) / 100.0 - 1e-9);
    const std::size_t k = std::size_t(std::clamp(rank - 1.0, 0.0, double(sorted.size() - 1)));
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(k), sorted.end());
    stats.white = sorted[k];

    // Log-mean over the pixels above 1e-6 white, summed in pixel order (deterministic).
    double sumLog = 0.0;
    std::size_t count = 0;
    for (double L : Y) {
        if (L > 1e-6 * stats.white) {
            sumLog += std::log(L);
            ++count;
        }
    }
    stats.logMean = std::exp(sumLog / double(count)); // count >= 1: white itself
    return stats;
}

ToneCurve toneCurveFromStats(const LuminanceStats& stats)
{
    ToneCurve curve; // a black frame: white 1, gamma 1
    if (!(stats.white > 0.0) || !std::isfinite(stats.white)) return curve;
    // gamma maps the log-mean to the photographic key, linear display 0.18 (sRGB ~0.46):
    // (L_avg / white)^gamma = 0.18; clamped so that dark frames are not flattened.
    curve.white = stats.white;
    if (stats.logMean > 0.0 && stats.logMean < stats.white) {
        curve.gamma = std::clamp(std::log(TONE_KEY) / std::log(stats.logMean / stats.white),
                                 TONE_MIN_GAMMA, 1.0);
    }
    return curve;
}

double srgbEncode(double linear)
{
    if (!(linear > 0.0)) return 0.0; // also NaN
    if (linear >= 1.0) return 1.0;
    if (linear <= 0.0031308) return 12.92 * linear;
    return 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// ---- PNG ------------------------------------------------------------------------------------

namespace {

/// Refuses a bit depth other than 8 or 16 and a tone curve that is not finite and positive.
void checkToneOutput(const std::string& where, int bitDepth, const ToneCurve& curve)
{
    if (bitDepth != 8 && bitDepth != 16) {
        throw Error(where + ": PNG bit depth must be 8 or 16, got " + std::to_string(bitDepth));
    }
    if (!(curve.white > 0.0) || !std::isfinite(curve.white) || !(curve.gamma > 0.0) ||
        !std::isfinite(curve.gamma)) {
        throw Error(where + ": invalid tone curve (white " + std::to_string(curve.white) +
                    ", gamma " + std::to_string(curve.gamma) + ")");
    }
}

/// The PNG of @p pixels (displayPixels()) with @p text's chunks into @p os; throws Error
/// naming @p where.
void encodePng(std::ostream& os, const std::string& where, const Image& image,
               std::vector<std::uint8_t>& pixels, int bitDepth,
               const std::map<std::string, std::string>& text)
{
    for (const auto& [key, value] : text) {
        if (!validPngKeyword(key)) {
            throw Error(where + ": PNG text key \"" + key +
                        "\" must be 1 to 79 printable ASCII characters without leading, "
                        "trailing or double spaces");
        }
    }
    const std::size_t bytes = std::size_t(bitDepth / 8);
    std::vector<png_bytep> rows(std::size_t(image.height));
    for (int y = 0; y < image.height; ++y) {
        rows[std::size_t(y)] =
            pixels.data() + std::size_t(y) * std::size_t(image.width) * 4 * bytes;
    }

    // tEXt for ASCII values, iTXt (UTF-8) otherwise. libpng copies the strings.
    std::vector<png_text> chunks;
    for (const auto& [key, value] : text) {
        png_text t;
        std::memset(&t, 0, sizeof t);
        const bool ascii = isAscii(value);
        t.compression = ascii ? PNG_TEXT_COMPRESSION_NONE : PNG_ITXT_COMPRESSION_NONE;
        t.key = const_cast<png_charp>(key.c_str());
        t.text = const_cast<png_charp>(value.c_str());
        t.text_length = ascii ? value.size() : 0;
        t.itxt_length = ascii ? 0 : value.size();
        t.lang = nullptr;
        t.lang_key = nullptr;
        chunks.push_back(t);
    }

    PngErrorState err;
    bool ok = false;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        std::snprintf(err.message, sizeof err.message, "out of memory");
    } else {
        ok = pngWriteAll(png, info, &os, png_uint_32(image.width), png_uint_32(image.height),
                         bitDepth, rows.data(), chunks.data(), int(chunks.size()));
    }
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
    if (!ok && os) {
        std::string why = err.message;
        if (err.lastWarning[0] != '\0') why += std::string(" (") + err.lastWarning + ")";
        throw Error(where + ": cannot write PNG: " + why);
    }
}

} // namespace

std::vector<std::uint8_t> displayPixels(const Image& image, const ToneCurve& curve, int bitDepth)
{
    validateImage("display pixels", image, false);
    checkToneOutput("display pixels", bitDepth, curve);
    // The tone curve acts on luminance and scales R,G,B alike, so hues survive (a per-channel
    // curve would push the blue of a hot star's halo to white); a colour brighter than
    // display white is scaled down as a whole. Then sRGB.
    const std::size_t n = pixelCount(image.width, image.height);
    const std::size_t bytes = std::size_t(bitDepth / 8); // 16-bit samples are big-endian
    const double maxValue = bitDepth == 16 ? 65535.0 : 255.0;
    std::vector<std::uint8_t> pixels(n * 4 * bytes);
    const auto put = [&](std::size_t sample, double v) { // v in [0, 1]
        const long q = std::lround(v * maxValue);
        if (bytes == 2) {
            pixels[2 * sample] = std::uint8_t(q >> 8);
            pixels[2 * sample + 1] = std::uint8_t(q & 0xff);
        } else {
            pixels[sample] = std::uint8_t(q);
        }
    };
    const double invWhite = 1.0 / curve.white;
    for (std::size_t i = 0; i < n; ++i) {
        double rgb[3];
        for (int c = 0; c < 3; ++c) {
            const double x = double(image.rgba[4 * i + c]) * invWhite;
            rgb[c] = x > 0.0 ? x : 0.0; // NaN -> 0
        }
        const double Y = linearSRGBLuminance(rgb[0], rgb[1], rgb[2]);
        const double scale = Y > 0.0 ? std::pow(Y, curve.gamma) / Y : 0.0;
        const double peak = std::max({rgb[0], rgb[1], rgb[2]}) * scale;
        const double fit = peak > 1.0 ? 1.0 / peak : 1.0;
        for (int c = 0; c < 3; ++c) {
            put(4 * i + std::size_t(c), srgbEncode(std::min(1.0, rgb[c] * scale * fit)));
        }
        // Space is black and opaque; a pixel outside the camera's view (a dome master's
        // corners) is transparent black.
        const bool outside = !image.inView.empty() && image.inView[i] == 0;
        if (outside) {
            for (int c = 0; c < 3; ++c)
                put(4 * i + std::size_t(c), 0.0);
        }
        put(4 * i + 3, outside ? 0.0 : 1.0);
    }
    return pixels;
}

void writePng(AtomicFile& file, const Image& image, const ToneCurve& curve,
              const std::map<std::string, std::string>& text, int bitDepth)
{
    const std::string& path = file.path();
    checkOutputName(path, "output", FileFormat::Png);
    validateImage(path, image, false);
    checkToneOutput(path, bitDepth, curve);
    std::vector<std::uint8_t> pixels = displayPixels(image, curve, bitDepth);
    encodePng(file.stream(), path, image, pixels, bitDepth, text);
    file.finish(); // names the OS error of a failed write
}

std::string pngBytes(const Image& image, const ToneCurve& curve,
                     const std::map<std::string, std::string>& text)
{
    std::vector<std::uint8_t> pixels = displayPixels(image, curve, 8);
    std::ostringstream os;
    encodePng(os, "PNG in memory", image, pixels, 8, text);
    return std::move(os).str();
}

void writePng(const std::string& path, const Image& image, const ToneCurve& curve,
              const std::map<std::string, std::string>& text, int bitDepth)
{
    AtomicFile file(path);
    writePng(file, image, curve, text, bitDepth);
    file.commit();
}

bool pngReadsBack(const std::string& path)
{
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return false;
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&image, path.c_str())) {
        png_image_free(&image);
        return false;
    }
    image.format = PNG_FORMAT_RGBA;
    const std::size_t bytes = PNG_IMAGE_SIZE(image);
    if (bytes == 0 || bytes > (std::size_t(1) << 34)) {
        png_image_free(&image);
        return false;
    }
    std::vector<png_byte> pixels(bytes);
    const bool ok = png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr) != 0;
    png_image_free(&image);
    return ok && (image.warning_or_error & PNG_IMAGE_ERROR) == 0;
}

} // namespace nebula
