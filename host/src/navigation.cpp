#include "navkit/navigation.hpp"

#include <cstdint>

namespace navkit {

static const int32_t kForever = 2000000000;  // the seed's "very large distance"

// Whether lisp_cmd value v (raw, the units of both sides) fits micro_cmd field `field`
// (NAVKIT_MICRO_CMD_FIELD_*): the spec's range of that field (the rule tools/navkit/sim/
// mission.py holds a mission's commands to, from the same spec).
static bool fits(int field, int32_t v)
{
    return navkit_micro_cmd_in_range(field, v) != 0;
}

navkit_micro_cmd_t Navigation::neutral(uint16_t dio)
{
    navkit_micro_cmd_t m;
    navkit_micro_cmd_defaults(&m);  // fwd none, turn none, no servo command
    m.dio_command = dio;
    return m;
}

int Navigation::convert(const navkit_lisp_cmd_t &in, std::optional<uint16_t> heading, uint16_t dio,
                        navkit_micro_cmd_t *out)
{
    navkit_micro_cmd_t m = neutral(dio);
    int result = NAVKIT_NAV_RESULT_OK;
    switch (in.fwd_cmd) {
    case NAVKIT_FWD_CMD_NONE:
        break;
    case NAVKIT_FWD_CMD_START:
    case NAVKIT_FWD_CMD_MODIFY:
    case NAVKIT_FWD_CMD_STOP:
        if (!fits(NAVKIT_MICRO_CMD_FIELD_ACCEL, in.accel) || !fits(NAVKIT_MICRO_CMD_FIELD_SPEED, in.speed)) {
            return NAVKIT_NAV_RESULT_REJECTED;
        }
        m.fwd_cmd = static_cast<uint16_t>(in.fwd_cmd);
        m.accel = static_cast<int16_t>(in.accel);
        m.speed = static_cast<int16_t>(in.speed);
        m.distance = in.distance;
        break;
    case NAVKIT_FWD_CMD_CONTEST_HALLWAY:
    case NAVKIT_FWD_CMD_CONTEST_START_CIRCLE:
    case NAVKIT_FWD_CMD_EXPLORE:
        result = NAVKIT_NAV_RESULT_NOT_IMPLEMENTED;  // high level: no forward motion
        break;
    default:
        return NAVKIT_NAV_RESULT_REJECTED;
    }

    if (in.turn_mode != NAVKIT_TURN_MODE_NONE && (!fits(NAVKIT_MICRO_CMD_FIELD_TURN_ACCEL, in.turn_accel) ||
                                                  !fits(NAVKIT_MICRO_CMD_FIELD_TURN_RATE, in.turn_rate))) {
        return NAVKIT_NAV_RESULT_REJECTED;
    }
    switch (in.turn_mode) {
    case NAVKIT_TURN_MODE_NONE:
        break;
    case NAVKIT_TURN_MODE_TURN:
    case NAVKIT_TURN_MODE_MODIFY:
    case NAVKIT_TURN_MODE_STOP:
        m.turn_cmd = static_cast<uint16_t>(in.turn_mode);
        m.turn_distance = in.turn_distance;
        break;
    case NAVKIT_TURN_MODE_HEADING_SELECT:
        // 0..3600 deg x 10 on both sides (docs/protocol.md seed slips): passed through
        if (in.turn_distance < 0 || in.turn_distance > 3600) {
            return NAVKIT_NAV_RESULT_REJECTED;
        }
        m.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
        m.turn_distance = in.turn_distance;
        break;
    case NAVKIT_TURN_MODE_HEADING_HOLD: {
        // HdgSel to the heading at arrival plus word 9, wrapped to 0..3599; no heading
        // known (no fresh micro_data): rejected, never a hold of heading 0
        if (!heading) {
            return NAVKIT_NAV_RESULT_REJECTED;
        }
        const int64_t h = (static_cast<int64_t>(*heading) + in.turn_distance) % 3600;
        m.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
        m.turn_distance = static_cast<int32_t>(h < 0 ? h + 3600 : h);
        break;
    }
    default:
        return NAVKIT_NAV_RESULT_REJECTED;
    }
    if (m.turn_cmd != NAVKIT_TURN_CMD_NONE) {
        m.turn_accel = static_cast<int16_t>(in.turn_accel);
        m.turn_rate = static_cast<int16_t>(in.turn_rate);
    }

    // open-loop excitation: copied whole (lisp_cmd's ranges are micro_cmd's, so it fits;
    // the micro refuses one sent with a forward or turn command)
    m.excite_mode = static_cast<uint16_t>(in.excite_mode);
    m.excite_wheels = static_cast<uint16_t>(in.excite_wheels);
    m.excite_amplitude = static_cast<int16_t>(in.excite_amplitude);
    m.excite_offset = static_cast<int16_t>(in.excite_offset);
    m.excite_duration = static_cast<uint16_t>(in.excite_duration);
    m.excite_period = static_cast<uint16_t>(in.excite_period);
    m.excite_f0 = static_cast<uint16_t>(in.excite_f0);
    m.excite_f1 = static_cast<uint16_t>(in.excite_f1);
    m.excite_seed = static_cast<uint16_t>(in.excite_seed);

    // RC servo: slot rc_servo_num 0..7 when param0 (rate) is not 0; else no effect
    if (in.rc_servo_num >= 0 && in.rc_servo_num <= 7 && in.rc_param0 != 0) {
        static const int fields[8][3] = {
            {NAVKIT_MICRO_CMD_FIELD_RC0_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC0_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC0_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC1_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC1_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC1_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC2_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC2_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC2_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC3_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC3_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC3_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC4_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC4_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC4_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC5_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC5_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC5_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC6_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC6_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC6_PARAM2},
            {NAVKIT_MICRO_CMD_FIELD_RC7_PARAM0, NAVKIT_MICRO_CMD_FIELD_RC7_PARAM1, NAVKIT_MICRO_CMD_FIELD_RC7_PARAM2},
        };
        const int *f = fields[in.rc_servo_num];  // micro_cmd rcN_param0..2
        if (!fits(f[0], in.rc_param0) || !fits(f[1], in.rc_param1) || !fits(f[2], in.rc_param2)) {
            return NAVKIT_NAV_RESULT_REJECTED;
        }
        int16_t *slots[8][3] = {
            {&m.rc0_param0, &m.rc0_param1, &m.rc0_param2}, {&m.rc1_param0, &m.rc1_param1, &m.rc1_param2},
            {&m.rc2_param0, &m.rc2_param1, &m.rc2_param2}, {&m.rc3_param0, &m.rc3_param1, &m.rc3_param2},
            {&m.rc4_param0, &m.rc4_param1, &m.rc4_param2}, {&m.rc5_param0, &m.rc5_param1, &m.rc5_param2},
            {&m.rc6_param0, &m.rc6_param1, &m.rc6_param2}, {&m.rc7_param0, &m.rc7_param1, &m.rc7_param2},
        };
        *slots[in.rc_servo_num][0] = static_cast<int16_t>(in.rc_param0);
        *slots[in.rc_servo_num][1] = static_cast<int16_t>(in.rc_param1);
        *slots[in.rc_servo_num][2] = static_cast<int16_t>(in.rc_param2);
    }
    *out = m;
    return result;
}

navkit_micro_cmd_t Navigation::teleop(Teleop t, const ConsoleCfg &c, uint16_t dio)
{
    navkit_micro_cmd_t m = neutral(dio);
    switch (t) {
    case Teleop::forward:
    case Teleop::reverse:
        m.fwd_cmd = NAVKIT_FWD_CMD_START;
        m.accel = static_cast<int16_t>(c.teleop_accel);
        m.speed = static_cast<int16_t>(c.teleop_speed);
        m.distance = t == Teleop::forward ? kForever : -kForever;
        break;
    case Teleop::left:
    case Teleop::right:
        m.turn_cmd = NAVKIT_TURN_CMD_TURN;
        m.turn_rate = static_cast<int16_t>(c.teleop_turn_rate);
        m.turn_distance = t == Teleop::right ? kForever : -kForever;  // + is clockwise (right)
        break;
    case Teleop::stop:
        m.fwd_cmd = NAVKIT_FWD_CMD_STOP;
        m.turn_cmd = NAVKIT_TURN_CMD_STOP;
        break;
    case Teleop::none:
        break;
    }
    return m;
}

Navigation::Navigation(const ConsoleCfg &console) : console_(console) {}

void Navigation::init()
{
    result_ = NAVKIT_NAV_RESULT_OK;
    ack_ = 0;
    dio_ = 0;
    mc_datalog_ = 0;
}

NavOutput Navigation::update(const Arbitration &a, std::optional<uint16_t> heading)
{
    NavOutput o;
    if (a.timeout_started) {
        result_ = NAVKIT_NAV_RESULT_PLANNER_TIMEOUT;
    }
    if (a.planner_rejected || a.planner_dropped) {  // judged like any new command: acknowledged
        result_ = NAVKIT_NAV_RESULT_REJECTED;
        ack_ = a.rejected_time_tag;
    }
    if (a.stop) {
        o.is_new = true;
        o.cmd = teleop(Teleop::stop, console_, a.dio);
    } else if (a.planner_new) {
        ack_ = a.planner.time_tag;
        navkit_micro_cmd_t m;
        result_ = convert(a.planner, heading, a.dio, &m);
        heading_missing_ = a.planner.turn_mode == NAVKIT_TURN_MODE_HEADING_HOLD && !heading;
        if (result_ != NAVKIT_NAV_RESULT_REJECTED) {
            o.is_new = true;
            o.cmd = m;
        }
    } else if (a.teleop_new) {
        o.is_new = true;
        o.cmd = teleop(a.teleop, console_, a.dio);
    }
    if (!o.is_new && (a.dio != dio_ || a.mc_datalog != mc_datalog_)) {
        // only the DIO levels or the datalog selection changed: a command that changes
        // nothing else
        o.is_new = true;
        o.cmd = neutral(a.dio);
    }
    if (o.is_new) {
        o.cmd.mc_datalog_cmd = a.mc_datalog;  // every new command carries the selection
        dio_ = o.cmd.dio_command;
        mc_datalog_ = a.mc_datalog;
    }
    return o;
}

}  // namespace navkit
