/* fw: the firmware state and the control tick. See fw.h. */
#include "fw.h"

#include <math.h>

#define FW_DUTY_SCALE 10000.0f /* hal_motor units per duty */
/* mm/s: wheel setpoints below this (both together) count as "commanded to stand" */
#define FW_STILL_SP_MM_S 0.5f
/* Before the tick's loops over its wires (ADC, sonar, servos): unrolled where the compiler
   takes the pragma (GCC 8 and later, clang), each pass is then a hal call with constant
   arguments instead of a loop step around one; elsewhere (avr-gcc 5, where flash counts
   more) an ordinary loop. */
#if defined(__clang__) || (defined(__GNUC__) && __GNUC__ >= 8)
#define FW_UNROLL _Pragma("GCC unroll 8")
#else
#define FW_UNROLL
#endif

void fw_init(fw_t *fw, hal_t *hal)
{
    uint8_t i;
    fw->hal = hal;
    fw->reset_cause = hal_reset_cause(hal);
    config_reset(&fw->cfg);
    link_reset(&fw->link);
    odom_reset(&fw->odom);
    heading_reset(&fw->hdg);
    motion_reset(&fw->fwd, 0, 0);
    turn_reset(&fw->turn, 0, 0);
    wheel_reset(&fw->wheel_l);
    wheel_reset(&fw->wheel_r);
    for (i = 0u; i < SERVO_COUNT; i++) {
        servo_reset(&fw->servo[i]);
        fw->servo_held[i] = 0u;
    }
    dio_reset(&fw->dio);
    watchdog_reset(&fw->wd);
    excite_reset(&fw->excite);
    fw->speed_setpoint_l = 0.0f;
    fw->speed_setpoint_r = 0.0f;
    fw->duty_l = 0;
    fw->duty_r = 0;
    for (i = 0u; i < FW_ADC_CHANNELS; i++) {
        fw->adc[i] = 0u;
    }
    for (i = 0u; i < 4u; i++) {
        fw->sonar[i] = 0u;
    }
    fw->compass = 0u;
    fw->gyro_raw = 0;
    fw->watchdog_stops = 0u;
    fw->ms = 0u;
    fw->us_frac = 0u;
    fw->wd_stop = 0u;
    fw->limited = 0u;
    fw->servo_next = 0u;
    fw->held = 0u; /* the first tick writes every output */
    fw->dio_dir_held = 0u;
    fw->dio_out_held = 0u;
    fw->slow_tick = 0u;
}

uint32_t fw_tick_period_us(const fw_t *fw)
{
    return fw->cfg.tick_us;
}

void fw_link_poll(fw_t *fw)
{
    link_poll(fw);
}

uint8_t fw_link_pending(const fw_t *fw)
{
    return link_pending(fw);
}

uint16_t fw_status(const fw_t *fw)
{
    uint16_t s = fw->cfg.received;
    if (config_complete(&fw->cfg)) {
        s |= NAVKIT_MICRO_STATUS_CONFIGURED;
    }
    if (fw->wd_stop) {
        s |= NAVKIT_MICRO_STATUS_WATCHDOG_STOP;
    }
    if (fw->fwd.started && fw->fwd.done) {
        s |= NAVKIT_MICRO_STATUS_FWD_DONE;
    }
    if ((fw->turn.ax.started && fw->turn.ax.done && !fw->turn.hdg) || fw->turn.hdg_reached) {
        s |= NAVKIT_MICRO_STATUS_TURN_DONE;
    }
    if (fw->fwd.latched) {
        s |= NAVKIT_MICRO_STATUS_FWD_STOP_LATCHED;
    }
    if (fw->turn.ax.latched) {
        s |= NAVKIT_MICRO_STATUS_TURN_STOP_LATCHED;
    }
    if (fw->hdg.calibrating) {
        s |= NAVKIT_MICRO_STATUS_GYRO_CALIBRATING;
    }
    if (fw->turn.hdg) {
        s |= NAVKIT_MICRO_STATUS_HDG_ACTIVE;
    }
    if (fw->turn.hdg_reached) {
        s |= NAVKIT_MICRO_STATUS_HDG_HOLD;
    }
    if (fw->limited) {
        s |= NAVKIT_MICRO_STATUS_SPEED_LIMITED;
    }
    if (excite_active(&fw->excite)) {
        s |= NAVKIT_MICRO_STATUS_EXCITE_ACTIVE;
    }
    return s;
}

void fw_config_applied(fw_t *fw, uint16_t msg_type)
{
    uint8_t i;
    if (msg_type == NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY) {
        for (i = 0u; i < SERVO_COUNT; i++) {
            servo_retime(&fw->servo[i], fw->cfg.control_rate);
        }
        /* a slow_tick left at or above a shorter xy_ticks would put the next fold one
           tick late */
        fw->slow_tick = 0u;
    } else if (msg_type == NAVKIT_MSG_TYPE_MICRO_CFG_IO) {
        dio_configure(&fw->dio, fw->cfg.dio_direction, fw->cfg.dio_safe_state);
    }
}

