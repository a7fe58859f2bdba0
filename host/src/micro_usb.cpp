#include "navkit/micro_usb.hpp"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <dirent.h>
#include <fcntl.h>
#include <fstream>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>
#include <stdexcept>
#include <vector>

#include "navkit/console.hpp"

namespace navkit {

// Rounds of config messages (and at least 1 s) without our config in force before the
// console says so; said again every 5 s (frame time) while it lasts.
static const uint64_t kConfigWarnRounds = 5;

// ------------------------------------------------------------------ SerialPort

SerialPort::~SerialPort()
{
    close();
}

static speed_t baud_constant(int baud)
{
    switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    default: return 0;
    }
}

static std::string read_line(const std::string &path)
{
    std::ifstream f(path);
    std::string s;
    std::getline(f, s);
    return s;
}

static std::string real_path(const std::string &p)
{
    char buf[PATH_MAX];
    return realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

static std::string base_name(const std::string &p)
{
    const size_t s = p.rfind('/');
    return s == std::string::npos ? p : p.substr(s + 1);
}

static std::vector<std::string> list_dir(const std::string &dir)
{
    std::vector<std::string> out;
    DIR *d = opendir(dir.c_str());
    if (!d) {
        return out;
    }
    while (dirent *e = readdir(d)) {
        if (e->d_name[0] != '.') {
            out.push_back(e->d_name);
        }
    }
    closedir(d);
    std::sort(out.begin(), out.end());
    return out;
}

// USB vendor of a tty (ttyUSB0): the interface's parent device holds idVendor.
static bool is_ftdi(const std::string &tty, const DeviceRoots &roots)
{
    for (const char *rel : {"/device/../idVendor", "/device/../../idVendor"}) {
        if (read_line(roots.sys + "/class/tty/" + tty + rel).rfind("0403", 0) == 0) {
            return true;
        }
    }
    return false;
}

std::string SerialPort::find_ftdi(const DeviceRoots &roots)
{
    const std::string by_id = roots.dev + "/serial/by-id";
    for (const std::string &e : list_dir(by_id)) {
        const std::string p = by_id + "/" + e;
        if (is_ftdi(base_name(real_path(p)), roots)) {
            return p;
        }
    }
    for (const std::string &e : list_dir(roots.sys + "/class/tty")) {
        if (e.rfind("ttyUSB", 0) == 0 && is_ftdi(e, roots)) {
            return roots.dev + "/" + e;
        }
    }
    return "";
}

std::string SerialPort::latency_timer_path(const std::string &dev, const DeviceRoots &roots)
{
    const std::string p = roots.sys + "/bus/usb-serial/devices/" + base_name(real_path(dev)) + "/latency_timer";
    return access(p.c_str(), F_OK) == 0 ? p : std::string();
}

std::string SerialPort::line_settings(const MicroCfg &cfg)
{
    return std::to_string(cfg.baud) + " baud " + std::to_string(cfg.data_bits) + cfg.parity +
           std::to_string(cfg.stop_bits);
}

std::string SerialPort::open(const MicroCfg &cfg)
{
    close();
    const std::string path = cfg.port == "auto" ? find_ftdi(roots_) : cfg.port;
    if (path.empty()) {
        return "no FTDI (USB VID 0403) serial port found";
    }
    const speed_t speed = baud_constant(cfg.baud);
    if (!speed) {
        return "baud " + std::to_string(cfg.baud) + " is not supported";
    }
    busy_ = false;
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        busy_ = errno == EBUSY;  // TIOCEXCL of another holder
        return path + ": " + (busy_ ? "in use by another process (it holds the port exclusively, TIOCEXCL)"
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
    ioctl(fd, TIOCEXCL);  // the lock is the rule; this also keeps out tools that do not ask for it
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
    t.c_cc[VMIN] = 0;  // reads never wait
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
        ioctl(fd_, TIOCNXCL);  // the tty is free for the next opener (a pty outlives our descriptor)
        ::close(fd_);
        fd_ = -1;
    }
}

long SerialPort::read_some(uint8_t *buf, size_t cap)
{
    if (fd_ < 0) {
        return -1;
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
            close();  // EIO/ENODEV: unplugged, or the other end of a pty went away
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
        return 0;  // the output buffer is full (nobody reads): this frame's message is lost
    }
    close();
    return -1;
}

// ------------------------------------------------------------------ MicroUsb

MicroUsb::MicroUsb(const MicroCfg &cfg, Console &console, DeviceRoots roots)
    : cfg_(cfg), con_(console), port_(std::move(roots))
{
    navkit_parser_init(&parser_, NAVKIT_DIR_TO_HOST);
}

navkit_micro_cmd_t MicroUsb::stop_command(uint16_t dio)
{
    navkit_micro_cmd_t m;
    navkit_micro_cmd_defaults(&m);
    m.fwd_cmd = NAVKIT_FWD_CMD_STOP;
    m.turn_cmd = NAVKIT_TURN_CMD_STOP;
    m.dio_command = dio;
    return m;
}

void MicroUsb::init()
{
    last_ = stop_command(0);  // the seed's Navigation Init: the current command is Stop
    last_.time_tag = 1;
    open_port(true);
}

void MicroUsb::shutdown()
{
    port_.close();
}

void MicroUsb::reset_parser()
{
    base_ = counters();  // decode failures are kept in base_ already
    navkit_parser_init(&parser_, NAVKIT_DIR_TO_HOST);
    seen_schema_mismatch_ = 0;
    slcan_ = Slcan();  // link = slcan: the old connection's lines and messages are gone
    navkit_isotp_rx_init(&can_rx_, NAVKIT_DIR_TO_HOST);
    navkit_isotp_tx_init(&can_tx_);
}

void MicroUsb::open_port(bool starting)
{
    const std::string err = port_.open(cfg_);
    if (starting && port_.busy()) {
        // another executive (or tool) drives this micro: starting beside it is refused
        throw std::runtime_error("micro port " + err + ": not starting");
    }
    if (!err.empty()) {
        if (err != last_open_error_) {
            con_.print("micro port: %s (trying again every frame)", err.c_str());
            last_open_error_ = err;
        }
        return;
    }
    last_open_error_.clear();
    reset_parser();  // bytes of the old connection are gone
    // whatever the micro on the other end reports, it may hold another config (a host
    // restarted without a micro reset, another micro plugged in): download ours whole
    config_again();
    rejected_seen_ = 0;  // its refusals so far are news (ours may be among them)
    if (slcan()) {
        adapter_pending_ = true;  // its set-up goes out at the start of the next frame (begin_frame)
        con_.print("micro port %s open (%s, raw; SLCAN adapter, CAN at %d bit/s, ISO-TP)", port_.path().c_str(),
                   SerialPort::line_settings(cfg_).c_str(), cfg_.can_bitrate);
    } else {
        con_.print("micro port %s open (%s, raw)", port_.path().c_str(), SerialPort::line_settings(cfg_).c_str());
    }
    const std::string lt = SerialPort::latency_timer_path(port_.path(), port_.roots());
    if (!lt.empty() && cfg_.latency_timer_ms > 0) {
        std::ofstream f(lt);
        f << cfg_.latency_timer_ms << "\n";
        f.close();
        const std::string now = read_line(lt);
        if (now != std::to_string(cfg_.latency_timer_ms)) {
            con_.print("micro port: FTDI latency timer is %s ms, could not set %d ms (%s): "
                       "request/response is capped near 60 Hz",
                       now.c_str(), cfg_.latency_timer_ms, lt.c_str());
        }
    }
}

void MicroUsb::config_again()
{
    taken_ = false;
    round_done_ = false;
    round_next_ = 0;
}

void MicroUsb::port_lost(const char *why)
{
    con_.print("micro port %s lost (%s): reopening when it returns", port_.path().c_str(), why);
    port_.close();
    reset_parser();
    last_open_error_.clear();
}

void MicroUsb::begin_frame(int64_t now_us)
{
    now_us_ = now_us;
    tx_frame_ = 0;
    if (!port_.is_open()) {
        open_port();
    }
    if (adapter_pending_ && port_.is_open()) {
        // the SLCAN adapter: channel closed (as another program may have left it), bit rate,
        // open; written in a frame, so lockstep counts its bytes as the frame's
        adapter_pending_ = false;
        can_write(Slcan::open_commands(cfg_.can_bitrate));
    }
}

static int64_t mono_ms()
{
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1000 + ts.tv_nsec / 1000000;
}

bool MicroUsb::receive(long want_bytes, navkit_micro_data_t *out)
{
    uint8_t buf[4096];
    long total = 0;
    unsigned got = 0;
    bool foreign_last = false;  // the newest whole micro_data carried another spec's hash
    uint32_t foreign_hash = 0;
    const int64_t deadline_ms = mono_ms() + 1000;  // lockstep: wait at most 1 s for rx_bytes
    // real time: read until nothing waits, bounded so a streaming micro cannot hold the frame
    for (int reads = 0; port_.is_open() && reads < 256; reads++) {
        const long n = port_.read_some(buf, sizeof buf);
        if (n < 0) {
            port_lost("read failed or hung up");
            break;
        }
        // bytes of frames (the line's, or one reassembled ISO-TP message's) through the parser
        auto take = [&](const uint8_t *d, size_t len) {
            while (len) {
                const size_t k = navkit_parser_feed(&parser_, d, len);
                d += k;
                len -= k;
                const uint8_t *f;
                size_t fl;
                while (navkit_parser_next(&parser_, &f, &fl)) {
                    // the parser only returns micro_data (DIR_TO_HOST); the newest one wins.
                    // One that does not decode, or has a field outside the spec's range, is
                    // dropped and counted (decode_failures). One of another spec's hash (our
                    // length, so it decodes) is used for nothing but saying so: its words
                    // may mean other things.
                    navkit_micro_data_t m;
                    int bad = -1;
                    const bool decoded = navkit_micro_data_decode(f, fl, &m) == NAVKIT_OK;
                    if (decoded && m.spec_hash != NAVKIT_SPEC_HASH) {
                        foreign_last = true;
                        foreign_hash = m.spec_hash;
                    } else if (decoded && navkit_micro_data_check(&m, &bad) == NAVKIT_OK) {
                        *out = m;
                        got++;
                        foreign_last = false;
                    } else {
                        base_.decode_failures++;
                        last_bad_field_ = bad;
                    }
                }
            }
        };
        if (slcan()) {
            can_take(buf, static_cast<size_t>(n), take);
        } else {
            take(buf, static_cast<size_t>(n));
        }
        total += n;
        if (want_bytes < 0) {
            if (n == 0) {
                break;
            }
            continue;
        }
        if (total >= want_bytes) {
            break;
        }
        if (n == 0) {
            const int64_t left = deadline_ms - mono_ms();
            if (left <= 0) {
                short_reads_++;
                con_.print("lockstep: %ld of %ld serial bytes arrived within 1 s", total, want_bytes);
                break;
            }
            pollfd p{port_.fd(), POLLIN, 0};
            poll(&p, 1, static_cast<int>(left));
        }
    }
    if (got > 1) {
        superseded_ += got - 1;
    }
    if (parser_.stats.schema_mismatch != seen_schema_mismatch_) {
        // a whole micro_data of another spec's length: its frozen words 4-5 name its spec
        seen_schema_mismatch_ = parser_.stats.schema_mismatch;
        if (!got) {
            note_foreign_hash(parser_.foreign_hash);
        }
    }
    const LinkCounters c = counters();
    if ((c.rejected() != reported_.rejected() || c.dropped_bytes != reported_.dropped_bytes) &&
        (last_error_report_us_ < 0 || now_us_ - last_error_report_us_ >= 1000000)) {
        // at most one line per second of frame time, naming the stream offset of the last
        // reject; bytes dropped while no frame was found to reject are said as such
        std::string why;
        if (parser_.last_error != NAVKIT_OK) {
            why = std::string("last reject: ") + navkit_error_text(parser_.last_error) + " at stream byte offset " +
                  std::to_string(parser_.last_error_offset);
        } else if (c.dropped_bytes) {
            why = "no frame rejected: the dropped bytes held no frame start";
        }
        if (c.decode_failures) {
            why += std::string(why.empty() ? "" : "; ") + "last decode failure: " +
                   (last_bad_field_ >= 0 ? navkit_micro_data_field_name(last_bad_field_) : "not a micro_data");
        }
        if (c.can_errors) {
            const navkit_isotp_rx_stats_t &r = can_rx_.stats;
            why += std::string(why.empty() ? "" : "; ") + "CAN " + std::to_string(c.can_errors) +
                   " (since the port opened: ISO-TP refused " + std::to_string(r.bad_frame) + " frames, aborted " +
                   std::to_string(r.wrong_sn) + " out of sequence, " + std::to_string(r.restarted) + " restarted, " +
                   std::to_string(r.timeout) + " timed out, " + std::to_string(r.overflow) + " too long; " +
                   std::to_string(slcan_.bad_lines()) + " adapter lines no frame)";
        }
        con_.print("micro link: bad CRC %llu, unknown type %llu, bad length %llu, other spec %llu, "
                   "decode failures %llu, dropped bytes %llu so far (%s)",
                   static_cast<unsigned long long>(c.bad_crc), static_cast<unsigned long long>(c.unknown_type),
                   static_cast<unsigned long long>(c.bad_length), static_cast<unsigned long long>(c.schema_mismatch),
                   static_cast<unsigned long long>(c.decode_failures),
                   static_cast<unsigned long long>(c.dropped_bytes), why.c_str());
        reported_ = c;
        last_error_report_us_ = now_us_;
    }
    if (got) {
        last_rx_us_ = now_us_;
        note_data(*out);
    }
    if (foreign_last) {
        note_foreign_hash(foreign_hash);  // after any of ours: the newest frame says what the micro is now
    }
    return got > 0;
}

void MicroUsb::note_data(const navkit_micro_data_t &d)
{
    have_data_ = true;
    status_ = d.status;
    if (mismatch_) {
        con_.print("micro spec hash matches the host's 0x%08X now (was 0x%08X): configuring it",
                   static_cast<unsigned>(NAVKIT_SPEC_HASH), static_cast<unsigned>(mismatch_hash_));
        mismatch_ = false;
        last_probe_us_ = -1;
        // as after a reset: the last command is not run again by a new micro
        queue_command(stop_command(last_.dio_command), true);
    }
    note_rejects(d);
    const bool conf = (d.status & NAVKIT_MICRO_STATUS_CONFIGURED) != 0;
    if (!conf && configured_) {
        // a reset micro has forgotten the time tags: repeating the last command would run
        // it again, so it is replaced by a stop (the seed's Navigation Init command)
        con_.print("micro reset (reports unconfigured): downloading the config again");
        queue_command(stop_command(last_.dio_command), true);
        config_again();
    }
    configured_ = conf;
    if (!conf) {
        taken_ = false;  // (a round in progress goes on)
    } else if (round_done_ && !taken_) {
        // configured, and this micro_data came after our three config messages went out
        con_.print("micro configured (firmware %u.%u)", d.fw_version >> 8, d.fw_version & 0xFFu);
        taken_ = true;
        round_next_ = 0;  // a second round, begun while waiting for this, is not finished
        rounds_waiting_ = 0;
        refused_type_ = 0;
        last_rounds_warn_us_ = -1;
    }
}

static const char *config_name(uint16_t msg_type)
{
    switch (msg_type) {
    case NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY: return "micro_cfg_geometry";
    case NAVKIT_MSG_TYPE_MICRO_CFG_MOTION: return "micro_cfg_motion";
    case NAVKIT_MSG_TYPE_MICRO_CFG_IO: return "micro_cfg_io";
    default: return nullptr;
    }
}

void MicroUsb::note_rejects(const navkit_micro_data_t &d)
{
    if (d.cmd_rejected == rejected_seen_) {
        return;
    }
    rejected_seen_ = d.cmd_rejected;
    // a refused config: last_reject = reject.range | its msg_type (the spec's flags reject)
    const uint16_t type = static_cast<uint16_t>(d.last_reject & ~NAVKIT_REJECT_RANGE);
    const char *name = config_name(type);
    if (!(d.last_reject & NAVKIT_REJECT_RANGE) || !name) {
        return;  // a refused micro_cmd: Navigation's business, not the config's
    }
    // said at once for a message it did not refuse last, else at most every 5 s
    if (type != refused_type_ || last_refusal_report_us_ < 0 || now_us_ - last_refusal_report_us_ >= 5000000) {
        con_.print("micro refused %s (last_reject 0x%04X: a field outside what it accepts, "
                   "firmware/core/config.c): check [%s] in NavAndControl.ini; sending the config again",
                   name, static_cast<unsigned>(d.last_reject), name);
        last_refusal_report_us_ = now_us_;
    }
    refused_type_ = type;
    // an already configured micro keeps saying configured: ours is not in force
    config_again();
}

void MicroUsb::warn_config_rounds()
{
    if (rounds_waiting_ == 1) {
        waiting_since_us_ = now_us_;
    }
    if (rounds_waiting_ < kConfigWarnRounds || now_us_ - waiting_since_us_ < 1000000 ||
        (last_rounds_warn_us_ >= 0 && now_us_ - last_rounds_warn_us_ < 5000000)) {
        return;
    }
    last_rounds_warn_us_ = now_us_;
    char why[96];
    if (!online(now_us_)) {
        std::snprintf(why, sizeof why, "no micro_data from it for 1 s");
    } else if (refused_type_) {
        std::snprintf(why, sizeof why, "it refuses %s", config_name(refused_type_));
    } else {
        std::snprintf(why, sizeof why, "it reports status 0x%04X", static_cast<unsigned>(status_));
    }
    con_.print("micro not configured after %llu rounds of config messages (%s): not driving it",
               static_cast<unsigned long long>(rounds_waiting_), why);
}

bool MicroUsb::online(int64_t now_us) const
{
    return port_.is_open() && last_rx_us_ >= 0 && now_us - last_rx_us_ <= 1000000;
}

void MicroUsb::queue_command(const navkit_micro_cmd_t &cmd, bool is_new)
{
    if (!is_new) {
        return;  // the last command is repeated with its time tag
    }
    const uint16_t tag = static_cast<uint16_t>(last_.time_tag + 1u);
    last_ = cmd;
    last_.time_tag = tag;
}

template <class Take> void MicroUsb::can_take(const uint8_t *buf, size_t len, Take take_frame_bytes)
{
    std::vector<SlcanFrame> frames;
    slcan_.feed(buf, len, &frames);
    for (const SlcanFrame &sf : frames) {
        const uint16_t id = static_cast<uint16_t>((sf.id & NAVKIT_ISOTP_ID_MASK) | (sf.extended ? NAVKIT_ISOTP_EXT : 0u) |
                                                  (sf.remote ? NAVKIT_ISOTP_RTR : 0u));
        navkit_isotp_frame_t fc;
        uint8_t fc_out = 0;
        navkit_isotp_tx_frame(&can_tx_, id, sf.data, sf.dlc, can_ms());
        const uint16_t n = navkit_isotp_rx_frame(&can_rx_, id, sf.data, sf.dlc, can_ms(), &fc, &fc_out);
        if (fc_out && port_.is_open()) {
            can_write(Slcan::frame_command(fc.id, fc.data));
        }
        if (n) {
            take_frame_bytes(can_rx_.buf, n);
            // an ISO-TP message is one frame: what the parser still holds (a message that was
            // no whole frame) belongs to no later message (as the firmware's CAN link does)
            parser_.stats.dropped_bytes += parser_.have;
            parser_.offset += parser_.have;
            parser_.have = 0;
            parser_.want = 0;
        }
    }
    navkit_isotp_rx_poll(&can_rx_, can_ms());
    can_pump();  // the consecutive frames a flow control just let go
}

void MicroUsb::can_write(const std::string &line)
{
    const long n = port_.write_all(reinterpret_cast<const uint8_t *>(line.data()), line.size());
    if (n < 0) {
        port_lost("write failed");
        return;
    }
    if (static_cast<size_t>(n) != line.size()) {
        tx_errors_++;
    }
    tx_frame_ += static_cast<uint32_t>(n);
}

void MicroUsb::can_pump()
{
    navkit_isotp_frame_t f;
    while (port_.is_open() && navkit_isotp_tx_next(&can_tx_, can_ms(), &f)) {
        can_write(Slcan::frame_command(f.id, f.data));
    }
}

void MicroUsb::can_send(const uint8_t *buf, size_t len)
{
    if (navkit_isotp_tx_busy(&can_tx_) || len > sizeof can_tx_.buf) {
        tx_errors_++;  // the last message still waits for its flow control: this one is skipped
        return;
    }
    std::memcpy(can_tx_.buf, buf, len);
    navkit_isotp_tx_start(&can_tx_, static_cast<uint16_t>(len), navkit_frame_type(buf), can_ms());
    can_pump();
    stop_last_ = false;
}

void MicroUsb::write_frame(const uint8_t *buf, size_t len)
{
    if (slcan()) {
        can_send(buf, len);
        return;
    }
    const long n = port_.write_all(buf, len);
    if (n < 0) {
        port_lost("write failed");
        return;
    }
    if (static_cast<size_t>(n) != len) {
        tx_errors_++;
    }
    tx_frame_ += static_cast<uint32_t>(n);
    stop_last_ = false;
}

void MicroUsb::send()
{
    if (!port_.is_open()) {
        return;
    }
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    size_t n = 0;
    if (mismatch_) {
        // never a command; the probe is the geometry config, which carries our spec hash
        if (last_probe_us_ >= 0 && now_us_ - last_probe_us_ < 1000000) {
            return;
        }
        last_probe_us_ = now_us_;
        navkit_micro_cfg_geometry_t m = cfg_.geometry;
        m.time_tag = ++cfg_tag_;
        write_frame(buf, navkit_micro_cfg_geometry_encode(&m, buf, sizeof buf));
        return;
    }
    if (needs_config()) {
        // the three config messages in order, one per frame, whatever the micro's cfg_*_ok
        // bits say (they may be another host's config), round after round until a
        // micro_data after a whole round says configured
        const int pick = round_next_;
        round_next_ = (round_next_ + 1) % 3;
        const uint16_t tag = ++cfg_tag_;
        if (pick == 0) {
            rounds_waiting_++;
            warn_config_rounds();
            navkit_micro_cfg_geometry_t m = cfg_.geometry;
            m.time_tag = tag;
            n = navkit_micro_cfg_geometry_encode(&m, buf, sizeof buf);
            config_sent_++;
        } else if (pick == 1) {
            navkit_micro_cfg_motion_t m = cfg_.motion;
            m.time_tag = tag;
            n = navkit_micro_cfg_motion_encode(&m, buf, sizeof buf);
        } else {
            navkit_micro_cfg_io_t m = cfg_.io;
            m.time_tag = tag;
            n = navkit_micro_cfg_io_encode(&m, buf, sizeof buf);
            round_done_ = true;
        }
    } else {
        n = navkit_micro_cmd_encode(&last_, buf, sizeof buf);
        const uint64_t errs = tx_errors_;
        write_frame(buf, n);
        stop_last_ = port_.is_open() && tx_errors_ == errs && last_.fwd_cmd == NAVKIT_FWD_CMD_STOP &&
                     last_.turn_cmd == NAVKIT_TURN_CMD_STOP;
        return;
    }
    write_frame(buf, n);
}

void MicroUsb::can_flush()
{
    // ISO-TP's own clock ends the wait: no flow control within N_Bs abandons the message
    // (can_pump); the bound below only guards against a clock that does not move
    const int64_t start_ms = mono_ms();
    const int64_t start_us = now_us_;
    while (port_.is_open() && navkit_isotp_tx_busy(&can_tx_) &&
           mono_ms() < start_ms + 2 * static_cast<int64_t>(NAVKIT_CAN_N_BS_MS)) {
        pollfd p{port_.fd(), POLLIN, 0};
        poll(&p, 1, 10);
        uint8_t in[256];
        const long n = port_.read_some(in, sizeof in);
        if (n < 0) {
            port_lost("read failed or hung up");
            break;
        }
        now_us_ = start_us + 1000 * (mono_ms() - start_ms);  // ISO-TP's clock moves on meanwhile
        can_take(in, static_cast<size_t>(n), [](const uint8_t *, size_t) {});  // micro_data: not wanted now
        can_pump();  // also notices an overdue flow control
    }
}

bool MicroUsb::send_stop(uint16_t dio)
{
    if (!port_.is_open() || mismatch_ || !configured_) {
        return false;
    }
    queue_command(stop_command(dio), true);
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    const uint64_t errs = tx_errors_;
    if (slcan()) {
        // outside the frame loop (shutdown): the message still going out first, then the
        // stop, each given ISO-TP's N_Bs for its flow control, so the stop goes out whole
        can_flush();
        const uint16_t sent = can_tx_.stats.sent;
        write_frame(buf, navkit_micro_cmd_encode(&last_, buf, sizeof buf));
        can_flush();
        stop_last_ = port_.is_open() && can_tx_.stats.sent != sent;
        return stop_last_;
    }
    write_frame(buf, navkit_micro_cmd_encode(&last_, buf, sizeof buf));
    stop_last_ = port_.is_open() && tx_errors_ == errs;
    return stop_last_;
}

void MicroUsb::note_foreign_hash(uint32_t hash)
{
    // said at once, then once a second of frame time while it lasts
    if (!mismatch_ || hash != mismatch_hash_ || now_us_ - last_mismatch_report_us_ >= 1000000) {
        con_.print("micro spec hash 0x%08X differs from the host's 0x%08X: not driving it "
                   "(no command; a config probe once a second)",
                   static_cast<unsigned>(hash), static_cast<unsigned>(NAVKIT_SPEC_HASH));
        last_mismatch_report_us_ = now_us_;
    }
    mismatch_ = true;
    mismatch_hash_ = hash;
    configured_ = false;  // whatever it said: our config was never taken
    config_again();
}

LinkCounters MicroUsb::counters() const
{
    const navkit_link_stats_t &s = parser_.stats;
    LinkCounters c = base_;
    c.bad_crc += s.bad_crc;
    c.unknown_type += s.unknown_type;
    c.bad_length += s.bad_length;
    c.schema_mismatch += s.schema_mismatch;
    c.dropped_bytes += s.dropped_bytes;
    const navkit_isotp_rx_stats_t &r = can_rx_.stats;
    c.can_errors += static_cast<uint64_t>(r.bad_frame) + r.wrong_sn + r.restarted + r.timeout + r.overflow +
                    slcan_.bad_lines();
    return c;
}

uint32_t MicroUsb::link_errors() const
{
    return static_cast<uint32_t>(counters().rejected());
}

}  // namespace navkit
