// FITS cubes (DESIGN §10): images read through cfitsio (io/fits.h), their WCS as the cube's
// geometry; cubes written as a primary float32 image with a linear WCS.
#include "cube_raw.h"

#include "nebula/core/error.h"

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

std::optional<CubeGeometry> readFitsGeometry(const FitsFile& f)
{
    const std::string where = f.name() + ": " + f.hduLabel();
    // A rotation or shear (CDi_j, PCi_j off the diagonal) has no place in an axis-aligned grid.
    bool anyCd = false;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            const auto cd = f.keyDouble("CD" + ax(i) + "_" + ax(j));
            const auto pc = f.keyDouble("PC" + ax(i) + "_" + ax(j));
            if (cd) anyCd = true;
            if (i != j && ((cd && *cd != 0.0) || (pc && *pc != 0.0))) {
                throw Error(where + ": the WCS rotates or shears the axes (" + (cd ? "CD" : "PC") +
                            ax(i) + "_" + ax(j) +
                            " is not 0); only axis-aligned cubes can be imported (give "
                            "--voxel-size to ignore the WCS)");
            }
        }
    }
    CubeGeometry g;
    g.wcs = nlohmann::json::object();
    int withStep = 0;
    bool anyRef = false;
    std::array<double, 3> step{}, crpix{}, crval{}, factor{};
    for (int i = 0; i < 3; ++i) {
        const auto cdelt = f.keyDouble("CDELT" + ax(i));
        const auto cd = f.keyDouble("CD" + ax(i) + "_" + ax(i));
        const auto pc = f.keyDouble("PC" + ax(i) + "_" + ax(i));
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
            throw Error(where + ": " + (anyCd ? "CD" + ax(i) + "_" + ax(i) : "CDELT" + ax(i)) +
                        " = " + fmt::format("{}", *s) +
                        ": the voxel size must be finite and not 0");
        }
        const std::string ctype = f.keyString("CTYPE" + ax(i)).value_or("");
        for (const char* sky : {"RA", "DEC", "GLON", "GLAT", "ELON", "ELAT"}) {
            if (startsWith(ctype, sky) && (ctype.size() == std::string(sky).size() ||
                                           ctype[std::string(sky).size()] == '-')) {
                throw Error(where + ": CTYPE" + ax(i) + " = '" + ctype +
                            "' is a sky coordinate: an image of the sky, not a cube in space "
                            "(give --voxel-size to import it as one)");
            }
        }
        for (const char* spec : {"FREQ", "VRAD", "VOPT", "VELO", "WAVE", "ZOPT", "VELO-LSR"}) {
            if (startsWith(ctype, spec)) {
                throw Error(where + ": CTYPE" + ax(i) + " = '" + ctype +
                            "' is a spectral axis (a position-position-velocity cube?), not a "
                            "length (give --voxel-size to import it as one)");
            }
        }
        const auto cunit = f.keyString("CUNIT" + ax(i));
        if (!cunit || cunit->empty()) {
            throw Error(where + ": CUNIT" + ax(i) +
                        " is missing: the voxel size's unit is unknown (give --voxel-size, or "
                        "CUNITn = 'pc', 'au', 'cm', 'm', 'km' or 'kpc')");
        }
        const auto pcPer = lengthUnitPc(*cunit);
        if (!pcPer) {
            const std::string l = *cunit;
            const bool angle =
                l == "deg" || l == "arcmin" || l == "arcsec" || l == "rad" || l == "mas";
            throw Error(where + ": CUNIT" + ax(i) + " = '" + *cunit + "' " +
                        (angle ? "is an angle, not a length" : "is not a length nebula knows") +
                        " (expected pc, au, cm, m, km or kpc; or give --voxel-size)");
        }
        factor[std::size_t(i)] = *pcPer;
        const auto rp = f.keyDouble("CRPIX" + ax(i));
        const auto rv = f.keyDouble("CRVAL" + ax(i));
        anyRef = anyRef || rp || rv;
        crpix[std::size_t(i)] = rp.value_or(0.0);
        crval[std::size_t(i)] = rv.value_or(0.0);
        g.wcs["ctype"][std::size_t(i)] = ctype;
        g.wcs["cunit"][std::size_t(i)] = *cunit;
    }
    if (withStep == 0) return std::nullopt;
    if (withStep != 3) {
        throw Error(where + ": the WCS gives a step (CDELTn) on " + std::to_string(withStep) +
                    " of the 3 axes; give all three, or --voxel-size");
    }
    std::array<double, 3> pc{};
    for (std::size_t i = 0; i < 3; ++i)
        pc[i] = step[i] * factor[i];
    for (std::size_t i = 1; i < 3; ++i) {
        if (std::abs(std::abs(pc[i]) - std::abs(pc[0])) > 1e-6 * std::abs(pc[0])) {
            throw Error(where + fmt::format(": the voxels are not cubes: the steps are {}, {}, {} "
                                            "pc along the axes; nebula needs equal steps (give "
                                            "--voxel-size to override)",
                                            std::abs(pc[0]), std::abs(pc[1]), std::abs(pc[2])));
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
    f.moveTo(0);
    const auto shape = f.imageShape();
    if (n == 1 && !shape.empty()) return; // a 2-D primary: checkCubeShape() names it
    throw Error(f.name() + ": no image HDU with 3 axes (" + seen + ")");
}

} // namespace

std::unique_ptr<CubeSource> openFitsCube(const std::string& path, const CubeSelect& select)
{
    FitsFile f = FitsFile::open(path, path);
    chooseHdu(f, select);
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
    const auto size = f.fileSize();
    const bool gz = path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0;
    if (!gz && need > double(size)) {
        throw Error(info.name + fmt::format(": truncated: the header says {} bytes of data from "
                                            "byte {}, the file has {} bytes",
                                            count * double(std::abs(bitpix) / 8), start, size));
    }
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

} // namespace detail
} // namespace nebula
