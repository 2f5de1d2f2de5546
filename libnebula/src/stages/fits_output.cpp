#include "nebula/stages/fits_output.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/render/camera.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <ostream>

namespace nebula {

void checkFitsOutput(const FitsOutput& fits, const RenderOptions& opts, bool manyFrames)
{
    if (!calibrated(fits)) return;
    const std::string option = fits.path.empty() ? "--sed" : "--fits";
    if (fits.unit != "MJy/sr" && fits.unit != "W/m2/sr/nm") {
        throw UsageError("--fits-unit must be MJy/sr or W/m2/sr/nm, got \"" +
                         detail::printable(fits.unit, 40) + "\"");
    }
    if (opts.spectral.enabled) {
        throw UsageError(option + " is for RGB mode (monochromatic images at the --wavelengths); "
                                  "--spectral has no calibrated output yet");
    }
    if (manyFrames) throw UsageError(option + " is for one image: render one frame");
    const CameraModel m = opts.camera.model;
    if (m != CameraModel::Orthographic && m != CameraModel::Perspective) {
        throw UsageError(option +
                         " needs --camera orthographic (a telescope's view) or "
                         "perspective; " +
                         toString(m) + " images have no FITS projection here");
    }
    if (m == CameraModel::Perspective && !fits.sky && !fits.path.empty()) {
        throw UsageError("--fits with the perspective camera needs --sky RA,DEC: its pixels are "
                         "angles (or use --camera orthographic for offsets in pc)");
    }
    if (fits.sky) {
        if (!(fits.ra >= 0.0 && fits.ra < 360.0) || !(fits.dec >= -90.0 && fits.dec <= 90.0)) {
            throw UsageError("--sky must be RA,DEC in degrees with RA in [0, 360) and DEC in "
                             "[-90, 90], got " +
                             detail::numberText(fits.ra) + "," + detail::numberText(fits.dec));
        }
        if (!(std::fabs(fits.positionAngle) <= 360.0)) {
            throw UsageError("--position-angle must be in [-360, 360] degrees, got " +
                             detail::numberText(fits.positionAngle));
        }
    }
    const auto& w = opts.wavelengths;
    if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2]) {
        throw UsageError(option + " needs three different --wavelengths (its wavelength axis)");
    }
}

double surfaceBrightnessFactor(const std::string& unit, double lambda_nm)
{
    if (unit == "W/m2/sr/nm") return LSUN_PC2_TO_WM2;
    return perNmToMegajanskyPerSr(lambda_nm);
}

std::vector<FitsCard> imageWcsCards(const Camera& camera, const FitsOutput& fits)
{
    const double cx = 0.5 * (camera.width + 1), cy = 0.5 * (camera.height + 1);
    std::vector<FitsCard> cards{
        {"CRPIX1", cx, "the image centre: the look-at point"},
        {"CRPIX2", cy, "the image centre: the look-at point"},
    };
    if (!fits.sky) { // orthographic: offsets in the image plane [pc]
        const double p = camera.orthographicPixel();
        cards.push_back({"CTYPE1", std::string("XOFFSET"), "along the image's right [pc]"});
        cards.push_back({"CTYPE2", std::string("YOFFSET"), "along the image's up [pc]"});
        cards.push_back({"CUNIT1", std::string("pc"), ""});
        cards.push_back({"CUNIT2", std::string("pc"), ""});
        cards.push_back({"CRVAL1", 0.0, "the look-at point"});
        cards.push_back({"CRVAL2", 0.0, "the look-at point"});
        cards.push_back({"CDELT1", p, "pixel size [pc]"});
        cards.push_back({"CDELT2", p, "pixel size [pc]"});
        return cards;
    }
    // Tangent-plane radians per pixel: the perspective camera's image plane at distance 1 is
    // the gnomonic plane; the orthographic camera's pixel spans pixel / distance.
    const double s = camera.model == CameraModel::Orthographic
                         ? camera.orthographicPixel() / camera.observerDistance()
                         : 2.0 * std::tan(0.5 * camera.fovDeg * DEG_RAD) / camera.width;
    const double deg = s / DEG_RAD, ct = std::cos(fits.positionAngle * DEG_RAD),
                 st = std::sin(fits.positionAngle * DEG_RAD);
    // The image's right and up on the sky, (east, north): up at the position angle from
    // north through east, right = up turned clockwise (west at angle 0).
    cards.push_back({"CTYPE1", std::string("RA---TAN"), "gnomonic projection"});
    cards.push_back({"CTYPE2", std::string("DEC--TAN"), "gnomonic projection"});
    cards.push_back({"CUNIT1", std::string("deg"), ""});
    cards.push_back({"CUNIT2", std::string("deg"), ""});
    cards.push_back({"CRVAL1", fits.ra, "right ascension of the look-at point [deg]"});
    cards.push_back({"CRVAL2", fits.dec, "declination of the look-at point [deg]"});
    cards.push_back({"CD1_1", -deg * ct, ""});
    cards.push_back({"CD1_2", deg * st, ""});
    cards.push_back({"CD2_1", deg * st, ""});
    cards.push_back({"CD2_2", deg * ct, ""});
    cards.push_back({"RADESYS", std::string("ICRS"), ""});
    cards.push_back({"LONPOLE", 180.0, ""});
    return cards;
}

