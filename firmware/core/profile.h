/* profile: one-axis online trapezoidal velocity profile (prefix profile_).
 *
 * Units are the caller's: "u" is mm for forward motion and deg for turning. The state
 * is the distance still to go (togo, u) and the reference velocity (vel, u/s), both
 * signed toward +target. Keeping togo instead of an absolute position keeps single
 * precision exact where it matters, near the target.
 *
 * Each tick the profile re-plans from its state (and, through profile_track(), from
 * the measured state): it accelerates at most amax toward min(vmax, braking speed),
 * where the braking speed is the exact discrete-time speed from which decelerating by
 * amax*dt per tick covers togo exactly (no truncation, no overshoot).
 */
#ifndef NAVKIT_PROFILE_H
#define NAVKIT_PROFILE_H

#include <stdint.h>

/* The braking curve (and a stop) is planned at (1 - margin) * amax: a stop takes
   amax*dt*(1 - margin) off the reference speed per tick. Following a curve that needs
   exactly amax is marginally stable in single precision (a rounding error above the
   curve can only grow once the limit clamps); the margin lets every tick correct it. */
#define PROFILE_BRAKE_MARGIN 2e-3f

typedef struct {
    float togo;   /* u: reference distance still to go, + toward the target */
    float togo_c; /* u: compensation of togo's rounding (Kahan): the exact distance to go is togo - togo_c */
    float vel;    /* u/s: reference velocity (+ = toward larger positions) */
    float vmax;   /* u/s: cruise limit, > 0 */
    float amax;   /* u/s^2: acceleration and deceleration limit, > 0 */
    /* per-(amax, dt) constants, recomputed only when either changes (no per-tick division) */
    float k_amax;     /* u/s^2: amax the constants are for */
    float k_dt;       /* s: dt the constants are for */
    float k_dv;       /* u/s: amax * dt */
    float k_dvp;      /* u/s: the braking curve's step, k_dv less the margin */
    float k_half_dvp; /* u/s: k_dvp / 2 */
    float k_inv_dt;   /* 1/s */
    float k_2_dvp;    /* s/u: 2 / k_dvp */
    float k_2ap;      /* u/s^2: 2 * amax less the margin */
    uint8_t moving;   /* 1 while the reference moves or has not reached the target */
} profile_t;

/* At rest on the target, with limits vmax (u/s) and amax (u/s^2). */
void profile_init(profile_t *p, float vmax, float amax);
/* Move the target by delta (u) and set new limits vmax (u/s) and amax (u/s^2), both > 0;
 * the reference position and velocity are kept (no jump). */
void profile_retarget(profile_t *p, float delta, float vmax, float amax);
/* Stop: decelerate at amax (u/s^2, > 0; the braking curve's 0.2 % margin less) and put
 * the target exactly where that stop ends for tick dt (s): the reference never passes it
 * and never reverses. */
void profile_stop(profile_t *p, float amax, float dt);
/* Distance (u, >= 0) the profile covers while stopping from speed v (u/s) at amax
 * (u/s^2, > 0) with tick dt (s): the exact discrete sum, not truncated. */
float profile_stop_distance(float v, float amax, float dt);
/* Re-plan from the measured state: lead (u) is how far the reference is ahead of the
 * measured position (reference - measured, + toward larger positions) and vel_meas (u/s)
 * the measured velocity. If |lead| > window (u) the reference is pulled back to the window
 * edge and its velocity to within vwindow (u/s) of vel_meas. Returns 1 if it had to pull
 * (the plant lags). */
uint8_t profile_track(profile_t *p, float lead, float vel_meas, float window, float vwindow);
/* Set the distance to go to target - pos (u, both from the same origin), exactly however
 * large target is; the velocity is kept. */
void profile_set_togo(profile_t *p, float target, float pos);
/* Reference position (u, from the origin target is counted from): target - togo, exact
 * with togo's compensation even for a far target (a "forever" move). */
float profile_ref_pos(const profile_t *p, float target);
/* Advance one tick of dt (s); returns the new reference velocity (u/s). */
float profile_step(profile_t *p, float dt);

#endif /* NAVKIT_PROFILE_H */
