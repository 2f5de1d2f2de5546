// SPDX-License-Identifier: Apache-2.0
// core/frames.h: output-name frame patterns and --frames ranges.
#include "nebula/core/frames.h"

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using namespace nebula;

TEST(Frames, PatternsAreExpanded)
{
    EXPECT_EQ(expandFramePattern("f.####.exr", 7), "f.0007.exr");
    EXPECT_EQ(expandFramePattern("f.#.exr", 1234), "f.1234.exr"); // wider than the pattern
    EXPECT_EQ(expandFramePattern("out/f.%04d.exr", 42), "out/f.0042.exr");
    EXPECT_EQ(expandFramePattern("f%d.exr", 42), "f42.exr");
    EXPECT_EQ(expandFramePattern("take#2/f.###.exr", 5), "take#2/f.005.exr"); // the last run
    EXPECT_EQ(expandFramePattern("plain.exr", 5), "plain.exr");
    EXPECT_TRUE(hasFramePattern("f.####.png"));
    EXPECT_TRUE(hasFramePattern("f.%03d.png"));
    EXPECT_FALSE(hasFramePattern("f.png"));
    EXPECT_THROW(expandFramePattern("f.%x.exr", 1), UsageError);
    EXPECT_THROW(expandFramePattern("f.%4d.exr", 1), UsageError);   // %4d pads with spaces
    EXPECT_THROW(expandFramePattern("f.%099d.exr", 1), UsageError); // absurd width
}

TEST(Frames, RangesAreParsed)
{
    EXPECT_EQ(parseFrameRange("1-10:3", "--frames").frames(), (std::vector<long>{1, 4, 7, 10}));
    EXPECT_EQ(parseFrameRange("5", "--frames").frames(), std::vector<long>{5});
    EXPECT_EQ(parseFrameRange("2-4", "--frames").frames(), (std::vector<long>{2, 3, 4}));
    for (const std::string bad :
         {"0", "3-1", "1-x", "", "-4", "1-4:0", "1-4:", "99999999999", "1.5", "1-2-3"}) {
        try {
            parseFrameRange(bad, "--frames");
            ADD_FAILURE() << "accepted \"" << bad << "\"";
        } catch (const UsageError& e) {
            EXPECT_EQ(std::string(e.what()).rfind("--frames \"", 0), 0u) << e.what();
        }
    }
}
