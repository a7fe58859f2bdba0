// MicroUsb: the seed's MicroUSB class. Finds the FTDI serial port (or uses a given
// path), sets it raw and non-blocking, receives micro_data (only the newest whole frame
// of those waiting is used), and sends exactly one message per frame: the config (all
// three messages, one per frame) at start-up, after every port reopen and whenever the
// micro reports unconfigured, until a micro_data after a whole round says configured;
// else the command (new, or the last one repeated with its time tag). A micro built from another spec is refused: it never gets a command,
// only a config probe once a second (which carries our spec hash, so such a micro
// refuses it, while a micro reflashed with our spec takes it and answers). A vanished
// port is reported and reopened when its path returns.
#pragma once

#include <cstdint>
#include <string>

#include "navkit/ini.hpp"
#include "navkit/slcan.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

class Console;

// Where SerialPort looks for devices: the roots of /dev and /sys (a test points them at
// a fake tree in a temporary folder).
struct DeviceRoots {
    std::string dev = "/dev";
    std::string sys = "/sys";
};

// The port: discovery, termios, non-blocking read/write. Pure OS plumbing. An open port
// is held exclusively, as serial tools hold theirs: an flock(LOCK_EX) on the device
// (seen by every process that asks for it, root too) and TIOCEXCL (further open()s of
// the tty fail with EBUSY, except root's), both dropped by close().
class SerialPort {
public:
    explicit SerialPort(DeviceRoots roots = DeviceRoots()) : roots_(std::move(roots)) {}
    ~SerialPort();
    // port = "auto" or a path. "" on success, else why not; busy() says whether the
    // reason was another process holding the port.
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
    long read_some(uint8_t *buf, size_t cap);
    // Bytes written (all or nothing on a tty), -1 the port is gone (closed by this call).
    long write_all(const uint8_t *buf, size_t len);
    // First FTDI (USB VID 0403) tty: <dev>/serial/by-id, then <sys>/class/tty; "" if none.
    static std::string find_ftdi(const DeviceRoots &roots);
    // <sys>/bus/usb-serial/devices/<tty>/latency_timer of tty path `dev`; "" if the
    // device has none (not FTDI).
    static std::string latency_timer_path(const std::string &dev, const DeviceRoots &roots);
    // "115200 baud 8N1": the line settings of cfg.
    static std::string line_settings(const MicroCfg &cfg);
    const DeviceRoots &roots() const { return roots_; }

private:
    DeviceRoots roots_;
    int fd_ = -1;
    bool busy_ = false;  // the last open() failed because another process holds the port
    std::string path_;
};

// The micro link's error counters, kept apart (summed over port reopens).
struct LinkCounters {
    uint64_t bad_crc = 0;          // candidate frames with a wrong CRC
    uint64_t unknown_type = 0;     // candidates of an unknown (or host-to-micro) type
    uint64_t bad_length = 0;       // candidates whose length word is not their type's
    uint64_t decode_failures = 0;  // whole micro_data frames that did not decode or had a
                                   // field outside the spec's range (dropped)
    uint64_t schema_mismatch = 0;  // CRC-good micro_data of another spec's length
    uint64_t dropped_bytes = 0;    // bytes not part of a returned frame
    uint64_t can_errors = 0;       // link = slcan: CAN frames ISO-TP refused, ISO-TP messages
                                   // aborted (lost, reordered, restarted, timed out, overflowed),
                                   // adapter lines that were no frame
    // Frames rejected for any reason (lisp_data.link_errors): the six frame counters.
    uint64_t rejected() const
    {
        return bad_crc + unknown_type + bad_length + decode_failures + schema_mismatch + can_errors;
    }
};

class MicroUsb {
public:
    MicroUsb(const MicroCfg &cfg, Console &console, DeviceRoots roots = DeviceRoots());
    void init();
    void shutdown();

    // Reads the port. want_bytes < 0 (real time): whatever is waiting; >= 0 (lockstep):
    // polls until that many bytes have been read (1 s limit, then counts an error).
    // True when at least one whole micro_data arrived; *out = the newest.
    bool receive(long want_bytes, navkit_micro_data_t *out);

    // The micro's state, from the data received.
    bool online(int64_t now_us) const;
    // Our config is in force: all three config messages went out since start-up (or the
    // last port reopen, micro reset or refusal) and a micro_data since says configured.
    bool configured() const { return taken_; }
    bool spec_mismatch() const { return mismatch_; }
    bool needs_config() const { return !taken_ || mismatch_; }

    // The command of this frame: new (a new time tag) or not (repeat the last one).
    void queue_command(const navkit_micro_cmd_t &cmd, bool is_new);
    // Send the one message of this frame: config while unconfigured, else the command;
    // to a micro of another spec nothing but a config probe once a second.
    void send();
    // Send a stop (fwd 5, turn 5) now, outside the frame order (shutdown). Only to a
    // configured micro of our spec (an unconfigured one is not moving); true if sent.
    bool send_stop(uint16_t dio);
    // The last message written whole was a stop command (fwd 5, turn 5).
    bool stop_was_last() const { return stop_last_; }

