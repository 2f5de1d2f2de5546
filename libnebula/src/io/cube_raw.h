// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to io/: the arrays behind FITS, HDF5 and .npy cubes, and the CubeSource that reads
// any of them plane by plane (cube_io.cpp).
#include "nebula/io/cube_io.h"

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace nebula::detail {

/// An N-D array in a file, read in blocks along its storage order.
class RawArray
{
public:
    virtual ~RawArray() = default;
    /// The axis lengths in nebula's index order (numpy's a.shape; FITS NAXISn reversed is
    /// storage order, so FITS's shape here is NAXIS1, NAXIS2, ...).
    virtual std::vector<std::int64_t> shape() const = 0;
    /// True: the first index varies fastest in the file (FITS, Fortran-ordered .npy);
    /// false: the last (C order: .npy, HDF5).
    virtual bool firstFastest() const = 0;
    /// Reads the block in which the @p fixed.size() slowest-varying indices (slowest first)
    /// take the values @p fixed and the others all their values, in file order.
    virtual void readBlock(const std::vector<std::int64_t>& fixed, double* out) = 0;
};

/// The CubeSource over a RawArray: a 3-D array, or component @p component of a 4-D array whose
/// first or last axis has 3 entries. Checks the shape and the plane buffer's memory.
std::unique_ptr<CubeSource> arrayCube(std::unique_ptr<RawArray> array, CubeInfo info,
                                      int component);

/// Throws Error unless @p shape has 3 axes (or 4 with a component axis when @p component >= 0),
/// each at least 1 and at most 2^31 - 1 voxels, and refuses (requireMemory()) a plane buffer
/// the machine cannot hold.
void checkCubeShape(const std::vector<std::int64_t>& shape, int component, const std::string& name);

std::unique_ptr<CubeSource> openFitsCube(const std::string& path, const CubeSelect& select);
std::unique_ptr<CubeSource> openHdf5Cube(const std::string& path, const CubeSelect& select);
/// openHdf5Cube() of an HDF5 file held in memory (@p bytes; @p name for messages): the same
/// checks and reader, over HDF5's core driver.
std::unique_ptr<CubeSource> openHdf5CubeImage(std::string_view bytes, const std::string& name,
                                              const CubeSelect& select);
std::unique_ptr<CubeSource> openNpyCube(const std::string& path, const CubeSelect& select);
std::unique_ptr<CubeSource> openRadmcCube(const std::string& path, const CubeSelect& select);

void writeFitsCube(const std::string& path, const CubeHeader& header, const PlaneFunction& plane);
void writeHdf5Cube(const std::string& path, const CubeHeader& header, const std::string& dataset,
                   const PlaneFunction& plane);
void writeNpyCube(const std::string& path, const CubeHeader& header, const PlaneFunction& plane);

} // namespace nebula::detail
