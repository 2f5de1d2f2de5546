// SPDX-License-Identifier: Apache-2.0
/// @file test_format.cpp
/// core/format.h: numbers in error messages (the shortest %g text, at least 6 significant
/// digits, that reads back as the same double) and parseJson()'s error message.

#include "nebula/core/format.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <sstream>
#include <string>

using nebula::detail::numberText;
using nebula::detail::parseJson;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

/// @p value printed like %g with @p digits significant digits.
std::string withDigits(double value, int digits)
{
    std::ostringstream out;
    out.precision(digits);
    out << value;
    return out.str();
}

TEST(NumberText, DocumentedExamples)
{
    EXPECT_EQ(numberText(-1.0), "-1");
    EXPECT_EQ(numberText(0.3), "0.3");
    EXPECT_EQ(numberText(1e300), "1e+300");
    EXPECT_EQ(numberText(0.0), "0");
    EXPECT_EQ(numberText(2.5), "2.5");
    EXPECT_EQ(numberText(1e-5), "1e-05");
}

TEST(NumberText, AtLeastSixSignificantDigits)
{
    // Six digits are kept even where fewer would read back the same after rounding to six.
    EXPECT_EQ(numberText(123456.0), "123456");
    EXPECT_EQ(numberText(0.000123456), "0.000123456");
    // More when six would not read back: 1234567 needs seven.
    EXPECT_EQ(numberText(1234567.0), "1234567");
    EXPECT_EQ(numberText(1.0000001), "1.0000001");
}

TEST(NumberText, ShortestTextThatReadsBackEqual)
{
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> mantissa(-10.0, 10.0);
    std::uniform_int_distribution<int> exponent(-300, 300);
    for (int i = 0; i < 5000; ++i) {
        double v = mantissa(rng) * std::pow(10.0, exponent(rng));
        if (i % 3 == 0) v = std::round(v * 1e3) / 1e3;    // short decimals too
        if (i % 5 == 0) v = double(float(mantissa(rng))); // float-valued doubles
        const std::string text = numberText(v);
        // Reads back as exactly the same double.
        ASSERT_EQ(std::strtod(text.c_str(), nullptr), v) << text;
        // It is %g at some precision p >= 6 ...
        int p = 6;
        while (p <= 17 && withDigits(v, p) != text)
            ++p;
        ASSERT_LE(p, 17) << "not %g text: " << text;
        // ... and no precision in [6, p) reads back: the shortest such text.
        for (int q = 6; q < p; ++q) {
            ASSERT_NE(std::strtod(withDigits(v, q).c_str(), nullptr), v)
                << text << " could be " << withDigits(v, q);
        }
    }
    // The extremes round trip too.
    for (double v : {std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
                     std::numeric_limits<double>::denorm_min(), -std::numeric_limits<double>::max(),
                     0.1, 1.0 / 3.0, 2.0 / 3.0, 1e23}) {
        EXPECT_EQ(std::strtod(numberText(v).c_str(), nullptr), v) << numberText(v);
    }
}

TEST(NumberText, NonFiniteValues)
{
    EXPECT_EQ(numberText(std::numeric_limits<double>::infinity()), "inf");
    EXPECT_EQ(numberText(-std::numeric_limits<double>::infinity()), "-inf");
    const std::string nan = numberText(std::numeric_limits<double>::quiet_NaN());
    EXPECT_TRUE(nan == "nan" || nan == "-nan") << nan;
}

TEST(ParseJson, ValidTextParses)
{
    const auto j = parseJson(R"({"a": [1, 2.5, "x"], "b": null})", "f.json");
    ASSERT_TRUE(j.is_object());
    EXPECT_EQ(j["a"][1].get<double>(), 2.5);
    EXPECT_EQ(j["a"][2].get<std::string>(), "x");
    EXPECT_TRUE(j["b"].is_null());
}

