// Navigation: the seed's Navigation class. Converts the planner's low-level commands
// (and the console's teleop keys) to micro commands; high-level codes 100, 101 and 105
// are reported as not implemented. Init() sets the current command to Stop.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "navkit/ini.hpp"
#include "navkit/process_commands.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

// Why Navigation::convert refused a planner command (none: it did not).
enum class Refusal {
    none,
    code,            // fwd_cmd or turn_mode is no code the host converts
    range,           // a value outside the range of the micro_cmd field it is copied to
    heading_range,   // heading select: turn_distance outside the headings 0..kFullTurn
    heading_missing, // heading hold without the micro's current heading
};

// Navigation::convert's verdict on one planner command, with the reason of a refusal
// for the console and `navkit-host --convert-lisp` (one wording: text()).
struct Conversion {
    int nav_result = NAVKIT_NAV_RESULT_OK; // ok, not_implemented or rejected
    Refusal refusal = Refusal::none;
    int lisp_field = -1;  // NAVKIT_LISP_CMD_FIELD_* of the refused value, -1 for none
    int64_t value = 0;    // its raw value
    int micro_field = -1; // range: the NAVKIT_MICRO_CMD_FIELD_* it is copied to, else -1
    int cause_field = -1; // the lisp_cmd field whose value makes that copy (fwd_cmd,
    int64_t cause = 0;    // turn_mode, rc_servo_num) and that value; -1: none

    // The refusal in one line without the field's name, e.g. "40000 is outside
    // -32768..32767 (mm/s), the range of micro_cmd.speed it is copied to for fwd_cmd 1
    // (start)"; "" when converted.
    std::string text() const;
};

struct NavOutput {
    bool is_new = false; // a new micro command (new time tag)
    navkit_micro_cmd_t cmd{};
};

class Navigation {
public:
    explicit Navigation(const ConsoleCfg &console);
    void init();
    // Update(): this frame's micro command from the arbitration; heading (deg x 10,
    // 0..3599) is the micro's current one (nullopt: no fresh micro_data, e.g. none yet
    // or the micro offline), used when heading hold (mode 11) arrives: without it a
    // heading hold is rejected (heading_missing() says why).
    NavOutput update(const Arbitration &a, std::optional<uint16_t> heading);
    int nav_result() const { return result_.nav_result; }
    // The verdict on the last new planner command (why it was rejected).
    const Conversion &conversion() const { return result_; }
    // The last new planner command was a heading hold rejected for want of a heading.
    bool heading_missing() const { return result_.refusal == Refusal::heading_missing; }
    int32_t ack_time_tag() const { return ack_; }

    // One full turn in turn_distance's raw units (deg x 0.1): a heading select takes
    // 0..kFullTurn (docs/protocol.md seed slips), a heading hold wraps to 0..kFullTurn-1.
    static constexpr int32_t kFullTurn = 3600;
    // Planner command -> micro command (time tag left 0), the one implementation of the
    // lisp_cmd -> micro_cmd rule (docs/host.md). The verdict's nav_result: ok,
    // not_implemented (high-level codes: the rest still applies) or rejected (a value
    // does not fit the micro_cmd field it is copied to, a heading select off 0..kFullTurn,
    // a heading hold without a heading, an unknown code; *out untouched). heading: the
    // micro's current one (deg x 0.1), nullopt when unknown. in is lisp_cmd-checked
    // (navkit_lisp_cmd_check) by the caller.
    static Conversion convert(const navkit_lisp_cmd_t &in, std::optional<uint16_t> heading, uint16_t dio,
                              navkit_micro_cmd_t *out);
    // Teleop key -> micro command.
    static navkit_micro_cmd_t teleop(Teleop t, const ConsoleCfg &c, uint16_t dio);
    // The command that changes nothing but the DIO levels.
    static navkit_micro_cmd_t neutral(uint16_t dio);

private:
    const ConsoleCfg &console_;
    uint16_t dio_ = 0;        // DIO levels of the last command handed out
    uint16_t mc_datalog_ = 0; // micro datalog selection of the last command handed out
    Conversion result_;       // nav_result of the last verdict (also timeouts, rejections upstream)
    int32_t ack_ = 0;
};

} // namespace navkit
