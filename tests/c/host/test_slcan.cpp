// Slcan (host/src/slcan.cpp): the host's side of the SLCAN text protocol. The adapter's
// side (navkit.can_slcan) and python-can's slcan interface are checked against each other
// in tests/test_can_slcan.py; the host against that adapter in tests/test_host_can.py.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "navkit/slcan.hpp"

using navkit::Slcan;
using navkit::SlcanFrame;

static std::vector<SlcanFrame> feed(Slcan &s, const std::string &text)
{
    std::vector<SlcanFrame> out;
    s.feed(reinterpret_cast<const uint8_t *>(text.data()), text.size(), &out);
    return out;
}

TEST(Slcan, CommandsOfTheHost)
{
    EXPECT_EQ(Slcan::bitrate_command(500000), "S6");
    EXPECT_EQ(Slcan::bitrate_command(10000), "S0");
    EXPECT_EQ(Slcan::bitrate_command(1000000), "S8");
    EXPECT_EQ(Slcan::bitrate_command(400000), "");
    EXPECT_EQ(Slcan::open_commands(125000), "C\rS4\rO\r");
    EXPECT_EQ(Slcan::open_commands(400000), "");
    const uint8_t d[8] = {0x10, 0x74, 0xA5, 0xFF, 0x07, 0x00, 0x01, 0x00};
    EXPECT_EQ(Slcan::frame_command(0x110, d), "t11081074A5FF07000100\r");
    EXPECT_EQ(Slcan::frame_command(0x7FF, d).substr(0, 5), "t7FF8");
}

TEST(Slcan, FramesInAnyChunkingAnswersSkipped)
{
    Slcan s;
    const std::string text = "z\r\rt1808DEADBEEF00112233\rT1ABCDEF02AABB\rr1230\rt12020102ABCD\r";
    std::vector<SlcanFrame> all;
    for (char c : text) { // one byte at a time
        std::vector<SlcanFrame> got = feed(s, std::string(1, c));
        all.insert(all.end(), got.begin(), got.end());
    }
    ASSERT_EQ(all.size(), 4u);
    EXPECT_EQ(all[0].id, 0x180u);
    EXPECT_FALSE(all[0].extended);
    EXPECT_EQ(all[0].dlc, 8);
    EXPECT_EQ(all[0].data[0], 0xDE);
    EXPECT_EQ(all[0].data[7], 0x33);
    EXPECT_TRUE(all[1].extended);
    EXPECT_EQ(all[1].id, 0x1ABCDEF0u);
    EXPECT_EQ(all[1].dlc, 2);
    EXPECT_TRUE(all[2].remote);
    EXPECT_EQ(all[2].dlc, 0);
    EXPECT_EQ(all[3].id, 0x120u); // a time stamp (4 digits) after the data is allowed
    EXPECT_EQ(all[3].dlc, 2);
    EXPECT_EQ(all[3].data[1], 0x02);
    EXPECT_EQ(s.bad_lines(), 0u);
    EXPECT_EQ(s.refused(), 0u);
}

TEST(Slcan, BadLinesAndRefusalsAreCounted)
{
    Slcan s;
    const char *bad[] = {"t18G\r",      "t1809\r", "t1802AA\r",     "t800100\r",
                         "t1801AABB\r", "x\r",     "T2000000000\r", "t1801AA123\r"};
    for (const char *b : bad) {
        EXPECT_TRUE(feed(s, b).empty()) << b;
    }
    EXPECT_EQ(s.bad_lines(), sizeof bad / sizeof bad[0]);
    EXPECT_TRUE(feed(s, std::string(100, 't') + "\r").empty()); // a line longer than any frame
    EXPECT_EQ(s.bad_lines(), sizeof bad / sizeof bad[0] + 1);
    EXPECT_TRUE(feed(s, "\a").empty());
    EXPECT_EQ(s.refused(), 1u);
    // after all that, a good line still parses
    ASSERT_EQ(feed(s, "t1100\r").size(), 1u);
}
