// Console: the seed's console window as a terminal. Print() scrolls status and warning
// lines; status() keeps one status line (redrawn in place on a terminal, printed every
// status_period_s otherwise); keys() reads the keys waiting on stdin without blocking,
// at most 64 bytes a frame (raw mode on a terminal, a pipe or file works too; EOF just
// ends key input).
// set_face() keeps the face (Animation) in a fixed block of lines just above the status
// line on a terminal; scrolling lines appear above the block.
#pragma once

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <termios.h>
#include <type_traits>
#include <vector>

namespace navkit {

// A line of text and integers built in a fixed buffer, cut at its capacity as snprintf
// cuts: the frame's frequent lines (the status line, the time stamps) without printf's
// parsing of a format and its per-field cost. Integers come out as %d / %u / %llu write
// them.
class TextLine {
public:
    TextLine &operator<<(const char *s) { return append(s, std::strlen(s)); }
    template <class T, class = std::enable_if_t<std::is_integral_v<T>>> TextLine &operator<<(T v)
    {
        char d[24];
        const std::to_chars_result r = std::to_chars(d, d + sizeof d, v);
        return append(d, static_cast<size_t>(r.ptr - d));
    }
    // v right-aligned in `width` characters (padded with spaces), as %*lld does
    TextLine &pad(long long v, size_t width)
    {
        char d[24];
        const std::to_chars_result r = std::to_chars(d, d + sizeof d, v);
        const size_t n = static_cast<size_t>(r.ptr - d);
        for (size_t i = n; i < width; i++) {
            append(" ", 1);
        }
        return append(d, n);
    }
    const char *c_str() const { return buf_; }
    size_t size() const { return len_; }

private:
    size_t room() const { return sizeof buf_ - 1 - len_; }
    // The n chars at s, as many as there is room for; the line stays 0-terminated.
    TextLine &append(const char *s, size_t n)
    {
        const size_t k = n < room() ? n : room();
        std::memcpy(buf_ + len_, s, k);
        len_ += k;
        buf_[len_] = '\0';
        return *this;
    }
    char buf_[320] = {};
    size_t len_ = 0;
};

class Console {
public:
    Console(std::FILE *out, int in_fd, double status_period_s);
    ~Console();
    void init();
    void shutdown();
    // A scrolling line, stamped with the frame time (s).
    void print(const char *fmt, ...) __attribute__((format(printf, 2, 3)));
    // print(), at most once per kRepeatPeriodUs of frame time for each format string (a
    // message that can come every frame: a planner writing bad commands, ...). The lines
    // held back are counted and said with the next one of that format; shutdown() says
    // the last held back of each.
    void print_limited(const char *fmt, ...) __attribute__((format(printf, 2, 3)));
    static constexpr int64_t kRepeatPeriodUs = 1000000;
    void set_time_us(int64_t t_us) { t_us_ = t_us; }
    void status(const char *line);
    // True when status() would show a line now (a terminal: always; else when the last
    // status line is status_period_s old, or none was shown yet): a caller formats its
    // status line only then.
    bool status_due() const
    {
        return out_tty_ || last_status_us_ < 0 ||
               static_cast<double>(t_us_ - last_status_us_) >= status_period_s_ * 1e6;
    }
    // The face's lines: on a terminal drawn above the status line from the next status()
    // on (only redrawn when they change); an empty list removes the face. Nothing when
    // stdout is not a terminal.
    void set_face(const std::vector<std::string> &lines);
    bool out_tty() const { return out_tty_; } // stdout is a terminal (known after init())
    // Keys typed since the last call (bytes), at most kMaxKeyBytes of them (the rest
    // comes with the next calls); never blocks.
    std::string keys();
    static constexpr size_t kMaxKeyBytes = 64;

private:
    void erase_block();          // terminal: cursor to the face block's first line, clear below
    void line(const char *text); // one scrolling line, stamped
    // Appends "[%9.3f] " of the frame time (s): a time of whole ms (every lockstep frame)
    // in integers, any other through printf (whose rounding of the last digit it keeps).
    void stamp(TextLine *t) const;

    struct Held {
        int64_t said_us = -1; // frame time its last line was printed, us
        unsigned held = 0;    // lines held back since
        std::string last;     // the last one held back
    };
    std::map<const char *, Held> held_; // print_limited's formats (literals: one address each)

    std::FILE *out_;
    int in_fd_;
    bool in_eof_ = false;
    bool out_tty_ = false;
    bool in_raw_ = false;
    bool status_shown_ = false;
    double status_period_s_;
    int64_t t_us_ = 0;
    int64_t last_status_us_ = -1;
    std::vector<std::string> face_; // lines of the face block
    size_t face_shown_ = 0;         // face lines on screen above the status line
    bool face_dirty_ = false;       // face_ differs from what is on screen
    termios saved_termios_{};       // stdin before raw mode (valid while in_raw_)
};

} // namespace navkit
