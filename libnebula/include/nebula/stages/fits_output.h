// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file fits_output.h
/// nebrender --fits: calibrated images (DESIGN §13). The render is calibrated
/// (RenderOptions::monochromatic, with its component layers): in RGB mode its channels are
/// monochromatic images at their wavelengths, in spectral mode its spectral layers are
/// bands' mean spectral radiance. This turns them into surface brightness in an astronomer's
/// unit per component (total, direct, scattered, single, field, and the gas's emission in
/// spectral mode) with a celestial TAN (or linear) WCS and the observer's keywords: in RGB
/// mode one image per component and wavelength (or, --fits-layout tab, a cube per component
/// with a WAVE-TAB axis), in spectral mode a cube per component with a linear WAVE axis.

#include "nebula/core/atomic_file.h"
#include "nebula/io/fits_image.h"
#include "nebula/io/image.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/filters.h"
#include "nebula/render/options.h"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// How --fits writes RGB mode's wavelengths, which are not evenly spaced (--fits-layout).
enum class FitsLayout {
    /// One 2-D image HDU per component and wavelength: EXTNAME the component, EXTVER 1..N in
    /// ascending wavelength, WAVELEN the wavelength [nm]. Every HDU opens with a plain
    /// astropy WCS(header) (the default).
    Planes,
    /// One cube per component with a WAVE-TAB axis and its table WCS-TAB (Greisen et al.
    /// 2006): a reader needs the whole file, WCS(header, hdul).
    Tab
};

/// What --fits writes.
struct FitsOutput
{
    std::string path;            ///< "" for none
    std::string sed;             ///< --sed: the SED as CSV ("" for none)
    std::string unit = "MJy/sr"; ///< BUNIT: "MJy/sr" or "W/m2/sr/nm"
    /// A celestial WCS: the look-at point at right ascension @p ra, declination @p dec
    /// [degrees] (ICRS); the image's up at position angle @p positionAngle [degrees] from
    /// north through east. Otherwise a linear WCS in pc (orthographic camera only).
    bool sky = false;
    double ra = 0.0;
    double dec = 0.0;
    double positionAngle = 0.0;
    /// A passband (--filter): the channels are its three quadrature nodes, and each
    /// component is one band-averaged image (DESIGN §13.1), the SED one row at the pivot.
    std::optional<Filter> filter;
    FitsLayout layout = FitsLayout::Planes; ///< --fits-layout (RGB mode without a filter)
};

/// Whether a calibrated output (--fits or --sed) is asked for.
inline bool calibrated(const FitsOutput& fits)
{
    return !fits.path.empty() || !fits.sed.empty();
}

/// Throws UsageError naming the option unless --fits and --sed suit the render: a
/// perspective or orthographic camera (a perspective FITS needs --sky), one frame,
/// --fits-unit known, --sky within [0, 360) x [-90, 90], distinct wavelengths (RGB mode), a
/// filter inside 360-830 nm (spectral mode), --fits-layout tab only for --fits of RGB mode
/// without a filter (the only cube with unevenly spaced wavelengths).
void checkFitsOutput(const FitsOutput& fits, const RenderOptions& opts, bool manyFrames);

/// Throws UsageError naming @p source (the option that set them: "--wavelengths", or the
/// filter whose quadrature nodes they are) unless the channels' wavelengths @p lambda_nm lie
/// in [MIN_FILTER_LAMBDA_NM, MAX_FILTER_LAMBDA_NM) (Planck's law of a calibrated render
/// stays finite there) and inside @p dust's extinction curve (CCM89: 125-3333 nm).
void checkChannelWavelengths(const std::array<double, 3>& lambda_nm, const DustParams& dust,
                             const std::string& source);

/// The factor that turns spectral radiance [L_sun pc^-2 sr^-1 nm^-1] at @p lambda_nm into
/// @p unit ("MJy/sr" or "W/m2/sr/nm").
double surfaceBrightnessFactor(const std::string& unit, double lambda_nm);

/// The WCS cards of the image plane (axes 1, 2) for @p camera: RA---TAN/DEC--TAN with a CD
/// matrix, CRVAL at the look-at point and CRPIX at the image centre when fits.sky (exact for
/// the perspective camera, a gnomonic projection; the orthographic camera's pixel spans
/// pixel / distance radians); else linear offsets in pc from the look-at point.
std::vector<FitsCard> imageWcsCards(const Camera& camera, const FitsOutput& fits);

/// The flux density at the observer [Jy] of each component at one wavelength: the sum over
/// the image of surface brightness times each pixel's solid angle. The gas's emission is
/// calibrated in spectral mode only (hasCalibratedEmission()); in RGB mode it is 0.
struct SedRow
{
    double lambda_nm = 0.0;
    double total = 0.0, direct = 0.0, scattered = 0.0, single = 0.0, field = 0.0;
    double emission = 0.0;
};

/// Whether a calibrated render with @p opts has the gas's emission as a component: spectral
/// mode (its lines and black bodies have spectra); RGB mode leaves the glow out.
inline bool hasCalibratedEmission(const RenderOptions& opts)
{
    return opts.spectral.enabled;
}

/// The SED of @p img (a calibrated render with component layers: RenderOptions::
/// monochromatic and componentLayers, with the camera of @p opts) at its wavelengths,
/// ascending: RGB mode, the channels'; spectral mode, the spectral layers' centres (each the
/// band's mean). Through @p filter, one row: the band averages <f_nu> at the pivot
/// wavelength (RGB mode: from the channels, its quadrature nodes; spectral mode: from the
/// layers, the spectrum constant across each).
std::vector<SedRow> imageSed(const Image& img, const RenderOptions& opts,
                             const std::optional<Filter>& filter = std::nullopt);

/// Writes @p sed as CSV (wavelength_nm, total_Jy, direct_Jy, scattered_Jy, single_Jy,
/// field_Jy, and with @p emission emission_Jy), after `#` comment lines @p comments.
void writeSedCsv(AtomicFile& file, const std::vector<SedRow>& sed, bool emission,
                 const std::vector<std::string>& comments);

/// The HDUs of @p img (as imageSed()): TOTAL (primary), DIRECT, SCATTERED (single + field),
/// SINGLE, FIELD and in spectral mode EMISSION, rows bottom first (FITS), with @p cards
/// (observer, history) and the WCS, then the table SED, @p sed (imageSed() of the same
/// image). Each component: through fits.filter one band-averaged W x H image; spectral mode
/// a W x H x N cube on a linear WAVE axis of band centres; RGB mode (fits.layout) N images
/// W x H in ascending wavelength (EXTVER 1..N, WAVELEN), or one W x H x N cube on a WAVE-TAB
/// axis with the table WCS-TAB after the images.
void writeCalibratedFits(AtomicFile& file, const Image& img, const RenderOptions& opts,
                         const FitsOutput& fits, const std::vector<SedRow>& sed,
                         const std::vector<FitsCard>& cards);

/// How many spectral layers a calibrated spectral render takes when --spectral-layers does
/// not say: bands of 10 nm over 360-830 nm.
inline constexpr int CALIBRATED_SPECTRAL_LAYERS = 47;

} // namespace nebula
