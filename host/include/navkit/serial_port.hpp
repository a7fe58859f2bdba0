// SerialPort: the micro link's tty. Opens the port [micro] port names (or, with "auto", the
// one port of the [micro] link's kind that port discovery finds, port_discovery.hpp), sets it raw and non-blocking with the
// line settings of [micro], and reads and writes without waiting. Pure OS plumbing: no
// framing, no console. An open port is held exclusively, as serial tools hold theirs: an
// flock(LOCK_EX) on the device (seen by every process that asks for it, root too) and
// TIOCEXCL (further open()s of the tty fail with EBUSY, except root's), both dropped by
// close().
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "navkit/ini.hpp"
#include "navkit/port_discovery.hpp"

namespace navkit {

class SerialPort {
public:
    explicit SerialPort(DeviceRoots roots = DeviceRoots()) : roots_(std::move(roots)) {}
    ~SerialPort();
    // cfg.port = "auto" (the one port of cfg.link's kind) or a path. "" on success, else why
    // not; busy() says whether the reason was another process holding the port.
    std::string open(const MicroCfg &cfg);
    void close();
    bool busy() const { return busy_; }
    // Process id holding an flock on the file of fd (st_dev, st_ino, from /proc/locks),
    // other than ours; 0 when none is listed.
    static long lock_holder(int fd);
    bool is_open() const { return fd_ >= 0; }
    int fd() const { return fd_; }
    const std::string &path() const { return path_; }
    // >0 bytes read, 0 nothing waiting, -1 the port is gone (closed by this call).
    // expect: bytes are known to be on their way (lockstep): a read at once, the poll
    // that tells a hang-up from nothing waiting only when it brought none (one call, not
    // two, when they are there); same results either way.
    long read_some(uint8_t *buf, size_t cap, bool expect = false);
    // Bytes written (all or nothing on a tty), -1 the port is gone (closed by this call).
    long write_all(const uint8_t *buf, size_t len);
    // "115200 baud 8N1": the line settings of cfg.
    static std::string line_settings(const MicroCfg &cfg);
    const DeviceRoots &roots() const { return roots_; }

private:
    DeviceRoots roots_;
    int fd_ = -1;
    bool busy_ = false; // the last open() failed because another process holds the port
    std::string path_;
};

} // namespace navkit
