// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file cube_io.h
/// Dense cubes from and to other programs (DESIGN §10): FITS images, HDF5 datasets, NumPy
/// .npy arrays and RADMC-3D regular grids read plane by plane through one interface,
/// CubeSource, so that nebimport never holds a whole cube; and dense float32 cubes written
/// as FITS, .npy or HDF5 with their geometry and units (nebexport).
///
/// Axes: voxel (x, y, z) is FITS (NAXIS1, NAXIS2, NAXIS3), numpy's a[x, y, z] (whatever the
/// file's order flag), an HDF5 dataset's [x, y, z] as h5py indexes it (dims in C order), and
/// RADMC-3D's (ix, iy, iz). astropy's fits.getdata() therefore returns the transpose a.T.

#include "nebula/core/file_format.h"
#include "nebula/io/fits.h"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace nebula {

/// A format a cube is read from or written to: a registered type, defined below (CubeFormat).
struct CubeFormat;

/// Every registered cube format, in the order --help lists them: FITS, HDF5, NumPy .npy,
/// RADMC-3D (src/io/cube_fits.cpp, cube_hdf5.cpp, cube_npy.cpp, cube_radmc.cpp).
const std::vector<const CubeFormat*>& cubeFormats();

/// The format named @p name ("fits", "hdf5", "npy", "radmc"); throws UsageError naming
/// @p option and the known names otherwise.
const CubeFormat& cubeFormat(const std::string& name, const std::string& option);

/// The format of @p path from its name (its endings, its whole name: .fits .fit .fts, with
/// .gz; .h5 .hdf5 .he5 .hdf; .npy; amr_grid.inp, dust_density.inp/.binp: RADMC-3D), or else a
/// folder's format (RADMC-3D); null if none.
const CubeFormat* cubeFormatOf(const std::string& path);

/// The names of the formats nebula reads (@p written false) or writes (true), as a list for
/// --help and messages: "fits, hdf5, npy or radmc".
std::string cubeFormatList(bool written);
/// The names of the formats nebula reads (@p written false) or writes (true).
std::vector<std::string> cubeFormatNames(bool written);
/// How the files of every format are named (each one's doc), for --help: ".fits/.fit/.fts,
/// .h5/.hdf5, .npy, or a RADMC-3D folder or its amr_grid.inp".
std::string cubeFileNamesDoc();

/// A cube's geometry as a file states it: the signed step along each axis and the world
/// position of voxel (0, 0, 0)'s centre, in pc.
struct CubeGeometry
{
    std::array<double, 3> spacing{0, 0, 0};      ///< [pc], signed (a FITS axis may run backwards)
    std::optional<std::array<double, 3>> origin; ///< [pc]; nullopt: the file has none
    /// The FITS WCS as read (CUNIT, CTYPE, CDELT, CRPIX, CRVAL), kept so that nebexport can
    /// write it back unchanged; null for other formats.
    nlohmann::json wcs;
    /// What in the file gave the steps and the origin, for messages ("CDELT1..3",
    /// "CRPIXn, CRVALn", "attribute voxel_size_pc").
    std::string stepSource = "the steps", originSource = "the origin";
};

/// Relative difference within which a file's three steps are taken as one voxel size (and
/// snapped to one value by nebimport); beyond it the voxels are not cubes and are refused.
inline constexpr double CUBIC_STEP_TOLERANCE = 1e-6;

/// What a CubeSource holds: the voxel counts, how its planes run, its unit and geometry.
struct CubeInfo
{
    std::string name;                          ///< "cube.fits, HDU 0", for messages
    std::array<std::int64_t, 3> dims{0, 0, 0}; ///< voxels along x, y, z
    /// Planes are perpendicular to planeAxis (the file's slowest axis); within a plane,
    /// fastAxis varies fastest, then slowAxis.
    int planeAxis = 2, fastAxis = 0, slowAxis = 1;
    std::string unit; ///< the file's own unit text (BUNIT, a units attribute), "" if none
    std::optional<CubeGeometry> geometry; ///< nullopt: the file has no voxel size
    /// Why the file's geometry cannot be used (a rotated WCS, angular axes), "" if it can:
    /// an error only when the geometry is needed (no --voxel-size).
    std::string geometryError;
    std::vector<std::string> warnings; ///< said once under the tool's name (resampling)

    std::int64_t planeCount() const { return dims[std::size_t(planeAxis)]; }
    std::int64_t planeSize() const
    {
        return dims[std::size_t(fastAxis)] * dims[std::size_t(slowAxis)];
    }
};

/// A cube read plane by plane, in order (readers may rely on it: RADMC-3D's ASCII files are
/// parsed as they are read).
class CubeSource
{
public:
    virtual ~CubeSource() = default;
    const CubeInfo& info() const { return mInfo; }
    /// Reads plane @p k (0 <= k < planeCount(), called with k = 0, 1, 2, ...) into @p out:
    /// planeSize() values, fastAxis fastest. Throws Error naming the file (truncated, unreadable).
    virtual void readPlane(std::int64_t k, double* out) = 0;

protected:
    CubeInfo mInfo;
};

