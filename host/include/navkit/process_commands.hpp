// ProcessCommands: the seed's arbitration between command sources. Rules (docs/host.md):
//  1. Safety first: while a safety condition holds, motion commands of every source are
//     ignored; when it starts, one stop is sent. After it clears, the next new command
//     is obeyed.
//  2. The planner has priority: every new planner command (a changed time tag) that
//     passes the spec's range check goes to Navigation. A planner that stops beating
//     its heartbeat for planner_timeout_s gets one stop sent and loses its DIO bits; its
//     next new command is obeyed again.
//  3. The console's stop key (space) always wins, like safety: one stop (a planner
//     command of the same frame is dropped); the planner is obeyed again on its next new
//     command. The other teleop keys are obeyed only when the planner has sent no
//     command for console_idle_s (or timed out, or never sent one) and no safety
//     condition holds; otherwise they are ignored and Arbitration says why.
//  4. DIO, exactly as the seed says: the planner owns a bit only while the bit is set in
//     dio_active of its current message; its level is then dio_command's bit. Every
//     other bit takes the console's level (dio_default, toggled by keys 0-9, '-', '=').
//  5. The micro datalog selection (micro_cmd word 44): [executive] mc_datalog at start-up,
//     then the last one chosen: the console's key l (the next selection of the spec's enum
//     mc_datalog, after the last back to none) or a new planner command's mc_datalog_cmd
//     (0 keeps the current one), taken like its DIO bits even when safety drops its motion.
#pragma once

#include <cstdint>

#include "navkit/ini.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

enum class Teleop { none, forward, reverse, left, right, stop };

struct PlannerInput {
    bool have = false; // a lisp_cmd was read this frame
    navkit_lisp_cmd_t cmd{};
    uint32_t heartbeat = 0;
};

struct ConsoleInput {
    Teleop teleop = Teleop::none;
    uint16_t dio_toggle = 0;   // DIO bits whose console level flips
    bool datalog_next = false; // key l: the next micro datalog selection
};

struct SafetyInput {
    bool stop = false; // a safety condition holds now
};

enum class Owner { none, planner, console };

// Why a teleop key (not the stop key) of this frame was not obeyed.
enum class TeleopIgnored { no, planner, safety };

struct Arbitration {
    bool planner_new = false; // pass arb.planner to Navigation
    navkit_lisp_cmd_t planner{};
    bool planner_rejected = false; // a new planner command failed the range check
    int rejected_field = -1;
    bool planner_dropped = false;  // a new planner command a console or safety stop dropped
    int32_t rejected_time_tag = 0; // the tag (ms) of either, acknowledged with nav_result rejected
    bool teleop_new = false;       // pass arb.teleop to Navigation
    Teleop teleop = Teleop::none;
    TeleopIgnored teleop_ignored = TeleopIgnored::no; // a teleop key was ignored, and why
    bool stop = false;                                // send a stop (safety started or planner timed out)
    bool timeout_started = false;                     // the planner timed out in this frame
    bool safety_started = false;
    uint16_t dio = 0;        // merged DIO levels
    uint16_t mc_datalog = 0; // micro datalog selection in force (rule 5)
    Owner owner = Owner::none;
};

class ProcessCommands {
public:
    ProcessCommands(const ExecutiveCfg &exec);
    Arbitration update(const PlannerInput &p, const ConsoleInput &c, const SafetyInput &s, int64_t now_us);
    bool planner_timed_out() const { return timed_out_; }

private:
    double timeout_s_, idle_s_;
    bool have_tag_ = false;
    int32_t last_tag_ = 0;
    bool hb_seen_ = false;
    uint32_t last_hb_ = 0;
    int64_t hb_change_us_ = 0;
    bool timed_out_ = false;
    bool safety_ = false;
    int64_t last_cmd_us_ = -1;
    uint16_t planner_active_ = 0, planner_dio_ = 0;
    uint16_t console_dio_;
    uint16_t mc_datalog_;
    Owner owner_ = Owner::none;
};

} // namespace navkit
