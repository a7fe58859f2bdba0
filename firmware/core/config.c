/* config: the three config messages. See config.h. */
#include "config.h"

#define CONFIG_PI 3.14159265f
#define CONFIG_RAD_TO_DEG 57.29577951f
#define CONFIG_STILL_S 0.25f /* s: quiet encoders for this long = standing still */

/* Values that depend on both geometry and motion. */
static void config_derive(config_t *c)
{
    c->fwd_track.window = CONFIG_TRACK_WINDOW_MM;
    c->fwd_track.vwindow = CONFIG_TRACK_VWINDOW_MM_S;
    c->fwd_track.tol = c->stop_tolerance;
    c->fwd_track.vtol = CONFIG_DONE_VTOL_MM_S;
    c->turn_track.window = CONFIG_TRACK_WINDOW_MM * c->wheel_deg_per_mm;
    c->turn_track.vwindow = CONFIG_TRACK_VWINDOW_MM_S * c->wheel_deg_per_mm;
    c->turn_track.tol = c->stop_tolerance * c->wheel_deg_per_mm;
    c->turn_track.vtol = CONFIG_DONE_VTOL_MM_S * c->wheel_deg_per_mm;
    wheel_gains_set_dt(&c->wheel, c->dt);
}

void config_reset(config_t *c)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    *c = (config_t){0}; /* config_derive() reads both halves before both are applied */
    navkit_micro_cfg_geometry_defaults(&g);
    navkit_micro_cfg_motion_defaults(&m);
    navkit_micro_cfg_io_defaults(&io);
    if (g.control_rate > CONFIG_RATE_MAX) {
        g.control_rate = CONFIG_RATE_MAX; /* a target below the spec's default 1 kHz starts at its ceiling */
    }
    (void)config_geometry(c, &g);
    (void)config_motion(c, &m);
    (void)config_io(c, &io);
    c->received = 0u;
}

config_result_t config_geometry(config_t *c, const navkit_micro_cfg_geometry_t *m)
{
    float track_mm = 0.1f * (float)m->track_width;
    if (m->spec_hash != NAVKIT_SPEC_HASH) {
        return CONFIG_ERR_HASH;
    }
    /* the spec's ranges and constraints (each sign +1 or -1), then this target's rate ceiling */
    if (navkit_micro_cfg_geometry_check(m, 0) != NAVKIT_OK || m->control_rate > CONFIG_RATE_MAX) {
        return CONFIG_ERR_RANGE;
    }
    c->mm_per_count = CONFIG_PI * 0.01f * (float)m->wheel_diameter / (float)m->counts_per_rev;
    c->gyro_dps_per_lsb = (float)m->gyro_sign / (0.01f * (float)m->gyro_lsb_per_dps);
    c->compass_gain = 0.001f * (float)m->compass_weight;
    c->control_rate = m->control_rate;
    c->dt = 1.0f / (float)m->control_rate;
    c->tick_us = (uint32_t)((1000000ul + m->control_rate / 2u) / m->control_rate);
    c->tick_ms = (uint16_t)(c->tick_us / 1000u);
    c->tick_us_rem = (uint16_t)(c->tick_us % 1000u);
    c->wheel_deg_per_mm = CONFIG_RAD_TO_DEG / (0.5f * track_mm);
    c->wheel_mm_per_deg = 1.0f / c->wheel_deg_per_mm;
    c->turn_rate_per_mm_s = 0.5f * c->wheel_deg_per_mm;
    c->still_ticks = (uint16_t)(CONFIG_STILL_S * (float)m->control_rate + 0.5f);
    c->odom.mm_per_count = c->mm_per_count;
    c->odom.speed_per_count = c->mm_per_count * (float)m->control_rate;
    c->odom.speed_alpha = c->dt / (ODOM_SPEED_TAU_S + c->dt);
    c->odom.turn_deg_per_count = c->mm_per_count / track_mm * CONFIG_RAD_TO_DEG;
    c->odom.sign_l = (int8_t)m->enc_left_sign;
    c->odom.sign_r = (int8_t)m->enc_right_sign;
    c->odom.xy_ticks = (uint8_t)((m->control_rate >= 200u) ? m->control_rate / 100u : 1u); /* ~10 ms */
    c->dt_fold = c->dt * (float)c->odom.xy_ticks;
    c->motor_left_sign = (int8_t)m->motor_left_sign;
    c->motor_right_sign = (int8_t)m->motor_right_sign;
    config_derive(c);
    c->received |= NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK;
    return CONFIG_OK;
}

config_result_t config_motion(config_t *c, const navkit_micro_cfg_motion_t *m)
{
    if (m->spec_hash != NAVKIT_SPEC_HASH) {
        return CONFIG_ERR_HASH;
    }
    if (navkit_micro_cfg_motion_check(m, 0) != NAVKIT_OK) {
        return CONFIG_ERR_RANGE;
    }
    c->default_accel = (float)m->default_accel;
    c->default_speed = (float)m->default_speed;
    c->default_turn_accel = 0.1f * (float)m->default_turn_accel;
    c->default_turn_rate = 0.1f * (float)m->default_turn_rate;
    c->max_speed = (float)m->max_speed;
    c->max_turn_rate = 0.1f * (float)m->max_turn_rate;
    c->wheel.kff = 1e-5f * (float)m->wheel_kff;
    c->wheel.kp = 1e-5f * (float)m->wheel_kp;
    c->wheel.ki = 1e-4f * (float)m->wheel_ki;
    c->wheel.kd = 1e-6f * (float)m->wheel_kd;
    c->wheel.i_limit = 1e-3f * (float)m->wheel_i_limit;
    c->wheel.pwm_limit = 1e-3f * (float)m->pwm_limit;
    c->heading_kp = 0.01f * (float)m->heading_kp;
    c->watchdog_timeout_us = (uint32_t)m->watchdog_timeout * 1000ul;
    c->watchdog_decel = (float)m->watchdog_decel;
    c->stop_tolerance = (float)m->stop_tolerance;
    config_derive(c);
    c->received |= NAVKIT_MICRO_STATUS_CFG_MOTION_OK;
    return CONFIG_OK;
}

config_result_t config_io(config_t *c, const navkit_micro_cfg_io_t *m)
{
    uint8_t i;
    if (m->spec_hash != NAVKIT_SPEC_HASH) {
        return CONFIG_ERR_HASH;
    }
    if (navkit_micro_cfg_io_check(m, 0) != NAVKIT_OK) { /* ranges, and servo_min <= servo_max per servo */
        return CONFIG_ERR_RANGE;
    }
    c->dio_direction = m->dio_direction;
    c->dio_safe_state = m->dio_safe_state;
    c->sensor_enable = m->sensor_enable;
    for (i = 0u; i < SERVO_COUNT; i++) {
        c->servo[i].center_us = m->servo_center[i];
        c->servo[i].us_per_deg_e2 = m->servo_us_per_deg[i];
        c->servo[i].min10 = m->servo_min[i];
        c->servo[i].max10 = m->servo_max[i];
    }
    c->received |= NAVKIT_MICRO_STATUS_CFG_IO_OK;
    return CONFIG_OK;
}
