/* heading: gyro heading with bias estimation and optional compass fusion (prefix heading_).
 *
 * Heading is clockwise positive, 0 <= heading < 360 deg, kept as a 32-bit fixed-point
 * angle (deg * 2^16) plus a float residual so long runs do not lose resolution.
 * Bias: averaged over the first second after reset while the robot stands still
 * (status gyro_calibrating), then tracked by a slow low-pass whenever the robot stands
 * still; while it stands still the heading does not integrate gyro noise.
 *
 * Cost on a 16 MHz AVR (no FPU; worst cycles of ctest firmware_avr_cycles: docs/firmware.md,
 * AVR budget): heading_update() runs every tick, so it only adds the tick's angle to the
 * residual and to the float heading; heading_fold() rounds the residual into the
 * fixed-point angle and re-derives the float heading from it, or heading_fuse() does so
 * with compass fusion (its fold included), once per slow period of ~10 ms on its first tick,
 * right after heading_update() (fw.c: every 10th tick at 1 kHz, every 4th at 400 Hz, every
 * tick below 200 Hz).
 */
#ifndef NAVKIT_HEADING_H
#define NAVKIT_HEADING_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

typedef struct {
    int32_t q;           /* deg * 2^16: heading at the last fold, 0 .. 360*2^16-1 */
    float q_frac;        /* deg * 2^16: turned since the last fold (plus its rounding residual) */
    float deg;           /* deg: the heading now, 0 <= deg < 360, (q + q_frac) / 2^16 */
    float bias;          /* LSB: gyro zero-rate offset estimate */
    float rate;          /* deg/s: bias-corrected yaw rate, clockwise positive */
    int32_t cal_sum;     /* LSB: sum of start-up calibration samples */
    uint16_t cal_n;      /* samples in cal_sum */
    uint8_t calibrating; /* 1 during the start-up bias calibration */
} heading_t;

/* Heading 0, bias 0, start-up calibration pending. */
void heading_reset(heading_t *h);
/* One tick: raw (LSB, counter-clockwise positive as read), dps_per_lsb (deg/s per LSB,
 * sign included so that the result is clockwise positive), still (1 = the robot stands
 * still), cal_samples (samples for the start-up calibration, i.e. ticks in 1 s), dt (s).
 * Call heading_fold() (or heading_fuse()) at least every ~10 ms (fw.c: every odom.xy_ticks
 * ticks, up to 20 at 2 kHz): the turn between folds must stay under 360 deg. */
void heading_update(heading_t *h, int16_t raw, float dps_per_lsb, uint8_t still, uint16_t cal_samples, float dt);
/* Round what heading_update() integrated since the last fold into the fixed-point angle
 * (the float heading is re-derived from it, so its rounding does not accumulate). */
void heading_fold(heading_t *h);
/* Pull the heading toward compass10 (deg*10, clockwise from north; whole turns above
 * 3599 are taken off) by gain (1/s) * dt (s) of the shortest-way error, dt the time since
 * the last fusion step; then fold. Fixed-point error: no float wrap, no trig, no division. */
void heading_fuse(heading_t *h, uint16_t compass10, float gain, float dt);
/* The heading's part of a checked micro_cmd c: with dg_control's set_heading bit, the
 * heading becomes dg_set (deg*10). */
void heading_micro_cmd(heading_t *h, const navkit_micro_cmd_t *c);
/* Set the heading to deg (any value; wrapped into 0..360). */
void heading_set(heading_t *h, float deg);
/* Heading, deg, 0 <= h < 360. */
static inline float heading_deg(const heading_t *h)
{
    return h->deg;
}
/* Heading, deg*10, 0..3599 (rounded). */
uint16_t heading_deg10(const heading_t *h);
/* deg wrapped into -180 <= result < 180 (shortest way). */
float heading_wrap180(float deg);
/* deg with -540 <= deg < 540 (as between two headings of 0..360, or one plus half that)
 * wrapped into -180 <= result < 180 by one whole turn at most: two compares, no floor
 * (cheaper than heading_wrap180() on an AVR, which has no FPU), for the every-tick users. */
float heading_wrap180_near(float deg);

#endif /* NAVKIT_HEADING_H */
