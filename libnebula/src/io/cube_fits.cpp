// SPDX-License-Identifier: Apache-2.0
// FITS cubes (DESIGN §10): images read through cfitsio (io/fits.h), their WCS as the cube's
// geometry; cubes written as a primary float32 image with a linear WCS.
#include "cube_raw.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>

namespace nebula {

namespace {

/// "1" for 1, "2" ..., the FITS axis suffix.
std::string ax(int i)
{
    return std::to_string(i + 1);
}

bool startsWith(const std::string& s, const char* head)
{
    return s.rfind(head, 0) == 0;
}

} // namespace

namespace {

/// A geometry keyword's value: nullopt if absent; a finite number, else Error naming it.
std::optional<double> finiteKey(const FitsFile& f, const std::string& where, const std::string& key)
{
    const auto v = f.keyNumber(key);
    if (v && !std::isfinite(*v)) {
        throw Error(where + ": " + key + " = " + fmt::format("{}", *v) +
                    ": expected a finite number");
    }
    return v;
}

/// Refuses a rotation or shear: CDi_j or PCi_j off the diagonal, or CROTAn, not 0 (an
/// axis-aligned grid has none). Returns whether the file uses CDi_j.
bool refuseRotation(const FitsFile& f, const std::string& where)
{
    const std::string fix =
        "; only axis-aligned cubes can be imported (give --voxel-size to ignore the WCS)";
    bool anyCd = false;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            for (const char* kind : {"CD", "PC"}) {
                const std::string key = kind + ax(i) + "_" + ax(j);
                const auto v = finiteKey(f, where, key);
                if (v && kind[0] == 'C') anyCd = true;
                if (v && i != j && *v != 0.0) {
                    throw Error(where + ": the WCS rotates or shears the axes (" + key + " = " +
                                fmt::format("{}", *v) + ", not 0)" + fix);
                }
            }
        }
        const std::string crota = "CROTA" + ax(i);
        const auto rot = finiteKey(f, where, crota);
        if (rot && *rot != 0.0) {
            throw Error(where + ": the WCS rotates the axes (" + crota + " = " +
                        fmt::format("{}", *rot) + " degrees, not 0)" + fix);
        }
    }
    return anyCd;
}

/// Refuses a CTYPEn that is not a length: a sky coordinate or a spectral axis.
void refuseNonSpatialAxis(const std::string& where, int i, const std::string& ctype)
{
    const std::string shown = detail::printable(ctype, 40);
    for (const char* sky : {"RA", "DEC", "GLON", "GLAT", "ELON", "ELAT"}) {
        if (startsWith(ctype, sky) &&
            (ctype.size() == std::string(sky).size() || ctype[std::string(sky).size()] == '-')) {
            throw Error(where + ": CTYPE" + ax(i) + " = '" + shown +
                        "' is a sky coordinate: an image of the sky, not a cube in space "
                        "(give --voxel-size to import it as one)");
        }
    }
    for (const char* spec : {"FREQ", "VRAD", "VOPT", "VELO", "WAVE", "ZOPT", "VELO-LSR"}) {
        if (startsWith(ctype, spec)) {
            throw Error(where + ": CTYPE" + ax(i) + " = '" + shown +
                        "' is a spectral axis (a position-position-velocity cube?), not a "
                        "length (give --voxel-size to import it as one)");
        }
    }
}

/// pc per unit of CUNITn (axis @p i), or Error: missing, an angle, unknown.
double axisUnitPc(const FitsFile& f, const std::string& where, int i)
{
    const auto cunit = f.keyString("CUNIT" + ax(i));
    if (!cunit || cunit->empty()) {
        throw Error(where + ": CUNIT" + ax(i) +
                    " is missing: the voxel size's unit is unknown (give --voxel-size, or "
                    "CUNITn = 'pc', 'au', 'cm', 'm', 'km' or 'kpc')");
    }
    const auto pcPer = lengthUnitPc(*cunit);
    if (!pcPer) {
        const std::string l = *cunit;
        const bool angle = l == "deg" || l == "arcmin" || l == "arcsec" || l == "rad" || l == "mas";
        throw Error(where + ": CUNIT" + ax(i) + " = '" + detail::printable(*cunit, 40) + "' " +
                    (angle ? "is an angle, not a length" : "is not a length nebula knows") +
                    " (expected pc, au, cm, m, km or kpc; or give --voxel-size)");
    }
    return *pcPer;
}

} // namespace