/// The most voxels a cube may have (4096^3): reading more, even into a sparse grid, would
/// take hours; a header that claims more is refused before anything is allocated.
inline constexpr std::int64_t MAX_CUBE_VOXELS = std::int64_t(1) << 36;

/// Which cube of a file to read.
struct CubeSelect
{
    const CubeFormat* format = nullptr; ///< null: from the name (cubeFormatOf())
    std::string hdu;     ///< FITS: HDU number (0 = primary) or EXTNAME; "" first cube
    std::string dataset; ///< HDF5: dataset path; "" the file's only 3-D dataset
    int species = 1;     ///< RADMC-3D: dust species (1 = first)
    /// A 4-D array one of whose end axes has 3 entries (a vector field): the component to
    /// read (0, 1, 2); -1: the array must be 3-D.
    int component = -1;
    std::string option = "-i"; ///< the option that named the file, for messages
};

/// Opens the cube @p path as @p select says. Throws Error (UsageError for a bad choice) naming
/// the file: missing, not the format, damaged, not 3-D (or 4-D with a component axis of 3),
/// an unsupported data type, a header that claims more data than the file holds.
std::unique_ptr<CubeSource> openCube(const std::string& path, const CubeSelect& select);

// The parsers, for tests and fuzzers.

/// openCube() of an HDF5 file held in memory (@p bytes; @p name for messages): the same
/// choice of dataset, the same checks (links, external storage, virtual datasets, filters,
/// unwritten data, chunk sizes, attributes) and the same reader as for a file.
std::unique_ptr<CubeSource> openHdf5Memory(std::string_view bytes, const std::string& name,
                                           const CubeSelect& select);

/// A parsed .npy header.
struct NpyHeader
{
    int major = 1, minor = 0;
    char byteOrder = '<'; ///< '<', '>' or '|' (one-byte types)
    char kind = 'f';      ///< 'f' float, 'i' signed, 'u' unsigned integer, 'b' bool
    int itemSize = 4;     ///< bytes per element
    bool fortranOrder = false;
    std::vector<std::int64_t> shape;
    std::size_t dataOffset = 0; ///< bytes before the data (magic, lengths, header)
};

/// The largest .npy header read [bytes] (numpy's own reader stops at 10,000 by default).
inline constexpr std::size_t MAX_NPY_HEADER_BYTES = 65536;

/// Parses the header at the start of @p bytes (at least the whole header). Throws Error naming
/// @p name: no magic, a version other than 1.0, 2.0, 3.0, a header longer than
/// MAX_NPY_HEADER_BYTES or than the bytes, a dict that does not parse, an unsupported dtype
/// (objects, structured types, strings, complex), a bad shape.
NpyHeader parseNpyHeader(std::string_view bytes, const std::string& name);
/// The .npy header for a little-endian float32 array of @p shape (version 1.0, or 2.0 when
/// needed), padded so that the data start at a multiple of 64 bytes.
std::string npyHeader(const std::vector<std::int64_t>& shape, bool fortranOrder);

/// RADMC-3D's amr_grid.inp of a regular cartesian grid: cell counts and walls [cm].
struct RadmcGrid
{
    std::array<std::int64_t, 3> cells{0, 0, 0};
    std::array<std::vector<double>, 3> walls; ///< cells + 1 increasing walls per axis [cm]
};
/// Parses amr_grid.inp text. Throws Error naming @p name: another format number, AMR style
/// other than 0 (regular), a coordinate system >= 100 (not cartesian), bad counts, walls
/// that do not increase.
RadmcGrid parseRadmcGrid(std::string_view text, const std::string& name);

/// The header of a RADMC-3D dust density file.
struct RadmcDataHeader
{
    std::int64_t cells = 0, species = 0;
    int precision = 8;          ///< binary: 4 or 8 bytes per value; ASCII: 0
    std::size_t dataOffset = 0; ///< binary: bytes before the values; ASCII: chars before them
};
/// Parses the header of a dust_density.binp (@p binary) or dust_density.inp. Throws Error
/// naming @p name on a bad format number, precision, count, or too little data.
RadmcDataHeader parseRadmcDataHeader(std::string_view bytes, bool binary, const std::string& name);

/// The FITS WCS of the current HDU of a 3-D image as a CubeGeometry (nullopt: no CDELTn/CDn_n).
/// Throws Error naming the file and the keyword: |steps| that differ by more than
/// CUBIC_STEP_TOLERANCE (within it they are returned as read), a rotation (CDi_j or PCi_j off
/// the diagonal, a CROTAn not 0), an unknown or angular CUNIT, a zero step, a CDELTn, CDi_j,
/// PCi_j, CROTAn, CRPIXn or CRVALn that is not a finite number (a string, NaN, 1e999).
std::optional<CubeGeometry> readFitsGeometry(const FitsFile& file);

/// A length unit's size in pc: "pc", "kpc", "au" (AU), "cm", "m", "km"; nullopt otherwise.
std::optional<double> lengthUnitPc(const std::string& unit);

