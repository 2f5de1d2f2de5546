// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file vdb_check.h
/// A structural check of VDB bytes before OpenVDB reads them. OpenVDB 10 trusts the lengths
/// and counts that it reads: a damaged file can make it allocate gigabytes, read past a
/// buffer (io::bloscFromStream, io::unzipFromStream), spin for minutes, or accept a file that
/// lacks its last bytes. checkVdbStructure() walks the archive in place instead, bounds-checks
/// every field against the bytes that remain, and refuses what OpenVDB 10.0.1 would misread.

#include <string>
#include <string_view>

namespace nebula {

/// Checks that @p bytes (a whole .vdb file, or a whole stream read from a pipe) is a
/// structurally sound VDB archive before OpenVDB reads it: the header (magic, file format
/// version 222-225, library version, grid-offsets flag, UUID), the file and grid metadata
/// (every value's length, and the size of each fixed-size type OpenVDB registers), the grid
/// descriptors and their offsets (inside the file, in order, without overlap), each grid's
/// compression flags and transform (the map types OpenVDB registers), and for the standard
/// 5-4-3 trees of float, double, int32, int64, bool, mask, vec3s, vec3d and vec3i values the
/// whole tree: root tiles and children, internal node masks and values, leaf topology and leaf
/// buffers, and every zip, Blosc or raw chunk (its byte count against the count of values
/// that the masks, compression flags and half-float setting imply). A grid of another type is
/// checked up to its transform, and its bytes skipped by its offsets; a stream (no offsets)
/// holding one is refused, as are bytes after the last grid of a stream.
///
/// Works on @p bytes in place: no copies of payloads, and no allocation in proportion to a
/// length or count read from the bytes (only what the tree itself holds: the leaves' places,
/// the delayed-load tables, one bool node's values). It does not decompress value payloads,
/// except those of bool and mask trees' internal nodes (OpenVDB loads them as bool, where any
/// byte but 0 and 1 is undefined behaviour), and cannot judge values: a flipped bit inside a
/// zip or Blosc payload, or in a voxel value, is OpenVDB's to find (it throws), or nobody's.
///
/// Throws nebula::Error with ONE line "<source>: <what is wrong>" naming the grid (by its
/// name, sanitised) and the byte offset where that applies, e.g.
/// "in.vdb: truncated: grid \"density\" leaf buffer at byte 81234 needs 2048 bytes, 17 remain".
void checkVdbStructure(std::string_view bytes, const std::string& source);

} // namespace nebula
