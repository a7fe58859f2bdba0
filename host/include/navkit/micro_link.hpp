// MicroLink: the micro link's frames over the serial port. Opens the port (and reopens it
// every frame while it is gone), carries each frame as it is on the line ([micro] link =
// serial) or as one ISO-TP message of the SLCAN lines of a USB-CAN adapter (link = slcan,
// docs/can.md), hands back the newest whole micro_data of those waiting, and counts
// everything it drops (LinkCounters, said on the console at most once a second). It does
// not know what the frames mean to the micro: MicroUsb decides what goes out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "navkit/ini.hpp"
#include "navkit/serial_port.hpp"
#include "navkit/slcan.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

class Console;

// The micro link's error counters, kept apart (summed over port reopens).
struct LinkCounters {
    uint64_t bad_crc = 0;         // candidate frames with a wrong CRC
    uint64_t unknown_type = 0;    // candidates of an unknown (or host-to-micro) type
    uint64_t bad_length = 0;      // candidates whose length word is not their type's
    uint64_t decode_failures = 0; // whole micro_data frames that did not decode or had a
                                  // field outside the spec's range (dropped)
    uint64_t schema_mismatch = 0; // CRC-good micro_data of another spec's length
    uint64_t dropped_bytes = 0;   // bytes not part of a returned frame
    uint64_t can_errors = 0;      // link = slcan: CAN frames ISO-TP refused, ISO-TP messages
                                  // aborted (lost, reordered, restarted, timed out, overflowed),
                                  // adapter lines that were no frame
    // Frames rejected for any reason (lisp_data.link_errors): the six frame counters.
    uint64_t rejected() const
    {
        return bad_crc + unknown_type + bad_length + decode_failures + schema_mismatch + can_errors;
    }
};

// What one MicroLink::receive() read, besides the newest micro_data of our spec.
struct MicroReceived {
    unsigned ours = 0;              // whole micro_data of our spec that passed the spec's checks
    bool foreign_last = false;      // the newest whole micro_data carried another spec's hash
    uint32_t foreign_hash = 0;      // ... that hash
    bool other_length = false;      // a micro_data of another spec's length arrived (new this call)
    uint32_t other_length_hash = 0; // ... the spec hash its frozen words 4-5 name
};

class MicroLink {
public:
    MicroLink(const MicroCfg &cfg, Console &console, DeviceRoots roots = DeviceRoots());

    // Opens the port. True when it opened (the caller's state of the micro starts anew).
    // starting: a port another process holds is refused (std::runtime_error), not retried;
    // else any failure is said once (per distinct reason) and tried again next frame.
    bool open(bool starting = false);
    void close() { port_.close(); }
    bool is_open() const { return port_.is_open(); }

    // Start of a frame at frame time now_us (us): reopens a lost port (true when it opened
    // now) and writes the SLCAN adapter's set-up after an open.
    bool begin_frame(int64_t now_us);

    // Reads the port. want_bytes < 0 (real time): whatever is waiting; >= 0 (lockstep):
    // polls until that many bytes have been read (1 s limit, then counts a short read).
    // *out = the newest whole micro_data of our spec, if any (MicroReceived::ours > 0).
    MicroReceived receive(long want_bytes, navkit_micro_data_t *out);
    // Says the counters on the console if they moved, at most once a second of frame time.
    void report_errors();

    // Writes one frame (a whole message). True when it went to the line (all or part of it,
    // a part counted in tx_errors); false when the port is gone or, link = slcan, the last
    // message is still going out (this one skipped, counted in tx_errors).
    bool write_frame(const uint8_t *buf, size_t len);
    // Outside the frame loop (shutdown's stop): writes one frame at once and waits until it
    // went out whole. link = slcan: a message still going out is abandoned (ISO-TP abort,
    // counted in tx_aborted; its receiver drops the part it has when our first frame comes),
    // so this one never waits behind it; it is given ISO-TP's N_Bs (ms) for its flow control.
    // True if it went out whole; else unsent_reason() says why not.
    bool write_frame_now(const uint8_t *buf, size_t len);
    // Outside the frame loop: waits until the message still going out (link = slcan) went
    // out whole or ISO-TP gave it up (no flow control within N_Bs, an overflow or bad flow
    // control). True if nothing is left unsent and the port is open; else unsent_reason().
    bool finish_now();
    // Why the last write_frame_now() / finish_now() left its frame unsent ("" if it did not).
    const std::string &unsent_reason() const { return unsent_; }

