// SPDX-License-Identifier: Apache-2.0
/// @file scatter_field_meta.cpp
/// A field source's name (io/scatter_field_meta.h): made and parsed here only.

#include "nebula/io/scatter_field_meta.h"

#include "nebula/core/error.h"

namespace nebula {

std::string scatterSourceName(const ScatterSource& source, const std::vector<Star>& stars)
{
    switch (source.kind) {
    case ScatterSource::Kind::Stars: return "stars";
    case ScatterSource::Kind::Star: return "star_" + stars.at(source.star).name;
    case ScatterSource::Kind::Emission: return "emission";
    }
    return "";
}

ScatterSource parseScatterSource(const std::string& name, const std::vector<Star>& stars,
                                 const std::string& where)
{
    if (name == "stars") return ScatterSource::allStars();
    if (name == "emission") return ScatterSource::emission();
    for (std::size_t s = 0; s < stars.size(); ++s)
        if (name == "star_" + stars[s].name) return ScatterSource::oneStar(s);
    throw Error(where + ": source \"" + name +
                "\" is none of \"stars\", \"emission\" or \"star_<name>\" of one of its stars");
}

} // namespace nebula
