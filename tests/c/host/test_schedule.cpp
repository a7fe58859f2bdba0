// Frame scheduling arithmetic: absolute deadlines, overruns, skipped (not bunched) frames.
#include <gtest/gtest.h>

#include "navkit/schedule.hpp"

using namespace navkit;

static const Schedule kS{1000, 100}; // t0 = 1000 ns, period 100 ns

TEST(Schedule, FrameStartsAreAbsolute)
{
    EXPECT_EQ(frame_start(kS, 0), 1000);
    EXPECT_EQ(frame_start(kS, 7), 1700);
    EXPECT_EQ(frame_start(kS, 1000000), 1000 + 100000000); // no accumulated error
}

TEST(Schedule, OnTimeGoesToTheNextFrame)
{
    const NextFrame n = next_frame(kS, 3, 1350);
    EXPECT_EQ(n.frame, 4u);
    EXPECT_FALSE(n.overrun);
    EXPECT_EQ(n.skipped, 0u);
    EXPECT_FALSE(next_frame(kS, 3, 1400).overrun) << "ending exactly at the next start is on time";
}

TEST(Schedule, SmallOverrunRunsTheNextFrameLateWithoutSkipping)
{
    const NextFrame n = next_frame(kS, 3, 1401);
    EXPECT_TRUE(n.overrun);
    EXPECT_EQ(n.frame, 4u);
    EXPECT_EQ(n.skipped, 0u);
}

TEST(Schedule, LongOverrunSkipsMissedFrames)
{
    const NextFrame n = next_frame(kS, 3, 1750); // frames 4, 5, 6 have passed; 7 starts at 1700
    EXPECT_TRUE(n.overrun);
    EXPECT_EQ(n.frame, 7u);
    EXPECT_EQ(n.skipped, 3u);
}

TEST(Schedule, PeriodOfRate)
{
    EXPECT_EQ(period_ns_of(10), 100000000);
    EXPECT_EQ(period_ns_of(100), 10000000);
    EXPECT_EQ(period_ns_of(3), 333333333);
}
