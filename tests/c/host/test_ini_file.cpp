// ini_read: every section in file order with its line and keys; each refusal names
// path:line: key: reason, the earliest line's only; the caller's check joins that order.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <fcntl.h>
#include <string>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include "navkit/ini_file.hpp"
#include "tmp_file.hpp"

using namespace navkit;

class IniRead : public ::testing::Test {
protected:
    // The ConfigError text of reading `text` (with `check`), or "" if it is read.
    std::string error(const std::string &text, const IniCheck &check = nullptr)
    {
        tmp_.write(text);
        try {
            ini_read(path_, check);
        } catch (const ConfigError &e) {
            return e.what();
        }
        return "";
    }
    TmpFile tmp_{"navkit-inifile", "t.ini"};
    const std::string &dir_ = tmp_.dir, &path_ = tmp_.path;
};

TEST_F(IniRead, KeepsSectionsInFileOrderWithTheirLines)
{
    tmp_.write("; comment\n[Beta]\nKey = Some Value ; note\n\n[alpha]\n[gamma]\nx = 1\ny=2\n");
    const IniFile f = ini_read(path_);
    ASSERT_EQ(f.sections.size(), 3u);
    EXPECT_EQ(f.sections[0].name, "beta");
    EXPECT_EQ(f.sections[0].written, "Beta");
    EXPECT_EQ(f.sections[0].line, 2);
    const IniKey &k = f.sections[0].keys.at("key");
    EXPECT_EQ(k.name, "Key");
    EXPECT_EQ(k.value, "Some Value");
    EXPECT_EQ(k.line, 3);
    EXPECT_EQ(f.sections[1].name, "alpha");
    EXPECT_EQ(f.sections[1].line, 5);
    EXPECT_TRUE(f.sections[1].keys.empty());
    EXPECT_EQ(f.find("gamma"), &f.sections[2]);
    EXPECT_EQ(f.find("delta"), nullptr);
    EXPECT_EQ(f.line("gamma", "y"), 8);
    EXPECT_EQ(f.line("gamma", "z"), 6) << "an absent key: the section's header";
    EXPECT_EQ(f.line("delta", "y"), 0);
}

TEST_F(IniRead, RefusalsNamePathLineKeyReason)
{
    const std::string p = path_ + ":";
    struct Case {
        std::string text, want;
    };
    const std::vector<Case> cases = {
        {"[a]\nx = 1\njust words\n", p + "3: line: malformed (not [section], key = value or a comment)"},
        {"[a\nx = 1\n", p + "1: line: malformed (not [section], key = value or a comment)"},
        {"x = 1\n[a]\n", p + "1: x: outside any [section]"},
        {"[a]\nX = 1\n\nx = 2\n", p + "4: x: duplicate key in [a]"},
        {"[a]\nx = 1\n[b]\n[A]\ny = 2\n", p + "4: [A]: duplicate section"},
        {"[a]\nx = " + std::string(300, 'v') + "\n", p + "2: line: longer than 198 characters"},
        // inih's multi-line continuation would append it to x, or blame x as a duplicate
        {"[a]\nx = 1\n  y = 2\n", p + "3: line: indented (keys and [sections] start at the beginning of the "
                                      "line; continuation lines are not supported)"},
        {"[a]\nx = 1\n\tx = 2\n", p + "3: line: indented (keys and [sections] start at the beginning of the "
                                      "line; continuation lines are not supported)"},
        {"[a]\nx = 1\n [b]\n", p + "3: line: indented (keys and [sections] start at the beginning of the "
                                   "line; continuation lines are not supported)"},
        // the earliest line wins, whichever part finds it
        {"[a]\nnot a key\nx = 1\nx = 2\n", p + "2: line: malformed (not [section], key = value or a comment)"},
        {"[a]\nx = 1\nx = 2\nnot a key\n", p + "3: x: duplicate key in [a]"},
    };
    for (const Case &c : cases) {
        EXPECT_EQ(error(c.text), c.want) << c.text;
    }
    EXPECT_EQ(error("[a]\nx = " + std::string(194, 'v') + "\n"), "") << "a 198-character line fits";
    EXPECT_EQ(error("[a]\nx = 1\n   ; an indented comment\n \t \r\ny = 2\n"), "")
        << "indented comments and blank lines are fine";
    EXPECT_EQ(error("[a]\nx = " + std::string(195, 'v') + "\n"), p + "2: line: longer than 198 characters");
}

