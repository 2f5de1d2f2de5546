// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal: parsing JSON, and numbers in error messages, for the dust and star metadata.

#include "nebula/core/error.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

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

/// nlohmann's message for a user, without its "[json.exception.type_error.302] " prefix and
/// made printable.
inline std::string jsonErrorText(const nlohmann::json::exception& e)
{
    std::string detail = e.what();
    const auto bracket = detail.find("] ");
    if (detail.rfind("[json.exception", 0) == 0 && bracket != std::string::npos) {
        detail.erase(0, bracket + 2);
    }
    return printable(detail);
}

/// The deepest nesting of arrays and objects any JSON input of nebula may have (its own
/// documents nest 4 levels at most).
inline constexpr int MAX_JSON_DEPTH = 64;
/// The largest JSON document nebula parses [bytes] (the same as input.h's
/// MAX_TEXT_INPUT_BYTES, for documents that come from metadata rather than files).
inline constexpr std::size_t MAX_JSON_BYTES = std::size_t(16) << 20;

/// Throws Error "<source>: <what>..." if @p text is larger than MAX_JSON_BYTES or nests
/// arrays and objects deeper than MAX_JSON_DEPTH. One pass, no recursion, before any JSON
/// library sees the text (whose parser, destructor and messages would otherwise recurse over
/// a document 100,000 levels deep).
inline void checkJsonBounds(const std::string& text, const std::string& source,
                            const std::string& what = "")
{
    if (text.size() > MAX_JSON_BYTES) {
        throw Error(source + ": " + what + "a JSON document of " + std::to_string(text.size()) +
                    " bytes, more than the " + std::to_string(MAX_JSON_BYTES) + " nebula reads");
    }
    int depth = 0;
    bool inString = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (inString) {
            if (c == '\\') {
                ++i;
            } else if (c == '"') {
                inString = false;
            }
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            if (++depth > MAX_JSON_DEPTH) {
                throw Error(source + ": " + what + "JSON nested deeper than " +
                            std::to_string(MAX_JSON_DEPTH) + " levels (at byte " +
                            std::to_string(i + 1) + "); nebula's documents nest a few levels");
            }
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
}

/// Parses @p text (checkJsonBounds() first); on failure throws Error "<source>: <what>not
/// valid JSON: <detail>", where detail is nlohmann's message without its
/// "[json.exception.parse_error.101] " prefix (parse errors, and out_of_range for a number
/// too large for a double).
inline nlohmann::json parseJson(const std::string& text, const std::string& source,
                                const std::string& what = "")
{
    checkJsonBounds(text, source, what);
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        throw Error(source + ": " + what + "not valid JSON: " + jsonErrorText(e));
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

/// numberText() of each value, joined by ", ": "650, 550, 450".
inline std::string numbersText(const std::vector<double>& values)
{
    std::string text;
    for (const double v : values)
        text += (text.empty() ? "" : ", ") + numberText(v);
    return text;
}

} // namespace nebula::detail