std::optional<CubeGeometry> readFitsGeometry(const FitsFile& f)
{
    const std::string where = f.name() + ": " + f.hduLabel();
    const bool anyCd = refuseRotation(f, where);
    CubeGeometry g;
    g.wcs = nlohmann::json::object();
    int withStep = 0;
    bool anyRef = false;
    std::array<double, 3> step{}, crpix{}, crval{}, factor{};
    for (int i = 0; i < 3; ++i) {
        const std::string stepKey = anyCd ? "CD" + ax(i) + "_" + ax(i) : "CDELT" + ax(i);
        const auto cdelt = finiteKey(f, where, "CDELT" + ax(i));
        const auto cd = finiteKey(f, where, "CD" + ax(i) + "_" + ax(i));
        const auto pc = finiteKey(f, where, "PC" + ax(i) + "_" + ax(i));
        std::optional<double> s;
        if (anyCd) {
            s = cd;
        } else if (cdelt) {
            s = *cdelt * (pc ? *pc : 1.0);
        }
        if (!s) continue;
        ++withStep;
        step[std::size_t(i)] = *s;
        if (!std::isfinite(*s) || *s == 0.0) {
            throw Error(where + ": " + stepKey +
                        (pc && !anyCd ? " x PC" + ax(i) + "_" + ax(i) : "") + " = " +
                        fmt::format("{}", *s) + ": the voxel size must be finite and not 0");
        }
        const std::string ctype = f.keyString("CTYPE" + ax(i)).value_or("");
        refuseNonSpatialAxis(where, i, ctype);
        factor[std::size_t(i)] = axisUnitPc(f, where, i);
        const auto rp = finiteKey(f, where, "CRPIX" + ax(i));
        const auto rv = finiteKey(f, where, "CRVAL" + ax(i));
        anyRef = anyRef || rp || rv;
        crpix[std::size_t(i)] = rp.value_or(0.0);
        crval[std::size_t(i)] = rv.value_or(0.0);
        g.wcs["ctype"][std::size_t(i)] = ctype;
        g.wcs["cunit"][std::size_t(i)] = *f.keyString("CUNIT" + ax(i));
    }
    if (withStep == 0) return std::nullopt;
    if (withStep != 3) {
        throw Error(where + ": the WCS gives a step (CDELTn) on " + std::to_string(withStep) +
                    " of the 3 axes; give all three, or --voxel-size");
    }
    g.stepSource = anyCd ? "CD1_1, CD2_2, CD3_3" : "CDELT1..3";
    g.originSource = "CRPIXn, CRVALn";
    std::array<double, 3> pc{};
    for (std::size_t i = 0; i < 3; ++i)
        pc[i] = step[i] * factor[i];
    for (std::size_t i = 0; i < 3; ++i) {
        if (!std::isfinite(pc[i])) { // 1e308 kpc
            throw Error(where + ": " + g.stepSource +
                        fmt::format(" give steps of {}, {}, {} pc", pc[0], pc[1], pc[2]) +
                        ": expected finite voxel sizes");
        }
    }
    // Steps equal within CUBIC_STEP_TOLERANCE are one voxel size (importCube() snaps them).
    for (std::size_t i = 1; i < 3; ++i) {
        if (std::abs(std::abs(pc[i]) - std::abs(pc[0])) > CUBIC_STEP_TOLERANCE * std::abs(pc[0])) {
            throw Error(where + fmt::format(": the voxels are not cubes: {} give steps of {}, {}, "
                                            "{} pc along the axes; nebula needs equal steps (give "
                                            "--voxel-size to override)",
                                            g.stepSource, std::abs(pc[0]), std::abs(pc[1]),
                                            std::abs(pc[2])));
        }
    }
    g.spacing = pc;
    if (anyRef) {
        std::array<double, 3> o{};
        // Voxel index 0 is FITS pixel 1: world = CRVAL + CDELT (1 - CRPIX).
        for (std::size_t i = 0; i < 3; ++i)
            o[i] = (crval[i] + step[i] * (1.0 - crpix[i])) * factor[i];
        g.origin = o;
    }
    for (std::size_t i = 0; i < 3; ++i) {
        g.wcs["cdelt"][i] = step[i];
        g.wcs["crpix"][i] = crpix[i];
        g.wcs["crval"][i] = crval[i];
    }
    return g;
}

