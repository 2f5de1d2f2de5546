// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scatter_reconstruct.h
/// Internal to render/: nebscatter's tallies turned into the field's cells (DESIGN §5b,
/// "Adaptive cells" and "Field lattice"), in scatter_reconstruct.cpp: the blocks of 2x2x2
/// cells tallied whole (gatherBlocks()), a cell of such a block from its block's value and
/// its neighbours' (reconstructCell()), every active cell's moments with the noise of its J
/// (fillFieldCells()), and the border cells (copyBorderCells()).

#include "scatter_filter.h"
#include "scatter_tally.h"
#include "scatter_transport.h"

#include <array>
#include <cstdint>
#include <vector>

namespace nebula::detail {

/// The adaptive cells' blocks (a block: 2x2x2 field cells, the next level's cell) that have
/// active cells, each with its moments: its own tally or its refined cells' tallies, over
/// the volume of its active cells.
struct FieldBlocks
{
    std::array<int, 3> lo{};         ///< the block lattice's first block (absolute)
    std::array<int, 3> dims{};       ///< the block lattice's size
    std::size_t per = 0;             ///< values per block: moments x channels
    std::vector<std::int32_t> index; ///< per block of the lattice: its row, or -1 (no active cell)
    std::vector<double> value;       ///< per row: its per values (k * C + c)
    std::vector<double> volume;      ///< per row: its active cells' volume [pc^3]
    std::vector<double> s1, sq;      ///< per row: its noise channel's tally and squares (weights)

    /// The row of block @p B (relative to lo), -1 off the lattice or without active cells.
    std::int32_t row(const int* B) const
    {
        for (int a = 0; a < 3; ++a)
            if (B[a] < 0 || B[a] >= dims[a]) return -1;
        return index[(std::size_t(B[2]) * dims[1] + std::size_t(B[1])) * dims[0] +
                     std::size_t(B[0])];
    }
};

/// The blocks of @p tr's adaptive cells with their moments from the tallies @p t (unit of
/// the weights @p U; @p detA a voxel's world volume [pc^3]); empty without adaptive cells.
FieldBlocks gatherBlocks(const Transport& tr, const SourceTallies& t, double U, double detA);

/// The moments of field cell @p X (absolute coordinates) of a block tallied whole, into
/// @p m[0..per): the block's value plus, along each axis, its slope times the cell's offset
/// from the block's centre (+-1/4 block). The slope is the monotonised central difference of
/// the neighbouring blocks' values (limited: no new extremes at a shadow's edge), 0 where a
/// neighbour has no active cells or the block is an extreme. The eight cells' offsets cancel,
/// so the block's mean is kept.
void reconstructCell(const FieldBlocks& blocks, const int* X, float* m);

/// Every active field cell's moments into @p moments (c_lm = sum (w U) (length) Y_lm / V over
/// the cell; a cell of a block tallied whole by reconstructCell()); returns the noise of J:
/// the mean relative standard error per cell, weighted by its dust times its scattered light.
/// @p relError (if not null) gets, per cell of the walked box (x fastest), the relative
/// standard error of its J (a cell of a block tallied whole: its block's), NOISE_UNKNOWN
/// for an active cell no packet reached and NOISE_INACTIVE elsewhere (scatter_filter.h).
double fillFieldCells(const Transport& tr, const SourceTallies& t, const FieldBlocks& blocks,
                      double U, double detA, SparseVolume& moments,
                      std::vector<float>* relError = nullptr);

/// The border cells (outside the walked box) copy their nearest cell, so the trilinear field
/// does not fall towards zero at the grid's edge.
void copyBorderCells(const Transport& tr, SparseVolume& moments);

} // namespace nebula::detail
