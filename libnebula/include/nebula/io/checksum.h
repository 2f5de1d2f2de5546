// SPDX-License-Identifier: Apache-2.0
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

namespace detail {

/// Calls @p fn(origin, depth, value) for the tiles of @p node and the internal nodes below it
/// (depth: @p depth at @p node) that are active (@p active) or inactive and not @p background,
/// in the order of OpenVDB's tree value iterators: each node's table in offset order, a
/// child's tiles where the child is. The iterators themselves also step through every voxel
/// of every leaf to skip it, which made hashing most of the cost of reading a file with many
/// grids under the sanitizers.
template <typename NodeT, typename Fn>
void forEachInternalTile(const NodeT& node, bool active,
                         const typename NodeT::ValueType& background, openvdb::Index depth,
                         const Fn& fn)
{
    using ChildT = typename NodeT::ChildNodeType;
    const auto& children = node.getChildMask();
    const auto& values = node.getValueMask();
    const auto* table = node.getTable();
    for (openvdb::Index n = 0; n < NodeT::NUM_VALUES; ++n) {
        if (children.isOn(n)) {
            if constexpr (ChildT::LEVEL > 0) {
                forEachInternalTile(*table[n].getChild(), active, background, depth + 1, fn);
            }
            continue;
        }
        if (values.isOn(n) != active) continue;
        const auto& v = table[n].getValue();
        if (!active && v == background) continue;
        fn(node.offsetToGlobalCoord(n), depth, v);
    }
}

/// detail::forEachInternalTile() from the root: its tiles and children in the order of its
/// table (by origin).
template <typename TreeT, typename Fn>
void forEachTile(const TreeT& tree, bool active, const Fn& fn)
{
    for (auto it = tree.root().cbeginChildAll(); it; ++it) {
        typename TreeT::ValueType v;
        if (const auto* child = it.probeChild(v)) {
            forEachInternalTile(*child, active, tree.background(), 1, fn);
        } else if (it.isValueOn() == active && (active || !(v == tree.background()))) {
            fn(it.getCoord(), 0, v);
        }
    }
}

} // namespace detail

} // namespace nebula