    // Bytes written in this frame (lockstep tells the driver).
    uint32_t tx_bytes_frame() const { return tx_frame_; }
    // The counters so far.
    LinkCounters counters() const;
    uint64_t superseded() const { return superseded_; }
    uint64_t short_reads() const { return short_reads_; }
    uint64_t tx_errors() const { return tx_errors_; }
    // link = slcan: messages abandoned unfinished for a more urgent one (a stop at shutdown).
    uint64_t tx_aborted() const { return can_tx_.stats.aborted; }

private:
    void port_lost(const char *why);
    void reset_parser();
    // Bytes to the port, counted in tx_bytes_frame(); a part written is counted in
    // tx_errors, a failed write loses the port (false).
    bool write_bytes(const uint8_t *buf, size_t len);
    // Bytes of frames (the line's, or one reassembled ISO-TP message's) through the parser;
    // the newest micro_data of our spec to *out.
    void take_frames(const uint8_t *d, size_t len, navkit_micro_data_t *out, MicroReceived *r);
    // link = slcan (docs/can.md): each frame one ISO-TP message of SLCAN lines. can_take():
    // the adapter's bytes to ISO-TP (flow controls go out at once), each message reassembled
    // to take_frames (out == nullptr: not wanted now); can_send(): start a message (skipped,
    // counted in tx_errors, while the last is still going out); can_pump(): the frames
    // ISO-TP lets go now.
    bool slcan() const { return is_slcan_; }
    void can_take(const uint8_t *buf, size_t len, navkit_micro_data_t *out, MicroReceived *r);
    bool can_send(const uint8_t *buf, size_t len);
    void can_pump();
    // Outside the frame loop: read the port until the message going out is sent whole (its
    // flow control came) or ISO-TP gives it up (no flow control within N_Bs); true if it went
    // whole (or none was going out), else unsent_ says why.
    bool can_flush();
    // Outside the frame loop: all the port holds (waiting up to wait_ms, ms, for the first
    // byte) through can_take.
    void can_read_now(int wait_ms);
    void can_write(const std::string &line);
    uint32_t can_ms() const { return static_cast<uint32_t>(now_us_ / 1000); } // ISO-TP clock: frame time

    const MicroCfg &cfg_;
    const bool is_slcan_; // cfg_.link == "slcan", as constructed (a MicroLink keeps its link)
    Console &con_;
    SerialPort port_;
    navkit_parser_t parser_{};
    Slcan slcan_;                  // link = slcan: the adapter's lines
    navkit_isotp_rx_t can_rx_{};   // link = slcan: micro_data reassembly
    navkit_isotp_tx_t can_tx_{};   // link = slcan: the message going out
    bool adapter_pending_ = false; // link = slcan: the port opened, the adapter not set up yet
    std::string last_open_error_;
    std::string unsent_; // why the last write_frame_now() / finish_now() left its frame unsent
    int64_t now_us_ = 0; // frame time of this frame, us
    uint32_t tx_frame_ = 0;
    uint64_t superseded_ = 0;  // whole micro_data dropped for a newer one
    uint64_t short_reads_ = 0; // lockstep ticks whose rx_bytes did not all arrive in 1 s
    uint64_t tx_errors_ = 0;   // frames written only in part (output buffer full), or skipped
    LinkCounters base_;        // counters of parsers before the last reopen, and decode failures
    LinkCounters reported_;    // the counters last shown on the console
    int64_t last_error_report_us_ = -1;
    uint32_t seen_schema_mismatch_ = 0; // parser_.stats.schema_mismatch already handled
    int last_bad_field_ = -1;           // field of the last micro_data outside the spec's range
};

} // namespace navkit
