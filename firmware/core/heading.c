/* heading: gyro heading with bias estimation and compass fusion. See heading.h. */
#include "heading.h"

#include <math.h>

#define HEADING_ONE_DEG 65536.0f           /* q units per deg */
#define HEADING_FULL_Q 23592960L           /* 360 * 2^16 */
#define HEADING_BIAS_TAU_S 2.0f            /* s: bias tracking time constant at standstill */

static void heading_wrap_q(heading_t *h)
{
    /* per-tick changes are small: a conditional add is enough (no 32-bit division) */
    while (h->q >= HEADING_FULL_Q) {
        h->q -= HEADING_FULL_Q;
    }
    while (h->q < 0) {
        h->q += HEADING_FULL_Q;
    }
}

/* Add d (deg) to the heading. */
static void heading_add(heading_t *h, float d)
{
    float f = h->q_frac + d * HEADING_ONE_DEG;
    int32_t k = (int32_t)((f >= 0.0f) ? f + 0.5f : f - 0.5f);
    h->q += k;
    h->q_frac = f - (float)k;
    heading_wrap_q(h);
}

void heading_reset(heading_t *h)
{
    h->q = 0;
    h->q_frac = 0.0f;
    h->bias = 0.0f;
    h->rate = 0.0f;
    h->cal_sum = 0;
    h->cal_n = 0u;
    h->calibrating = 1u;
}

void heading_update(heading_t *h, int16_t raw, float dps_per_lsb, uint8_t still, uint16_t cal_samples, float dt)
{
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
    heading_add(h, h->rate * dt);
}

float heading_wrap180(float deg)
{
    return deg - 360.0f * floorf(deg * (1.0f / 360.0f) + 0.5f);
}

void heading_fuse(heading_t *h, uint16_t compass10, float gain, float dt)
{
    float err = heading_wrap180(0.1f * (float)compass10 - heading_deg(h));
    heading_add(h, err * gain * dt);
}

void heading_set(heading_t *h, float deg)
{
    float w = deg - 360.0f * floorf(deg * (1.0f / 360.0f));
    h->q = (int32_t)(w * HEADING_ONE_DEG + 0.5f);
    h->q_frac = 0.0f;
    heading_wrap_q(h);
}

float heading_deg(const heading_t *h)
{
    return ((float)h->q + h->q_frac) * (1.0f / HEADING_ONE_DEG);
}

uint16_t heading_deg10(const heading_t *h)
{
    /* q / (2^16 / 10), rounded, then 3600 -> 0 */
    uint16_t d = (uint16_t)(((int32_t)h->q * 10L + 32768L) >> 16);
    return (d >= 3600u) ? (uint16_t)(d - 3600u) : d;
}
