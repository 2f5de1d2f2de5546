// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file grid_io.h
/// Reading and writing the grids that flow between the tools (DESIGN §1-2): files or "-"
/// (stdin/stdout), input grids passed through, a grid of the same name replaced, and the
/// file metadata that records provenance, stars and dust.

#include "nebula/core/atomic_file.h"
#include "nebula/core/input.h"
#include "nebula/core/run.h"
#include "nebula/io/grid_names.h"
#include "nebula/physics/dust.h"
#include "nebula/physics/stars.h"

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace nebula {

/// The grids of one VDB file or stream, with its file-level metadata.
struct GridSet;

/// A digest of @p grids' contents, as text: the file metadata's checksum and every grid's
/// name and checksum (gridChecksum(); where the file's verified nebula:checksums lists the
/// grid, that value, not computed again). Two sets with the same digest hold the same grids
/// and metadata (MPI ranks compare their inputs with it).
std::string contentDigest(const GridSet& grids);

struct GridSet
{
    std::string source; ///< file name, or "<stdin>", for error messages
    openvdb::GridPtrVec grids;
    openvdb::MetaMap meta;

    /// The grid called @p name, or null.
    openvdb::GridBase::Ptr find(const std::string& name) const;
    /// Adds @p grid, replacing any grid of the same name (never duplicating it).
    void replace(openvdb::GridBase::Ptr grid);

    /// The FloatGrid @p name; throws Error naming the source and grid if it is missing, of
    /// another type, or has a non-affine transform. @p option names the option that chose
    /// the name (e.g. "--density-grid"), for the message.
    openvdb::FloatGrid::Ptr floatGrid(const std::string& name, const std::string& option) const;

    /// Stars from `nebula:stars` (empty if absent). Throws Error if it does not parse.
    std::vector<Star> stars() const;
    void setStars(const std::vector<Star>& stars);
    /// Dust from `nebula:dust`, or the defaults if absent; a field it lacks takes its
    /// default (DustParams::fromJson()).
    DustParams dust() const;
    /// dust(), warning through @p run (once per call) which fields `nebula:dust` lacks and
    /// the defaults used for them.
    DustParams dust(const Run& run) const;
    bool hasDust() const;
    void setDust(const DustParams& dust);

    /// The stages that made these grids, oldest first: `nebula:history` (a JSON array of
    /// {"tool", "version", "command"}). A file without it but with `nebula:tool` (written
    /// before the history existed) gives that one stage; a file with neither, an empty array.
    /// Throws Error naming the source if the metadata is not a JSON array.
    nlohmann::json history() const;
    /// history() with one more stage appended (what writeGrids() records).
    nlohmann::json historyWith(const std::string& tool, const std::string& command) const;

    /// A string file-level metadata value, or @p fallback.
    std::string metaString(const std::string& key, const std::string& fallback = "") const;
    void setMetaString(const std::string& key, const std::string& value);
};

/// Reads every grid of @p path ("-" = stdin), given by @p option (for messages). A file is
/// mapped, a stream read once (mapInput(): its first 8 bytes must be the VDB magic number, and
/// it may hold at most MAX_GRID_INPUT_BYTES; a stream also at most the machine's memory), with
/// no second copy of a file in memory; its structure is checked
/// (checkVdbStructure()) before OpenVDB parses it; grid names must be unique; the grids are
/// verified against `nebula:checksums` where the file has it. Throws Error naming the file
/// (and grid): missing, not a VDB, too large, truncated, damaged or unreadable. Initialises
/// OpenVDB (openvdb::initialize()) first, so a program of one's own need not.
GridSet readGrids(const std::string& path, const std::string& option = "-i");

/// readGrids() of a whole file or stream already in memory; @p source names it in messages.
/// (The fuzzer's entry point: tests/fuzz.)
GridSet readGridsFromMemory(const std::string& bytes, const std::string& source);

/// readGrids() of an input's bytes (mapInput()): a mapped file's pages are released once
/// checked and again behind the parser, so the file is never held whole besides its grids.
GridSet readGridsFromBytes(const InputBytes& bytes, const std::string& source);

/// readGrids(), reporting what it read under -v ("read <file>: 3 grids: density, ...").
GridSet readGrids(const std::string& path, const Run& run, const std::string& option = "-i");

/// "N grids: name, name, ..." (for -v reports); a run of more than 3 grids named alike in
/// their first two dot-separated parts is one entry, "scatter.stars.* (75)".
std::string describeGrids(const GridSet& grids);

/// writeGrids() as @p run's tool and command, reporting what it wrote under -v.
void writeGrids(const std::string& path, GridSet grids, const Run& run);

/// Writes @p grids to @p path ("-" = stdout) atomically (AtomicFile: every write checked,
/// fsynced, renamed into place), stamping `nebula:tool`, `nebula:version` and
/// `nebula:command` into the file metadata, appending this stage to `nebula:history`
/// (GridSet::historyWith()) and recording `nebula:checksums`. @p path "-" on a terminal
/// is refused (UsageError).
void writeGrids(const std::string& path, GridSet grids, const std::string& tool,
                const std::string& command);

/// writeGrids() into an open AtomicFile, finished but not committed (for outputs committed
/// together with commitAll()).
void writeGrids(AtomicFile& file, GridSet grids, const std::string& tool,
                const std::string& command);

/// Throws UsageError if @p path is "-" and stdout is a terminal (binary output); @p option
/// names the option that gave the path.
void refuseBinaryToTerminal(const std::string& path, const std::string& option);

/// The grid type as users know it ("FloatGrid", "Vec3fGrid", ...), else OpenVDB's name.
std::string gridTypeName(const openvdb::GridBase& grid);

/// Throws Error unless @p grid's transform is affine (linear map, any scale/rotation/mirror).
void requireAffine(const openvdb::GridBase& grid, const std::string& source);

/// The smallest voxel edge a grid may have [pc]: OpenVDB refuses a transform whose determinant
/// (the voxel's volume) is within 1e-15 of 0.
inline constexpr double MIN_VOXEL_SIZE_PC = 1e-5;
/// The largest voxel edge a grid may have [pc]: the voxel's volume must be a finite double,
/// or requireVoxelSize() refuses the grid in every tool that reads it (about 5.6e102 pc).
inline constexpr double MAX_VOXEL_SIZE_PC = 1e100;
/// The largest magnitude of a world coordinate of a grid's corners [pc]: the bound on camera
/// and star coordinates (MAX_CAMERA_COORDINATE, MAX_STAR_COORDINATE), so that a camera can
/// reach every grid nebimport writes.
inline constexpr double MAX_WORLD_COORDINATE_PC = 1e150;
/// The largest magnitude of a world coordinate of a grid's corners, in voxels: beyond it,
/// neighbouring voxels' world positions differ by less than 1e-4 voxel in double precision (and
/// from about 1e16, not at all: OpenVDB then cannot write the transform).
inline constexpr double MAX_WORLD_COORDINATE_VOXELS = 1e12;

/// Throws Error naming @p source and the grid unless @p grid's transform has a finite voxel
/// size > 0 along every axis and is invertible (its voxel axes span a volume). A file can
/// hold a zero or NaN scale that OpenVDB reads without complaint (GridSet::floatGrid() checks).
void requireVoxelSize(const openvdb::GridBase& grid, const std::string& source);

/// Throws Error naming @p source and the grid if any active value is NaN, infinite or
/// negative (returns the number of active voxels checked).
std::size_t requireFiniteNonNegative(const openvdb::FloatGrid& grid, const std::string& source);

} // namespace nebula
