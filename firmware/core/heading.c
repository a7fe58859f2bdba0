/* heading: gyro heading with bias estimation and compass fusion. See heading.h. */
#include "heading.h"

#include <math.h>

#define HEADING_ONE_DEG 65536.0f /* q units per deg */
#define HEADING_FULL_Q 23592960L /* 360 * 2^16 */
#define HEADING_HALF_Q 11796480L /* 180 * 2^16 */
#define HEADING_BIAS_TAU_S 2.0f  /* s: bias tracking time constant at standstill */
/* q units per deg*10, times 64: 2^16 / 10 * 64 = 419430.4 (the 0.4 is 3.4e-4 deg at 3599,
   far below the compass's 0.1 deg); 3599 * 419430 < 2^31 */
#define HEADING_Q_PER_DEG10_X64 419430L

/* deg (-360..720) into 0 <= deg < 360. */
static float heading_wrap360(float deg)
{
    if (deg >= 360.0f) {
        deg -= 360.0f;
    } else if (deg < 0.0f) {
        deg += 360.0f;
        if (deg >= 360.0f) { /* -tiny + 360 rounds to 360 */
            deg = 0.0f;
        }
    }
    return deg;
}

/* Wrap q into 0..360 deg and refresh the float heading from q + q_frac. */
static void heading_wrap_q(heading_t *h)
{
    /* changes between folds are small: a conditional add is enough (no 32-bit division) */
    while (h->q >= HEADING_FULL_Q) {
        h->q -= HEADING_FULL_Q;
    }
    while (h->q < 0) {
        h->q += HEADING_FULL_Q;
    }
    h->deg = heading_wrap360(((float)h->q + h->q_frac) * (1.0f / HEADING_ONE_DEG));
}

void heading_reset(heading_t *h)
{
    h->q = 0;
    h->q_frac = 0.0f;
    h->deg = 0.0f;
    h->bias = 0.0f;
    h->rate = 0.0f;
    h->cal_sum = 0;
    h->cal_n = 0u;
    h->calibrating = 1u;
}

void heading_update(heading_t *h, int16_t raw, float dps_per_lsb, uint8_t still, uint16_t cal_samples, float dt)
{
    float d; /* deg turned this tick */
    if (h->calibrating) {
        if (still) {
            h->cal_sum += raw;
            h->cal_n++;
        }
        /* done after 1 s of standstill, or as soon as the robot moves */
        if (h->cal_n >= cal_samples || !still) {
            if (h->cal_n > 0u) {
                h->bias = (float)h->cal_sum / (float)h->cal_n;
            }
            h->calibrating = 0u;
        } else {
            h->rate = 0.0f;
            return;
        }
    }
    if (still) {
        h->bias += ((float)raw - h->bias) * (dt * (1.0f / HEADING_BIAS_TAU_S));
        h->rate = 0.0f;
        return;
    }
    h->rate = ((float)raw - h->bias) * dps_per_lsb;
    d = h->rate * dt;
    /* the exact sum goes to q_frac, rounded into q by heading_fold(); the float heading
       moves along at once (its rounding is undone at the next fold) */
    h->q_frac += d * HEADING_ONE_DEG;
    h->deg = heading_wrap360(h->deg + d);
}

void heading_fold(heading_t *h)
{
    int32_t k = (int32_t)((h->q_frac >= 0.0f) ? h->q_frac + 0.5f : h->q_frac - 0.5f); /* rounded */
    h->q += k;
    h->q_frac -= (float)k;
    heading_wrap_q(h);
}

float heading_wrap180_near(float deg)
{
    if (deg >= 180.0f) {
        return deg - 360.0f;
    }
    if (deg < -180.0f) {
        return deg + 360.0f;
    }
    return deg;
}

float heading_wrap180(float deg)
{
    return deg - 360.0f * floorf(deg * (1.0f / 360.0f) + 0.5f);
}

void heading_fuse(heading_t *h, uint16_t compass10, float gain, float dt)
{
    int32_t err;                 /* deg * 2^16: compass - folded heading, the shortest way */
    while (compass10 >= 3600u) { /* outside the hal_compass() contract: whole turns off */
        compass10 = (uint16_t)(compass10 - 3600u);
    }
    /* in the heading's own fixed point: no float wrap, no floor, one conversion */
    err = (((int32_t)compass10 * HEADING_Q_PER_DEG10_X64 + 32L) >> 6) - h->q;
    if (err >= HEADING_HALF_Q) {
        err -= HEADING_FULL_Q;
    } else if (err < -HEADING_HALF_Q) {
        err += HEADING_FULL_Q;
    }
    /* less what has not been folded yet: the error from the heading now */
    h->q_frac += ((float)err - h->q_frac) * (gain * dt);
    heading_fold(h);
}

void heading_set(heading_t *h, float deg)
{
    float w = deg - 360.0f * floorf(deg * (1.0f / 360.0f));
    h->q = (int32_t)(w * HEADING_ONE_DEG + 0.5f);
    h->q_frac = 0.0f;
    heading_wrap_q(h);
}

uint16_t heading_deg10(const heading_t *h)
{
    /* the heading now (deg is 0 <= deg < 360), rounded, then 3600 -> 0 */
    uint16_t d = (uint16_t)(h->deg * 10.0f + 0.5f);
    return (d >= 3600u) ? (uint16_t)(d - 3600u) : d;
}

void heading_micro_cmd(heading_t *h, const navkit_micro_cmd_t *c)
{
    if (c->dg_control & NAVKIT_DG_CONTROL_SET_HEADING) {
        heading_set(h, 0.1f * (float)c->dg_set);
    }
}
