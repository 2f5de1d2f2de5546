// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file frames.h
/// Frame numbers for sequences: output-name patterns (`f.####.exr`, `f.%04d.exr`) and frame
/// ranges (`--frames A-B[:STEP]`), as render farms and Make rules write them.

#include <string>
#include <vector>

namespace nebula {

/// Whether @p name holds a frame pattern: a run of '#' (zero-padded to the run's length) or
/// a printf-style `%d` / `%0Nd`. Only the last such pattern in the name is one ("#" in a
/// folder name is left alone if the file name has its own).
bool hasFramePattern(const std::string& name);

/// @p name with its frame pattern replaced by @p frame (zero-padded to the pattern's width;
/// a negative frame gets a minus sign before the digits); @p name unchanged if it has none.
/// Throws UsageError for a malformed printf pattern (`%x`, `%5`, a width above 16).
std::string expandFramePattern(const std::string& name, long frame);

/// Whether file name @p name is @p pattern with a frame number in place of its pattern (the
/// number into @p frame): "f.0012.exr" matches "f.####.exr" with 12; false if @p pattern has
/// no frame pattern.
bool matchFramePattern(const std::string& pattern, const std::string& name, long& frame);

/// A frame range: first..last (inclusive) every step.
struct FrameRange
{
    long first = 1;
    long last = 1;
    long step = 1;
    long count() const; ///< the number of frames, without listing them
    std::vector<long> frames() const;
};

/// The most frames one range may hold (11.6 hours at 24 fps): a range is checked against this
/// (and a camera path's length) before its frames are listed.
inline constexpr long MAX_FRAMES = 1000000;

/// Parses "N", "A-B" or "A-B:STEP" (frames numbered from 1; A <= B; STEP >= 1; at most
/// MAX_FRAMES frames), naming @p option in a UsageError otherwise.
FrameRange parseFrameRange(const std::string& text, const std::string& option);

} // namespace nebula
