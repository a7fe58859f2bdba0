#include "navkit/micro_link.hpp"

#include <cstring>
#include <ctime>
#include <poll.h>
#include <stdexcept>
#include <utility>
#include <vector>

#include "navkit/console.hpp"

namespace navkit {

// Monotonic clock, ms: the lockstep read's 1 s limit and the shutdown's wait for ISO-TP.
static int64_t mono_ms()
{
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1000 + ts.tv_nsec / 1000000;
}

MicroLink::MicroLink(const MicroCfg &cfg, Console &console, DeviceRoots roots)
    : cfg_(cfg), is_slcan_(cfg.link == "slcan"), con_(console), port_(std::move(roots))
{
    navkit_parser_init(&parser_, NAVKIT_DIR_TO_HOST);
}

void MicroLink::reset_parser()
{
    base_ = counters(); // decode failures are kept in base_ already
    navkit_parser_init(&parser_, NAVKIT_DIR_TO_HOST);
    seen_schema_mismatch_ = 0;
    slcan_ = Slcan(); // link = slcan: the old connection's lines and messages are gone
    navkit_isotp_rx_init(&can_rx_, NAVKIT_DIR_TO_HOST);
    navkit_isotp_tx_init(&can_tx_);
}

bool MicroLink::open(bool starting)
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
        return false;
    }
    last_open_error_.clear();
    reset_parser(); // bytes of the old connection are gone
    if (slcan()) {
        adapter_pending_ = true; // its set-up goes out at the start of the next frame (begin_frame)
        con_.print("micro port %s open (%s, raw; SLCAN adapter, CAN at %d bit/s, ISO-TP)", port_.path().c_str(),
                   SerialPort::line_settings(cfg_).c_str(), cfg_.can_bitrate);
    } else {
        con_.print("micro port %s open (%s, raw)", port_.path().c_str(), SerialPort::line_settings(cfg_).c_str());
    }
    if (cfg_.latency_timer_ms > 0) {
        const std::string why = set_latency_timer(port_.path(), port_.roots(), cfg_.latency_timer_ms);
        if (!why.empty()) {
            con_.print("micro port: %s: request/response is capped near 60 Hz", why.c_str());
        }
    }
    return true;
}

void MicroLink::port_lost(const char *why)
{
    con_.print("micro port %s lost (%s): reopening when it returns", port_.path().c_str(), why);
    port_.close();
    reset_parser();
    last_open_error_.clear();
}

bool MicroLink::begin_frame(int64_t now_us)
{
    now_us_ = now_us;
    tx_frame_ = 0;
    const bool opened = !port_.is_open() && open();
    if (adapter_pending_ && port_.is_open()) {
        // the SLCAN adapter: channel closed (as another program may have left it), bit rate,
        // open; written in a frame, so lockstep counts its bytes as the frame's
        adapter_pending_ = false;
        can_write(Slcan::open_commands(cfg_.can_bitrate));
    }
    return opened;
}

void MicroLink::take_frames(const uint8_t *d, size_t len, navkit_micro_data_t *out, MicroReceived *r)
{
    while (len) {
        const size_t k = navkit_parser_feed(&parser_, d, len);
        d += k;
        len -= k;
        const uint8_t *f;
        size_t fl;
        while (navkit_parser_next(&parser_, &f, &fl)) {
            // the parser only returns micro_data (DIR_TO_HOST); the newest one wins. One
            // that does not decode, or has a field outside the spec's range, is dropped and
            // counted (decode_failures). One of another spec's hash (our length, so it
            // decodes) is used for nothing but saying so: its words may mean other things.
            navkit_micro_data_t m;
            int bad = -1;
            // the parser checked start, length and CRC: only the type is left to check
            const bool decoded = navkit_frame_type(f) == NAVKIT_MSG_TYPE_MICRO_DATA;
            if (decoded) {
                navkit_micro_data_decode_parsed(f, &m);
            }
            if (decoded && m.spec_hash != NAVKIT_SPEC_HASH) {
                r->foreign_last = true;
                r->foreign_hash = m.spec_hash;
            } else if (decoded && navkit_micro_data_check(&m, &bad) == NAVKIT_OK) {
                *out = m;
                r->ours++;
                r->foreign_last = false;
            } else {
                base_.decode_failures++;
                last_bad_field_ = bad;
            }
        }
    }
}

