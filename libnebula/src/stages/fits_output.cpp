// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/fits_output.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/render/camera_model.h"
#include "nebula/render/frame_layers.h"
#include "nebula/render/spectral.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <ostream>

namespace nebula {

namespace {
/// The most of a filter's weight (int T dlambda/lambda) that may lie outside 360-830 nm for a
/// spectral band average: the part lost, 1e-3, is 0.001 mag.
constexpr double MAX_FILTER_WEIGHT_OUTSIDE = 1e-3;
} // namespace

void checkFitsOutput(const FitsOutput& fits, const RenderOptions& opts, bool manyFrames)
{
    if (!calibrated(fits)) return;
    const std::string option = fits.path.empty() ? "--sed" : "--fits";
    if (fits.unit != "MJy/sr" && fits.unit != "W/m2/sr/nm") {
        throw UsageError("--fits-unit must be MJy/sr or W/m2/sr/nm, got \"" +
                         detail::printable(fits.unit, 40) + "\"");
    }
    if (manyFrames) throw UsageError(option + " is for one image: render one frame");
    const auto plane = cameraModel(opts.camera.model).skyPlane(opts.camera);
    if (!plane) {
        std::string have;
        for (const CameraModel* m : cameraModels()) {
            if (!m->skyPlane(Camera{}).has_value()) continue;
            have += (have.empty() ? "" : " or ") + m->name();
        }
        throw UsageError(option + " needs --camera " + have + "; " + opts.camera.model +
                         " images have no FITS projection here");
    }
    if (std::isnan(plane->pixelPc) && !fits.sky && !fits.path.empty()) {
        throw UsageError("--fits with the " + opts.camera.model +
                         " camera needs --sky RA,DEC: its pixels are angles (or use --camera "
                         "orthographic for offsets in pc)");
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
    if (fits.layout == FitsLayout::Tab) {
        const char* why = fits.path.empty()       ? "needs --fits"
                          : opts.spectral.enabled ? "is for RGB mode: --spectral cubes have a "
                                                    "linear WAVE axis of evenly spaced bands"
                          : fits.filter ? "has no wavelength axis to tabulate: --filter and "
                                          "--filter-file write one band-averaged image per "
                                          "component"
                                        : nullptr;
        if (why) throw UsageError(std::string("--fits-layout tab ") + why);
    }
    if (opts.spectral.enabled) {
        // The band average integrates the spectrum under the filter: all but a negligible
        // part of the band (its weight, 1e-3 at the most: 0.001 mag) must be rendered.
        if (fits.filter) {
            const Filter& f = *fits.filter;
            const double inside = bandAverageFnu(f, [](double lambda) {
                return lambda >= SPECTRAL_MIN_NM && lambda <= SPECTRAL_MAX_NM ? 1.0 : 0.0;
            });
            if (!(inside >= 1.0 - MAX_FILTER_WEIGHT_OUTSIDE)) {
                throw UsageError(fmt::format(
                    "--filter {}: {:.3g} % of its passband's weight lies outside the spectral "
                    "renderer's {:g}-{:g} nm; render it in RGB mode (without --spectral)",
                    f.name, 100.0 * (1.0 - inside), SPECTRAL_MIN_NM, SPECTRAL_MAX_NM));
            }
        }
        return;
    }
    const auto& w = opts.wavelengths;
    if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2]) {
        throw UsageError(option + " needs three different --wavelengths (its wavelength axis)");
    }
}

