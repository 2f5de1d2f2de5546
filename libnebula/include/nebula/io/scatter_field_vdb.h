// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_field_vdb.h
/// nebscatter's field as grids (DESIGN §5b), written and read here only: per source, per
/// moment (l, m) of degree l <= order and per channel, one FloatGrid on the field level's
/// transform (cells of 2^level voxels, level >= -1) named by scatterGridName() (R, G, B) or
/// spectralScatterGridName() (a spectral field), active on the cells the renderer reads;
/// the l = 0 grids hold the mean intensity J, the others c_lm. What the field was made for
/// (dust, stars, wavelengths, grids, level 0's transform) is ScatterFieldMeta
/// (io/scatter_field_meta.h), the JSON of the file metadata `nebula:scatter`
/// (`nebula:scatter_spectral`). Sources are named (scatterSourceName()) here only.

#include "nebula/io/grid_io.h"
#include "nebula/io/scatter_field_meta.h"
#include "nebula/volume/volume.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// The metadata key of a field of the kind: META_SCATTER or META_SCATTER_SPECTRAL.
const char* scatterMetaKey(bool spectral);

/// @p value stored to @p bits significant bits against its cell's @p reference
/// (ScatterFieldMeta::storedBits; the reference is the cell's c_00 for a moment, J itself for
/// J): the nearest multiple of 2^(e + 1 - bits), 2^e <= |reference| < 2^(e + 1), so within
/// 2^-bits |reference| of @p value; against |value| where the reference is 0 or not finite;
/// @p value itself where bits >= FIELD_FLOAT_BITS.
float storedFieldValue(float value, float reference, int bits);

/// Replaces any field of the kind (R, G, B or @p spectral) in @p grids by this one:
/// moments[s] (shCount(meta.order) x meta.wavelengths.size() channels, channel
/// shIndex(l, m) * C + c, the l = 0 one holding c_00 = 4 pi Y_00 J) becomes source s's grids,
/// written on the cells where @p active is 1 (one byte per cell of the moments'
/// lattice, x fastest, then y, then z),
/// on @p fieldTransform, each value stored to meta.storedBits significant bits
/// (storedFieldValue()); @p meta becomes the file metadata.
void writeScatterField(GridSet& grids, const ScatterFieldMeta& meta,
                       const std::vector<const SparseVolume*>& moments,
                       const std::vector<std::uint8_t>& active,
                       const openvdb::math::Transform& fieldTransform, bool spectral);

/// The metadata of the field of the kind in @p grids; nullopt if there is none. Throws
/// Error naming grids.source if field grids have no metadata, or the metadata is not
/// nebscatter's (not JSON, a field missing or mistyped, order or level out of range,
/// wavelengths not as the kind needs).
std::optional<ScatterFieldMeta> readScatterFieldMeta(const GridSet& grids, bool spectral);

/// The field as one dense volume: the sum over sources s of factors[s][c] times source s's
/// grids (the l = 0 ones turned into c_00), channel shIndex(l, m) * C + c, on the lattice
/// of the J grids' active voxels with a one-cell border and the index-to-world map
/// @p fieldMap. Each grid is read straight into the sum (no per-source copy). Throws Error
/// naming @p what and the grid if one is missing or not on @p fieldMap, or the lattice
/// would not fit in memory.
SparseVolume readScatterMoments(const GridSet& grids, const ScatterFieldMeta& meta, bool spectral,
                                const std::vector<std::vector<double>>& factors,
                                const Affine& fieldMap, const std::string& what,
                                const std::string& rerun);

} // namespace nebula
