// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: FITS files in memory (io/fits.h, cfitsio) and nebula's reading of them:
// gzipped bytes inflated within their declared size (openMemory() on the gzip magic; seed
// cube-wcs.gz), the header diagnosis behind a failed open, every HDU's type, shape, BUNIT,
// BSCALE/BZERO and WCS (readFitsGeometry(): CROTAn, PC/CD, NaN and string values; seed
// cube-scaling-rotation), and the data of small images whose header says they lie inside the
// bytes. Anything but a clean nebula::Error is a finding.
#include "nebula/core/error.h"
#include "nebula/io/cube_io.h"
#include "nebula/io/fits.h"

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    try {
        auto f = nebula::FitsFile::openMemory(bytes, "fuzz.fits");
        const int n = f.hduCount();
        for (int i = 0; i < n && i < 8; ++i) {
            f.moveTo(i);
            (void)f.hduLabel();
            if (!f.isImage()) continue;
            const auto shape = f.imageShape();
            (void)f.keyString("BUNIT");
            for (const char* key : {"BSCALE", "BZERO"}) {
                try {
                    (void)f.keyNumber(key);
                } catch (const nebula::Error&) {
                }
            }
            if (shape.size() == 3) {
                try {
                    (void)nebula::readFitsGeometry(f);
                } catch (const nebula::Error&) {
                }
            }
            double count = shape.empty() ? 0.0 : 1.0;
            for (auto a : shape)
                count *= double(a);
            const auto [start, end] = f.dataSpan();
            (void)end;
            const int bytesPer = f.bitpix() < 0 ? -f.bitpix() / 8 : f.bitpix() / 8;
            if (count > 0 && count <= 4096 &&
                double(start) + count * bytesPer <= double(f.fileSize())) {
                std::vector<double> values(static_cast<std::size_t>(count));
                f.readDoubles(0, std::int64_t(count), values.data());
            }
        }
    } catch (const nebula::Error&) {
    }
    return 0;
}