namespace {

enum Part { Total, Direct, Scattered, Single, Field, PARTS };

/// The render's component layers (frameImage(): the stars', transmittance, then field,
/// emission, direct).
struct Components
{
    const Image& img;
    const std::vector<float>& field;
    const std::vector<float>& emission;
    const std::vector<float>& direct;

    Components(const Image& image, std::size_t starCount, const std::string& what)
        : img(image), field(layer(image, starCount + 1, what)),
          emission(layer(image, starCount + 2, what)), direct(layer(image, starCount + 3, what))
    {}
    static const std::vector<float>& layer(const Image& img, std::size_t i, const std::string& what)
    {
        if (img.layers.size() <= i) throw Error(what + ": the render has no component layers");
        return img.layers[i].rgb;
    }
    /// Component @p part of channel @p c at pixel @p p [L_sun pc^-2 sr^-1 nm^-1].
    double at(int part, std::size_t p, std::size_t c) const
    {
        const double total = img.rgba[p * 4 + c];
        const double d = direct[p * 3 + c], f = field[p * 3 + c];
        const double scattered = total - d - emission[p * 3 + c];
        switch (part) {
        case Total: return total;
        case Direct: return d;
        case Scattered: return scattered;
        case Single: return scattered - f;
        default: return f;
        }
    }
};

/// The channels in ascending wavelength.
std::array<std::size_t, 3> ascending(const RenderOptions& opts)
{
    std::array<std::size_t, 3> order{0, 1, 2};
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return opts.wavelengths[a] < opts.wavelengths[b];
    });
    return order;
}

/// One plane of the calibrated output: its wavelength [nm] and, per channel, the factor that
/// turns spectral radiance [L_sun pc^-2 sr^-1 nm^-1] into @p unit; the plane is the sum.
struct Plane
{
    double lambda_nm;
    std::array<double, 3> factor;
};

/// The planes in @p unit: one per channel in ascending wavelength (monochromatic), or through
/// @p filter one band average at the pivot wavelength, the channels (its quadrature nodes,
/// ascending) weighted by the quadrature: <f_nu> in MJy/sr, or <f_lambda> = <f_nu> c /
/// lambda_p^2 in W/m2/sr/nm.
std::vector<Plane> planes(const RenderOptions& opts, const std::string& unit,
                          const std::optional<Filter>& filter)
{
    const auto order = ascending(opts);
    if (!filter) {
        std::vector<Plane> out;
        for (const std::size_t c : order) {
            Plane p{opts.wavelengths[c], {0.0, 0.0, 0.0}};
            p.factor[c] = surfaceBrightnessFactor(unit, opts.wavelengths[c]);
            out.push_back(p);
        }
        return out;
    }
    const BandQuadrature q = bandQuadrature(*filter, 3);
    const double pivot = pivotWavelength(*filter);
    const double toUnit =
        unit == "MJy/sr" ? 1.0
                         : 1e6 * JANSKY * SPEED_OF_LIGHT / (pivot * 1e-9 * pivot * 1e-9) * 1e-9;
    Plane band{pivot, {0.0, 0.0, 0.0}};
    for (std::size_t k = 0; k < 3 && k < q.weight.size(); ++k) {
        const std::size_t c = order[k];
        band.factor[c] = q.weight[k] * perNmToMegajanskyPerSr(opts.wavelengths[c]) * toUnit;
    }
    return {band};
}

