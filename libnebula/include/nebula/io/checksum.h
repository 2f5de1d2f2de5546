#pragma once
/// @file checksum.h
/// Integrity of nebula's own VDB outputs (README "Failure behaviour"): writeGrids() records a
/// checksum of every grid and of the file metadata in `nebula:checksums`
/// ({"algorithm": CHECKSUM_ALGORITHM, "grids": {name: 16 hex digits}, "metadata": 16 hex
/// digits}), and readGrids() verifies
/// them: every grid listed must be present and match, and so must the metadata. This catches what a
/// structural check cannot: a flipped bit inside a voxel value, or inside a compressed block that
/// still decompresses. External tools that edit grids do not copy file-level metadata, so a grid
/// they changed carries no stale checksum.

#include <openvdb/openvdb.h>

#include <optional>
#include <string>

namespace nebula {

/// The name of the hash below, recorded in `nebula:checksums` ("algorithm"); a file naming
/// another is refused (damaged, or from a newer nebula), so that a flipped byte in the name
/// cannot switch the verification off.
inline constexpr const char* CHECKSUM_ALGORITHM = "nebula-hash64-1";

/// A 64-bit hash of @p grid's contents: its metadata (name included; not the "file_*"
/// statistics OpenVDB rewrites on every save), its transform, background, tiles (value and state),
/// and every leaf's origin, value mask and values, in tree order; as 16 hex digits. Empty for
/// grids it does not cover (value types other than float, double, int32, int64, bool, mask and
/// Vec3f/d/i, and grids saved as half float, whose values the file rounds).
std::string gridChecksum(const openvdb::GridBase& grid);

/// A 64-bit hash of file-level metadata (every entry's name, type and value as text, except
/// @p skip and the "file_*" statistics), as 16 hex digits.
std::string metadataChecksum(const openvdb::MetaMap& meta, const std::string& skip);

} // namespace nebula
