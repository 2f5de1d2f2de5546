#pragma once
// Internal: parsing JSON, and numbers in error messages, for the dust and star metadata.

#include "nebula/core/error.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

namespace nebula::detail {

/// @p text for a one-line message: bytes that are not printable ASCII are shown as \xNN, and
/// text beyond @p maxChars is cut and marked with "...", so that a damaged file's bytes can
/// neither mangle a terminal nor flood it.
inline std::string printable(const std::string& text, std::size_t maxChars = 200)
{
    static const char hex[] = "0123456789abcdef";
    std::string out;
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (out.size() >= maxChars) {
            out += "...";
            break;
        }
        const auto c = static_cast<unsigned char>(text[i]);
        if (c >= 32 && c < 127) {
            out += char(c);
        } else {
            out += "\\x";
            out += hex[c >> 4];
            out += hex[c & 15];
        }
    }
    return out;
}

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
        throw Error(source + ": " + what + "not valid JSON: " + printable(detail));
    }
}

/// A double for an error message: %g style with at least 6 and otherwise the fewest
/// significant digits that read back as the same value ("-1", "0.3", "1e+300").
inline std::string numberText(double value)
{
    std::string text;
    for (int digits = 6; digits <= 17; ++digits) {
        std::ostringstream out;
        out.precision(digits);
        out << value;
        text = out.str();
        if (!std::isfinite(value) || std::strtod(text.c_str(), nullptr) == value) break;
    }
    return text;
}

} // namespace nebula::detail
