// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/fits_image.h"

#include "nebula/core/error.h"
#include "nebula/core/file_format.h"
#include "nebula/io/fits.h"

#include <ostream>

namespace nebula {

void writeFits(AtomicFile& file, const std::vector<FitsImageHdu>& images,
               const std::vector<FitsTableHdu>& tables,
               const std::vector<FitsColumnsHdu>& columnTables)
{
    writeFits(
        file, images.size(), [&](std::size_t i) { return images[i]; }, tables, columnTables);
}

void writeFits(AtomicFile& file, std::size_t count,
               const std::function<FitsImageHdu(std::size_t)>& image,
               const std::vector<FitsTableHdu>& tables,
               const std::vector<FitsColumnsHdu>& columnTables)
{
    checkOutputName(file.path(), "output", FileFormat::Fits);
    if (count == 0) throw Error(file.path() + ": FITS: no image to write");
    FitsFile f = FitsFile::createMemory(file.path());
    for (std::size_t i = 0; i < count; ++i) {
        const FitsImageHdu img = image(i);
        std::int64_t n = 1;
        for (const long a : img.axes)
            n *= a;
        if (img.axes.empty() || std::size_t(n) != img.data.size()) {
            throw Error(file.path() + ": FITS: HDU " + img.name + ": " +
                        std::to_string(img.data.size()) + " values for its axes");
        }
        f.createImage(std::vector<std::int64_t>(img.axes.begin(), img.axes.end()), img.name);
        for (const auto& card : img.cards) {
            if (const auto* s = std::get_if<std::string>(&card.value)) {
                if (card.key == "HISTORY") {
                    f.writeHistory(*s);
                } else if (card.key == "COMMENT") {
                    f.writeComment(*s);
                } else {
                    f.writeKey(card.key, *s, card.comment);
                }
            } else if (const auto* d = std::get_if<double>(&card.value)) {
                f.writeKey(card.key, *d, card.comment);
            } else {
                f.writeKey(card.key, std::int64_t(std::get<long long>(card.value)), card.comment);
            }
        }
        f.writeFloats(0, n, img.data.data());
    }
    for (const auto& t : tables)
        f.createDoubleTable(t.name, t.column,
                            std::vector<std::int64_t>(t.tdim.begin(), t.tdim.end()), t.values,
                            t.unit);
    for (const auto& t : columnTables)
        f.createTable(t.name, t.columns);
    f.finishTo(file.stream());
}

} // namespace nebula
