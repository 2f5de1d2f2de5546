// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file fits_image.h
/// FITS files described as data (FITS standard 4.0): float images and cubes with their
/// header cards, and the binary table of a -TAB coordinate axis (Greisen et al. 2006 §6), the
/// calibrated images of nebrender --fits (DESIGN §13). Built in memory through FitsFile
/// (io/fits.h) and written through an AtomicFile, so the file lands whole or not at all.

#include "nebula/core/atomic_file.h"
#include "nebula/io/fits.h"

#include <cstddef>
#include <functional>
#include <string>
#include <variant>
#include <vector>

namespace nebula {

/// One header card: a keyword (at most 8 characters, FITS upper case), its value and comment.
/// A keyword "HISTORY" or "COMMENT" writes its string value as such cards.
struct FitsCard
{
    std::string key;
    std::variant<std::string, double, long long> value;
    std::string comment;
};

/// An image HDU: axes[0] x axes[1] (x axes[2] for a cube) float32 values, the first axis
/// fastest (FITS order: data[(k * axes[1] + j) * axes[0] + i] is pixel (i + 1, j + 1, k + 1)).
struct FitsImageHdu
{
    std::string name; ///< EXTNAME ("" for none)
    std::vector<long> axes;
    std::vector<float> data;
    std::vector<FitsCard> cards;
};

/// A one-row binary table of one column of doubles with the given TDIM, e.g. the coordinate
/// array of a WAVE-TAB axis (name "WCS-TAB", column "COORDS", tdim {1, N}).
struct FitsTableHdu
{
    std::string name;
    std::string column;
    std::vector<long> tdim;
    std::vector<double> values;
    std::string unit; ///< TUNIT of the column
};

/// A binary table of columns of doubles, one row per value (e.g. an SED).
struct FitsColumnsHdu
{
    std::string name;
    std::vector<FitsFile::Column> columns;
};

/// Writes @p images (the first is the primary HDU), then @p tables and @p columnTables to
/// @p file. Throws Error naming the file, the HDU and cfitsio's message on any failure.
void writeFits(AtomicFile& file, const std::vector<FitsImageHdu>& images,
               const std::vector<FitsTableHdu>& tables = {},
               const std::vector<FitsColumnsHdu>& columnTables = {});

/// The same for @p count images made one at a time by @p image(i), so that only one image's
/// data is held besides the file's bytes.
void writeFits(AtomicFile& file, std::size_t count,
               const std::function<FitsImageHdu(std::size_t)>& image,
               const std::vector<FitsTableHdu>& tables = {},
               const std::vector<FitsColumnsHdu>& columnTables = {});

} // namespace nebula
