// MicroUsb: the seed's MicroUSB class, the host's state of the micro on top of its link
// (MicroLink: the port, the frames, the counters). It receives micro_data (only the newest
// whole frame of those waiting is used) and sends exactly one message per frame: the
// config (all three messages, one per frame) at start-up, after every port reopen and
// whenever the micro reports unconfigured, until a micro_data after a whole round says
// configured; else the command (new, or the last one repeated with its time tag). A micro
// built from another spec is refused: it never gets a command, only a config probe once a
// second (which carries our spec hash, so such a micro refuses it, while a micro
// reflashed with our spec takes it and answers).
#pragma once

#include <cstdint>
#include <string>

#include "navkit/ini.hpp"
#include "navkit/micro_link.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

class Console;

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
    // The shutdown's stop (fwd 5, turn 5), outside the frame order, so that a stop is the
    // last message the micro gets. Only to a configured micro of our spec (an unconfigured
    // one is not moving). quit_frame: the last frame queued a stop (Q); if it went out, it
    // is let finish (link = slcan: its flow control awaited), else a new stop carrying dio
    // goes now, pre-empting a message still going out. Returns the console's words for what
    // happened: "stop sent", or why no stop went out whole.
    std::string stop_at_shutdown(uint16_t dio, bool quit_frame);

    // A stop command carrying these DIO levels (the seed's Navigation Init command).
    static navkit_micro_cmd_t stop_command(uint16_t dio);

    bool port_open() const { return link_.is_open(); }
    uint32_t tx_bytes_frame() const { return link_.tx_bytes_frame(); }
    void begin_frame(int64_t now_us);
    // The counters so far; link_errors() is their rejected() sum (lisp_data.link_errors).
    LinkCounters counters() const { return link_.counters(); }
    uint32_t link_errors() const;
    uint64_t config_downloads() const { return config_sent_; } // rounds started
    uint64_t superseded() const { return link_.superseded(); }
    uint64_t short_reads() const { return link_.short_reads(); }
    uint64_t tx_errors() const { return link_.tx_errors(); }
    uint64_t tx_aborted() const { return link_.tx_aborted(); }
    uint16_t last_tag() const { return last_.time_tag; }
    const navkit_micro_cmd_t &last_command() const { return last_; }

private:
    // The port (re)opened: whatever the micro on the other end reports, it may hold another
    // config (a host restarted without a micro reset, another micro plugged in).
    void port_opened();
    void note_data(const navkit_micro_data_t &d);
    // A micro that runs spec `hash` (not ours): not driven, said once a second.
    void note_foreign_hash(uint32_t hash);
    // Writes one frame through the link; a frame that went out is no stop unless send() says so.
    void write_frame(const uint8_t *buf, size_t len);
    // The length (bytes) of last_ encoded in cmd_frame_, encoding it if not done since it changed.
    size_t cmd_bytes();
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
    MicroLink link_;
    int64_t now_us_ = 0;
    int64_t last_rx_us_ = -1;
    bool have_data_ = false;
    uint16_t status_ = 0;
    bool configured_ = false;      // the micro's word (status bit of its last micro_data)
    bool taken_ = false;           // our config is in force (configured())
    bool round_done_ = false;      // all three config messages went out since config_again()
    int round_next_ = 0;           // next config message of the round: 0 geometry, 1 motion, 2 io
    uint64_t rounds_waiting_ = 0;  // rounds started since our config was last in force
    int64_t waiting_since_us_ = 0; // frame time of the first of them
    int64_t last_rounds_warn_us_ = -1;
    uint16_t rejected_seen_ = 0; // micro_data.cmd_rejected already looked at
    uint16_t refused_type_ = 0;  // msg_type of the last config the micro refused, 0 = none
    int64_t last_refusal_report_us_ = -1;
    bool mismatch_ = false;
    uint32_t mismatch_hash_ = 0;
    uint16_t cfg_tag_ = 0;
    navkit_micro_cmd_t last_{}; // the command repeated while nothing new comes
    // last_ encoded (a repeat goes out as these bytes again); cmd_len_ 0: not encoded yet.
    // Every change of last_ sets cmd_len_ = 0 (init, queue_command).
    uint8_t cmd_frame_[NAVKIT_MAX_FRAME_BYTES] = {};
    size_t cmd_len_ = 0;
    uint64_t config_sent_ = 0;   // config rounds started (a geometry message sent)
    int64_t last_probe_us_ = -1; // mismatch: frame time of the last config probe
    int64_t last_mismatch_report_us_ = -1;
    bool stop_last_ = false; // the last message written (link = slcan: begun) was a stop (fwd 5, turn 5)
};

} // namespace navkit
