// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file image.h
/// Rendered frames: float RGBA plus named RGB layers, written as EXR (linear radiance,
/// DESIGN §8) and PNG (8-bit sRGB after the automatic tone curve).

#include "nebula/core/atomic_file.h"

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// An RGB layer written as EXR channels <name>.R, <name>.G, <name>.B.
struct ImageLayer
{
    std::string name;
    std::vector<float> rgb; ///< width * height * 3, row-major, top row first
};

/// A single float channel written under its own name (e.g. a spectral band "S0.550,00nm").
struct ImageChannel
{
    std::string name;
    std::vector<float> values; ///< width * height, row-major, top row first
};

/// A layer of an Image, as addLayer() or findLayer() returns it: what a renderer holds
/// instead of the layer's position, looked up once per frame and used per pixel.
struct LayerId
{
    std::size_t index = 0; ///< its place in Image::layers
};

/// A single channel of an Image, as addChannel() or findChannel() returns it.
struct ChannelId
{
    std::size_t index = 0; ///< its place in Image::channels
};

/// A frame: premultiplied linear RGBA (A = 1 - transmittance) plus extra layers. Layers and
/// channels are written in the order they were added, and are found by name.
struct Image
{
    int width = 0;
    int height = 0;
    std::vector<float> rgba;            ///< width * height * 4, row-major, top row first
    std::vector<ImageLayer> layers;     ///< e.g. "star.<name>"
    std::vector<ImageChannel> channels; ///< single channels, e.g. spectral bands
    /// width * height: 1 where the pixel is in the camera's view, 0 outside it (a fisheye's
    /// corners: black, and transparent in the PNG). Empty: every pixel is in view.
    std::vector<unsigned char> inView;
    /// width * height: 1 where the star sprites give more than half the pixel's luminance (the
    /// automatic white point leaves these pixels out unless ToneParams::stars). Empty: no
    /// such pixel.
    std::vector<unsigned char> starPixel;

    Image() = default;
    Image(int w, int h) : width(w), height(h), rgba(std::size_t(w) * h * 4, 0.0f) {}

    /// Adds the RGB layer @p name after the others, every value @p fill. Throws Error if the
    /// image has a layer of that name already.
    LayerId addLayer(const std::string& name, float fill = 0.0f);
    /// Adds the single channel @p name after the others, every value 0. Throws Error if the
    /// image has a channel of that name already.
    ChannelId addChannel(const std::string& name);
    /// The layer named @p name, or nullopt.
    std::optional<LayerId> findLayer(const std::string& name) const;
    /// The channel named @p name, or nullopt.
    std::optional<ChannelId> findChannel(const std::string& name) const;
    /// The layer named @p name; throws Error naming it if the image has none.
    LayerId layerId(const std::string& name) const;
    /// The channel named @p name; throws Error naming it if the image has none.
    ChannelId channelId(const std::string& name) const;
    /// Removes the layers named in @p names (those it has); the others keep their order. Ids
    /// taken before are then stale.
    void removeLayers(const std::vector<std::string>& names);

    /// Layer @p id's values (width * height * 3).
    std::vector<float>& rgb(LayerId id) { return layers[id.index].rgb; }
    const std::vector<float>& rgb(LayerId id) const { return layers[id.index].rgb; }
    /// The values of the layer named @p name; throws Error naming it if the image has none.
    const std::vector<float>& rgb(const std::string& name) const { return rgb(layerId(name)); }
    /// Channel @p id's values (width * height).
    std::vector<float>& values(ChannelId id) { return channels[id.index].values; }
    const std::vector<float>& values(ChannelId id) const { return channels[id.index].values; }
};

/// The longest EXR channel name OpenEXR keeps (longer ones are truncated); writeExr() refuses
/// a layer or channel whose name would exceed it.
inline constexpr std::size_t EXR_MAX_CHANNEL_NAME = 255;

/// Writes @p image as a float (32-bit) ZIP-compressed EXR: channels R,G,B,A, each layer's
/// <name>.R/G/B and each single channel under its name. @p attributes become string header
/// attributes (e.g. "nebula:command"), "comments" is set if present. Atomic (AtomicFile). Throws
/// Error on failure.
void writeExr(const std::string& path, const Image& image,
              const std::map<std::string, std::string>& attributes);
/// writeExr() into an open AtomicFile, finished but not committed: for outputs that are
/// committed together (commitAll()).
void writeExr(AtomicFile& file, const Image& image,
              const std::map<std::string, std::string>& attributes);

/// Reads only the string attributes of an EXR (its header). Throws Error on failure.
std::map<std::string, std::string> readExrAttributes(const std::string& path);

/// Reads an EXR written by writeExr (R,G,B,A and layers) and its string attributes; for
/// tests and tools that post-process frames. Layers are every "<name>.R/G/B" triple, in
/// channel-name (alphabetical) order; every other channel (not R,G,B,A) is read into
/// Image::channels, in channel-name order; a missing A reads as 1. @p attributes (may be null) is
/// replaced by the file's string attributes. Throws Error on failure.
Image readExr(const std::string& path, std::map<std::string, std::string>* attributes);

