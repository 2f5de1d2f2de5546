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
    std::vector<SedRow> sed;
    for (const std::size_t c : ascending(opts)) {
        double sum[PARTS] = {};
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x) {
                const std::size_t p = std::size_t(y) * std::size_t(img.width) + std::size_t(x);
                const double omega = projection.pixelSolidAngle(x + 0.5, y + 0.5);
                for (int part = Total; part < PARTS; ++part)
                    sum[part] += parts.at(part, p, c) * omega;
            }
        // L_sun pc^-2 nm^-1 -> Jy: the MJy/sr factor times 1e6.
        const double jy = perNmToMegajanskyPerSr(opts.wavelengths[c]) * 1e6;
        sed.push_back({opts.wavelengths[c], sum[Total] * jy, sum[Direct] * jy, sum[Scattered] * jy,
                       sum[Single] * jy, sum[Field] * jy});
    }
    if (!filter) return sed;
    // The band average: the quadrature's weights on the ascending nodes.
    const BandQuadrature q = bandQuadrature(*filter, 3);
    SedRow band;
    band.lambda_nm = pivotWavelength(*filter);
    for (std::size_t k = 0; k < sed.size() && k < q.weight.size(); ++k) {
        const double w = q.weight[k];
        band.total += w * sed[k].total;
        band.direct += w * sed[k].direct;
        band.scattered += w * sed[k].scattered;
        band.single += w * sed[k].single;
        band.field += w * sed[k].field;
    }
    return {band};
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
                         const std::vector<FitsCard>& cards)
{
    const std::size_t W = std::size_t(img.width), H = std::size_t(img.height);
    const std::size_t plane = W * H;
    const Components components(img, starCount, file.path());
    const auto order = ascending(opts);
    const char* names[] = {"TOTAL", "DIRECT", "SCATTERED", "SINGLE", "FIELD"};
    const char* what[] = {"everything that reaches the observer: starlight, scattered light",
                          "the stars' light that reached the observer unscattered (the sprites)",
                          "light scattered by the dust once or more (SINGLE + FIELD)",
                          "light scattered once (exact from the tau grids)",
                          "light scattered more than once (nebscatter's field)"};
    std::vector<FitsImageHdu> hdus;
    const auto wcs = imageWcsCards(opts.camera, fits);
    if (fits.filter) { // one band-averaged image per component
        const BandQuadrature q = bandQuadrature(*fits.filter, 3);
        const double pivot = pivotWavelength(*fits.filter);
        // <f_lambda> = <f_nu> c / lambda_p^2: MJy/sr -> W m^-2 sr^-1 nm^-1.
        const double toUnit = fits.unit == "MJy/sr" ? 1.0
                                                    : 1e6 * JANSKY * SPEED_OF_LIGHT /
                                                          (pivot * 1e-9 * pivot * 1e-9) * 1e-9;
        for (int part = Total; part < PARTS; ++part) {
            FitsImageHdu h;
            h.name = names[part];
            h.axes = {long(W), long(H)};
            h.data.assign(plane, 0.0f);
            std::vector<double> sum(plane, 0.0);
            for (std::size_t k = 0; k < 3; ++k) {
                const std::size_t c = order[k];
                const double f = q.weight[k] * perNmToMegajanskyPerSr(opts.wavelengths[c]) * toUnit;
                for (std::size_t row = 0; row < H; ++row) {
                    const std::size_t src = (H - 1 - row) * W;
                    for (std::size_t x = 0; x < W; ++x)
                        sum[row * W + x] += components.at(part, src + x, c) * f;
                }
            }
            for (std::size_t i = 0; i < plane; ++i)
                h.data[i] = float(sum[i]);
            h.cards = wcs;
            h.cards.push_back({"BUNIT", fits.unit, "band-averaged surface brightness"});
            h.cards.push_back({"BTYPE", std::string("phot.flux.density.sb"), "IVOA UCD"});
            h.cards.push_back({"COMPONT", std::string(names[part]), what[part]});
            h.cards.push_back({"FILTER", fits.filter->name, "passband (photon-counting)"});
            h.cards.push_back({"PIVOT", pivot, "pivot wavelength [nm]"});
            h.cards.push_back({"FILTSRC", fits.filter->source, "the passband's source"});
            for (std::size_t k = 0; k < 3; ++k) {
                h.cards.push_back({"QNODE" + std::to_string(k + 1), q.lambda_nm[k],
                                   "quadrature wavelength [nm]"});
                h.cards.push_back(
                    {"QWGHT" + std::to_string(k + 1), q.weight[k], "quadrature weight"});
            }
            for (const auto& card : cards)
                h.cards.push_back(card);
            hdus.push_back(std::move(h));
        }
        writeFits(file, hdus, {}, {sedTable(imageSed(img, starCount, opts, fits.filter))});
        return;
    }
    for (int part = Total; part < PARTS; ++part) {
        FitsImageHdu h;
        h.name = names[part];
        h.axes = {long(W), long(H), 3};
        h.data.resize(plane * 3);
        for (std::size_t k = 0; k < 3; ++k) {
            const std::size_t c = order[k];
            const double f = surfaceBrightnessFactor(fits.unit, opts.wavelengths[c]);
            for (std::size_t row = 0; row < H; ++row) { // FITS rows go up from the bottom
                const std::size_t src = (H - 1 - row) * W;
                for (std::size_t x = 0; x < W; ++x)
                    h.data[k * plane + row * W + x] = float(components.at(part, src + x, c) * f);
            }
        }
        h.cards = wcs;
        h.cards.push_back({"CTYPE3", std::string("WAVE-TAB"), "wavelength, from table WCS-TAB"});
        h.cards.push_back({"CUNIT3", std::string("m"), ""});
        h.cards.push_back({"CRPIX3", 1.0, ""});
        // With a CD matrix the third axis's scale is CD3_3 (mixing CDi_j and CDELTi is not
        // allowed, WCS paper I §2.1.2).
        h.cards.push_back({fits.sky ? "CD3_3" : "CDELT3", 1.0, ""});
        h.cards.push_back({"CRVAL3", 1.0, ""});
        h.cards.push_back({"PS3_0", std::string("WCS-TAB"), "the table of wavelengths"});
        h.cards.push_back({"PS3_1", std::string("COORDS"), "its column"});
        h.cards.push_back({"BUNIT", fits.unit, "surface brightness"});
        h.cards.push_back({"BTYPE", std::string("phot.flux.density.sb"), "IVOA UCD"});
        h.cards.push_back({"COMPONT", std::string(names[part]), what[part]});
        for (const auto& card : cards)
            h.cards.push_back(card);
        hdus.push_back(std::move(h));
    }
    FitsTableHdu table;
    table.name = "WCS-TAB";
    table.column = "COORDS";
    table.unit = "m";
    table.tdim = {1, 3};
    for (const std::size_t c : order)
        table.values.push_back(opts.wavelengths[c] * 1e-9);
    writeFits(file, hdus, {table}, {sedTable(imageSed(img, starCount, opts))});
}

} // namespace nebula
