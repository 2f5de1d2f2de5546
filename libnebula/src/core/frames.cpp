// SPDX-License-Identifier: Apache-2.0
#include "nebula/core/frames.h"

#include <algorithm>

#include "nebula/core/error.h"
#include "nebula/core/format.h"

#include <cctype>
#include <cstdio>
#include <limits>

namespace nebula {

namespace {

/// The pattern's place in @p name: [begin, end) and its zero-padding width; false if none.
bool findPattern(const std::string& name, std::size_t& begin, std::size_t& end, int& width)
{
    // The last '#' run or printf conversion in the name.
    std::size_t hashEnd = std::string::npos, percent = std::string::npos;
    for (std::size_t i = name.size(); i-- > 0;) {
        if (name[i] == '#' && hashEnd == std::string::npos) hashEnd = i + 1;
        if (name[i] == '%' && percent == std::string::npos) percent = i;
    }
    std::size_t hashBegin = hashEnd;
    if (hashEnd != std::string::npos) {
        while (hashBegin > 0 && name[hashBegin - 1] == '#')
            --hashBegin;
    }
    const bool usePercent =
        percent != std::string::npos && (hashEnd == std::string::npos || percent > hashBegin);
    if (usePercent) {
        std::size_t i = percent + 1;
        std::string digits;
        while (i < name.size() && std::isdigit(static_cast<unsigned char>(name[i])))
            digits += name[i++];
        if (i >= name.size() || name[i] != 'd' || (!digits.empty() && digits[0] != '0') ||
            digits.size() > 3 || (!digits.empty() && std::stoi(digits) > 16)) {
            throw UsageError("\"" + detail::printable(name, 120) +
                             "\": a frame pattern is #### (as many digits as #) or %d / %0Nd "
                             "(N at most 16); got \"" +
                             detail::printable(name.substr(percent, i + 1 - percent), 20) + "\"");
        }
        begin = percent;
        end = i + 1;
        width = digits.empty() ? 0 : std::stoi(digits);
        return true;
    }
    if (hashEnd == std::string::npos) return false;
    begin = hashBegin;
    end = hashEnd;
    width = int(end - begin);
    return true;
}

long parseFrameNumber(const std::string& text, const std::string& option, const std::string& whole)
{
    const auto bad = [&] {
        return UsageError(option + " \"" + detail::printable(whole, 60) +
                          "\": expected N, A-B or A-B:STEP with whole frame numbers >= 1 "
                          "(at most 1e9), e.g. 1-240 or 1-240:10");
    };
    if (text.empty() || text.size() > 10) throw bad();
    for (char c : text) {
        if (!std::isdigit(static_cast<unsigned char>(c))) throw bad();
    }
    const long n = std::stol(text);
    if (n < 1 || n > 1000000000L) throw bad();
    return n;
}

} // namespace

bool hasFramePattern(const std::string& name)
{
    std::size_t b, e;
    int w;
    return findPattern(name, b, e, w);
}

std::string expandFramePattern(const std::string& name, long frame)
{
    std::size_t b, e;
    int width;
    if (!findPattern(name, b, e, width)) return name;
    char digits[32];
    std::snprintf(digits, sizeof digits, "%0*ld", width, frame);
    return name.substr(0, b) + digits + name.substr(e);
}

bool matchFramePattern(const std::string& pattern, const std::string& name, long& frame)
{
    std::size_t b, e;
    int width;
    if (!findPattern(pattern, b, e, width)) return false;
    const std::string prefix = pattern.substr(0, b), suffix = pattern.substr(e);
    if (name.size() <= prefix.size() + suffix.size()) return false;
    if (name.compare(0, prefix.size(), prefix) != 0) return false;
    if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) return false;
    const std::string digits = name.substr(b, name.size() - prefix.size() - suffix.size());
    if (digits.size() > 10) return false;
    for (char c : digits) {
        if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    }
    frame = std::stol(digits);
    return expandFramePattern(pattern, frame) == name; // the same padding
}

long FrameRange::count() const
{
    return (last - first) / step + 1;
}

std::vector<long> FrameRange::frames() const
{
    std::vector<long> out;
    out.reserve(std::size_t(std::max(0L, count())));
    for (long f = first; f <= last; f += step)
        out.push_back(f);
    return out;
}

FrameRange parseFrameRange(const std::string& text, const std::string& option)
{
    FrameRange r;
    std::string range = text;
    const auto colon = text.find(':');
    if (colon != std::string::npos) {
        range = text.substr(0, colon);
        r.step = parseFrameNumber(text.substr(colon + 1), option, text);
    }
    const auto dash = range.find('-');
    if (dash == std::string::npos) {
        r.first = r.last = parseFrameNumber(range, option, text);
    } else {
        r.first = parseFrameNumber(range.substr(0, dash), option, text);
        r.last = parseFrameNumber(range.substr(dash + 1), option, text);
    }
    if (r.first > r.last) {
        throw UsageError(option + " \"" + detail::printable(text, 60) +
                         "\": the first frame is after the last");
    }
    if (r.count() > MAX_FRAMES) {
        throw UsageError(option + " \"" + detail::printable(text, 60) +
                         "\": " + std::to_string(r.count()) + " frames; at most " +
                         std::to_string(MAX_FRAMES) + " frames in one range");
    }
    return r;
}

} // namespace nebula
