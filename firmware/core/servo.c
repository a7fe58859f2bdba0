/* servo: RC servo GoTo and Scan. See servo.h. */
#include "servo.h"

#include <stddef.h>

static int16_t servo_clamp(const servo_cal_t *cal, int16_t a10)
{
    if (a10 < cal->min10) {
        return cal->min10;
    }
    if (a10 > cal->max10) {
        return cal->max10;
    }
    return a10;
}

void servo_reset(servo_t *s)
{
    s->pos = 0;
    s->step = 0;
    s->goal = 0;
    s->right = 0;
    s->left = 0;
    s->rate = 0u;
    s->pulse = 0u;
    s->mode = SERVO_OFF;
}

void servo_retime(servo_t *s, uint16_t rate_hz)
{
    /* deg*10/s -> deg*10*Q per tick, at least 1 so a move always ends */
    s->step = (int32_t)((int32_t)s->rate * SERVO_Q / (int32_t)rate_hz);
    if (s->step < 1) {
        s->step = 1;
    }
}

void servo_command(servo_t *s, const servo_cal_t *cal, int16_t p0, int16_t p1, int16_t p2, uint16_t rate_hz)
{
    if (p0 <= 0) {
        return;
    }
    s->rate = (uint16_t)p0;
    servo_retime(s, rate_hz);
    if (p2 == SERVO_GOTO_FLAG) {
        s->goal = servo_clamp(cal, p1);
        s->mode = SERVO_GOTO;
    } else {
        s->right = servo_clamp(cal, p1);
        s->left = servo_clamp(cal, p2);
        s->goal = s->right;
        s->mode = SERVO_SCAN;
    }
    servo_update_pulse(s, cal);
}

void servo_hold(servo_t *s)
{
    if (s->mode != SERVO_OFF) {
        s->mode = SERVO_HOLD;
    }
}

void servo_step(servo_t *s, const servo_cal_t *cal)
{
    int32_t goal;
    if (!servo_moving(s)) {
        return;
    }
    goal = (int32_t)servo_clamp(cal, s->goal) * SERVO_Q;
    if (s->pos < goal) {
        s->pos = (goal - s->pos > s->step) ? s->pos + s->step : goal;
    } else if (s->pos > goal) {
        s->pos = (s->pos - goal > s->step) ? s->pos - s->step : goal;
    }
    if (s->pos == goal) {
        if (s->mode == SERVO_GOTO) {
            s->mode = SERVO_HOLD;
        } else if (s->left != s->right) {
            s->goal = (s->goal == s->right) ? s->left : s->right;
        }
    }
}

int16_t servo_pos10(const servo_t *s)
{
    int32_t p = s->pos;
    return (int16_t)((p >= 0) ? (p + SERVO_Q / 2) / SERVO_Q : (p - SERVO_Q / 2) / SERVO_Q);
}

void servo_update_pulse(servo_t *s, const servo_cal_t *cal)
{
    int32_t us;
    if (s->mode == SERVO_OFF) {
        return; /* pulse stays 0 (servo_pulse_us()) */
    }
    /* deg*10 * (0.01 us/deg) / 1000 = us */
    us = (int32_t)cal->center_us + ((int32_t)servo_pos10(s) * (int32_t)cal->us_per_deg_e2) / 1000L;
    s->pulse = (us < 0) ? 0u : (uint16_t)us;
}

void servo_micro_cmd(servo_t s[SERVO_COUNT], const servo_cal_t cal[SERVO_COUNT], const navkit_micro_cmd_t *c,
                     uint16_t rate_hz)
{
    /* where each servo's param0 sits in the command: param1 and param2 follow it (three
       int16 fields in a row, words N, N+1, N+2); a table instead of 24 copies keeps the AVR
       image small */
    static const uint8_t rc_at[SERVO_COUNT] = {
        offsetof(navkit_micro_cmd_t, rc0_param0), offsetof(navkit_micro_cmd_t, rc1_param0),
        offsetof(navkit_micro_cmd_t, rc2_param0), offsetof(navkit_micro_cmd_t, rc3_param0),
        offsetof(navkit_micro_cmd_t, rc4_param0), offsetof(navkit_micro_cmd_t, rc5_param0),
        offsetof(navkit_micro_cmd_t, rc6_param0), offsetof(navkit_micro_cmd_t, rc7_param0),
    };
    uint8_t i;
    for (i = 0u; i < SERVO_COUNT; i++) {
        const int16_t *rc = (const int16_t *)(const void *)((const uint8_t *)c + rc_at[i]);
        servo_command(&s[i], &cal[i], rc[0], rc[1], rc[2], rate_hz);
    }
}