MicroReceived MicroLink::receive(long want_bytes, navkit_micro_data_t *out)
{
    MicroReceived r;
    uint8_t buf[4096];
    long total = 0;
    int64_t deadline_ms = -1; // lockstep: wait at most 1 s for rx_bytes (from the first wait)
    // real time: read until nothing waits, bounded so a streaming micro cannot hold the frame
    for (int reads = 0; port_.is_open() && reads < 256; reads++) {
        const long n = port_.read_some(buf, sizeof buf, want_bytes > total);
        if (n < 0) {
            port_lost("read failed or hung up");
            break;
        }
        if (slcan()) {
            can_take(buf, static_cast<size_t>(n), out, &r);
        } else {
            take_frames(buf, static_cast<size_t>(n), out, &r);
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
            if (deadline_ms < 0) {
                deadline_ms = mono_ms() + 1000;
            }
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
    if (r.ours > 1) {
        superseded_ += r.ours - 1;
    }
    if (parser_.stats.schema_mismatch != seen_schema_mismatch_) {
        // a whole micro_data of another spec's length: its frozen words 4-5 name its spec
        seen_schema_mismatch_ = parser_.stats.schema_mismatch;
        r.other_length = true;
        r.other_length_hash = parser_.foreign_hash;
    }
    return r;
}

void MicroLink::report_errors()
{
    const LinkCounters c = counters();
    if ((c.rejected() == reported_.rejected() && c.dropped_bytes == reported_.dropped_bytes) ||
        (last_error_report_us_ >= 0 && now_us_ - last_error_report_us_ < 1000000)) {
        return;
    }
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
        const navkit_isotp_rx_stats_t &s = can_rx_.stats;
        why += std::string(why.empty() ? "" : "; ") + "CAN " + std::to_string(c.can_errors) +
               " (since the port opened: ISO-TP refused " + std::to_string(s.bad_frame) + " frames, aborted " +
               std::to_string(s.wrong_sn) + " out of sequence, " + std::to_string(s.restarted) + " restarted, " +
               std::to_string(s.timeout) + " timed out, " + std::to_string(s.overflow) + " too long; " +
               std::to_string(slcan_.bad_lines()) + " adapter lines no frame)";
    }
    con_.print("micro link: bad CRC %llu, unknown type %llu, bad length %llu, other spec %llu, "
               "decode failures %llu, dropped bytes %llu so far (%s)",
               static_cast<unsigned long long>(c.bad_crc), static_cast<unsigned long long>(c.unknown_type),
               static_cast<unsigned long long>(c.bad_length), static_cast<unsigned long long>(c.schema_mismatch),
               static_cast<unsigned long long>(c.decode_failures), static_cast<unsigned long long>(c.dropped_bytes),
               why.c_str());
    reported_ = c;
    last_error_report_us_ = now_us_;
}

void MicroLink::can_take(const uint8_t *buf, size_t len, navkit_micro_data_t *out, MicroReceived *r)
{
    std::vector<SlcanFrame> frames;
    slcan_.feed(buf, len, &frames);
    for (const SlcanFrame &sf : frames) {
        const uint16_t id = static_cast<uint16_t>((sf.id & NAVKIT_ISOTP_ID_MASK) |
                                                  (sf.extended ? NAVKIT_ISOTP_EXT : 0u) |
                                                  (sf.remote ? NAVKIT_ISOTP_RTR : 0u));
        navkit_isotp_frame_t fc;
        uint8_t fc_out = 0;
        navkit_isotp_tx_frame(&can_tx_, id, sf.data, sf.dlc, can_ms());
        const uint16_t n = navkit_isotp_rx_frame(&can_rx_, id, sf.data, sf.dlc, can_ms(), &fc, &fc_out);
        if (fc_out && port_.is_open()) {
            can_write(Slcan::frame_command(fc.id, fc.data));
        }
        if (n) {
            if (out) {
                take_frames(can_rx_.buf, n, out, r);
            }
            navkit_parser_discard(&parser_); // an ISO-TP message carries one frame
        }
    }
    navkit_isotp_rx_poll(&can_rx_, can_ms());
    can_pump(); // the consecutive frames a flow control just let go
}

bool MicroLink::write_bytes(const uint8_t *buf, size_t len)
{
    const long n = port_.write_all(buf, len);
    if (n < 0) {
        port_lost("write failed");
        return false;
    }
    if (static_cast<size_t>(n) != len) {
        tx_errors_++;
    }
    tx_frame_ += static_cast<uint32_t>(n);
    return true;
}

void MicroLink::can_write(const std::string &line)
{
    write_bytes(reinterpret_cast<const uint8_t *>(line.data()), line.size());
}

void MicroLink::can_pump()
{
    navkit_isotp_frame_t f;
    while (port_.is_open() && navkit_isotp_tx_next(&can_tx_, can_ms(), &f)) {
        can_write(Slcan::frame_command(f.id, f.data));
    }
}

bool MicroLink::can_send(const uint8_t *buf, size_t len)
{
    if (navkit_isotp_tx_busy(&can_tx_) || len > sizeof can_tx_.buf) {
        tx_errors_++; // the last message still waits for its flow control: this one is skipped
        return false;
    }
    std::memcpy(can_tx_.buf, buf, len);
    navkit_isotp_tx_start(&can_tx_, static_cast<uint16_t>(len), navkit_frame_type(buf), can_ms());
    can_pump();
    return true;
}

bool MicroLink::write_frame(const uint8_t *buf, size_t len)
{
    if (!port_.is_open()) {
        return false;
    }
    if (slcan()) {
        return can_send(buf, len);
    }
    return write_bytes(buf, len);
}

void MicroLink::can_read_now(int wait_ms)
{
    pollfd p{port_.fd(), POLLIN, 0};
    poll(&p, 1, wait_ms);
    uint8_t in[256];
    long n;
    while ((n = port_.read_some(in, sizeof in)) > 0) {
        can_take(in, static_cast<size_t>(n), nullptr, nullptr); // micro_data: not wanted now
    }
    if (n < 0) {
        port_lost("read failed or hung up");
    }
}

bool MicroLink::can_flush()
{
    // ISO-TP's own clock ends the wait: no flow control within N_Bs abandons the message
    // (can_pump); the bound below only guards against a clock that does not move
    const int64_t start_ms = mono_ms();
    const int64_t start_us = now_us_;
    const navkit_isotp_tx_stats_t before = can_tx_.stats;
    while (port_.is_open() && navkit_isotp_tx_busy(&can_tx_) &&
           mono_ms() < start_ms + 2 * static_cast<int64_t>(NAVKIT_CAN_N_BS_MS)) {
        can_read_now(10);
        now_us_ = start_us + 1000 * (mono_ms() - start_ms); // ISO-TP's clock moves on meanwhile
        can_pump();                                         // also notices an overdue flow control
    }
    const navkit_isotp_tx_stats_t &s = can_tx_.stats;
    if (!port_.is_open()) {
        unsent_ = "the port was lost";
    } else if (navkit_isotp_tx_busy(&can_tx_)) {
        unsent_ = "its flow control never came and ISO-TP's clock stood still";
    } else if (s.timeout != before.timeout) {
        unsent_ = "no flow control from the micro within N_Bs (" + std::to_string(NAVKIT_CAN_N_BS_MS) + " ms)";
    } else if (s.overflow != before.overflow) {
        unsent_ = "the micro's flow control said overflow";
    } else if (s.bad_fc != before.bad_fc) {
        unsent_ = "the micro's flow control had an invalid status";
    } else {
        return true;
    }
    return false;
}

bool MicroLink::finish_now()
{
    unsent_.clear();
    if (!port_.is_open()) {
        unsent_ = "the port is closed";
        return false;
    }
    return !slcan() || can_flush();
}

bool MicroLink::write_frame_now(const uint8_t *buf, size_t len)
{
    unsent_.clear();
    if (!port_.is_open()) {
        unsent_ = "the port is closed";
        return false;
    }
    const uint64_t errs = tx_errors_;
    if (slcan()) {
        // the message going out (the last command) ends with what already came (its flow
        // control may be waiting in the port), else gives way: ISO-TP lets a new first
        // frame pre-empt it, and a stop must not wait behind it
        if (navkit_isotp_tx_busy(&can_tx_)) {
            can_read_now(0);
        }
        navkit_isotp_tx_abort(&can_tx_);
        if (!port_.is_open()) {
            unsent_ = "the port was lost";
            return false;
        }
        const uint16_t sent = can_tx_.stats.sent;
        if (!write_frame(buf, len)) {
            unsent_ = port_.is_open() ? "ISO-TP refused the message" : "the port was lost";
            return false;
        }
        return can_flush() && can_tx_.stats.sent != sent;
    }
    write_frame(buf, len);
    if (!port_.is_open()) {
        unsent_ = "the port was lost";
    } else if (tx_errors_ != errs) {
        unsent_ = "the port took only part of it (output buffer full)";
    }
    return unsent_.empty();
}

LinkCounters MicroLink::counters() const
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

} // namespace navkit