/// The SED as the FITS table "SED".
FitsColumnsHdu sedTable(const std::vector<SedRow>& sed)
{
    FitsColumnsHdu t;
    t.name = "SED";
    t.columns = {{"WAVELENGTH", "nm", {}}, {"TOTAL", "Jy", {}},  {"DIRECT", "Jy", {}},
                 {"SCATTERED", "Jy", {}},  {"SINGLE", "Jy", {}}, {"FIELD", "Jy", {}}};
    for (const auto& r : sed) {
        const double v[] = {r.lambda_nm, r.total, r.direct, r.scattered, r.single, r.field};
        for (std::size_t i = 0; i < 6; ++i)
            t.columns[i].values.push_back(v[i]);
    }
    return t;
}

} // namespace

std::vector<SedRow> imageSed(const Image& img, std::size_t starCount, const RenderOptions& opts,
                             const std::optional<Filter>& filter)
{
    const Components parts(img, starCount, "the SED");
    const Projection projection(opts.camera);
    const auto bands = planes(opts, "MJy/sr", filter);
    // Per plane and component: surface brightness [MJy/sr] times solid angle, summed.
    std::vector<std::array<double, PARTS>> sum(bands.size(), std::array<double, PARTS>{});
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const std::size_t p = std::size_t(y) * std::size_t(img.width) + std::size_t(x);
            const double omega = projection.pixelSolidAngle(x + 0.5, y + 0.5);
            for (std::size_t b = 0; b < bands.size(); ++b)
                for (std::size_t c = 0; c < 3; ++c) {
                    if (bands[b].factor[c] == 0.0) continue;
                    const double f = bands[b].factor[c] * omega;
                    for (int part = Total; part < PARTS; ++part)
                        sum[b][std::size_t(part)] += parts.at(part, p, c) * f;
                }
        }
    std::vector<SedRow> sed;
    for (std::size_t b = 0; b < bands.size(); ++b) { // MJy -> Jy
        const auto& s = sum[b];
        sed.push_back({bands[b].lambda_nm, s[Total] * 1e6, s[Direct] * 1e6, s[Scattered] * 1e6,
                       s[Single] * 1e6, s[Field] * 1e6});
    }
    return sed;
}

void writeSedCsv(AtomicFile& file, const std::vector<SedRow>& sed,
                 const std::vector<std::string>& comments)
{
    std::ostream& out = file.stream();
    for (const auto& c : comments)
        out << "# " << c << "\n";
    out << "wavelength_nm,total_Jy,direct_Jy,scattered_Jy,single_Jy,field_Jy\n";
    for (const auto& r : sed) {
        out << fmt::format("{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g}\n", r.lambda_nm,
                           r.total, r.direct, r.scattered, r.single, r.field);
    }
}

