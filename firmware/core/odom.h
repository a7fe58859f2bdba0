/* odom: encoder distance, encoder turn angle, wheel speeds and X/Y odometry (prefix odom_).
 *
 * Frame: X along heading 0, Y along heading 270 (to the left of heading 0); heading is
 * clockwise positive, so at reset (heading 0) X is forward and Y is left.
 */
#ifndef NAVKIT_ODOM_H
#define NAVKIT_ODOM_H

#include <stdint.h>

typedef struct {
    int32_t enc_l;   /* counts: left encoder, sign-corrected, since reset */
    int32_t enc_r;   /* counts: right encoder, sign-corrected, since reset */
    int32_t raw_l;   /* counts: last raw left reading */
    int32_t raw_r;   /* counts: last raw right reading */
    float v_l;       /* mm/s: left wheel speed, low-pass filtered */
    float v_r;       /* mm/s: right wheel speed, low-pass filtered */
    int32_t x;       /* mm: X, whole part */
    int32_t y;       /* mm: Y, whole part */
    float x_frac;    /* mm: X residual, -0.5..0.5 */
    float y_frac;    /* mm: Y residual, -0.5..0.5 */
    float still_s;   /* s: time since an encoder last changed (capped) */
    uint8_t primed;  /* raw_* hold a reading */
} odom_t;

/* Counts and X/Y zero, not primed (the first update only takes the raw readings). */
void odom_reset(odom_t *o);
/* One tick: raw_l/raw_r (counts, raw sign), sign_l/sign_r (+1/-1), mm_per_count (mm),
 * heading_deg (deg, clockwise) for the X/Y step, dt (s). */
void odom_update(odom_t *o, int32_t raw_l, int32_t raw_r, int8_t sign_l, int8_t sign_r, float mm_per_count,
                 float heading_deg, float dt);
/* Counts moved by the left (right) wheel since the reference count ref (counts). */
int32_t odom_counts_since(int32_t now, int32_t ref);
/* Distance (mm) moved since the reference counts ref_l/ref_r: mean of the wheels. */
float odom_distance(const odom_t *o, int32_t ref_l, int32_t ref_r, float mm_per_count);
/* Turn angle (deg, clockwise) since the reference counts, from the wheel difference
 * over track_mm (mm). */
float odom_turn(const odom_t *o, int32_t ref_l, int32_t ref_r, float mm_per_count, float track_mm);
/* Set X/Y (mm). */
void odom_set_xy(odom_t *o, int32_t x, int32_t y);

#endif /* NAVKIT_ODOM_H */
