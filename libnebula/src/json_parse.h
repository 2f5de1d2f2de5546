#pragma once
// Internal: parsing JSON with error messages that name the source.

#include "nebula/error.h"

#include <nlohmann/json.hpp>

#include <string>

namespace nebula::detail {

/// Parses @p text; on failure throws Error "<source>: <what>not valid JSON: <detail>", where
/// detail is nlohmann's message without its "[json.exception.parse_error.101] " prefix
/// (parse errors, and out_of_range for a number too large for a double).
inline nlohmann::json parseJson(const std::string& text, const std::string& source,
                                const std::string& what = "")
{
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        std::string detail = e.what();
        const auto bracket = detail.find("] ");
        if (detail.rfind("[json.exception", 0) == 0 && bracket != std::string::npos) {
            detail.erase(0, bracket + 2);
        }
        throw Error(source + ": " + what + "not valid JSON: " + detail);
    }
}

} // namespace nebula::detail
