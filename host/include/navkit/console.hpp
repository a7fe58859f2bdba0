// Console: the seed's console window as a terminal. Print() scrolls status and warning
// lines; status() keeps one status line (redrawn in place on a terminal, printed every
// status_period_s otherwise); keys() reads the keys waiting on stdin without blocking,
// at most 64 bytes a frame (raw mode on a terminal, a pipe or file works too; EOF just
// ends key input).
// set_face() keeps the face (Animation) in a fixed block of lines just above the status
// line on a terminal; scrolling lines appear above the block.
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <termios.h>
#include <vector>

namespace navkit {

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
    void status(const std::string &line);
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
