#include "navkit/micro_usb.hpp"

#include <cstdio>
#include <utility>

#include "navkit/console.hpp"

namespace navkit {

// Rounds of config messages (and at least 1 s) without our config in force before the
// console says so; said again every 5 s (frame time) while it lasts.
static const uint64_t kConfigWarnRounds = 5;

MicroUsb::MicroUsb(const MicroCfg &cfg, Console &console, DeviceRoots roots)
    : cfg_(cfg), con_(console), link_(cfg, console, std::move(roots))
{
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
    last_ = stop_command(0); // the seed's Navigation Init: the current command is Stop
    last_.time_tag = 1;
    cmd_len_ = 0;
    if (link_.open(true)) {
        port_opened();
    }
}

void MicroUsb::shutdown()
{
    link_.close();
}

void MicroUsb::port_opened()
{
    config_again();     // our config, downloaded whole
    rejected_seen_ = 0; // its refusals so far are news (ours may be among them)
}

void MicroUsb::config_again()
{
    taken_ = false;
    round_done_ = false;
    round_next_ = 0;
}

void MicroUsb::begin_frame(int64_t now_us)
{
    now_us_ = now_us;
    if (link_.begin_frame(now_us)) {
        port_opened();
    }
}

bool MicroUsb::receive(long want_bytes, navkit_micro_data_t *out)
{
    const MicroReceived r = link_.receive(want_bytes, out);
    if (r.other_length && !r.ours) {
        note_foreign_hash(r.other_length_hash);
    }
    link_.report_errors();
    if (r.ours) {
        last_rx_us_ = now_us_;
        note_data(*out);
    }
    if (r.foreign_last) {
        note_foreign_hash(r.foreign_hash); // after any of ours: the newest frame says what the micro is now
    }
    return r.ours > 0;
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
        taken_ = false; // (a round in progress goes on)
    } else if (round_done_ && !taken_) {
        // configured, and this micro_data came after our three config messages went out
        con_.print("micro configured (firmware %u.%u)", d.fw_version >> 8, d.fw_version & 0xFFu);
        taken_ = true;
        round_next_ = 0; // a second round, begun while waiting for this, is not finished
        rounds_waiting_ = 0;
        refused_type_ = 0;
        last_rounds_warn_us_ = -1;
    }
}

static const char *config_name(uint16_t msg_type)
{
    switch (msg_type) {
    case NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY:
        return "micro_cfg_geometry";
    case NAVKIT_MSG_TYPE_MICRO_CFG_MOTION:
        return "micro_cfg_motion";
    case NAVKIT_MSG_TYPE_MICRO_CFG_IO:
        return "micro_cfg_io";
    default:
        return nullptr;
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
        return; // a refused micro_cmd: Navigation's business, not the config's
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
    return link_.is_open() && last_rx_us_ >= 0 && now_us - last_rx_us_ <= 1000000;
}

void MicroUsb::queue_command(const navkit_micro_cmd_t &cmd, bool is_new)
{
    if (!is_new) {
        return; // the last command is repeated with its time tag
    }
    const uint16_t tag = static_cast<uint16_t>(last_.time_tag + 1u);
    last_ = cmd;
    last_.time_tag = tag;
    cmd_len_ = 0;
}

size_t MicroUsb::cmd_bytes()
{
    if (!cmd_len_) {
        cmd_len_ = navkit_micro_cmd_encode(&last_, cmd_frame_, sizeof cmd_frame_);
    }
    return cmd_len_;
}

void MicroUsb::write_frame(const uint8_t *buf, size_t len)
{
    if (link_.write_frame(buf, len)) {
        stop_last_ = false;
    }
}

void MicroUsb::send()
{
    if (!link_.is_open()) {
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
        const size_t n_cmd = cmd_bytes();
        const uint64_t errs = link_.tx_errors();
        write_frame(cmd_frame_, n_cmd);
        stop_last_ = link_.is_open() && link_.tx_errors() == errs && last_.fwd_cmd == NAVKIT_FWD_CMD_STOP &&
                     last_.turn_cmd == NAVKIT_TURN_CMD_STOP;
        return;
    }
    write_frame(buf, n);
}

std::string MicroUsb::stop_at_shutdown(uint16_t dio, bool quit_frame)
{
    if (!link_.is_open()) {
        return "port closed: no stop sent";
    }
    if (mismatch_) {
        return "micro of another spec, never driven: no stop sent";
    }
    if (!configured_) {
        return "micro not configured by us: not moving, no stop sent";
    }
    if (quit_frame && stop_last_ && link_.finish_now()) {
        return "stop sent";
    }
    queue_command(stop_command(dio), true);
    stop_last_ = link_.write_frame_now(cmd_frame_, cmd_bytes());
    return stop_last_ ? "stop sent" : "stop not sent whole: " + link_.unsent_reason();
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
    configured_ = false; // whatever it said: our config was never taken
    config_again();
}

uint32_t MicroUsb::link_errors() const
{
    return static_cast<uint32_t>(counters().rejected());
}

} // namespace navkit
