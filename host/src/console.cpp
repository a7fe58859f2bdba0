#include "navkit/console.hpp"

#include <cerrno>
#include <cstdarg>
#include <cstring>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

namespace navkit {

Console::Console(std::FILE *out, int in_fd, double status_period_s)
    : out_(out), in_fd_(in_fd), status_period_s_(status_period_s)
{
}

Console::~Console()
{
    shutdown();
}

void Console::init()
{
    out_tty_ = isatty(fileno(out_)) == 1;
    if (isatty(in_fd_) == 1) {
        termios t;
        if (tcgetattr(in_fd_, &t) == 0) {
            saved_termios_ = t;
            t.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
            t.c_cc[VMIN] = 0;
            t.c_cc[VTIME] = 0;
            in_raw_ = tcsetattr(in_fd_, TCSANOW, &t) == 0;
        }
    }
}

void Console::shutdown()
{
    for (auto &kv : held_) {
        if (kv.second.held) {
            char text[600];
            if (kv.second.held > 1) {
                std::snprintf(text, sizeof text, "%s (the last of %u like it held back)", kv.second.last.c_str(),
                              kv.second.held);
            } else {
                std::snprintf(text, sizeof text, "%s (held back)", kv.second.last.c_str());
            }
            line(text);
            kv.second.held = 0;
        }
    }
    if (in_raw_) {
        tcsetattr(in_fd_, TCSANOW, &saved_termios_);
        in_raw_ = false;
    }
    if (status_shown_ && out_tty_) {
        std::fputs("\n", out_);
        status_shown_ = false;
    }
    std::fflush(out_);
}

void Console::stamp(TextLine *t) const
{
    if (t_us_ >= 0 && t_us_ % 1000 == 0) {
        const long long ms = t_us_ / 1000;
        const long long frac = ms % 1000;
        *t << "[";
        t->pad(ms / 1000, 5) << "." << (frac < 100 ? "0" : "") << (frac < 10 ? "0" : "") << frac << "] ";
        return;
    }
    char b[48];
    std::snprintf(b, sizeof b, "[%9.3f] ", static_cast<double>(t_us_) / 1e6);
    *t << b;
}

void Console::line(const char *text)
{
    erase_block(); // the face and status line move below the new line (next status())
    TextLine t;
    stamp(&t);
    std::fputs(t.c_str(), out_);
    std::fputs(text, out_);
    std::fputc('\n', out_);
    std::fflush(out_);
}

void Console::print(const char *fmt, ...)
{
    char text[512];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    line(text);
}

void Console::print_limited(const char *fmt, ...)
{
    char text[512];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    Held &h = held_[fmt];
    if (h.said_us >= 0 && t_us_ - h.said_us < kRepeatPeriodUs && t_us_ >= h.said_us) {
        h.held++;
        h.last = text;
        return;
    }
    if (h.held) {
        char more[600];
        std::snprintf(more, sizeof more, "%s (%u more like it in the last %.1f s held back)", text, h.held,
                      static_cast<double>(t_us_ - h.said_us) / 1e6);
        line(more);
    } else {
        line(text);
    }
    h.said_us = t_us_;
    h.held = 0;
}

void Console::status(const char *line)
{
    if (out_tty_) {
        if (face_dirty_) {
            erase_block();
        }
        // autowrap off while the block is drawn: a line wider than the terminal is cut at
        // its edge instead of taking a second row, so erase_block() knows the rows used
        std::fputs("\033[?7l", out_);
        if (status_shown_) {
            std::fprintf(out_, "\r\033[K%s", line);
        } else {
            for (const std::string &f : face_) {
                std::fprintf(out_, "%s\n", f.c_str());
            }
            face_shown_ = face_.size();
            face_dirty_ = false;
            std::fputs(line, out_);
        }
        std::fputs("\033[?7h", out_);
        status_shown_ = true;
        std::fflush(out_);
        return;
    }
    if (!status_due()) {
        return;
    }
    last_status_us_ = t_us_;
    TextLine t;
    stamp(&t);
    t << "status: ";
    std::fputs(t.c_str(), out_);
    std::fputs(line, out_);
    std::fputc('\n', out_);
    std::fflush(out_);
}

void Console::set_face(const std::vector<std::string> &lines)
{
    if (out_tty_ && lines != face_) {
        face_ = lines;
        face_dirty_ = true;
    }
}

void Console::erase_block()
{
    if (!status_shown_ || !out_tty_) {
        return;
    }
    std::fputs("\r", out_);
    if (face_shown_ > 0) {
        std::fprintf(out_, "\033[%zuA", face_shown_);
    }
    std::fputs("\033[J", out_);
    status_shown_ = false;
    face_shown_ = 0;
}

std::string Console::keys()
{
    // one read of at most kMaxKeyBytes per frame: a flood (a stuck key, `yes w |`,
    // </dev/zero) cannot hold the frame; what is left waits for the next frames
    if (in_eof_) {
        return "";
    }
    pollfd p{in_fd_, POLLIN, 0};
    if (poll(&p, 1, 0) <= 0) {
        return "";
    }
    if (p.revents & POLLNVAL) {
        in_eof_ = true; // not an open file: no keys
        return "";
    }
    if (!(p.revents & (POLLIN | POLLHUP))) {
        return "";
    }
    char buf[kMaxKeyBytes];
    const ssize_t n = ::read(in_fd_, buf, sizeof buf);
    if (n > 0) {
        return std::string(buf, static_cast<size_t>(n));
    }
    if ((n == 0 && (!in_raw_ || (p.revents & POLLHUP))) || (n < 0 && errno != EAGAIN && errno != EINTR)) {
        in_eof_ = true; // no more keys (EOF, a hung-up terminal): the executive keeps running
    }
    return "";
}

} // namespace navkit
