// Console: the seed's console window as a terminal. Print() scrolls status and warning
// lines; status() keeps one status line (redrawn in place on a terminal, printed every
// status_period_s otherwise); keys() reads the keys waiting on stdin without blocking
// (raw mode on a terminal, a pipe or file works too; EOF just ends key input).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace navkit {

class Console {
public:
    Console(std::FILE *out, int in_fd, double status_period_s);
    ~Console();
    void init();
    void shutdown();
    // A scrolling line, stamped with the frame time (s).
    void print(const char *fmt, ...) __attribute__((format(printf, 2, 3)));
    void set_time_us(int64_t t_us) { t_us_ = t_us; }
    void status(const std::string &line);
    // Keys typed since the last call (bytes), never blocks.
    std::string keys();

private:
    std::FILE *out_;
    int in_fd_;
    bool in_eof_ = false;
    bool out_tty_ = false;
    bool in_raw_ = false;
    bool status_shown_ = false;
    double status_period_s_;
    int64_t t_us_ = 0;
    int64_t last_status_us_ = -1;
    unsigned char saved_termios_[64];  // struct termios of stdin before raw mode
};

}  // namespace navkit
