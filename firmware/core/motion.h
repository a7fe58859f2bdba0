/* motion: one commanded axis with the seed's command rules (prefix motion_).
 *
 * Used for forward motion (u = mm, measured by encoder distance) and for turning
 * (u = deg, measured by encoder turn angle). The rules of the seed's "Notes on use of
 * robot motion control commands":
 *   start (cmd 1)  : new distance reference here; go to target; clears the stop latch.
 *   modify (cmd 3) : new limits and/or target, same reference; speeds up, slows down,
 *                    reverses if the target is now behind, restarts after completion;
 *                    no effect while the stop latch is set (or before any start).
 *   stop (cmd 5)   : decelerate at the given rate to rest; sets the stop latch. A stop
 *                    never turns back: it ends where the robot comes to rest.
 * Each tick re-plans from the measured state (profile_track) so a plant that cannot
 * reach the speed still stops at the target.
 */
#ifndef NAVKIT_MOTION_H
#define NAVKIT_MOTION_H

#include <stdint.h>

#include "config.h"
#include "navkit/navkit_proto.h"
#include "odom.h"
#include "profile.h"

/* Result of motion_modify(). */
typedef enum {
    MOTION_OK = 0,          /* applied */
    MOTION_LATCHED = 1,     /* ignored: an explicit stop latched the axis */
    MOTION_NOT_STARTED = 2, /* ignored: no start (cmd 1) since reset */
    MOTION_STARTED = 3      /* motion_micro_cmd(), turn_micro_cmd(): a start, from a new reference */
} motion_result_t;

typedef struct {
    profile_t prof;  /* reference profile, u and u/s */
    int32_t ref_l;   /* counts: left encoder at the reference (cmd 1) */
    int32_t ref_r;   /* counts: right encoder at the reference */
    float target;    /* u: target measured from the reference */
    float meas;      /* u: measured position from the reference, as of the last tick */
    uint8_t started; /* a start since reset */
    uint8_t latched; /* stop latch */
    uint8_t done;    /* at rest within tolerance of the target */
    uint8_t limited; /* the plant lagged the reference on the last tick */
} motion_t;

/* The forward axis's part of a checked micro_cmd c, on the forward axis m: fwd_cmd 1
 * starts (distance, mm, from a new reference at the encoder counts of o), 3 modifies, 5
 * stops (at accel, with the tick cfg->dt, s), others do nothing; the limits are |accel|
 * (mm/s^2) and |speed| (mm/s), or cfg's defaults for a word of 0, speed at most
 * cfg->max_speed. An experiment (excite_mode 1-3; the check keeps fwd_cmd 0 with it)
 * leaves the axis idle with its reference at the encoder counts of o (the distance counts
 * from the experiment's start). Returns MOTION_STARTED for a start, motion_modify()'s
 * result for a modify, else MOTION_OK. */
motion_result_t motion_micro_cmd(motion_t *m, const navkit_micro_cmd_t *c, const odom_t *o, const config_t *cfg);
/* A command limit in working units (u/s or u/s^2): v (|command word| in the same units), or
 * dflt when v is 0; at most max. */
float motion_limit(float v, float dflt, float max);
/* The forward axis m's measured distance (mm) from its reference: the mean of the wheels'
 * travel in o since the reference counts, mm_per_count (mm per count). */
static inline float motion_distance(const motion_t *m, const odom_t *o, float mm_per_count)
{
    return odom_distance(o, m->ref_l, m->ref_r, mm_per_count);
}
/* Idle, no reference yet (reference counts = the given encoder counts). */
void motion_reset(motion_t *m, int32_t enc_l, int32_t enc_r);
/* Start (cmd 1): reference = encoder counts enc_l/enc_r (counts); meas (u) is the
 * measured position relative to the old reference, so the reference keeps its lead and
 * velocity (no jump). target (u, signed), vmax (u/s, > 0), amax (u/s^2, > 0). */
void motion_start(motion_t *m, int32_t enc_l, int32_t enc_r, float meas, float target, float vmax, float amax);
/* Modify (cmd 3): new target (u from the original reference), vmax (u/s), amax (u/s^2).
 * The distance to go is recomputed from the reference's position (exact even after a far
 * "forever" target). */
motion_result_t motion_modify(motion_t *m, float target, float vmax, float amax);
/* Stop (cmd 5, or the watchdog): decelerate at amax (u/s^2, > 0) with tick dt (s); latch.
 * The stop is planned from the reference's position and speed (exact even after a far
 * target); the reference never passes the stop point nor reverses. */
void motion_stop(motion_t *m, float amax, float dt);
/* 1 while the axis wants the wheels driven (moving, or not yet settled on its target).
 * Inline: the tick asks it of both axes before it measures them. */
static inline uint8_t motion_active(const motion_t *m)
{
    return (uint8_t)(m->started && (m->prof.moving || !m->done));
}
/* One tick: meas (u) and vel_meas (u/s) are the measured position from the reference
 * and velocity; k's window (u) and vwindow (u/s) bound how far the reference may lead the
 * measurement, its tol (u) and vtol (u/s) define "done"; dt (s). Returns the reference
 * velocity (u/s). */
float motion_tick(motion_t *m, float meas, float vel_meas, const config_track_t *k, float dt);
/* motion_tick() of an axis that is not motion_active(), which reads none of its
 * measurements: not limited, returns reference velocity 0 (u/s). So a caller skips
 * measuring an idle axis. */
float motion_tick_idle(motion_t *m);

#endif /* NAVKIT_MOTION_H */