void fw_watchdog_stop(fw_t *fw)
{
    uint8_t i;
    /* the same wheel deceleration for the turn: mm/s^2 at the wheel -> deg/s^2 */
    float turn_decel = fw->cfg.watchdog_decel * fw->cfg.wheel_deg_per_mm;
    motion_stop(&fw->fwd, fw->cfg.watchdog_decel, fw->cfg.dt);
    turn_stop(&fw->turn, turn_decel, fw->cfg.dt);
    excite_stop(&fw->excite); /* open loop: duty 0 from the next tick */
    for (i = 0u; i < SERVO_COUNT; i++) {
        servo_hold(&fw->servo[i]);
    }
    dio_safe(&fw->dio);
    fw->wd_stop = 1u;
    fw->watchdog_stops++;
}

/* Inputs, once each, at the start of the tick; disabled sensors read as 0. */
static void fw_sample(fw_t *fw, int32_t *enc_l, int32_t *enc_r)
{
    uint8_t i;
    uint16_t en = fw->cfg.sensor_enable;
    uint16_t compass;
    *enc_l = hal_enc_left(fw->hal);
    *enc_r = hal_enc_right(fw->hal);
    fw->gyro_raw = hal_gyro_raw(fw->hal);
    compass = hal_compass(fw->hal);
    fw->compass = (en & NAVKIT_SENSOR_ENABLE_COMPASS) ? compass : 0u;
    FW_UNROLL
    for (i = 0u; i < FW_ADC_CHANNELS; i++) {
        uint16_t v = hal_adc(fw->hal, i);
        /* ch0-3 IR (enable bits 0-3), ch4 battery */
        uint8_t on = (i < 4u) ? (uint8_t)((en >> i) & 1u) : (uint8_t)((en & NAVKIT_SENSOR_ENABLE_BATTERY) != 0u);
        fw->adc[i] = on ? v : 0u;
    }
    FW_UNROLL
    for (i = 0u; i < 4u; i++) {
        uint16_t v = hal_sonar_echo(fw->hal, i);
        fw->sonar[i] = ((en >> (4u + i)) & 1u) ? v : 0u;
    }
    fw->dio.in = (uint16_t)(hal_dio_in(fw->hal) & DIO_MASK);
}

/* duty (-1..1) -> hal_motor units with the motor sign, rounded half away from zero */
static int16_t fw_duty_e4(float duty, int8_t sign)
{
    float d = duty * FW_DUTY_SCALE;
    int16_t k = (int16_t)((d >= 0.0f) ? d + 0.5f : d - 0.5f);
    return (sign < 0) ? (int16_t)-k : k;
}

