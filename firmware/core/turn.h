/* turn: turning by encoder degrees (cmd 1/3/5) and HdgSel to a gyro heading (cmd 10)
 * (prefix turn_).
 *
 * Angles are deg, clockwise positive looking down, also when reversing. The turn rate
 * is added to the forward motion as a wheel-speed difference, so a robot that is not
 * moving forward pivots in place. HdgSel keeps steering to its heading (heading hold)
 * until a turn stop or a new turn start; it is "reached" within tolerance.
 */
#ifndef NAVKIT_TURN_H
#define NAVKIT_TURN_H

#include <stdint.h>

#include "config.h"
#include "heading.h"
#include "motion.h"
#include "navkit/navkit_proto.h"
#include "odom.h"

typedef struct {
    motion_t ax;         /* the turn axis, deg from the turn reference */
    float hdg_target;    /* deg, 0..360: HdgSel heading */
    float hdg_rate;      /* deg/s: HdgSel rate limit */
    uint8_t hdg;         /* 1 while HdgSel steers */
    uint8_t hdg_reached; /* 1 while HdgSel is within tolerance and at rest */
} turn_t;

/* The turn axis's part of a checked micro_cmd c, on t: turn_cmd 1 turns (turn_distance,
 * deg*10, from a new reference at the encoder counts of o), 3 modifies, 5 stops (at
 * turn_accel, with the tick cfg->dt, s), 10 HdgSel steers to heading turn_distance (deg*10)
 * from the heading of h, others do nothing; the limits are |turn_accel| (deg*10/s^2) and
 * |turn_rate| (deg*10/s), or cfg's defaults for a word of 0, the rate at most
 * cfg->max_turn_rate. An experiment (excite_mode 1-3; the check keeps turn_cmd 0 with it)
 * leaves the axis idle with its reference at the encoder counts of o (the turn angle counts
 * from the experiment's start). Returns MOTION_STARTED for a turn 1 or a HdgSel,
 * turn_modify()'s result for a modify, else MOTION_OK. */
motion_result_t turn_micro_cmd(turn_t *t, const navkit_micro_cmd_t *c, const odom_t *o, const heading_t *h,
                               const config_t *cfg);
/* The turn axis t's measured turn angle (deg, clockwise) from its reference: the wheels'
 * travel difference in o since the reference counts, deg_per_count (deg per count of
 * left-minus-right difference). */
static inline float turn_angle(const turn_t *t, const odom_t *o, float deg_per_count)
{
    return odom_turn(o, t->ax.ref_l, t->ax.ref_r, deg_per_count);
}
/* Idle, no reference (reference counts = enc_l/enc_r, counts). */
void turn_reset(turn_t *t, int32_t enc_l, int32_t enc_r);
/* Turn 1: new reference at enc_l/enc_r (counts); meas (deg) is the turn angle from the
 * old reference; target (deg, + clockwise), vmax (deg/s), amax (deg/s^2). */
void turn_start(turn_t *t, int32_t enc_l, int32_t enc_r, float meas, float target, float vmax, float amax);
/* Turn 3: new target (deg from the turn-1 reference), vmax (deg/s), amax (deg/s^2).
 * MOTION_NOT_STARTED while HdgSel steers (there is no turn 1 to modify). */
motion_result_t turn_modify(turn_t *t, float target, float vmax, float amax);
/* Turn 5 (or the watchdog): decelerate at amax (deg/s^2) with tick dt (s); latch; ends
 * HdgSel. */
void turn_stop(turn_t *t, float amax, float dt);
/* HdgSel: new reference at enc_l/enc_r (counts), meas (deg) as in turn_start; steer the
 * shortest way to heading hdg (deg, any value, wrapped) from the current heading
 * heading_now (deg); vmax (deg/s), amax (deg/s^2). */
void turn_hdg_select(turn_t *t, int32_t enc_l, int32_t enc_r, float meas, float hdg, float heading_now, float vmax,
                     float amax);
/* 1 while the turn wants the wheels driven (HdgSel: while off its heading or moving). */
uint8_t turn_active(const turn_t *t);
/* One tick: meas (deg) turn angle from the reference, vel_meas (deg/s) measured turn
 * rate, heading_now (deg) gyro heading, kp ((deg/s)/deg) HdgSel gain, k the re-plan window
 * and "done" limits (deg, deg/s; HdgSel is reached within k->tol and k->vtol), dt (s).
 * Returns the reference turn rate (deg/s, clockwise). */
float turn_tick(turn_t *t, float meas, float vel_meas, float heading_now, float kp, const config_track_t *k, float dt);
/* 1 while turn_tick() has work (HdgSel steers, or the axis is motion_active()); otherwise
 * turn_tick() is motion_tick_idle() of the axis and reads none of its measurements. */
static inline uint8_t turn_ticking(const turn_t *t)
{
    return (uint8_t)(t->hdg || motion_active(&t->ax));
}

#endif /* NAVKIT_TURN_H */
