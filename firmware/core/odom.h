/* odom: encoder distance, encoder turn angle, wheel speeds and X/Y odometry (prefix odom_).
 *
 * Frame: X along heading 0, Y along heading 270 (to the left of heading 0); heading is
 * clockwise positive, so at reset (heading 0) X is forward and Y is left. X/Y advance in
 * steps of about 10 ms (odom_geom_t.xy_ticks) along the mid-step heading, so the sine and
 * cosine are not paid every tick.
 */
#ifndef NAVKIT_ODOM_H
#define NAVKIT_ODOM_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

/* Geometry in working units, computed once per config (no division per tick). */
typedef struct {
    float mm_per_count;       /* mm of wheel travel per count */
    float speed_per_count;    /* mm/s per count moved in one tick (mm_per_count / dt) */
    float speed_alpha;        /* wheel-speed low-pass coefficient per tick, dt / (tau + dt) */
    float turn_deg_per_count; /* deg of turn per count of (left - right) difference */
    int8_t sign_l;            /* +1/-1: enc_left_sign */
    int8_t sign_r;            /* +1/-1: enc_right_sign */
    uint8_t xy_ticks;         /* ticks per X/Y step, >= 1 */
} odom_geom_t;

typedef struct {
    int32_t enc_l;        /* counts: left encoder, sign-corrected, since reset */
    int32_t enc_r;        /* counts: right encoder, sign-corrected, since reset */
    int32_t raw_l;        /* counts: last raw left reading */
    int32_t raw_r;        /* counts: last raw right reading */
    float v_l;            /* mm/s: left wheel speed, low-pass filtered */
    float v_r;            /* mm/s: right wheel speed, low-pass filtered */
    int32_t x;            /* mm: X, whole part */
    int32_t y;            /* mm: Y, whole part */
    float x_frac;         /* mm: X residual, -0.5..0.5 */
    float y_frac;         /* mm: Y residual, -0.5..0.5 */
    int32_t xy_sum;       /* counts: left + right counts of the X/Y step in progress */
    float xy_h0;          /* deg: heading at its start */
    uint16_t still_ticks; /* ticks since an encoder last changed (capped) */
    uint8_t xy_n;         /* ticks in the X/Y step in progress (0 = none) */
    uint8_t primed;       /* raw_* hold a reading */
} odom_t;

/* Wheel-speed low-pass time constant, s. */
#define ODOM_SPEED_TAU_S 0.01f

/* Counts and X/Y zero, not primed (the first update only takes the raw readings). */
void odom_reset(odom_t *o);
/* Every tick: counts, wheel speeds, standstill, the X/Y step in progress; raw_l/raw_r
 * (counts, raw sign), heading_deg (deg, clockwise, 0..360). */
void odom_count(odom_t *o, const odom_geom_t *g, int32_t raw_l, int32_t raw_r, float heading_deg);
/* 1 when the X/Y step in progress has xy_ticks ticks or more (fw.c runs it on the next
 * tick that is not a fold's, so it waits one tick at most). */
static inline uint8_t odom_xy_due(const odom_t *o, const odom_geom_t *g)
{
    return (uint8_t)(o->xy_n >= g->xy_ticks);
}
/* The X/Y half: finish the step in progress at heading_deg (deg, clockwise, 0..360). */
void odom_xy_step(odom_t *o, const odom_geom_t *g, float heading_deg);
/* Counts moved since the reference count ref (counts), wrap-safe (inline: the tick
 * measures both axes with it). */
static inline int32_t odom_counts_since(int32_t now, int32_t ref)
{
    /* modulo 2^32, then back to signed without overflow */
    uint32_t d = (uint32_t)now - (uint32_t)ref;
    return (d <= 0x7FFFFFFFul) ? (int32_t)d : -(int32_t)(~d) - 1;
}
/* Distance (mm) moved since the reference counts ref_l/ref_r: mean of the wheels;
 * mm_per_count (mm per count). */
float odom_distance(const odom_t *o, int32_t ref_l, int32_t ref_r, float mm_per_count);
/* Turn angle (deg, clockwise) since the reference counts; deg_per_count (deg per count
 * of left-right difference). */
float odom_turn(const odom_t *o, int32_t ref_l, int32_t ref_r, float deg_per_count);
/* Set X/Y (mm); a partial X/Y step is dropped. */
void odom_set_xy(odom_t *o, int32_t x, int32_t y);
/* The odometry's part of a checked micro_cmd c: with dg_control's set_xy bit, X/Y become
 * x_set/y_set (mm), as odom_set_xy(). */
void odom_micro_cmd(odom_t *o, const navkit_micro_cmd_t *c);

#endif /* NAVKIT_ODOM_H */
