// Navigation: the seed's Navigation class. Converts the planner's low-level commands
// (and the console's teleop keys) to micro commands; high-level codes 100, 101 and 105
// are reported as not implemented. Init() sets the current command to Stop.
#pragma once

#include <cstdint>
#include <optional>

#include "navkit/ini.hpp"
#include "navkit/process_commands.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

struct NavOutput {
    bool is_new = false;         // a new micro command (new time tag)
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
    int nav_result() const { return result_; }
    // The last new planner command was a heading hold rejected for want of a heading.
    bool heading_missing() const { return heading_missing_; }
    int32_t ack_time_tag() const { return ack_; }

    // Planner command -> micro command (time tag left 0); returns a nav_result:
    // ok, not_implemented (high-level codes: the rest still applies) or rejected (a
    // value does not fit the micro, or a heading hold without a heading; *out untouched).
    static int convert(const navkit_lisp_cmd_t &in, std::optional<uint16_t> heading, uint16_t dio,
                       navkit_micro_cmd_t *out);
    // Teleop key -> micro command.
    static navkit_micro_cmd_t teleop(Teleop t, const ConsoleCfg &c, uint16_t dio);
    // The command that changes nothing but the DIO levels.
    static navkit_micro_cmd_t neutral(uint16_t dio);

private:
    const ConsoleCfg &console_;
    uint16_t dio_ = 0;           // DIO levels of the last command handed out
    uint16_t mc_datalog_ = 0;    // micro datalog selection of the last command handed out
    int result_ = NAVKIT_NAV_RESULT_OK;
    int32_t ack_ = 0;
    bool heading_missing_ = false;
};

}  // namespace navkit
