// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: HDF5 files in memory, through nebimport's HDF5 reader (openHdf5Memory():
// the same code as for a file, over HDF5's core driver): the choice of dataset, the links on
// its path, external storage, virtual datasets, filters, unwritten data, chunk sizes, the
// attributes, and the values of small cubes. Anything but a clean nebula::Error is a finding;
// so is a read of another file (the target runs with its working folder and / holding no .h5
// the seeds name, and external storage is refused before any value is read).
#include "nebula/core/error.h"
#include "nebula/io/cube_io.h"

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

namespace {

void readSmall(std::string_view bytes, const nebula::CubeSelect& select)
{
    auto cube = nebula::openHdf5Memory(bytes, "fuzz.h5", select);
    const auto& info = cube->info();
    // Small cubes only: the reader's time is bounded by the declared size, which the fuzzer
    // sets at will (a 4096^3 declaration of a few bytes is refused only if nothing is stored).
    if (double(info.planeSize()) * double(info.planeCount()) > 65536.0) return;
    std::vector<double> plane(static_cast<std::size_t>(info.planeSize()));
    for (std::int64_t k = 0; k < info.planeCount(); ++k)
        cube->readPlane(k, plane.data());
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    // The file's only cube, and a path named as --dataset names it (the seeds' /density).
    for (const char* dataset : {"", "/density"}) {
        nebula::CubeSelect select;
        select.format = &nebula::cubeFormat("hdf5", "--format");
        select.dataset = dataset;
        try {
            readSmall(bytes, select);
        } catch (const nebula::Error&) {
        }
    }
    return 0;
}
