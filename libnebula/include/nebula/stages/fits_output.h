#pragma once
/// @file fits_output.h
/// nebrender --fits: calibrated images (DESIGN §13). The render's channels are monochromatic
/// images at their wavelengths (RenderOptions::monochromatic, with its component layers);
/// this turns them into surface brightness in an astronomer's unit, one HDU per component
/// (total, direct, scattered, single, field), each a cube (x, y, wavelength) with a
/// celestial TAN (or linear) WCS and a WAVE-TAB wavelength axis, and the observer's keywords.

#include "nebula/core/atomic_file.h"
#include "nebula/io/fits_image.h"
#include "nebula/io/image.h"
#include "nebula/render/options.h"

#include <string>
#include <vector>

namespace nebula {

/// What --fits writes.
struct FitsOutput
{
    std::string path;            ///< "" for none
    std::string unit = "MJy/sr"; ///< BUNIT: "MJy/sr" or "W/m2/sr/nm"
    /// A celestial WCS: the look-at point at right ascension @p ra, declination @p dec
    /// [degrees] (ICRS); the image's up at position angle @p positionAngle [degrees] from
    /// north through east. Otherwise a linear WCS in pc (orthographic camera only).
    bool sky = false;
    double ra = 0.0;
    double dec = 0.0;
    double positionAngle = 0.0;
};

/// Throws UsageError naming the option unless --fits suits the render: the fast or path
/// integrator in RGB mode, a perspective or orthographic camera (perspective needs --sky),
/// one frame, --fits-unit known, --sky within [0, 360) x [-90, 90], distinct wavelengths.
void checkFitsOutput(const FitsOutput& fits, const RenderOptions& opts, bool manyFrames);

/// The factor that turns spectral radiance [L_sun pc^-2 sr^-1 nm^-1] at @p lambda_nm into
/// @p unit ("MJy/sr" or "W/m2/sr/nm").
double surfaceBrightnessFactor(const std::string& unit, double lambda_nm);

/// The WCS cards of the image plane (axes 1, 2) for @p camera: RA---TAN/DEC--TAN with a CD
/// matrix, CRVAL at the look-at point and CRPIX at the image centre when fits.sky (exact for
/// the perspective camera, a gnomonic projection; the orthographic camera's pixel spans
/// pixel / distance radians); else linear offsets in pc from the look-at point.
std::vector<FitsCard> imageWcsCards(const Camera& camera, const FitsOutput& fits);

/// The HDUs of @p img (a monochromatic render with component layers, @p starCount stars):
/// TOTAL (primary), DIRECT, SCATTERED (single + field), SINGLE, FIELD, each W x H x N planes
/// in ascending wavelength, rows bottom first (FITS), with @p cards (observer, history) and
/// the WCS; and the WCS-TAB table of the wavelengths.
void writeCalibratedFits(AtomicFile& file, const Image& img, std::size_t starCount,
                         const RenderOptions& opts, const FitsOutput& fits,
                         const std::vector<FitsCard>& cards);

} // namespace nebula
