#include "navkit/navigation.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

namespace navkit {

static const int32_t kForever = 2000000000; // the seed's "very large distance"

std::string Conversion::text() const
{
    // "<lisp_cmd field> <code> (<name>)" for the enums the conversion branches on
    auto code = [](int field, int64_t v) {
        const char *name = field == NAVKIT_LISP_CMD_FIELD_FWD_CMD     ? navkit_fwd_cmd_name(v)
                           : field == NAVKIT_LISP_CMD_FIELD_TURN_MODE ? navkit_turn_mode_name(v)
                                                                      : nullptr;
        std::string s = std::string(navkit_lisp_cmd_field_name(field)) + " " + std::to_string(v);
        return name ? s + " (" + name + ")" : s;
    };
    const std::string v = std::to_string(value);
    switch (refusal) {
    case Refusal::none:
        return "";
    case Refusal::code:
        return v + " is no " + navkit_lisp_cmd_field_name(lisp_field) + " code the host converts";
    case Refusal::range:
        return v + " is outside " + std::to_string(navkit_micro_cmd_field_min(micro_field)) + ".." +
               std::to_string(navkit_micro_cmd_field_max(micro_field)) + " (" +
               navkit_micro_cmd_field_units(micro_field) + "), the range of micro_cmd." +
               navkit_micro_cmd_field_name(micro_field) + " it is copied to for " + code(cause_field, cause);
    case Refusal::heading_range:
        return v + " is outside 0.." + std::to_string(Navigation::kFullTurn) + " (" +
               navkit_lisp_cmd_field_units(lisp_field) + "), the headings of " + code(cause_field, cause);
    case Refusal::heading_missing:
        return "heading hold (turn mode " + std::to_string(cause) +
               ") needs the micro's current heading, and no fresh micro_data has come (micro offline): send it "
               "again later";
    }
    return "";
}

navkit_micro_cmd_t Navigation::neutral(uint16_t dio)
{
    navkit_micro_cmd_t m;
    navkit_micro_cmd_defaults(&m); // fwd none, turn none, no servo command
    m.dio_command = dio;
    return m;
}

namespace {

// A rejection of lisp_cmd field `lisp` (value v) for reason `why`, caused by lisp_cmd
// field `cause_field` holding `cause`; micro: the micro_cmd field of a range refusal.
Conversion refuse(Refusal why, int lisp, int64_t v, int cause_field, int64_t cause, int micro = -1)
{
    Conversion c;
    c.nav_result = NAVKIT_NAV_RESULT_REJECTED;
    c.refusal = why;
    c.lisp_field = lisp;
    c.value = v;
    c.micro_field = micro;
    c.cause_field = cause_field;
    c.cause = cause;
    return c;
}

// The first of lisp_cmd fields lisp[i] (values v[i]) that does not fit the spec range of
// micro_cmd field micro[i], as a range refusal caused by cause_field = cause; none: nav ok.
template <size_t N>
Conversion fit(const int (&lisp)[N], const int32_t (&v)[N], const int (&micro)[N], int cause_field, int64_t cause)
{
    for (size_t i = 0; i < N; i++) {
        if (!navkit_micro_cmd_in_range(micro[i], v[i])) {
            return refuse(Refusal::range, lisp[i], v[i], cause_field, cause, micro[i]);
        }
    }
    return Conversion{};
}

// micro_cmd's servo slots: [n][k] = NAVKIT_MICRO_CMD_FIELD_* of rc<n>_param<k>, n up to
// the spec's last servo (the first n without an rc<n>_param0 field ends them); the spec
// names the slots, so a servo number is one of the micro's when its slot exists.
struct ServoSlots {
    int field[NAVKIT_MICRO_CMD_FIELD_COUNT / 3 + 1][3]; // at most every field a slot
    int count = 0;
    ServoSlots()
    {
        for (; count < NAVKIT_MICRO_CMD_FIELD_COUNT / 3 + 1; count++) {
            for (int k = 0; k < 3; k++) {
                const std::string name = "rc" + std::to_string(count) + "_param" + std::to_string(k);
                field[count][k] = navkit_micro_cmd_field_index(name.c_str());
            }
            if (field[count][0] < 0) {
                break;
            }
        }
    }
};

const ServoSlots &servo_slots()
{
    static const ServoSlots slots;
    return slots;
}

} // namespace

Conversion Navigation::convert(const navkit_lisp_cmd_t &in, std::optional<uint16_t> heading, uint16_t dio,
                               navkit_micro_cmd_t *out)
{
    navkit_micro_cmd_t m = neutral(dio);
    Conversion result;
    switch (in.fwd_cmd) {
    case NAVKIT_FWD_CMD_NONE:
        break;
    case NAVKIT_FWD_CMD_START:
    case NAVKIT_FWD_CMD_MODIFY:
    case NAVKIT_FWD_CMD_STOP: {
        // raw values copied unscaled (the same units on both sides) into narrower words
        const Conversion c = fit({NAVKIT_LISP_CMD_FIELD_ACCEL, NAVKIT_LISP_CMD_FIELD_SPEED}, {in.accel, in.speed},
                                 {NAVKIT_MICRO_CMD_FIELD_ACCEL, NAVKIT_MICRO_CMD_FIELD_SPEED},
                                 NAVKIT_LISP_CMD_FIELD_FWD_CMD, in.fwd_cmd);
        if (c.refusal != Refusal::none) {
            return c;
        }
        m.fwd_cmd = static_cast<uint16_t>(in.fwd_cmd);
        m.accel = static_cast<int16_t>(in.accel);
        m.speed = static_cast<int16_t>(in.speed);
        m.distance = in.distance;
        break;
    }
    case NAVKIT_FWD_CMD_CONTEST_HALLWAY:
    case NAVKIT_FWD_CMD_CONTEST_START_CIRCLE:
    case NAVKIT_FWD_CMD_EXPLORE:
        result.nav_result = NAVKIT_NAV_RESULT_NOT_IMPLEMENTED; // high level: no forward motion
        break;
    default:
        return refuse(Refusal::code, NAVKIT_LISP_CMD_FIELD_FWD_CMD, in.fwd_cmd, -1, 0);
    }

    const int turn = NAVKIT_LISP_CMD_FIELD_TURN_MODE;
    if (in.turn_mode != NAVKIT_TURN_MODE_NONE) {
        const Conversion c = fit(
            {NAVKIT_LISP_CMD_FIELD_TURN_ACCEL, NAVKIT_LISP_CMD_FIELD_TURN_RATE}, {in.turn_accel, in.turn_rate},
            {NAVKIT_MICRO_CMD_FIELD_TURN_ACCEL, NAVKIT_MICRO_CMD_FIELD_TURN_RATE}, turn, in.turn_mode);
        if (c.refusal != Refusal::none) {
            return c;
        }
    }
    switch (in.turn_mode) {
    case NAVKIT_TURN_MODE_NONE:
        break;
    case NAVKIT_TURN_MODE_TURN:
    case NAVKIT_TURN_MODE_MODIFY:
    case NAVKIT_TURN_MODE_STOP:
        m.turn_cmd = static_cast<uint16_t>(in.turn_mode);
        m.turn_distance = in.turn_distance; // int32 to int32: any angle fits
        break;
    case NAVKIT_TURN_MODE_HEADING_SELECT:
        // 0..kFullTurn deg x 10 on both sides (docs/protocol.md seed slips): passed through
        if (in.turn_distance < 0 || in.turn_distance > kFullTurn) {
            return refuse(Refusal::heading_range, NAVKIT_LISP_CMD_FIELD_TURN_DISTANCE, in.turn_distance, turn,
                          in.turn_mode);
        }
        m.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
        m.turn_distance = in.turn_distance;
        break;
    case NAVKIT_TURN_MODE_HEADING_HOLD: {
        // HdgSel to the heading at arrival plus word 9, wrapped to 0..kFullTurn-1; no
        // heading known (no fresh micro_data): rejected, never a hold of heading 0
        if (!heading) {
            return refuse(Refusal::heading_missing, turn, in.turn_mode, turn, in.turn_mode);
        }
        const int64_t h = (static_cast<int64_t>(*heading) + in.turn_distance) % kFullTurn;
        m.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
        m.turn_distance = static_cast<int32_t>(h < 0 ? h + kFullTurn : h);
        break;
    }
    default:
        return refuse(Refusal::code, turn, in.turn_mode, -1, 0);
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

    // RC servo: rc_servo_num one of micro_cmd's slots and param0 (rate) not 0: params
    // 0..2 to rc<N>_param0..2; else no effect
    const ServoSlots &slots = servo_slots();
    if (in.rc_servo_num >= 0 && in.rc_servo_num < slots.count && in.rc_param0 != 0) {
        const int(&f)[3] = slots.field[in.rc_servo_num];
        const Conversion c = fit(
            {NAVKIT_LISP_CMD_FIELD_RC_PARAM0, NAVKIT_LISP_CMD_FIELD_RC_PARAM1, NAVKIT_LISP_CMD_FIELD_RC_PARAM2},
            {in.rc_param0, in.rc_param1, in.rc_param2}, {f[0], f[1], f[2]}, NAVKIT_LISP_CMD_FIELD_RC_SERVO_NUM,
            in.rc_servo_num);
        if (c.refusal != Refusal::none) {
            return c;
        }
        navkit_micro_cmd_set(&m, f[0], 0, in.rc_param0);
        navkit_micro_cmd_set(&m, f[1], 0, in.rc_param1);
        navkit_micro_cmd_set(&m, f[2], 0, in.rc_param2);
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
        m.turn_distance = t == Teleop::right ? kForever : -kForever; // + is clockwise (right)
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
    result_ = Conversion{};
    ack_ = 0;
    dio_ = 0;
    mc_datalog_ = 0;
}

NavOutput Navigation::update(const Arbitration &a, std::optional<uint16_t> heading)
{
    NavOutput o;
    if (a.timeout_started) {
        result_ = Conversion{};
        result_.nav_result = NAVKIT_NAV_RESULT_PLANNER_TIMEOUT;
    }
    if (a.planner_rejected || a.planner_dropped) { // judged like any new command: acknowledged
        result_ = Conversion{};
        result_.nav_result = NAVKIT_NAV_RESULT_REJECTED;
        ack_ = a.rejected_time_tag;
    }
    if (a.stop) {
        o.is_new = true;
        o.cmd = teleop(Teleop::stop, console_, a.dio);
    } else if (a.planner_new) {
        ack_ = a.planner.time_tag;
        navkit_micro_cmd_t m;
        result_ = convert(a.planner, heading, a.dio, &m);
        if (result_.nav_result != NAVKIT_NAV_RESULT_REJECTED) {
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
        o.cmd.mc_datalog_cmd = a.mc_datalog; // every new command carries the selection
        dio_ = o.cmd.dio_command;
        mc_datalog_ = a.mc_datalog;
    }
    return o;
}

} // namespace navkit