TEST_F(IniRead, MissingOrUnreadableFileIsLineZero)
{
    EXPECT_THROW(ini_read(dir_ + "/nope.ini"), ConfigError);
    try {
        ini_read(dir_ + "/nope.ini");
    } catch (const ConfigError &e) {
        EXPECT_EQ(std::string(e.what()), dir_ + "/nope.ini:0: file: No such file or directory");
    }
    try {
        ini_read(dir_);
        FAIL() << "read a directory";
    } catch (const ConfigError &e) {
        EXPECT_EQ(std::string(e.what()), dir_ + ":0: file: Is a directory");
    }
}

TEST_F(IniRead, CheckSeesHeadersAndKeysInOrderAndJoinsTheFirstRefusal)
{
    std::vector<std::string> seen;
    const IniCheck log = [&seen](const IniSection &s, const IniKey *k) -> std::string {
        seen.push_back(s.name + (k ? "." + k->name + "@" + std::to_string(k->line) : "@" + std::to_string(s.line)));
        return "";
    };
    EXPECT_EQ(error("[a]\nx = 1\n[b]\ny = 2\n", log), "");
    EXPECT_EQ(seen, (std::vector<std::string>{"a@1", "a.x@2", "b@3", "b.y@4"}));

    const IniCheck no_b = [](const IniSection &s, const IniKey *k) -> std::string {
        return s.name == "b" && !k ? "[b]: unknown section" : "";
    };
    EXPECT_EQ(error("[a]\nx = 1\n[b]\nnot a key\n", no_b), path_ + ":3: [b]: unknown section");
    EXPECT_EQ(error("[a]\nnot a key\n[b]\n", no_b),
              path_ + ":2: line: malformed (not [section], key = value or a comment)");
    const IniCheck odd = [](const IniSection &, const IniKey *k) -> std::string {
        return k && k->value == "odd" ? k->name + ": odd" : "";
    };
    EXPECT_EQ(error("[a]\nx = odd\ny = odd\nx = 2\n", odd), path_ + ":2: x: odd");
}

TEST_F(IniRead, NulByteIsRefusedNotACutValue)
{
    // `frame_rate_hz = 2\0 0` would read as 2 through a C string
    EXPECT_EQ(error(std::string("[a]\nx = 2\0 0\n", 13)), path_ + ":2: line: a NUL byte at column 6 (not a text file)");
}

TEST_F(IniRead, CrOnlyLineEndsAreSaidAsSuch)
{
    EXPECT_EQ(error("[a]\rx = 1\r"), path_ + ":1: line: a carriage return not followed by a line feed at column 4 "
                                             "(CR-only line ends: save the file with LF or CR LF)");
    EXPECT_EQ(error("[a]\r\nx = 1\r\n"), "") << "CR LF is fine";
}

TEST_F(IniRead, EndlessInputIsReadBounded)
{
    // a link to /dev/zero: refused at its first byte, not read for ever
    std::remove(path_.c_str());
    ASSERT_EQ(symlink("/dev/zero", path_.c_str()), 0);
    try {
        ini_read(path_);
        ADD_FAILURE() << "read";
    } catch (const ConfigError &e) {
        EXPECT_EQ(std::string(e.what()), path_ + ":1: line: a NUL byte at column 1 (not a text file)");
    }
    std::remove(path_.c_str());
    // an endless stream of comment lines (a FIFO whose writer never stops): refused at
    // the byte bound; the writer sees the reader go (EPIPE) and ends
    ASSERT_EQ(mkfifo(path_.c_str(), 0600), 0);
    std::thread writer([this] {
        signal(SIGPIPE, SIG_IGN);
        const int fd = open(path_.c_str(), O_WRONLY);
        const std::string chunk(4096, '\n');
        while (fd >= 0 && write(fd, chunk.data(), chunk.size()) > 0) {
        }
        close(fd);
    });
    try {
        ini_read(path_);
        ADD_FAILURE() << "read";
    } catch (const ConfigError &e) {
        EXPECT_EQ(std::string(e.what()), path_ + ":1048577: file: longer than 1048576 bytes (not an INI file)");
    }
    writer.join();
}
