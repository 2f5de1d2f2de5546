// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file grid_values.h
/// Checks of a grid's values that a reader makes before it uses them (implemented beside
/// readGrids() in grid_io.cpp, with requireFiniteNonNegative()): no NaN or infinite value
/// reaches an output or a statistic.

#include <openvdb/openvdb.h>

#include <cstddef>
#include <string>

namespace nebula {

/// Throws Error naming @p source, the grid, the value as it is ("nan", "inf", "-inf") and the
/// first such voxel if a value of @p grid that a reader sees is NaN or infinite: every active
/// value; and where @p box is given, also the background and the inactive values inside
/// @p box (a dense cube over the box holds them: nebexport). Negative values pass (nebstats,
/// nebexport: any grid). Returns the number of active values checked.
std::size_t requireFinite(const openvdb::FloatGrid& grid, const std::string& source,
                          const openvdb::CoordBBox* box = nullptr);

/// A value as an error message shows it: "nan", "inf" and "-inf" as they are (never "-nan"),
/// else its shortest exact text.
std::string valueText(double v);

} // namespace nebula
