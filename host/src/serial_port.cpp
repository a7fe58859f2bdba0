#include "navkit/serial_port.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

namespace navkit {

SerialPort::~SerialPort()
{
    close();
}

static speed_t baud_constant(int baud)
{
    switch (baud) {
    case 9600:
        return B9600;
    case 19200:
        return B19200;
    case 38400:
        return B38400;
    case 57600:
        return B57600;
    case 115200:
        return B115200;
    case 230400:
        return B230400;
    case 460800:
        return B460800;
    case 500000:
        return B500000;
    case 921600:
        return B921600;
    case 1000000:
        return B1000000;
    case 2000000:
        return B2000000;
    case 3000000:
        return B3000000;
    default:
        return 0;
    }
}

std::string SerialPort::line_settings(const MicroCfg &cfg)
{
    return std::to_string(cfg.baud) + " baud " + std::to_string(cfg.data_bits) + cfg.parity +
           std::to_string(cfg.stop_bits);
}

std::string SerialPort::open(const MicroCfg &cfg)
{
    close();
    std::string path = cfg.port;
    if (cfg.port == "auto") {
        const std::string why = find_port(cfg.link, roots_, &path);
        if (!why.empty()) {
            return why;
        }
    }
    const speed_t speed = baud_constant(cfg.baud);
    if (!speed) {
        return "baud " + std::to_string(cfg.baud) + " is not supported";
    }
    busy_ = false;
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        busy_ = errno == EBUSY; // TIOCEXCL of another holder
        return path + ": " +
               (busy_ ? "in use by another process (it holds the port exclusively, TIOCEXCL)"
                      : std::string(std::strerror(errno)));
    }
    termios t;
    if (tcgetattr(fd, &t) != 0) {
        const int e = errno;
        ::close(fd);
        return path + ": not a serial port (" + std::strerror(e) + ")";
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        const int e = errno;
        const long pid = lock_holder(fd);
        ::close(fd);
        busy_ = e == EWOULDBLOCK;
        if (!busy_) {
            return path + ": lock: " + std::strerror(e);
        }
        return path + ": in use by " + (pid > 0 ? "process " + std::to_string(pid) : std::string("another process")) +
               " (it holds the port's lock): two programs must not drive one micro";
    }
    ioctl(fd, TIOCEXCL); // the lock is the rule; this also keeps out tools that do not ask for it
    cfmakeraw(&t);
    cfsetispeed(&t, speed);
    cfsetospeed(&t, speed);
    t.c_cflag &= static_cast<tcflag_t>(~(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS));
    const tcflag_t sizes[] = {CS5, CS6, CS7, CS8};
    t.c_cflag |= sizes[cfg.data_bits - 5] | CLOCAL | CREAD;
    if (cfg.parity != 'N') {
        t.c_cflag |= PARENB | (cfg.parity == 'O' ? PARODD : 0);
    }
    if (cfg.stop_bits == 2) {
        t.c_cflag |= CSTOPB;
    }
    t.c_cc[VMIN] = 0; // reads never wait
    t.c_cc[VTIME] = 0;
    if (tcsetattr(fd, TCSANOW, &t) != 0) {
        const int e = errno;
        ::close(fd);
        return path + ": " + std::strerror(e);
    }
    fd_ = fd;
    path_ = path;
    return "";
}

long SerialPort::lock_holder(int fd)
{
    struct stat st;
    if (fstat(fd, &st) != 0) {
        return 0;
    }
    // "1: FLOCK  ADVISORY  WRITE 12308 00:1a:3 0 EOF": pid, then major:minor (hex) and inode
    std::ifstream f("/proc/locks");
    std::string line;
    while (std::getline(f, line)) {
        long pid = 0;
        unsigned maj = 0, min = 0;
        unsigned long long ino = 0;
        char kind[16];
        if (std::sscanf(line.c_str(), "%*d: %15s %*s %*s %ld %x:%x:%llu", kind, &pid, &maj, &min, &ino) == 5 &&
            std::strcmp(kind, "FLOCK") == 0 && maj == major(st.st_dev) && min == minor(st.st_dev) &&
            ino == static_cast<unsigned long long>(st.st_ino) && pid != getpid()) {
            return pid;
        }
    }
    return 0;
}

void SerialPort::close()
{
    if (fd_ >= 0) {
        ioctl(fd_, TIOCNXCL); // the tty is free for the next opener (a pty outlives our descriptor)
        ::close(fd_);
        fd_ = -1;
    }
}

long SerialPort::read_some(uint8_t *buf, size_t cap, bool expect)
{
    if (fd_ < 0) {
        return -1;
    }
    if (expect) {
        const ssize_t n = ::read(fd_, buf, cap);
        if (n > 0) {
            return n;
        }
        // none: 0 (raw, VMIN 0), EAGAIN, or the other end gone; the poll below tells which
    }
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, 0) < 0) {
        return 0;
    }
    if (p.revents & POLLIN) {
        const ssize_t n = ::read(fd_, buf, cap);
        if (n > 0) {
            return n;
        }
        if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
            return 0;
        }
        if (n < 0 || (p.revents & POLLHUP)) {
            close(); // EIO/ENODEV: unplugged, or the other end of a pty went away
            return -1;
        }
        return 0;
    }
    if (p.revents & (POLLHUP | POLLERR | POLLNVAL)) {
        close();
        return -1;
    }
    return 0;
}

long SerialPort::write_all(const uint8_t *buf, size_t len)
{
    if (fd_ < 0) {
        return -1;
    }
    const ssize_t n = ::write(fd_, buf, len);
    if (n >= 0) {
        return n;
    }
    if (errno == EAGAIN || errno == EINTR) {
        return 0; // the output buffer is full (nobody reads): this frame's message is lost
    }
    close();
    return -1;
}

} // namespace navkit
