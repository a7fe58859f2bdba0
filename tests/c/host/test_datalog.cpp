// Datalog: the seed's file name and header, one flushed row per call.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "navkit/datalog.hpp"

using namespace navkit;

TEST(Datalog, FileNameAsTheSeedSays)
{
    std::tm t{};
    t.tm_year = 105;
    t.tm_mon = 4;
    t.tm_mday = 18;
    t.tm_hour = 8;
    t.tm_min = 49;
    t.tm_sec = 25;
    EXPECT_EQ(Datalog::file_name(t), "Data 05-18-05 08;49;25.txt");
}

TEST(Datalog, HeaderCountsNamesAndRanges)
{
    EXPECT_EQ(Datalog::header({{"time_s", 0, 600}, {"speed_mm_s", -1000, 1000}}),
              "2\ntime_s 0 600\nspeed_mm_s -1000 1000\n");
    EXPECT_EQ(Datalog::format_row({0.1, -5, 12.25}), "0.1\t-5\t12.25\n");
}

static std::string slurp(const std::string &p)
{
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

TEST(Datalog, RowsAreOnDiskAfterEachCall)
{
    char dir[] = "/tmp/navkit-dlXXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    Datalog d(dir);
    ASSERT_EQ(d.start(1000000000, {{"a", 0, 1}, {"b", 0, 2}}), "");
    EXPECT_EQ(d.row({1, 2}), "");
    EXPECT_EQ(slurp(d.path()), "2\na 0 1\nb 0 2\n1\t2\n") << "flushed without closing";
    EXPECT_EQ(d.row({1}), d.path() + ": a row of 1 values for 2 columns: not written") << "refused aloud";
    EXPECT_EQ(slurp(d.path()), "2\na 0 1\nb 0 2\n1\t2\n");
    Datalog d2(dir);
    ASSERT_EQ(d2.start(1000000000, {{"a", 0, 1}}), "");
    EXPECT_NE(d2.path(), d.path()) << "same second: a second file, never overwritten";
    const std::string p1 = d.path(), p2 = d2.path();
    d.stop();
    d2.stop();
    EXPECT_FALSE(d.recording());
    std::remove(p1.c_str());
    std::remove(p2.c_str());
    rmdir(dir);
}