void checkChannelWavelengths(const std::array<double, 3>& lambda_nm, const DustParams& dust,
                             const std::string& source)
{
    for (const double lambda : lambda_nm) {
        if (!(lambda >= MIN_FILTER_LAMBDA_NM && lambda < MAX_FILTER_LAMBDA_NM)) {
            throw UsageError(fmt::format("{}: wavelength {} nm is outside [{}, {}) nm", source,
                                         detail::numberText(lambda),
                                         detail::numberText(MIN_FILTER_LAMBDA_NM),
                                         detail::numberText(MAX_FILTER_LAMBDA_NM)));
        }
        try {
            extinctionRatio(dust, lambda);
        } catch (const Error& e) { // the curve's range: CCM89's 125-3333 nm
            throw UsageError(source + ": " + e.what() +
                             " (--extinction-curve grey takes any wavelength)");
        }
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
    if (!fits.sky) { // pixels of a size in pc (orthographic): offsets in the image plane
        const double p = cameraModel(camera.model).skyPlane(camera)->pixelPc;
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
    const double s = cameraModel(camera.model).skyPlane(camera)->radiansPerPixel;
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

enum Part { Total, Direct, Scattered, Single, Field, Emission, PARTS };

constexpr const char* PART_NAMES[PARTS] = {"TOTAL",  "DIRECT", "SCATTERED",
                                           "SINGLE", "FIELD",  "EMISSION"};

/// The calibrated samples of a render, per pixel and component: RGB mode, its three channels
/// (monochromatic at their wavelengths) with the component layers "field", "emission" and
/// "direct"; spectral mode, its N spectral layers (bands' means) followed by N channels of
/// each of SPECTRAL_COMPONENTS. Spectral radiance [L_sun pc^-2 sr^-1 nm^-1].
class Components
{
public:
    Components(const Image& image, const RenderOptions& opts, const std::string& what)
        : mImg(image), mSpectral(opts.spectral.enabled)
    {
        if (!mSpectral) {
            for (std::size_t c = 0; c < 3; ++c)
                mLambda.push_back(opts.wavelengths[c]);
            mField = &layer(FIELD_LAYER, what);
            mEmission = &layer(EMISSION_LAYER, what);
            mDirect = &layer(DIRECT_LAYER, what);
            return;
        }
        mLayers = std::size_t(std::max(opts.spectral.layers, 0));
        const double width =
            (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / double(std::max<std::size_t>(mLayers, 1));
        for (std::size_t b = 0; b < mLayers; ++b)
            mLambda.push_back(SPECTRAL_MIN_NM + (double(b) + 0.5) * width);
        if (mLayers == 0) throw Error(what + ": the spectral render has no component channels");
        // Per component (the total, then SPECTRAL_COMPONENTS) and band, its channel.
        for (std::size_t i = 0; i <= SPECTRAL_COMPONENT_COUNT; ++i)
            for (std::size_t b = 0; b < mLayers; ++b) {
                const auto id = image.findChannel(
                    spectralChannelName(b, mLayers, i == 0 ? "" : SPECTRAL_COMPONENTS[i - 1]));
                if (!id) throw Error(what + ": the spectral render has no component channels");
                mChannels.push_back(&image.values(*id));
            }
    }

    bool spectral() const { return mSpectral; }
    /// The components this render has: the gas's emission only in spectral mode.
    int parts() const { return mSpectral ? PARTS : Emission; }
    std::size_t samples() const { return mLambda.size(); }
    double lambda(std::size_t k) const { return mLambda[k]; }
    /// Spectral mode: the bands' width [nm].
    double bandWidth() const { return (SPECTRAL_MAX_NM - SPECTRAL_MIN_NM) / double(mLayers); }

    /// Component @p part of sample @p k at pixel @p p [L_sun pc^-2 sr^-1 nm^-1].
    double at(int part, std::size_t p, std::size_t k) const
    {
        if (mSpectral) {
            const auto ch = [&](std::size_t i) { return double((*mChannels[i * mLayers + k])[p]); };
            switch (part) { // channels: total, then SPECTRAL_COMPONENTS
            case Total: return ch(0);
            case Direct: return ch(1);
            case Scattered: return ch(2) + ch(3);
            case Single: return ch(2);
            case Field: return ch(3);
            default: return ch(4);
            }
        }
        const double total = mImg.rgba[p * 4 + k];
        const double d = (*mDirect)[p * 3 + k], f = (*mField)[p * 3 + k];
        const double scattered = total - d - (*mEmission)[p * 3 + k];
        switch (part) {
        case Total: return total;
        case Direct: return d;
        case Scattered: return scattered;
        case Single: return scattered - f;
        case Field: return f;
        default: return (*mEmission)[p * 3 + k];
        }
    }

private:
    const std::vector<float>& layer(const std::string& name, const std::string& what) const
    {
        if (const auto id = mImg.findLayer(name)) return mImg.rgb(*id);
        throw Error(what + ": the render has no component layer \"" + name + "\"");
    }

    const Image& mImg;
    bool mSpectral;
    std::vector<double> mLambda; ///< each sample's wavelength [nm]
    std::size_t mLayers = 0;     ///< spectral mode: N
    /// Spectral mode: the channel of each component (the total, then SPECTRAL_COMPONENTS)
    /// and band, [component * N + band].
    std::vector<const std::vector<float>*> mChannels;
    const std::vector<float>* mField = nullptr;
    const std::vector<float>* mEmission = nullptr;
    const std::vector<float>* mDirect = nullptr;
};

/// One plane of the calibrated output: its wavelength [nm] and the samples it sums, each
/// with the factor that turns spectral radiance [L_sun pc^-2 sr^-1 nm^-1] into the unit.
struct Plane
{
    double lambda_nm;
    std::vector<std::pair<std::size_t, double>> terms;
};

/// The planes in @p unit: one per sample in ascending wavelength, or through @p filter one
/// band average at the pivot wavelength, <f_nu> in MJy/sr or <f_lambda> = <f_nu> c /
/// lambda_p^2 in W/m2/sr/nm. RGB mode: the channels are the filter's quadrature nodes,
/// weighted by the quadrature. Spectral mode: each layer's weight is the band average of
/// its constant f_lambda (direct integration of the filter curve, DESIGN §13.1).
std::vector<Plane> planes(const Components& parts, const std::string& unit,
                          const std::optional<Filter>& filter)
{
    std::vector<std::size_t> order(parts.samples());
    std::iota(order.begin(), order.end(), std::size_t(0));
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return parts.lambda(a) < parts.lambda(b); });
    if (!filter) {
        std::vector<Plane> out;
        for (const std::size_t k : order)
            out.push_back({parts.lambda(k), {{k, surfaceBrightnessFactor(unit, parts.lambda(k))}}});
        return out;
    }
    const double pivot = pivotWavelength(*filter);
    const double toUnit =
        unit == "MJy/sr" ? 1.0
                         : 1e6 * JANSKY * SPEED_OF_LIGHT / (pivot * 1e-9 * pivot * 1e-9) * 1e-9;
    Plane band{pivot, {}};
    if (parts.spectral()) {
        const double width = parts.bandWidth();
        for (const std::size_t k : order) {
            const double lo = parts.lambda(k) - 0.5 * width, hi = lo + width;
            const double w = bandAverageFnu(*filter, [&](double lambda) {
                return lambda >= lo && lambda < hi ? perNmToMegajanskyPerSr(lambda) : 0.0;
            });
            if (w != 0.0) band.terms.push_back({k, w * toUnit});
        }
        return {band};
    }
    const BandQuadrature q = bandQuadrature(*filter, 3);
    for (std::size_t i = 0; i < 3 && i < q.weight.size(); ++i) {
        const std::size_t k = order[i];
        band.terms.push_back({k, q.weight[i] * perNmToMegajanskyPerSr(parts.lambda(k)) * toUnit});
    }
    return {band};
}

/// Plane @p plane of component @p part at pixel @p p, in the planes' unit.
double planeValue(const Components& parts, const Plane& plane, int part, std::size_t p)
{
    double v = 0.0;
    for (const auto& [k, factor] : plane.terms)
        v += parts.at(part, p, k) * factor;
    return v;
}

/// The SED as the FITS table "SED".
FitsColumnsHdu sedTable(const std::vector<SedRow>& sed, bool emission)
{
    FitsColumnsHdu t;
    t.name = "SED";
    t.columns = {{"WAVELENGTH", "nm", {}}, {"TOTAL", "Jy", {}},  {"DIRECT", "Jy", {}},
                 {"SCATTERED", "Jy", {}},  {"SINGLE", "Jy", {}}, {"FIELD", "Jy", {}}};
    if (emission) t.columns.push_back({"EMISSION", "Jy", {}});
    for (const auto& r : sed) {
        const double v[] = {r.lambda_nm, r.total, r.direct,  r.scattered,
                            r.single,    r.field, r.emission};
        for (std::size_t i = 0; i < t.columns.size(); ++i)
            t.columns[i].values.push_back(v[i]);
    }
    return t;
}

} // namespace

std::vector<SedRow> imageSed(const Image& img, const RenderOptions& opts,
                             const std::optional<Filter>& filter)
{
    const Components parts(img, opts, "the SED");
    const Projection projection(opts.camera);
    const auto bands = planes(parts, "MJy/sr", filter);
    // Per plane and component: surface brightness [MJy/sr] times solid angle, summed.
    std::vector<std::array<double, PARTS>> sum(bands.size(), std::array<double, PARTS>{});
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const std::size_t p = std::size_t(y) * std::size_t(img.width) + std::size_t(x);
            const double omega = projection.pixelSolidAngle(x + 0.5, y + 0.5);
            for (std::size_t b = 0; b < bands.size(); ++b)
                for (int part = Total; part < parts.parts(); ++part)
                    sum[b][std::size_t(part)] += planeValue(parts, bands[b], part, p) * omega;
        }
    std::vector<SedRow> sed;
    for (std::size_t b = 0; b < bands.size(); ++b) { // MJy -> Jy
        const auto& s = sum[b];
        sed.push_back({bands[b].lambda_nm, s[Total] * 1e6, s[Direct] * 1e6, s[Scattered] * 1e6,
                       s[Single] * 1e6, s[Field] * 1e6, s[Emission] * 1e6});
    }
    return sed;
}