TEST(ParseJson, ErrorNamesTheSourceWithoutNlohmannsPrefix)
{
    for (const char* bad : {"{", "[1, 2", "{\"a\": }", "nul", "", "[1,]", "{\"a\" 1}"}) {
        const std::string msg = errorMessage([&] { parseJson(bad, "stars.json"); });
        EXPECT_EQ(msg.rfind("stars.json: not valid JSON: ", 0), 0u) << bad << ": " << msg;
        EXPECT_FALSE(contains(msg, "[json.exception")) << msg;
        EXPECT_GT(msg.size(), std::string("stars.json: not valid JSON: ").size()) << msg;
        EXPECT_THROW(parseJson(bad, "stars.json"), nebula::Error);
    }
    // @p what goes between the source and "not valid JSON".
    const std::string msg =
        errorMessage([] { parseJson("[", "cloud.vdb", "metadata nebula:stars is "); });
    EXPECT_EQ(msg.rfind("cloud.vdb: metadata nebula:stars is not valid JSON: ", 0), 0u) << msg;
    // nlohmann's own detail (position, what it expected) follows.
    EXPECT_TRUE(contains(msg, "parse error")) << msg;
}

TEST(ParseJson, NumberTooLargeForADoubleIsAnError)
{
    const std::string msg = errorMessage([] { parseJson("[1e999]", "dust.json"); });
    EXPECT_EQ(msg.rfind("dust.json: not valid JSON: ", 0), 0u) << msg;
    EXPECT_FALSE(contains(msg, "[json.exception")) << msg;
    EXPECT_TRUE(contains(msg, "1e999")) << msg;
}

// checkJsonBounds(): depth counted over arrays and objects outside strings, one pass; the
// limit is MAX_JSON_DEPTH, the size MAX_JSON_BYTES; parseJson() applies it first.
TEST(JsonBounds, DepthAndSizeAreBoundedBeforeParsing)
{
    using nebula::detail::MAX_JSON_DEPTH;
    const auto nested = [](std::size_t n) { return std::string(n, '[') + std::string(n, ']'); };
    EXPECT_NO_THROW(parseJson(nested(MAX_JSON_DEPTH), "a.json"));
    std::string msg = errorMessage([&] { parseJson(nested(MAX_JSON_DEPTH + 1), "a.json"); });
    EXPECT_EQ(msg, "a.json: JSON nested deeper than 64 levels (at byte 65); nebula's documents "
                   "nest a few levels");
    msg = errorMessage([&] { parseJson(nested(100000), "a.json", "the camera path is "); });
    EXPECT_TRUE(contains(msg, "a.json: the camera path is JSON nested deeper than 64")) << msg;
    // Objects count as arrays do; brackets in strings (escaped quotes too) do not count.
    std::string objects;
    for (int i = 0; i < MAX_JSON_DEPTH + 1; ++i)
        objects += "{\"k\":";
    objects += "1" + std::string(std::size_t(MAX_JSON_DEPTH + 1), '}');
    EXPECT_TRUE(contains(errorMessage([&] { parseJson(objects, "o"); }), "deeper than 64"));
    const std::string inString =
        "[\"" + std::string(1000, '[') + "\\\"" + std::string(1000, '{') + "\"]";
    EXPECT_EQ(parseJson(inString, "s")[0].get<std::string>().size(), 2001u);
    // Unbalanced closers never make the count negative enough to hide a deep tail.
    EXPECT_TRUE(
        contains(errorMessage([&] { parseJson("]]]]" + nested(70), "u"); }), "deeper than 64"));
    // Size.
    const std::string big(nebula::detail::MAX_JSON_BYTES + 1, ' ');
    EXPECT_TRUE(contains(errorMessage([&] { parseJson(big, "big"); }),
                         "big: a JSON document of 16777217 bytes, more than the 16777216"));
    // Library messages lose their "[json.exception...]" prefix.
    msg = errorMessage([&] { parseJson("[1,", "t.json"); });
    EXPECT_FALSE(contains(msg, "json.exception")) << msg;
    EXPECT_TRUE(contains(msg, "t.json: not valid JSON: ")) << msg;
}

} // namespace