namespace detail {

namespace {

class FitsArray final : public RawArray
{
public:
    FitsArray(FitsFile file, std::vector<std::int64_t> shape)
        : mFile(std::move(file)), mShape(std::move(shape))
    {}
    std::vector<std::int64_t> shape() const override { return mShape; }
    bool firstFastest() const override { return true; }
    void readBlock(const std::vector<std::int64_t>& fixed, double* out) override
    {
        // Storage order is NAXISn (slowest) ... NAXIS1: the fixed indices are the last axes.
        const std::size_t nd = mShape.size();
        std::int64_t stride = 1, count = 1, offset = 0;
        for (std::size_t i = 0; i < nd - fixed.size(); ++i)
            count *= mShape[i];
        stride = count;
        for (std::size_t f = fixed.size(); f-- > 0;) {
            const std::size_t axis = nd - 1 - f;
            offset += fixed[f] * stride;
            stride *= mShape[axis];
        }
        mFile.readDoubles(offset, count, out);
    }

private:
    FitsFile mFile;
    std::vector<std::int64_t> mShape;
};

std::string shapeText(const std::vector<std::int64_t>& shape)
{
    if (shape.empty()) return "no data";
    std::string s;
    for (std::size_t i = 0; i < shape.size(); ++i)
        s += (i ? " x " : "") + std::to_string(shape[i]);
    return std::to_string(shape.size()) + "-D image " + s;
}

/// Refuses a BSCALE or BZERO that is not a finite number (a string such as 'NaN', which cfitsio
/// would take as 1) and a BSCALE of 0 (every value would be BZERO).
void checkScaling(const FitsFile& f, const std::string& where)
{
    for (const char* key : {"BSCALE", "BZERO"}) {
        const auto v = f.keyNumber(key);
        if (!v) continue;
        if (!std::isfinite(*v)) {
            throw Error(where + ": " + key + " = " + fmt::format("{}", *v) +
                        ": expected a finite number");
        }
        if (*v == 0.0 && key[1] == 'S') {
            throw Error(where + ": BSCALE = 0: every value would be BZERO; expected a finite "
                                "number other than 0");
        }
    }
}

/// Moves @p f to the HDU @p select names, or to the first image HDU with 3 or more axes.
void chooseHdu(FitsFile& f, const CubeSelect& select)
{
    if (!select.hdu.empty()) {
        const bool number = select.hdu.find_first_not_of("0123456789") == std::string::npos &&
                            select.hdu.size() < 6;
        if (number) {
            f.moveTo(std::stoi(select.hdu));
        } else {
            f.moveTo(select.hdu);
        }
        if (!f.isImage()) throw Error(f.name() + ": " + f.hduLabel() + " is a table, not an image");
        return;
    }
    const int n = f.hduCount();
    std::string seen;
    for (int i = 0; i < n; ++i) {
        f.moveTo(i);
        if (!f.isImage()) {
            seen += (seen.empty() ? "" : "; ") + f.hduLabel() + ": a table";
            continue;
        }
        const auto shape = f.imageShape();
        if (shape.size() >= 3) return;
        seen += (seen.empty() ? "" : "; ") + f.hduLabel() + ": " + shapeText(shape);
    }
    // An HDU cfitsio stopped counting at, damaged, is the likelier cause than no cube at all.
    const std::string damaged = f.unreadHduFault();
    if (!damaged.empty()) throw Error(f.name() + ": cannot read it: " + damaged);
    f.moveTo(0);
    const auto shape = f.imageShape();
    if (n == 1 && !shape.empty()) return; // a 2-D primary: checkCubeShape() names it
    throw Error(f.name() + ": no image HDU with 3 axes (" + seen + ")");
}

} // namespace

std::unique_ptr<CubeSource> openFitsCube(const std::string& path, const CubeSelect& select)
{
    FitsFile f = FitsFile::open(path, path);
    f.checkHeaderText(); // the primary's, then the cube's
    chooseHdu(f, select);
    if (f.hdu() != 0) f.checkHeaderText();
    CubeInfo info;
    info.name = path + ": " + f.hduLabel();
    const auto shape = f.imageShape();
    checkCubeShape(shape, select.component, info.name);
    // A file shorter than its data is refused before anything is read.
    const int bitpix = f.bitpix();
    double count = 1.0;
    for (auto n : shape)
        count *= double(n);
    const auto [start, end] = f.dataSpan();
    (void)end;
    const double need = double(start) + count * double(std::abs(bitpix) / 8);
    const auto size = f.fileSize(); // a gzipped file's: its inflated size
    if (need > double(size)) {
        throw Error(info.name + fmt::format(": truncated: the header says {} bytes of data from "
                                            "byte {}, the file has {} bytes",
                                            count * double(std::abs(bitpix) / 8), start, size));
    }
    checkScaling(f, info.name);
    info.unit = f.keyString("BUNIT").value_or("");
    if (shape.size() == 3) {
        try {
            info.geometry = readFitsGeometry(f);
        } catch (const Error& e) {
            info.geometryError = e.what();
        }
    }
    auto array = std::make_unique<FitsArray>(std::move(f), shape);
    return arrayCube(std::move(array), std::move(info), select.component);
}

void writeFitsCube(const std::string& path, const CubeHeader& h, const PlaneFunction& plane)
{
    FitsFile f = FitsFile::createMemory(path);
    f.createImage({h.dims[0], h.dims[1], h.dims[2]});
    if (!h.name.empty()) f.writeKey("BTYPE", h.name, "the nebula grid this cube holds");
    f.writeKey("BUNIT", h.unit, h.unit.empty() ? "no unit" : "unit of the values");
    static const char* const AXIS[3] = {"X", "Y", "Z"};
    for (int i = 0; i < 3; ++i) {
        const std::size_t a = std::size_t(i);
        if (!h.wcs.is_null()) {
            f.writeKey("CTYPE" + ax(i), h.wcs["ctype"][a].get<std::string>(), "axis type");
            f.writeKey("CUNIT" + ax(i), h.wcs["cunit"][a].get<std::string>(), "axis unit");
            f.writeKey("CDELT" + ax(i), h.wcs["cdelt"][a].get<double>(), "voxel size");
            f.writeKey("CRPIX" + ax(i), h.wcs["crpix"][a].get<double>(), "reference pixel");
            f.writeKey("CRVAL" + ax(i), h.wcs["crval"][a].get<double>(), "its coordinate");
        } else {
            f.writeKey("CTYPE" + ax(i), std::string(AXIS[i]), "world axis (nebula's, linear)");
            f.writeKey("CUNIT" + ax(i), std::string("pc"), "axis unit");
            f.writeKey("CDELT" + ax(i), h.spacing[a], "voxel size [pc]");
            f.writeKey("CRPIX" + ax(i), 1.0, "reference pixel: the first voxel");
            f.writeKey("CRVAL" + ax(i), h.origin[a], "its centre [pc]");
        }
    }
    for (const auto& line : h.history)
        f.writeHistory(line);
    const std::int64_t nx = h.dims[0], ny = h.dims[1], nz = h.dims[2];
    std::vector<float> buf(std::size_t(nx * ny));
    for (std::int64_t k = 0; k < nz; ++k) {
        plane(PlaneOrder{2, 0, 1}, k, buf.data());
        f.writeFloats(k * nx * ny, nx * ny, buf.data());
    }
    f.writeFile(path);
}

const CubeFormat& fitsCubeFormat()
{
    static const CubeFormat format = [] {
        CubeFormat f;
        f.name = "fits";
        f.title = "FITS";
        f.doc = ".fits/.fit/.fts";
        f.hint = ".fits";
        f.endings = {".fits", ".fit", ".fts", ".fits.gz", ".fit.gz", ".fts.gz"};
        f.selector = &CubeSelect::hdu;
        f.open = openFitsCube;
        f.fileFormat = FileFormat::Fits;
        f.write = [](const std::string& path, const CubeHeader& header, const std::string&,
                     const PlaneFunction& plane) {
            const double bytes =
                double(header.dims[0]) * double(header.dims[1]) * double(header.dims[2]) * 4.0;
            requireMemory(bytes, path + ": the FITS file (built in memory)");
            writeFitsCube(path, header, plane);
        };
        f.writerMemory = [](const std::array<std::int64_t, 3>& dims, double fileBytes) {
            // The file in memory (cfitsio's), and one z plane.
            return WriterMemory{fileBytes + 4.0 * double(dims[0]) * double(dims[1]),
                                "the FITS file is built in memory"};
        };
        return f;
    }();
    return format;
}

} // namespace detail
} // namespace nebula