    // A stop command carrying these DIO levels (the seed's Navigation Init command).
    static navkit_micro_cmd_t stop_command(uint16_t dio);

    bool port_open() const { return port_.is_open(); }
    uint32_t tx_bytes_frame() const { return tx_frame_; }
    void begin_frame(int64_t now_us);
    // The counters so far; link_errors() is their rejected() sum (lisp_data.link_errors).
    LinkCounters counters() const;
    uint32_t link_errors() const;
    uint64_t config_downloads() const { return config_sent_; }  // rounds started
    uint64_t superseded() const { return superseded_; }
    uint64_t short_reads() const { return short_reads_; }
    uint64_t tx_errors() const { return tx_errors_; }
    uint16_t last_tag() const { return last_.time_tag; }
    const navkit_micro_cmd_t &last_command() const { return last_; }

private:
    // starting: a port another process holds is refused (std::runtime_error), not retried.
    void open_port(bool starting = false);
    void port_lost(const char *why);
    void note_data(const navkit_micro_data_t &d);
    // A micro that runs spec `hash` (not ours): not driven, said once a second.
    void note_foreign_hash(uint32_t hash);
    void write_frame(const uint8_t *buf, size_t len);
    // link = slcan (docs/can.md): each frame one ISO-TP message of SLCAN lines. can_take():
    // the adapter's bytes to ISO-TP (flow controls go out at once), each message reassembled
    // to take_frame_bytes; can_send(): start a message (skipped, counted in tx_errors, while
    // the last is still going out); can_pump(): the frames ISO-TP lets go now.
    bool slcan() const { return cfg_.link == "slcan"; }
    template <class Take> void can_take(const uint8_t *buf, size_t len, Take take_frame_bytes);
    void can_send(const uint8_t *buf, size_t len);
    void can_pump();
    // Outside the frame loop: read the port until the message going out is sent whole (its
    // flow control came) or ISO-TP gives it up (no flow control within N_Bs).
    void can_flush();
    void can_write(const std::string &line);
    uint32_t can_ms() const { return static_cast<uint32_t>(now_us_ / 1000); }  // ISO-TP clock: frame time
    void reset_parser();
    // Our config is no longer known to be in force: download it again from geometry on.
    void config_again();
    // micro_data.cmd_rejected moved: a refused config message is said, and the config
    // goes again.
    void note_rejects(const navkit_micro_data_t &d);
    // Says that our config is not in force after kConfigWarnRounds rounds and 1 s, then
    // every 5 s (frame time) while it lasts.
    void warn_config_rounds();

    const MicroCfg &cfg_;
    Console &con_;
    SerialPort port_;
    navkit_parser_t parser_{};
    Slcan slcan_;                // link = slcan: the adapter's lines
    navkit_isotp_rx_t can_rx_{}; // link = slcan: micro_data reassembly
    navkit_isotp_tx_t can_tx_{}; // link = slcan: the message going out
    bool adapter_pending_ = false;  // link = slcan: the port opened, the adapter not set up yet
    std::string last_open_error_;
    int64_t now_us_ = 0;
    int64_t last_rx_us_ = -1;
    bool have_data_ = false;
    uint16_t status_ = 0;
    bool configured_ = false;    // the micro's word (status bit of its last micro_data)
    bool taken_ = false;         // our config is in force (configured())
    bool round_done_ = false;    // all three config messages went out since config_again()
    int round_next_ = 0;         // next config message of the round: 0 geometry, 1 motion, 2 io
    uint64_t rounds_waiting_ = 0;    // rounds started since our config was last in force
    int64_t waiting_since_us_ = 0;   // frame time of the first of them
    int64_t last_rounds_warn_us_ = -1;
    uint16_t rejected_seen_ = 0;     // micro_data.cmd_rejected already looked at
    uint16_t refused_type_ = 0;      // msg_type of the last config the micro refused, 0 = none
    int64_t last_refusal_report_us_ = -1;
    bool mismatch_ = false;
    uint32_t mismatch_hash_ = 0;
    uint16_t cfg_tag_ = 0;
    navkit_micro_cmd_t last_{};  // the command repeated while nothing new comes
    uint32_t tx_frame_ = 0;
    uint64_t config_sent_ = 0;   // config rounds started (a geometry message sent)
    uint64_t superseded_ = 0;    // whole micro_data dropped for a newer one
    uint64_t short_reads_ = 0;   // lockstep ticks whose rx_bytes did not all arrive in 1 s
    uint64_t tx_errors_ = 0;     // frames written only in part (output buffer full)
    LinkCounters base_;          // counters of parsers before the last reopen, and decode failures
    LinkCounters reported_;      // the counters last shown on the console
    int64_t last_error_report_us_ = -1;
    int64_t last_probe_us_ = -1;     // mismatch: frame time of the last config probe
    int64_t last_mismatch_report_us_ = -1;
    uint32_t seen_schema_mismatch_ = 0;  // parser_.stats.schema_mismatch already handled
    bool stop_last_ = false;
    int last_bad_field_ = -1;    // field of the last micro_data outside the spec's range
};

}  // namespace navkit
