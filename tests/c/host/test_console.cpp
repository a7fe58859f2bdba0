// Console's scrolling and status lines in a log (not a terminal): the time stamp and the
// status line period; TextLine, the builder of the frame's frequent lines.
#include <gtest/gtest.h>

#include <climits>
#include <cstdint>
#include <cstdio>
#include <string>
#include <unistd.h>

#include "navkit/console.hpp"

using namespace navkit;

namespace {

// What Console wrote into f since the start.
std::string contents(std::FILE *f)
{
    std::fflush(f);
    std::rewind(f);
    std::string s;
    char b[1024];
    size_t n;
    while ((n = std::fread(b, 1, sizeof b, f)) > 0) {
        s.append(b, n);
    }
    return s;
}

} // namespace

TEST(TextLine, IntegersAndTextAsPrintfWritesThem)
{
    TextLine t;
    t << "a " << -12 << " " << 0u << " " << static_cast<uint16_t>(65535) << " " << INT_MIN << " " << ULLONG_MAX << " "
      << LLONG_MIN;
    char want[160];
    std::snprintf(want, sizeof want, "a %d %u %u %d %llu %lld", -12, 0u, 65535u, INT_MIN, ULLONG_MAX, LLONG_MIN);
    EXPECT_STREQ(t.c_str(), want);
    TextLine p;
    p.pad(42, 5).pad(-7, 3).pad(123456, 2);
    std::snprintf(want, sizeof want, "%5lld%3lld%2lld", 42LL, -7LL, 123456LL);
    EXPECT_STREQ(p.c_str(), want);
}

TEST(TextLine, CutAtItsCapacityAsSnprintfCuts)
{
    TextLine t;
    const std::string x(500, 'x');
    t << x.c_str() << 12345;
    char want[320];
    std::snprintf(want, sizeof want, "%s%d", x.c_str(), 12345);
    EXPECT_STREQ(t.c_str(), want);
    EXPECT_EQ(t.size(), 319u);
}

TEST(Console, TimeStampsAsPrintfOfTheSeconds)
{
    // whole ms (integers) and any other time (printf), against "[%9.3f]" of the seconds
    for (const int64_t us :
         {0LL, 1000LL, 599900000LL, 12345678000LL, 123456789012000LL, 1500LL, 4500LL, 999999LL, -2000LL}) {
        std::FILE *f = std::tmpfile();
        ASSERT_NE(f, nullptr);
        {
            Console c(f, -1, 1.0);
            c.set_time_us(us);
            c.print("x %d", 1);
            c.status("s");
            char want[128];
            const double s = static_cast<double>(us) / 1e6;
            std::snprintf(want, sizeof want, "[%9.3f] x 1\n[%9.3f] status: s\n", s, s);
            EXPECT_EQ(contents(f), want) << us << " us";
        }
        std::fclose(f);
    }
}

TEST(Console, StatusLineDueEveryPeriodInALog)
{
    std::FILE *f = std::tmpfile();
    ASSERT_NE(f, nullptr);
    {
        Console c(f, -1, 1.0);
        EXPECT_TRUE(c.status_due()) << "none shown yet";
        c.status("a");
        EXPECT_FALSE(c.status_due());
        c.set_time_us(999999);
        EXPECT_FALSE(c.status_due());
        c.status("b"); // not due: not shown
        c.set_time_us(1000000);
        EXPECT_TRUE(c.status_due());
        c.status("c");
        EXPECT_EQ(contents(f), "[    0.000] status: a\n[    1.000] status: c\n");
    }
    std::fclose(f);
}

TEST(Console, KeysFromAPipeWithoutBlockingThenItsEof)
{
    int p[2];
    ASSERT_EQ(pipe(p), 0);
    {
        Console c(stdout, p[0], 1.0);
        c.init();
        EXPECT_EQ(c.keys(), "") << "nothing waiting: no wait";
        const std::string flood(100, 'w');
        ASSERT_EQ(write(p[1], flood.data(), flood.size()), 100);
        EXPECT_EQ(c.keys(), std::string(Console::kMaxKeyBytes, 'w')) << "at most kMaxKeyBytes a call";
        EXPECT_EQ(c.keys(), std::string(100 - Console::kMaxKeyBytes, 'w'));
        EXPECT_EQ(c.keys(), "");
        ASSERT_EQ(write(p[1], "q", 1), 1);
        close(p[1]);
        EXPECT_EQ(c.keys(), "q") << "what came before the EOF";
        EXPECT_EQ(c.keys(), "");
    }
    close(p[0]);
}

TEST(Console, KeysFromAFile)
{
    std::FILE *f = std::tmpfile();
    ASSERT_NE(f, nullptr);
    std::fputs("wasd", f);
    std::fflush(f);
    std::rewind(f);
    Console c(stdout, fileno(f), 1.0);
    c.init();
    EXPECT_EQ(c.keys(), "wasd");
    EXPECT_EQ(c.keys(), "") << "EOF";
    c.shutdown();
    std::fclose(f);
}