// Writers: a dense float32 cube, plane by plane.

/// What a writer needs besides the values.
struct CubeHeader
{
    std::array<std::int64_t, 3> dims{0, 0, 0};
    std::array<double, 3> spacing{1, 1, 1}; ///< [pc] per axis, signed
    std::array<double, 3> origin{0, 0, 0};  ///< voxel (0, 0, 0)'s centre [pc]
    std::string unit;                       ///< BUNIT / units attribute ("" none)
    std::string name;                       ///< the grid's name (FITS BTYPE, HDF5 attribute grid)
    nlohmann::json wcs;                     ///< FITS keywords to write instead of pc ones, or null
    std::vector<std::string> history;       ///< the pipeline's stages, one line each
};

/// How a writer asks for a plane: perpendicular to planeAxis, fastAxis varying fastest.
struct PlaneOrder
{
    int planeAxis = 2, fastAxis = 0, slowAxis = 1;
};
/// The values of plane @p k in @p order (dims[fastAxis] * dims[slowAxis] floats).
using PlaneFunction = std::function<void(const PlaneOrder& order, std::int64_t k, float* out)>;

/// Writes the cube whose planes @p plane gives as @p format to @p path ("-" stdout) through
/// AtomicFile: FITS (primary image, WCS, BUNIT, HISTORY), .npy (Fortran order: the planes
/// are z planes, streamed straight to the file) or HDF5 (dataset @p dataset, C order, with
/// attributes voxel_size_pc, origin_pc, units; x planes). FITS and HDF5 are built in memory
/// first, so their size is checked against the machine's memory (requireMemory()). Throws
/// UsageError for a format nebula does not write, or a name that says another format.
void writeCube(const CubeFormat& format, const std::string& path, const CubeHeader& header,
               const std::string& dataset, const PlaneFunction& plane);

/// The memory a cube's writer holds, and why.
struct WriterMemory
{
    double bytes = 0.0;   ///< [bytes]
    const char* use = ""; ///< "the FITS file is built in memory"
};

/// A cube format (DESIGN §18): its names, how its files are named, its documentation, its
/// reader and writer. Each is defined in its own src/io/cube_<name>.cpp and listed once in
/// cube_io.cpp's cubeFormats(); the tools and stages look formats up there and name none.
struct CubeFormat
{
    std::string name;  ///< --format's value: "fits"
    std::string title; ///< for messages: "FITS", "RADMC-3D"
    /// How its files are named, for -i's --help: ".fits/.fit/.fts", "a RADMC-3D folder or
    /// its amr_grid.inp".
    std::string doc;
    std::string hint;                   ///< the name to give, for messages: ".fits"
    std::vector<std::string> endings;   ///< its names' endings, lower case: ".fits.gz"
    std::vector<std::string> fileNames; ///< whole file names, lower case: "amr_grid.inp"
    bool folder = false;                ///< a folder is a cube of this format
    /// What a file's selector (nebimport's FILE:SELECTOR) chooses: &CubeSelect::hdu,
    /// &CubeSelect::dataset; null: it has no choice.
    std::string CubeSelect::*selector = nullptr;
    /// Opens a cube (openCube()).
    std::unique_ptr<CubeSource> (*open)(const std::string& path,
                                        const CubeSelect& select) = nullptr;
    /// What its writer writes (core/file_format.h: checkOutputName()); nullopt: not written.
    std::optional<FileFormat> fileFormat;
    /// Writes a cube (writeCube(), after the name's check); null: nebula only reads it.
    void (*write)(const std::string& path, const CubeHeader& header, const std::string& dataset,
                  const PlaneFunction& plane) = nullptr;
    /// The memory its writer holds for a cube of @p dims in a file of @p fileBytes.
    WriterMemory (*writerMemory)(const std::array<std::int64_t, 3>& dims,
                                 double fileBytes) = nullptr;
};

// Density units (DESIGN §10).

/// The density units a cube may be in.
enum class DensityUnit {
    NumberDensity, ///< n_H [cm^-3]
    GasMass,       ///< gas mass density [g cm^-3]
    DustMass,      ///< dust mass density [g cm^-3] (RADMC-3D's dust_density)
    SolarMass,     ///< gas mass density [M_sun pc^-3]
};
/// The unit a text names ("cm-3", "cm^-3", "1/cm3", "g/cm3", "g cm-3", "g/cm3-dust",
/// "Msun/pc3", "solMass / pc3", ...: case, spaces, ^ and ** ignored), or nullopt.
std::optional<DensityUnit> parseDensityUnit(const std::string& text);
/// The canonical name: "cm-3", "g/cm3", "g/cm3-dust", "Msun/pc3".
std::string densityUnitName(DensityUnit unit);
/// n_H [cm^-3] per unit of @p unit: 1; 1/(mu m_H); 1/(dustToGas mu m_H);
/// M_sun pc^-3 in g cm^-3 / (mu m_H). @p mu [m_H per H atom], @p dustToGas (mass ratio).
double densityToNH(DensityUnit unit, double mu, double dustToGas);

} // namespace nebula