void writeCalibratedFits(AtomicFile& file, const Image& img, std::size_t starCount,
                         const RenderOptions& opts, const FitsOutput& fits,
                         const std::vector<SedRow>& sed, const std::vector<FitsCard>& cards)
{
    const std::size_t W = std::size_t(img.width), H = std::size_t(img.height);
    const std::size_t plane = W * H;
    const Components components(img, starCount, file.path());
    const auto bands = planes(opts, fits.unit, fits.filter);
    const char* names[] = {"TOTAL", "DIRECT", "SCATTERED", "SINGLE", "FIELD"};
    const char* what[] = {"everything that reaches the observer: starlight, scattered light",
                          "the stars' light that reached the observer unscattered (the sprites)",
                          "light scattered by the dust once or more (SINGLE + FIELD)",
                          "light scattered once (exact from the tau grids)",
                          "light scattered more than once (nebscatter's field)"};
    // The cards of the third axis (monochromatic: WAVE-TAB) or of the band (a filter).
    std::vector<FitsCard> axisCards;
    if (fits.filter) {
        const BandQuadrature q = bandQuadrature(*fits.filter, 3);
        axisCards = {{"FILTER", fits.filter->name, "passband (photon-counting)"},
                     {"PIVOT", bands.front().lambda_nm, "pivot wavelength [nm]"},
                     {"FILTSRC", fits.filter->source, "the passband's source"}};
        for (std::size_t k = 0; k < q.lambda_nm.size(); ++k) {
            axisCards.push_back(
                {"QNODE" + std::to_string(k + 1), q.lambda_nm[k], "quadrature wavelength [nm]"});
            axisCards.push_back(
                {"QWGHT" + std::to_string(k + 1), q.weight[k], "quadrature weight"});
        }
    } else {
        axisCards = {{"CTYPE3", std::string("WAVE-TAB"), "wavelength, from table WCS-TAB"},
                     {"CUNIT3", std::string("m"), ""},
                     {"CRPIX3", 1.0, ""},
                     // With a CD matrix the third axis's scale is CD3_3 (mixing CDi_j and
                     // CDELTi is not allowed, WCS paper I §2.1.2).
                     {fits.sky ? "CD3_3" : "CDELT3", 1.0, ""},
                     {"CRVAL3", 1.0, ""},
                     {"PS3_0", std::string("WCS-TAB"), "the table of wavelengths"},
                     {"PS3_1", std::string("COORDS"), "its column"}};
    }
    std::vector<FitsImageHdu> hdus;
    const auto wcs = imageWcsCards(opts.camera, fits);
    for (int part = Total; part < PARTS; ++part) {
        FitsImageHdu h;
        h.name = names[part];
        h.axes = {long(W), long(H)};
        if (!fits.filter) h.axes.push_back(long(bands.size()));
        h.data.resize(plane * bands.size());
        for (std::size_t b = 0; b < bands.size(); ++b)
            for (std::size_t row = 0; row < H; ++row) { // FITS rows go up from the bottom
                const std::size_t src = (H - 1 - row) * W;
                for (std::size_t x = 0; x < W; ++x) {
                    double v = 0.0;
                    for (std::size_t c = 0; c < 3; ++c)
                        if (bands[b].factor[c] != 0.0)
                            v += components.at(part, src + x, c) * bands[b].factor[c];
                    h.data[b * plane + row * W + x] = float(v);
                }
            }
        h.cards = wcs;
        h.cards.insert(h.cards.end(), axisCards.begin(), axisCards.end());
        h.cards.push_back(
            {"BUNIT", fits.unit,
             fits.filter ? "band-averaged surface brightness" : "surface brightness"});
        h.cards.push_back({"BTYPE", std::string("phot.flux.density.sb"), "IVOA UCD"});
        h.cards.push_back({"COMPONT", std::string(names[part]), what[part]});
        h.cards.insert(h.cards.end(), cards.begin(), cards.end());
        hdus.push_back(std::move(h));
    }
    std::vector<FitsTableHdu> tables;
    if (!fits.filter) {
        FitsTableHdu table;
        table.name = "WCS-TAB";
        table.column = "COORDS";
        table.unit = "m";
        table.tdim = {1, long(bands.size())};
        for (const auto& b : bands)
            table.values.push_back(b.lambda_nm * 1e-9);
        tables.push_back(std::move(table));
    }
    writeFits(file, hdus, tables, {sedTable(sed)});
}

} // namespace nebula