void fw_tick(fw_t *fw)
{
    const config_t *c = &fw->cfg;
    float dt = c->dt;
    float v_fwd, w_turn, half; /* mm/s, deg/s, mm/s */
    float ex_l, ex_r;          /* duty: an excitation's wheel duties */
    int32_t raw_l, raw_r;
    uint8_t still, i, fold, excited;

    fw_sample(fw, &raw_l, &raw_r);
    /* the slow steps (estimation only, nothing re-planned): the heading fold on the first tick
       of the ~10 ms slow period, the X/Y step when due on any other, so at 200 Hz and
       above a tick pays for at most one of them (below, the period is one tick and both
       run every tick) */
    fold = (uint8_t)(fw->slow_tick == 0u);

    /* estimation */
    odom_count(&fw->odom, &c->odom, raw_l, raw_r, heading_deg(&fw->hdg));
    /* standing still: judged from the wheels (encoders quiet, setpoints ~0), not from
       whether a mode is active, so a held HdgSel or a finished move keeps the bias fresh
       (the integer tests first: the float sum only once the encoders are quiet) */
    still = (uint8_t)(fw->odom.still_ticks > 0u && (fw->hdg.calibrating || fw->odom.still_ticks >= c->still_ticks) &&
                      fabsf(fw->speed_setpoint_l) + fabsf(fw->speed_setpoint_r) < FW_STILL_SP_MM_S);
    heading_update(&fw->hdg, fw->gyro_raw, c->gyro_dps_per_lsb, still, c->control_rate, dt);
    /* fold the integrated angle into the fixed-point heading, with compass fusion over
       dt_fold if enabled (the pull is slow, gain <= 1/s, and the compass slower still) */
    if (fold) {
        if ((c->sensor_enable & NAVKIT_SENSOR_ENABLE_COMPASS) && c->compass_gain > 0.0f && !fw->hdg.calibrating) {
            heading_fuse(&fw->hdg, fw->compass, c->compass_gain, c->dt_fold);
        } else {
            heading_fold(&fw->hdg);
        }
    }

    /* link silence */
    if (config_complete(c) && watchdog_tick(&fw->wd, c->tick_us, c->watchdog_timeout_us)) {
        fw_watchdog_stop(fw);
    }

    /* motion, every tick: forward + turn re-planned from the measured state -> wheel
       setpoints -> wheel loops; an idle axis is not measured (its tick reads nothing) */
    if (motion_active(&fw->fwd)) {
        v_fwd = motion_tick(&fw->fwd, fw_fwd_distance(fw), 0.5f * (fw->odom.v_l + fw->odom.v_r), &c->fwd_track, dt);
    } else {
        v_fwd = motion_tick_idle(&fw->fwd);
    }
    if (turn_ticking(&fw->turn)) {
        w_turn = turn_tick(&fw->turn, fw_turn_angle(fw), (fw->odom.v_l - fw->odom.v_r) * c->turn_rate_per_mm_s,
                           heading_deg(&fw->hdg), c->heading_kp, &c->turn_track, dt);
    } else {
        w_turn = motion_tick_idle(&fw->turn.ax);
    }
    /* an excitation runs open loop: the loops idle (their duty shows the excitation's to
       the datalog); with no excitation and no motion everything is 0 (an idle excitation
       costs the one compare of excite_active) */
    excited = (uint8_t)(excite_active(&fw->excite) && excite_tick(&fw->excite, c->wheel.pwm_limit, &ex_l, &ex_r));
    if (excited || !(motion_active(&fw->fwd) || turn_active(&fw->turn))) {
        fw->speed_setpoint_l = 0.0f;
        fw->speed_setpoint_r = 0.0f;
        wheel_reset(&fw->wheel_l); /* duty 0 */
        wheel_reset(&fw->wheel_r);
        fw->duty_l = 0;
        fw->duty_r = 0;
        if (excited) {
            fw->wheel_l.duty = ex_l;
            fw->wheel_r.duty = ex_r;
            fw->duty_l = fw_duty_e4(ex_l, c->motor_left_sign);
            fw->duty_r = fw_duty_e4(ex_r, c->motor_right_sign);
        }
    } else {
        half = w_turn * c->wheel_mm_per_deg; /* mm/s at each wheel */
        fw->speed_setpoint_l = v_fwd + half;
        fw->speed_setpoint_r = v_fwd - half;
        fw->duty_l = fw_duty_e4(wheel_update(&fw->wheel_l, &c->wheel, fw->speed_setpoint_l, fw->odom.v_l),
                                c->motor_left_sign);
        fw->duty_r = fw_duty_e4(wheel_update(&fw->wheel_r, &c->wheel, fw->speed_setpoint_r, fw->odom.v_r),
                                c->motor_right_sign);
    }
    if ((!fold || c->odom.xy_ticks == 1u) && odom_xy_due(&fw->odom, &c->odom)) {
        odom_xy_step(&fw->odom, &c->odom, heading_deg(&fw->hdg));
    }
    fw->slow_tick = (uint8_t)((fw->slow_tick + 1u < c->odom.xy_ticks) ? fw->slow_tick + 1u : 0u);
    /* each flag is 0 or 1 */
    fw->limited = (uint8_t)(fw->fwd.limited | fw->turn.ax.limited | fw->wheel_l.saturated | fw->wheel_r.saturated);

    /* the moving servos step (servo_step() leaves the others as they are); one servo's
       pulse width is refreshed per tick: each every 8 ticks */
    FW_UNROLL
    for (i = 0u; i < SERVO_COUNT; i++) {
        if (servo_moving(&fw->servo[i])) {
            servo_step(&fw->servo[i], &c->servo[i]);
        }
    }
    fw->servo_next = (uint8_t)((fw->servo_next + 1u) % SERVO_COUNT);
    if (fw->servo[fw->servo_next].mode != SERVO_OFF) {
        servo_update_pulse(&fw->servo[fw->servo_next], &c->servo[fw->servo_next]);
    }

    /* uptime */
    fw->us_frac = (uint16_t)(fw->us_frac + c->tick_us_rem);
    fw->ms += c->tick_ms;
    if (fw->us_frac >= 1000u) {
        fw->us_frac = (uint16_t)(fw->us_frac - 1000u);
        fw->ms++;
    }

    /* outputs, at the end of the tick: the motors every tick, a servo pulse and the DIO
       when they change (the target holds each output; hal.h, ordering contract 2) */
    hal_motor(fw->hal, fw->duty_l, fw->duty_r);
    FW_UNROLL
    for (i = 0u; i < SERVO_COUNT; i++) {
        uint16_t us = servo_pulse_us(&fw->servo[i]);
        if (!fw->held || us != fw->servo_held[i]) {
            fw->servo_held[i] = us;
            hal_servo_pulse(fw->hal, i, us);
        }
    }
    if (!fw->held || fw->dio.dir != fw->dio_dir_held || fw->dio.out != fw->dio_out_held) {
        fw->dio_dir_held = fw->dio.dir;
        fw->dio_out_held = fw->dio.out;
        hal_dio_write(fw->hal, fw->dio.dir, fw->dio.out);
    }
    fw->held = 1u;
}