void writeSedCsv(AtomicFile& file, const std::vector<SedRow>& sed, bool emission,
                 const std::vector<std::string>& comments)
{
    std::ostream& out = file.stream();
    for (const auto& c : comments)
        out << "# " << c << "\n";
    out << "wavelength_nm,total_Jy,direct_Jy,scattered_Jy,single_Jy,field_Jy"
        << (emission ? ",emission_Jy\n" : "\n");
    for (const auto& r : sed) {
        out << fmt::format("{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g}", r.lambda_nm, r.total,
                           r.direct, r.scattered, r.single, r.field);
        out << (emission ? fmt::format(",{:.10g}\n", r.emission) : std::string("\n"));
    }
}

void writeCalibratedFits(AtomicFile& file, const Image& img, const RenderOptions& opts,
                         const FitsOutput& fits, const std::vector<SedRow>& sed,
                         const std::vector<FitsCard>& cards)
{
    const std::size_t W = std::size_t(img.width), H = std::size_t(img.height);
    const std::size_t plane = W * H;
    const Components components(img, opts, file.path());
    const auto bands = planes(components, fits.unit, fits.filter);
    const char* what[PARTS] = {
        components.spectral()
            ? "everything that reaches the observer: starlight, scattered light, gas emission"
            : "everything that reaches the observer: starlight, scattered light",
        "the stars' light that reached the observer unscattered (the sprites)",
        "light scattered by the dust once or more (SINGLE + FIELD)",
        "light scattered once (exact from the tau grids)",
        "light scattered more than once (nebscatter's field)",
        "the gas's emission: its lines and black bodies"};
    // RGB mode's planes: one image per component and wavelength (a plain WCS(header) opens
    // each); otherwise one image (a filter) or cube per component.
    const bool perPlane =
        !fits.filter && !components.spectral() && fits.layout == FitsLayout::Planes;
    const std::size_t hdusPerPart = perPlane ? bands.size() : 1;
    const std::size_t planesPerHdu = perPlane || fits.filter ? 1 : bands.size();
    // The cards of the third axis (RGB: WAVE-TAB; spectral: linear) or of the band (a filter).
    std::vector<FitsCard> axisCards;
    if (fits.filter) {
        axisCards = {{"FILTER", fits.filter->name, "passband (photon-counting)"},
                     {"PIVOT", bands.front().lambda_nm, "pivot wavelength [nm]"},
                     {"FILTSRC", fits.filter->source, "the passband's source"}};
        if (components.spectral()) {
            axisCards.push_back(
                {"BANDWID", components.bandWidth(), "the spectrum's bands, each constant [nm]"});
        } else {
            const BandQuadrature q = bandQuadrature(*fits.filter, 3);
            for (std::size_t k = 0; k < q.lambda_nm.size(); ++k) {
                axisCards.push_back({"QNODE" + std::to_string(k + 1), q.lambda_nm[k],
                                     "quadrature wavelength [nm]"});
                axisCards.push_back(
                    {"QWGHT" + std::to_string(k + 1), q.weight[k], "quadrature weight"});
            }
        }
    } else if (components.spectral()) {
        // With a CD matrix the third axis's scale is CD3_3 (mixing CDi_j and CDELTi is not
        // allowed, WCS paper I §2.1.2).
        axisCards = {
            {"CTYPE3", std::string("WAVE"), "wavelength (lines at their air wavelengths)"},
            {"CUNIT3", std::string("m"), ""},
            {"CRPIX3", 1.0, ""},
            {"CRVAL3", bands.front().lambda_nm * 1e-9, "the first band's centre [m]"},
            {fits.sky ? "CD3_3" : "CDELT3", components.bandWidth() * 1e-9, "band width [m]"},
            {"BANDWID", components.bandWidth(), "each plane: the band's mean [nm]"}};
    } else if (!perPlane) {
        axisCards = {{"CTYPE3", std::string("WAVE-TAB"), "wavelength, from table WCS-TAB"},
                     {"CUNIT3", std::string("m"), ""},
                     {"CRPIX3", 1.0, ""},
                     {fits.sky ? "CD3_3" : "CDELT3", 1.0, ""},
                     {"CRVAL3", 1.0, ""},
                     {"PS3_0", std::string("WCS-TAB"), "the table of wavelengths"},
                     {"PS3_1", std::string("COORDS"), "its column"}};
    }
    const auto wcs = imageWcsCards(opts.camera, fits);
    // One HDU at a time: only it is held besides the file's bytes. HDU i is component
    // i / hdusPerPart, its planes from (i % hdusPerPart) * planesPerHdu on.
    const auto hdu = [&](std::size_t i) {
        const int part = int(i / hdusPerPart);
        const std::size_t first = (i % hdusPerPart) * planesPerHdu;
        FitsImageHdu h;
        h.name = PART_NAMES[part];
        h.axes = {long(W), long(H)};
        if (planesPerHdu > 1) h.axes.push_back(long(planesPerHdu));
        h.data.resize(plane * planesPerHdu);
        for (std::size_t b = 0; b < planesPerHdu; ++b)
            for (std::size_t row = 0; row < H; ++row) { // FITS rows go up from the bottom
                const std::size_t src = (H - 1 - row) * W;
                for (std::size_t x = 0; x < W; ++x)
                    h.data[b * plane + row * W + x] =
                        float(planeValue(components, bands[first + b], part, src + x));
            }
        if (perPlane) {
            h.cards.push_back({"EXTVER", static_cast<long long>(first + 1),
                               "the component's planes, in ascending wavelength"});
        }
        h.cards.insert(h.cards.end(), wcs.begin(), wcs.end());
        h.cards.insert(h.cards.end(), axisCards.begin(), axisCards.end());
        if (perPlane) {
            h.cards.push_back(
                {"WAVELEN", bands[first].lambda_nm, "wavelength [nm] (monochromatic)"});
        }
        h.cards.push_back(
            {"BUNIT", fits.unit,
             fits.filter ? "band-averaged surface brightness" : "surface brightness"});
        h.cards.push_back({"BTYPE", std::string("phot.flux.density.sb"), "IVOA UCD"});
        h.cards.push_back({"COMPONT", std::string(PART_NAMES[part]), what[part]});
        h.cards.insert(h.cards.end(), cards.begin(), cards.end());
        return h;
    };
    std::vector<FitsTableHdu> tables;
    if (!fits.filter && !components.spectral() && !perPlane) {
        FitsTableHdu table;
        table.name = "WCS-TAB";
        table.column = "COORDS";
        table.unit = "m";
        table.tdim = {1, long(bands.size())};
        for (const auto& b : bands)
            table.values.push_back(b.lambda_nm * 1e-9);
        tables.push_back(std::move(table));
    }
    writeFits(file, std::size_t(components.parts()) * hdusPerPart, hdu, tables,
              {sedTable(sed, components.spectral())});
}

} // namespace nebula
