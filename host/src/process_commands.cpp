#include "navkit/process_commands.hpp"

namespace navkit {

static const uint16_t kDioMask = 0x0FFF; // 12 DIO bits

ProcessCommands::ProcessCommands(const ExecutiveCfg &exec)
    : timeout_s_(exec.planner_timeout_s), idle_s_(exec.console_idle_s),
      console_dio_(static_cast<uint16_t>(exec.dio_default & kDioMask)),
      mc_datalog_(static_cast<uint16_t>(exec.mc_datalog))
{
}

Arbitration ProcessCommands::update(const PlannerInput &p, const ConsoleInput &c, const SafetyInput &s, int64_t now_us)
{
    Arbitration a;
    console_dio_ = static_cast<uint16_t>((console_dio_ ^ c.dio_toggle) & kDioMask);
    if (c.datalog_next) {
        mc_datalog_ = mc_datalog_error(mc_datalog_ + 1L).empty() ? static_cast<uint16_t>(mc_datalog_ + 1) : 0;
    }

    // planner liveness: the heartbeat, and every new command, count as signs of life
    if (!hb_seen_ || p.heartbeat != last_hb_) {
        hb_seen_ = hb_seen_ || p.heartbeat != 0;
        last_hb_ = p.heartbeat;
        hb_change_us_ = now_us;
    }
    const bool is_new = p.have && (!have_tag_ || p.cmd.time_tag != last_tag_);
    if (is_new) {
        have_tag_ = true;
        last_tag_ = p.cmd.time_tag;
        hb_seen_ = true;
        hb_change_us_ = now_us;
        timed_out_ = false;
    }
    if (timeout_s_ > 0 && hb_seen_ && !timed_out_ && static_cast<double>(now_us - hb_change_us_) >= timeout_s_ * 1e6) {
        timed_out_ = true;
        a.timeout_started = true;
        a.stop = true;
        if (owner_ == Owner::planner) {
            owner_ = Owner::none;
        }
    }

    // safety: a stop when the condition starts; motion ignored while it holds
    if (s.stop && !safety_) {
        a.safety_started = true;
        a.stop = true;
    }
    safety_ = s.stop;

    if (is_new) {
        int bad = -1;
        if (navkit_lisp_cmd_check(&p.cmd, &bad) != NAVKIT_OK) {
            a.planner_rejected = true; // a rejected message changes nothing
            a.rejected_field = bad;
            a.rejected_time_tag = p.cmd.time_tag;
        } else {
            planner_active_ = static_cast<uint16_t>(p.cmd.dio_active & kDioMask);
            planner_dio_ = static_cast<uint16_t>(p.cmd.dio_command & kDioMask);
            if (p.cmd.mc_datalog_cmd != NAVKIT_MC_DATALOG_NONE) {
                mc_datalog_ = static_cast<uint16_t>(p.cmd.mc_datalog_cmd); // checked: a selection
            }
            last_cmd_us_ = now_us;
            if (!safety_) {
                a.planner_new = true;
                a.planner = p.cmd;
                owner_ = Owner::planner;
            } else {
                a.planner_dropped = true; // not obeyed while safety holds
                a.rejected_time_tag = p.cmd.time_tag;
            }
        }
    } else if (p.have && navkit_lisp_cmd_check(&p.cmd, nullptr) == NAVKIT_OK) {
        // the current message keeps (or drops) the planner's DIO bits
        planner_active_ = static_cast<uint16_t>(p.cmd.dio_active & kDioMask);
        planner_dio_ = static_cast<uint16_t>(p.cmd.dio_command & kDioMask);
    }

    const bool planner_quiet = last_cmd_us_ < 0 || timed_out_ ||
                               static_cast<double>(now_us - last_cmd_us_) >= idle_s_ * 1e6;
    if (c.teleop == Teleop::stop) {
        // the console's stop always wins, like safety's: one stop (a planner command of
        // this same frame is dropped); the planner is obeyed again on its next new command
        if (a.planner_new) {
            a.planner_new = false;
            a.planner_dropped = true;
            a.rejected_time_tag = a.planner.time_tag;
        }
        a.teleop_new = true;
        a.teleop = Teleop::stop;
        owner_ = Owner::console;
    } else if (c.teleop != Teleop::none) {
        if (safety_) {
            a.teleop_ignored = TeleopIgnored::safety;
        } else if (a.planner_new || !planner_quiet) {
            a.teleop_ignored = TeleopIgnored::planner;
        } else {
            a.teleop_new = true;
            a.teleop = c.teleop;
            owner_ = Owner::console;
        }
    }

    const uint16_t active = timed_out_ ? 0 : planner_active_;
    a.dio = static_cast<uint16_t>(((active & planner_dio_) | (~active & console_dio_)) & kDioMask);
    a.mc_datalog = mc_datalog_;
    a.owner = owner_;
    return a;
}

} // namespace navkit
