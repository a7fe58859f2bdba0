// The seed's RobotInit / RobotMain / RobotShutdown: the functions a user edits to make
// the robot do more. RobotMain runs once per frame in the seed's order; nothing in it
// waits (the lockstep receive waits only for bytes the driver says were already sent).
#include "navkit/robot.hpp"

#include <ctime>
#include <functional>
#include <optional>
#include <stdexcept>
#include <unistd.h>
#include <vector>

namespace navkit {

Robot::Robot(const Config &c)
    : cfg(c), console(stdout, STDIN_FILENO, cfg.console.status_period_s), micro(cfg.micro, console),
      comm(cfg.exec.shm_name, cfg.exec.shm_group), process(cfg.exec), nav(cfg.console), sensors(cfg.sensors),
      datalog(cfg.exec.log_dir)
{
}

// What the datalog records each frame: one table of columns (name, default plot range,
// and how the value is read from the Robot after step 8), so the header and every row
// come from the same list and cannot disagree in length.
struct LogColumn {
    LogParam param;
    std::function<double(const Robot &)> value;
};

static const std::vector<LogColumn> &log_columns()
{
    static const std::vector<LogColumn> cols = [] {
        using R = const Robot &;
        std::vector<LogColumn> c = {
            {{"time_s", 0, 600}, [](R r) { return static_cast<double>(r.tick.time_us) / 1e6; }},
            {{"frame", 0, 10000}, [](R r) { return static_cast<double>(r.frames); }},
            {{"distance_mm", -5000, 5000}, [](R r) { return static_cast<double>(r.data.distance); }},
            {{"speed_mm_s", -1000, 1000}, [](R r) { return static_cast<double>(r.data.fwd_speed); }},
            {{"heading_deg", 0, 360}, [](R r) { return r.data.heading / 10.0; }},
            {{"turn_deg", -360, 360}, [](R r) { return r.data.turn_progress / 10.0; }},
            {{"x_mm", -5000, 5000}, [](R r) { return static_cast<double>(r.data.x); }},
            {{"y_mm", -5000, 5000}, [](R r) { return static_cast<double>(r.data.y); }},
        };
        for (int i = 0; i < 4; i++) {
            c.push_back({{"ir" + std::to_string(i) + "_mm", 0, 800},
                         [i](R r) { return static_cast<double>(r.lisp_data.ir_range[i]); }});
        }
        for (int i = 0; i < 4; i++) {
            c.push_back({{"sonar" + std::to_string(i) + "_mm", 0, 3000},
                         [i](R r) { return static_cast<double>(r.lisp_data.sonar_range[i]); }});
        }
        c.push_back({{"battery_v", 0, 15}, [](R r) { return r.sensors.battery.value(); }});
        for (int i = 0; i < 8; i++) { // calibrated RC servo positions (sensors.ini [servoN])
            c.push_back({{"servo" + std::to_string(i) + "_deg", -180, 180},
                         [i](R r) { return r.lisp_data.servo_pos[i] / 10.0; }});
        }
        const std::vector<LogColumn> tail = {
            {{"fwd_cmd", 0, 5}, [](R r) { return static_cast<double>(r.micro.last_command().fwd_cmd); }},
            {{"turn_cmd", 0, 25}, [](R r) { return static_cast<double>(r.micro.last_command().turn_cmd); }},
            {{"cmd_time_tag", 0, 65535}, [](R r) { return static_cast<double>(r.micro.last_command().time_tag); }},
            {{"dio", 0, 4095}, [](R r) { return static_cast<double>(r.micro.last_command().dio_command); }},
            {{"micro_status", 0, 8191}, [](R r) { return static_cast<double>(r.data.status); }},
            {{"overruns", 0, 100}, [](R r) { return static_cast<double>(r.lisp_data.overruns); }},
            // who commanded the robot last: 0 none, 1 planner, 2 console (ProcessCommands)
            {{"owner", 0, 2}, [](R r) { return static_cast<double>(static_cast<int>(r.owner)); }},
            // the micro datalog: its clock (the sample's time, ms), the selection that filled
            // the four words (spec enum mc_datalog, whose `words` name them) and the words
            {{"micro_time_ms", 0, 600000}, [](R r) { return static_cast<double>(r.data.micro_time); }},
            {{"mc_datalog_sel", 0, 6}, [](R r) { return static_cast<double>(r.data.mc_datalog_sel); }},
        };
        c.insert(c.end(), tail.begin(), tail.end());
        for (int i = 0; i < 4; i++) {
            c.push_back({{"mc_datalog" + std::to_string(i), -32768, 32767},
                         [i](R r) { return static_cast<double>(r.data.mc_datalog[i]); }});
        }
        return c;
    }();
    return cols;
}

static std::vector<LogParam> log_params()
{
    std::vector<LogParam> p;
    for (const LogColumn &c : log_columns()) {
        p.push_back(c.param);
    }
    return p;
}

static const char *owner_name(Owner o)
{
    switch (o) {
    case Owner::planner:
        return "planner";
    case Owner::console:
        return "console";
    case Owner::none:
        break;
    }
    return "none";
}

// Starts the datalog (R key, --record); "" when recording, else why not (said on the console).
static std::string start_recording(Robot &r)
{
    if (r.datalog.recording()) {
        return "";
    }
    const std::string err = r.datalog.start(std::time(nullptr), log_params());
    if (err.empty()) {
        r.console.print("recording to %s", r.datalog.path().c_str());
    } else {
        r.console.print("cannot record: %s", err.c_str());
    }
    return err;
}

static void stop_recording(Robot &r)
{
    if (r.datalog.recording()) {
        r.console.print("recording stopped: %s", r.datalog.path().c_str());
        r.datalog.stop();
    }
}

// Keys typed since the last frame: the seed's R / S, Q to quit, and the teleop keys (the
// last one counts, but a stop among them wins).
static ConsoleInput handle_keys(Robot &r)
{
    ConsoleInput in;
    static const char dio_keys[] = "1234567890-="; // DIO bits 0..11
    auto teleop = [&in](Teleop t) {
        if (in.teleop != Teleop::stop) {
            in.teleop = t;
        }
    };
    for (char k : r.console.keys()) {
        switch (k) {
        case 'R':
        case 'r':
            start_recording(r);
            break;
        case 'S':
        case 's':
            stop_recording(r);
            break;
        case 'Q':
        case 'q':
            r.quit = true;
            break;
        case 'L':
        case 'l':
            in.datalog_next = true;
            break;
        case 'w':
            teleop(Teleop::forward);
            break;
        case 'x':
            teleop(Teleop::reverse);
            break;
        case 'a':
            teleop(Teleop::left);
            break;
        case 'd':
            teleop(Teleop::right);
            break;
        case ' ':
            in.teleop = Teleop::stop;
            break;
        default:
            for (int b = 0; dio_keys[b]; b++) {
                if (k == dio_keys[b]) {
                    in.dio_toggle = static_cast<uint16_t>(in.dio_toggle ^ (1u << b));
                }
            }
        }
    }
    return in;
}

// Step 1: the face moves one step toward the planner's emotion; on a terminal it is
// drawn above the status line, else ([animation] log = 1) a "face:" line says each change.
static void update_face(Robot &r, bool micro_active)
{
    const FaceUpdate u = r.animation.update(r.emotion, micro_active);
    if (u.rejected) {
        r.console.print_limited("planner emotion %d rejected: %s out of the spec's range (face keeps the last one)",
                                static_cast<int>(r.emotion.time_tag), navkit_emotion_field_name(u.rejected_field));
    }
    r.console.set_face(r.animation.lines());
    if (u.changed && r.cfg.animation.log && !r.console.out_tty()) {
        r.console.print("face: %s", r.animation.state().c_str());
    }
}

void RobotInit(Robot &r)
{
    if (r.cfg.animation.on) {
        r.animation.start(r.cfg.animation.file); // a bad Animation.ini stops start-up (ConfigError)
    }
    r.console.init();
    r.console.print("navkit-host: spec hash 0x%08X, %.3g Hz frames, rcomm %s", static_cast<unsigned>(NAVKIT_SPEC_HASH),
                    r.cfg.exec.frame_rate_hz, r.cfg.exec.shm_name.c_str());
    r.comm.init();
    r.micro.init();
    r.nav.init();
    navkit_lisp_data_defaults(&r.lisp_data);
    if (r.cfg.exec.record) {
        // asked for at start-up (--record, record = 1): running without it is refused
        const std::string err = start_recording(r);
        if (!err.empty()) {
            throw std::runtime_error("--record / [executive] record = 1: cannot record (" + err + "): not starting");
        }
    }
}

void RobotMain(Robot &r)
{
    const int64_t now = r.tick.time_us;
    r.console.set_time_us(now);
    r.micro.begin_frame(now);
    const ConsoleInput keys = handle_keys(r);

    // 1. face, when on: the planner's emotion, then one ramp step (micro active = online
    // as of the last frame's data); the region's size is checked once, before the frame's
    // accesses (a region cut short is let go here)
    r.comm.begin_frame();
    r.comm.read_emotion(&r.emotion);
    if (r.cfg.animation.on) {
        update_face(r, r.micro.online(now));
    }
    // 2. receive the micro's data (the newest whole micro_data)
    if (r.micro.receive(r.tick.rx_bytes, &r.data)) {
        r.have_data = true;
        r.sensors.update(r.data);
    }
    // 3. until our config is in force (start-up, port reopen, micro reset) the micro gets
    // config messages: MicroUsb::send() picks them
    // 4. read the planner's command
    PlannerInput pin;
    pin.have = r.comm.read_lisp_cmd(&r.lisp_cmd);
    pin.cmd = r.lisp_cmd;
    pin.heartbeat = r.comm.planner_heartbeat();
    // 5. arbitrate
    SafetyInput safety;
    const bool online = r.micro.online(now);
    if (online && r.cfg.safety.battery_min_v > 0 && r.sensors.battery.value() < r.cfg.safety.battery_min_v) {
        safety.stop = true;
    }
    for (int i = 0; i < 4 && online && r.cfg.safety.ir_stop_mm > 0; i++) {
        const int d = r.sensors.ir[i].value();
        safety.stop = safety.stop || (d > 0 && d < r.cfg.safety.ir_stop_mm);
    }
    const Arbitration arb = r.process.update(pin, keys, safety, now);
    if (arb.timeout_started) {
        r.console.print("planner silent for %.2f s: robot stopped (obeys its next new command)",
                        r.cfg.exec.planner_timeout_s);
    }
    if (arb.safety_started) {
        r.console.print("safety stop (battery below %.2f V or IR range below %d mm)", r.cfg.safety.battery_min_v,
                        r.cfg.safety.ir_stop_mm);
    }
    if (arb.teleop_ignored != TeleopIgnored::no && (r.key_ignored_us < 0 || now - r.key_ignored_us >= 1000000)) {
        // once per frame with an ignored key, at most once a second (a held key repeats)
        r.console.print("key ignored: %s (space stops the robot at any time)",
                        arb.teleop_ignored == TeleopIgnored::planner ? "planner has priority" : "safety stop holds");
        r.key_ignored_us = now;
    }
    if (arb.planner_rejected) {
        r.console.print_limited("planner command %d rejected: %s out of the spec's range",
                                static_cast<int>(r.lisp_cmd.time_tag), navkit_lisp_cmd_field_name(arb.rejected_field));
    }
    if (arb.planner_dropped) {
        r.console.print_limited("planner command %d not obeyed: %s", static_cast<int>(arb.rejected_time_tag),
                                arb.teleop == Teleop::stop ? "the console's stop key came in the same frame"
                                                           : "a safety stop holds");
    }
    r.owner = arb.owner;
    if (keys.datalog_next) {
        r.console.print("micro datalog selection %u (spec enum mc_datalog: docs/protocol.md)",
                        static_cast<unsigned>(arb.mc_datalog));
    }
    // 6. navigation: a heading hold needs the micro's heading of this moment, so only
    // fresh data of a micro of our spec counts (none yet, offline: the hold is rejected)
    const std::optional<uint16_t> heading = online && r.have_data && !r.micro.spec_mismatch()
                                                ? std::optional<uint16_t>(r.data.heading)
                                                : std::nullopt;
    const NavOutput nav = r.nav.update(arb, heading);
    if (arb.planner_new && r.nav.nav_result() == NAVKIT_NAV_RESULT_NOT_IMPLEMENTED) {
        r.console.print_limited("planner fwd_cmd %d (high level) is not implemented",
                                static_cast<int>(arb.planner.fwd_cmd));
    } else if (arb.planner_new && r.nav.heading_missing()) { // its own line (and repeat limit): a state, not a value
        r.console.print_limited("planner command %d rejected: %s", static_cast<int>(arb.planner.time_tag),
                                r.nav.conversion().text().c_str());
    } else if (arb.planner_new && r.nav.nav_result() == NAVKIT_NAV_RESULT_REJECTED) {
        // the value, the micro_cmd field and range it missed and why it was copied (Conversion)
        r.console.print_limited("planner command %d rejected: %s: %s", static_cast<int>(arb.planner.time_tag),
                                navkit_lisp_cmd_field_name(r.nav.conversion().lisp_field),
                                r.nav.conversion().text().c_str());
    }
    // 7. send one micro message (Q: this frame's message is the stop, when the micro is
    // configured; else it gets its config as usual and RobotShutdown says it is not moving)
    if (r.quit) {
        r.micro.queue_command(MicroUsb::stop_command(arb.dio), true);
    } else if (!nav.is_new && r.micro.last_command().mc_datalog_cmd != arb.mc_datalog) {
        // the link replaced our last command (a stop after a micro reset): that command
        // again, new, with the datalog selection, so a reset micro gets the selection back
        navkit_micro_cmd_t again = r.micro.last_command();
        again.mc_datalog_cmd = arb.mc_datalog;
        r.micro.queue_command(again, true);
    } else {
        r.micro.queue_command(nav.cmd, nav.is_new);
    }
    r.micro.send();
    // 8. publish the planner's data
    navkit_lisp_data_t &ld = r.lisp_data;
    const navkit_micro_data_t &d = r.data;
    ld.time_tag = static_cast<int32_t>(now / 1000);
    ld.ack_time_tag = r.nav.ack_time_tag();
    ld.nav_result = r.nav.nav_result();
    uint32_t hs = 0;
    hs |= online ? NAVKIT_HOST_STATUS_MICRO_ONLINE : 0u;
    hs |= r.micro.configured() && !r.micro.spec_mismatch() ? NAVKIT_HOST_STATUS_MICRO_CONFIGURED : 0u;
    hs |= r.micro.spec_mismatch() ? NAVKIT_HOST_STATUS_SPEC_MISMATCH : 0u;
    hs |= r.process.planner_timed_out() ? NAVKIT_HOST_STATUS_PLANNER_TIMEOUT_STOP : 0u;
    hs |= (d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP) ? NAVKIT_HOST_STATUS_WATCHDOG_STOP : 0u;
    hs |= r.datalog.recording() ? NAVKIT_HOST_STATUS_RECORDING : 0u;
    hs |= r.micro.port_open() ? 0u : NAVKIT_HOST_STATUS_PORT_LOST;
    ld.host_status = static_cast<int32_t>(hs);
    ld.micro_status = d.status;
    ld.frame = static_cast<int32_t>(r.frames);
    ld.distance = d.distance;
    ld.speed = d.fwd_speed;
    ld.turn_progress = d.turn_progress;
    ld.heading = d.heading;
    ld.yaw_rate = d.yaw_rate;
    ld.x = d.x;
    ld.y = d.y;
    for (int i = 0; i < 4; i++) {
        ld.ir_range[i] = r.sensors.ir[i].value();
        ld.sonar_range[i] = r.sensors.sonar[i].value();
    }
    ld.battery = static_cast<int32_t>(r.sensors.battery.value() * 1000.0 + 0.5);
    for (int i = 0; i < 8; i++) {
        ld.servo_pos[i] = r.sensors.servo[i].value();
    }
    ld.dio_state = d.dio_state;
    ld.compass = d.compass;
    ld.overruns = static_cast<int32_t>(r.clock ? r.clock->overruns() : 0);
    ld.link_errors = static_cast<int32_t>(r.micro.link_errors());
    r.comm.send_lisp_data(ld);
    r.comm.set_host_heartbeat(r.frames);
    // 9. datalog row
    if (r.datalog.recording()) {
        std::vector<double> row;
        for (const LogColumn &c : log_columns()) {
            row.push_back(c.value(r));
        }
        const std::string err = r.datalog.row(row);
        if (!err.empty()) {
            r.console.print("datalog: %s: recording stopped", err.c_str());
            stop_recording(r);
        }
    }
    // 10. status line, formatted only when the console shows one (a log: every
    // status_period_s of frame time)
    if (r.console.status_due()) {
        const LinkCounters lc = r.micro.counters();
        const char *state = r.micro.spec_mismatch() ? " (spec mismatch)"
                                                    : (r.micro.configured() ? " configured" : " unconfigured");
        // hdg: deg x 10 as whole deg and tenths (the text of %.1f of heading / 10.0 for
        // every uint16)
        TextLine t;
        t << "frame " << r.frames << "  micro " << (online ? "online" : "offline") << state << "  owner "
          << owner_name(r.owner) << "  cmd tag " << r.micro.last_tag() << "  dist " << d.distance << " mm  hdg "
          << d.heading / 10u << "." << d.heading % 10u << "  link crc/type/len/spec/decode " << lc.bad_crc << "/"
          << lc.unknown_type << "/" << lc.bad_length << "/" << lc.schema_mismatch << "/" << lc.decode_failures
          << " dropped " << lc.dropped_bytes << " B  overruns " << ld.overruns
          << (r.datalog.recording() ? "  REC" : "");
        r.console.status(t.c_str());
    }
    r.frames++;
}

void RobotShutdown(Robot &r)
{
    if (r.animation.started()) {
        r.animation.end();
        r.console.set_face({}); // the closing lines scroll without the face
    }
    // The last message to the micro is a stop: Q's frame sent it (when the micro was
    // configured); otherwise it goes now. A micro that is not configured (or of another
    // spec, never driven) is not moving and gets none. MicroUsb says which.
    const std::string stopped = r.micro.stop_at_shutdown(r.micro.last_command().dio_command, r.quit);
    stop_recording(r);
    r.comm.shutdown();
    r.micro.shutdown();
    const LinkCounters lc = r.micro.counters();
    r.console.print(
        "link: %llu config downloads; rejected frames: %llu bad CRC, %llu unknown type, %llu bad length, "
        "%llu of another spec, %llu decode failures; %llu bytes dropped; %llu micro_data superseded by newer ones, "
        "%llu messages written in part, %llu abandoned unfinished for the stop, %llu lockstep reads short",
        static_cast<unsigned long long>(r.micro.config_downloads()), static_cast<unsigned long long>(lc.bad_crc),
        static_cast<unsigned long long>(lc.unknown_type), static_cast<unsigned long long>(lc.bad_length),
        static_cast<unsigned long long>(lc.schema_mismatch), static_cast<unsigned long long>(lc.decode_failures),
        static_cast<unsigned long long>(lc.dropped_bytes), static_cast<unsigned long long>(r.micro.superseded()),
        static_cast<unsigned long long>(r.micro.tx_errors()), static_cast<unsigned long long>(r.micro.tx_aborted()),
        static_cast<unsigned long long>(r.micro.short_reads()));
    if (r.have_data) {
        // the micro's own receive counters (host-to-micro direction), each apart
        const navkit_micro_data_t &d = r.data;
        r.console.print("micro's receive counters (its last micro_data): %u good, %u bad CRC, %u unknown type, "
                        "%u bad length, %u schema mismatch, %u bytes dropped; %u commands rejected",
                        static_cast<unsigned>(d.rx_good), static_cast<unsigned>(d.rx_bad_crc),
                        static_cast<unsigned>(d.rx_unknown_type), static_cast<unsigned>(d.rx_bad_length),
                        static_cast<unsigned>(d.rx_schema_mismatch), static_cast<unsigned>(d.rx_dropped_bytes),
                        static_cast<unsigned>(d.cmd_rejected));
        if (r.cfg.micro.link == "slcan") { // its CAN transport's (0 from a micro on serial)
            r.console.print("micro's CAN counters (its last micro_data): %u frames refused, %u stray consecutive "
                            "frames; messages to it aborted: %u out of sequence, %u restarted, %u N_Cr timeouts, "
                            "%u overflows; micro_data abandoned: %u N_Bs timeouts, %u overflows, %u bad flow "
                            "controls; %u waits; %u frames lost before the transport (controller or driver)",
                            static_cast<unsigned>(d.can_rx_bad_frame), static_cast<unsigned>(d.can_rx_unexpected),
                            static_cast<unsigned>(d.can_rx_wrong_sn), static_cast<unsigned>(d.can_rx_restarted),
                            static_cast<unsigned>(d.can_rx_timeout), static_cast<unsigned>(d.can_rx_overflow),
                            static_cast<unsigned>(d.can_tx_timeout), static_cast<unsigned>(d.can_tx_overflow),
                            static_cast<unsigned>(d.can_tx_bad_fc), static_cast<unsigned>(d.can_tx_wait),
                            static_cast<unsigned>(d.can_rx_lost));
        }
    }
    if (r.clock) {
        r.console.print("clock: %llu overruns, %llu frames skipped",
                        static_cast<unsigned long long>(r.clock->overruns()),
                        static_cast<unsigned long long>(r.clock->skipped()));
    }
    r.console.print("shut down after %u frames (%s, rcomm %s removed)", r.frames, stopped.c_str(),
                    r.cfg.exec.shm_name.c_str());
    r.console.shutdown();
}

} // namespace navkit
