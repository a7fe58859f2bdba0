/* turn: encoder turns and HdgSel. See turn.h. */
#include "turn.h"

#include <math.h>

#define TURN_HDG_MIN_RATE 0.5f /* deg/s: HdgSel rate floor so the P law arrives */

void turn_reset(turn_t *t, int32_t enc_l, int32_t enc_r)
{
    motion_reset(&t->ax, enc_l, enc_r);
    t->hdg_target = 0.0f;
    t->hdg_rate = 0.0f;
    t->hdg = 0u;
    t->hdg_reached = 0u;
}

void turn_start(turn_t *t, int32_t enc_l, int32_t enc_r, float meas, float target, float vmax, float amax)
{
    t->hdg = 0u;
    t->hdg_reached = 0u;
    motion_start(&t->ax, enc_l, enc_r, meas, target, vmax, amax);
}

motion_result_t turn_modify(turn_t *t, float target, float vmax, float amax)
{
    if (t->hdg) {
        return MOTION_NOT_STARTED;
    }
    return motion_modify(&t->ax, target, vmax, amax);
}

void turn_stop(turn_t *t, float amax, float dt)
{
    t->hdg = 0u;
    t->hdg_reached = 0u;
    motion_stop(&t->ax, amax, dt);
}

void turn_hdg_select(turn_t *t, int32_t enc_l, int32_t enc_r, float meas, float hdg, float heading_now, float vmax,
                     float amax)
{
    float h = hdg - 360.0f * floorf(hdg / 360.0f);
    motion_start(&t->ax, enc_l, enc_r, meas, heading_wrap180(h - heading_now), vmax, amax);
    t->hdg_target = h;
    t->hdg_rate = vmax;
    t->hdg = 1u;
    t->hdg_reached = 0u;
}

uint8_t turn_active(const turn_t *t)
{
    /* a held heading whose reference has arrived, with the robot within tolerance and at
       rest, releases the wheels until the heading drifts out of tolerance */
    return (uint8_t)(t->hdg ? !(t->hdg_reached && !t->ax.prof.moving) : motion_active(&t->ax));
}

float turn_tick(turn_t *t, float meas, float vel_meas, float heading_now, float kp, const config_track_t *k, float dt)
{
    if (t->hdg) {
        /* re-aim the axis at the gyro heading every tick: target = here + heading error
           (both headings 0..360: the near wrap is enough) */
        float err = heading_wrap180_near(t->hdg_target - heading_now);
        float target = meas + err;
        float vmax = kp * fabsf(err);
        if (vmax > t->hdg_rate) {
            vmax = t->hdg_rate;
        }
        if (vmax < TURN_HDG_MIN_RATE) {
            vmax = TURN_HDG_MIN_RATE;
        }
        profile_retarget(&t->ax.prof, target - t->ax.target, vmax, t->ax.prof.amax);
        t->ax.target = target;
        t->ax.done = 0u;
        t->hdg_reached = (uint8_t)(fabsf(err) <= k->tol && fabsf(vel_meas) <= k->vtol);
    }
    return motion_tick(&t->ax, meas, vel_meas, k, dt);
}

motion_result_t turn_micro_cmd(turn_t *t, const navkit_micro_cmd_t *c, const odom_t *o, const heading_t *h,
                               const config_t *cfg)
{
    float accel = motion_limit(0.1f * fabsf((float)c->turn_accel), cfg->default_turn_accel, 1e9f); /* deg/s^2 */
    float rate = motion_limit(0.1f * fabsf((float)c->turn_rate), cfg->default_turn_rate, cfg->max_turn_rate);
    float target = 0.1f * (float)c->turn_distance; /* deg */
    motion_result_t r = MOTION_OK;
    switch (c->turn_cmd) {
    case NAVKIT_TURN_CMD_TURN:
        turn_start(t, o->enc_l, o->enc_r, turn_angle(t, o, cfg->odom.turn_deg_per_count), target, rate, accel);
        r = MOTION_STARTED;
        break;
    case NAVKIT_TURN_CMD_MODIFY:
        r = turn_modify(t, target, rate, accel);
        break;
    case NAVKIT_TURN_CMD_STOP:
        turn_stop(t, accel, cfg->dt);
        break;
    case NAVKIT_TURN_CMD_HDG_SEL:
        turn_hdg_select(t, o->enc_l, o->enc_r, turn_angle(t, o, cfg->odom.turn_deg_per_count), target, heading_deg(h),
                        rate, accel);
        r = MOTION_STARTED;
        break;
    default: /* NAVKIT_TURN_CMD_NONE */
        break;
    }
    if (c->excite_mode != NAVKIT_EXCITE_MODE_NONE) {
        turn_reset(t, o->enc_l, o->enc_r);
    }
    return r;
}