/// Tone curve from linear radiance to display values (DESIGN §8).
struct ToneParams
{
    bool automatic = true;    ///< automatic per-frame exposure and gamma
    double exposure = 0.0;    ///< manual: white point = 2^-exposure (used when !automatic)
    double gamma = 1.0;       ///< manual: display = (L / white)^gamma before sRGB encoding
    double percentile = 99.5; ///< automatic: white point = this percentile of luminance
    /// automatic: keep `gamma` instead of fitting it to the key (the white point stays
    /// automatic), for scenes whose faint parts the fitted gamma would lift too far.
    bool fixedGamma = false;
    /// automatic: let the pixels that are mostly a star's sprite (Image::starPixel) count in
    /// the white point and the log-mean; by default they do not, so that the nebula, not a
    /// star, sets the exposure (an ODS or dome frame, where the cloud fills a few per cent of
    /// the pixels and a sprite the top half per cent).
    bool stars = false;
};

/// The tone curve actually applied to a frame.
struct ToneCurve
{
    double white = 1.0; ///< linear radiance mapped to display 1
    double gamma = 1.0; ///< display = (L / white)^gamma, per channel, then sRGB encode
};

/// Display value (linear, before sRGB encoding) that the automatic curve gives the log-mean
/// luminance: the photographic "key" (18 % grey).
constexpr double TONE_KEY = 0.18;
/// Smallest automatic gamma: frames with a huge dynamic range are compressed no further.
constexpr double TONE_MIN_GAMMA = 0.3;

/// Automatic curve: white = the @p params.percentile luminance (nearest rank) of the pixels
/// with finite luminance > 0; gamma chosen so that the log-mean luminance of the pixels above
/// 1e-6 white maps to display TONE_KEY, clamped to [TONE_MIN_GAMMA, 1] (DESIGN §8; a key
/// of 0.5, as some tone mappers use, flattens nebulae whose 1/r^2 halo spans decades), or
/// @p params.gamma with fixedGamma; a black frame gives white 1, gamma 1. Manual: white =
/// 2^-exposure, gamma as given. Throws Error on an invalid parameter.
ToneCurve computeToneCurve(const Image& image, const ToneParams& params);

/// What the automatic tone curve reads from a frame (recorded in nebrender's EXRs as
/// nebula:luminance, so that a sequence's curve can be computed from all its frames).
struct LuminanceStats
{
    double percentile = 99.5; ///< the white point's luminance percentile
    double white = 0.0;       ///< that percentile of the lit pixels' luminance (0: black)
    double logMean = 0.0;     ///< log-mean luminance of the pixels above 1e-6 white
    std::size_t lit = 0;      ///< pixels with finite luminance > 0
};

/// The statistics of @p image (see computeToneCurve()), over its lit pixels less those of
/// Image::starPixel unless @p stars. Throws Error for a percentile outside [0, 100].
LuminanceStats luminanceStats(const Image& image, double percentile, bool stars = false);

/// The automatic curve of @p stats: white = stats.white, gamma such that the log-mean maps
/// to TONE_KEY, clamped to [TONE_MIN_GAMMA, 1]; white 1, gamma 1 for a black frame. A
/// sequence's curve is this of its smoothed statistics.
ToneCurve toneCurveFromStats(const LuminanceStats& stats);

/// IEC 61966-2-1 sRGB encoding of a linear value in [0, 1].
double srgbEncode(double linear);

/// The EXR channel that holds Image::inView (1 in view, 0 outside), written only for images
/// that have pixels outside the view.
inline constexpr const char* EXR_IN_VIEW_CHANNEL = "inview";
/// The EXR channel that holds Image::starPixel (1: mostly a star's sprite), written only for
/// images that have such pixels.
inline constexpr const char* EXR_STAR_PIXEL_CHANNEL = "starpixel";

/// Writes an 8-bit (or @p bitDepth 16-bit) RGBA sRGB PNG after applying @p curve to the
/// premultiplied RGB (alpha written as 255: the background is black space; 0 for pixels not in
/// view, Image::inView). The curve maps the pixel's luminance Y/white to (Y/white)^gamma and scales
/// R,G,B by the same factor, so hues are kept; a colour whose largest channel would exceed display
/// white is scaled down as a whole. Text chunks from @p text ("Software", "Comment", ...): keys are
/// PNG keywords (1-79 printable ASCII), non-ASCII values are written as UTF-8 iTXt. Carries an sRGB
/// chunk. Atomic. Throws Error on failure.
void writePng(const std::string& path, const Image& image, const ToneCurve& curve,
              const std::map<std::string, std::string>& text, int bitDepth = 8);
/// writePng() into an open AtomicFile, finished but not committed (see writeExr()).
void writePng(AtomicFile& file, const Image& image, const ToneCurve& curve,
              const std::map<std::string, std::string>& text, int bitDepth = 8);

/// The display pixels writePng() writes: RGBA, 8 bits per sample (or 16, big-endian), rows
/// top first, after @p curve and the sRGB encoding (nebview's JPEG frames are these).
/// Throws Error on an invalid curve or bit depth.
std::vector<std::uint8_t> displayPixels(const Image& image, const ToneCurve& curve,
                                        int bitDepth = 8);
/// The 8-bit PNG writePng() would write, as bytes in memory (nebview's lossless frames).
std::string pngBytes(const Image& image, const ToneCurve& curve,
                     const std::map<std::string, std::string>& text = {});

/// True if @p path is a regular file that decodes whole as a PNG (its header, every row and
/// the end chunk, CRCs checked): what --skip-existing requires of a PNG it keeps. A missing,
/// empty, truncated or damaged file gives false.
bool pngReadsBack(const std::string& path);

} // namespace nebula
