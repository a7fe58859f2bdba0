/* odom: encoder distance, turn angle, wheel speeds and X/Y. See odom.h. */
#include "odom.h"

#include <math.h>

#define ODOM_SPEED_TAU_S 0.01f   /* s: wheel-speed low-pass time constant */
#define ODOM_STILL_CAP_S 60.0f   /* s: still_s stops growing here */
#define ODOM_RAD_TO_DEG 57.29577951f
#define ODOM_DEG_TO_RAD 0.01745329252f

void odom_reset(odom_t *o)
{
    o->enc_l = 0;
    o->enc_r = 0;
    o->raw_l = 0;
    o->raw_r = 0;
    o->v_l = 0.0f;
    o->v_r = 0.0f;
    o->x = 0;
    o->y = 0;
    o->x_frac = 0.0f;
    o->y_frac = 0.0f;
    o->still_s = 0.0f;
    o->primed = 0u;
}

int32_t odom_counts_since(int32_t now, int32_t ref)
{
    /* modulo 2^32, then back to signed without overflow */
    uint32_t d = (uint32_t)now - (uint32_t)ref;
    return (d <= 0x7FFFFFFFul) ? (int32_t)d : -(int32_t)(~d) - 1;
}

/* Add step (mm) to a whole+residual coordinate, keeping the residual within +/-0.5. */
static void odom_accumulate(int32_t *whole, float *frac, float step)
{
    float f = *frac + step;
    int32_t k = (int32_t)((f >= 0.0f) ? f + 0.5f : f - 0.5f);
    *whole += k;
    *frac = f - (float)k;
}

void odom_update(odom_t *o, int32_t raw_l, int32_t raw_r, int8_t sign_l, int8_t sign_r, float mm_per_count,
                 float heading_deg, float dt)
{
    int32_t dl = 0, dr = 0;
    float alpha = dt / (ODOM_SPEED_TAU_S + dt);
    if (o->primed) {
        dl = odom_counts_since(raw_l, o->raw_l) * sign_l;
        dr = odom_counts_since(raw_r, o->raw_r) * sign_r;
    }
    o->raw_l = raw_l;
    o->raw_r = raw_r;
    o->primed = 1u;
    o->enc_l = (int32_t)((uint32_t)o->enc_l + (uint32_t)dl);
    o->enc_r = (int32_t)((uint32_t)o->enc_r + (uint32_t)dr);
    o->v_l += ((float)dl * mm_per_count / dt - o->v_l) * alpha;
    o->v_r += ((float)dr * mm_per_count / dt - o->v_r) * alpha;
    if (dl == 0 && dr == 0) {
        if (o->still_s < ODOM_STILL_CAP_S) {
            o->still_s += dt;
        }
    } else {
        float ds = 0.5f * (float)(dl + dr) * mm_per_count;
        float h = heading_deg * ODOM_DEG_TO_RAD;
        o->still_s = 0.0f;
        odom_accumulate(&o->x, &o->x_frac, ds * cosf(h));
        odom_accumulate(&o->y, &o->y_frac, -ds * sinf(h));
    }
}

float odom_distance(const odom_t *o, int32_t ref_l, int32_t ref_r, float mm_per_count)
{
    float cl = (float)odom_counts_since(o->enc_l, ref_l);
    float cr = (float)odom_counts_since(o->enc_r, ref_r);
    return 0.5f * (cl + cr) * mm_per_count;
}

float odom_turn(const odom_t *o, int32_t ref_l, int32_t ref_r, float mm_per_count, float track_mm)
{
    float cl = (float)odom_counts_since(o->enc_l, ref_l);
    float cr = (float)odom_counts_since(o->enc_r, ref_r);
    return (cl - cr) * mm_per_count / track_mm * ODOM_RAD_TO_DEG;
}

void odom_set_xy(odom_t *o, int32_t x, int32_t y)
{
    o->x = x;
    o->y = y;
    o->x_frac = 0.0f;
    o->y_frac = 0.0f;
}
