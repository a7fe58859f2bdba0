/* odom: encoder distance, turn angle, wheel speeds and X/Y. See odom.h. */
#include "odom.h"

#include <math.h>

#include "heading.h"

#define ODOM_DEG_TO_RAD 0.01745329252f

void odom_reset(odom_t *o)
{
    o->enc_l = 0;
    o->enc_r = 0;
    o->raw_l = 0;
    o->raw_r = 0;
    o->v_l = 0.0f;
    o->v_r = 0.0f;
    odom_set_xy(o, 0, 0);
    o->still_ticks = 0u;
    o->primed = 0u;
}

/* Add step (mm) to a whole+residual coordinate, keeping the residual within +/-0.5. */
static void odom_accumulate(int32_t *whole, float *frac, float step)
{
    float f = *frac + step;
    int32_t k = (int32_t)((f >= 0.0f) ? f + 0.5f : f - 0.5f);
    *whole += k;
    *frac = f - (float)k;
}

/* Wheel-speed low-pass (mm/s) after d counts this tick; quiet ticks only decay. */
static float odom_lowpass(float v, int32_t d, const odom_geom_t *g)
{
    if (d == 0) {
        return v - v * g->speed_alpha;
    }
    return v + ((float)d * g->speed_per_count - v) * g->speed_alpha;
}

/* Sine and cosine of deg (-180..180): one library call for the component nearer zero,
   the other from sqrt(1 - x^2) (>= 0.707 there, so as exact as the library's). */
static void odom_sincos(float deg, float *sn, float *c)
{
    float a = fabsf(deg);
    if (a <= 45.0f || a >= 135.0f) {
        float s1 = sinf(deg * ODOM_DEG_TO_RAD);
        float c1 = sqrtf(1.0f - s1 * s1);
        *sn = s1;
        *c = (a <= 90.0f) ? c1 : -c1;
    } else {
        float c1 = cosf(deg * ODOM_DEG_TO_RAD);
        float s1 = sqrtf(1.0f - c1 * c1);
        *c = c1;
        *sn = (deg >= 0.0f) ? s1 : -s1;
    }
}

void odom_count(odom_t *o, const odom_geom_t *g, int32_t raw_l, int32_t raw_r, float heading_deg)
{
    int32_t dl = 0, dr = 0;
    if (o->primed) {
        dl = odom_counts_since(raw_l, o->raw_l) * g->sign_l;
        dr = odom_counts_since(raw_r, o->raw_r) * g->sign_r;
    }
    o->raw_l = raw_l;
    o->raw_r = raw_r;
    o->primed = 1u;
    o->enc_l = (int32_t)((uint32_t)o->enc_l + (uint32_t)dl);
    o->enc_r = (int32_t)((uint32_t)o->enc_r + (uint32_t)dr);
    o->v_l = odom_lowpass(o->v_l, dl, g);
    o->v_r = odom_lowpass(o->v_r, dr, g);
    if (dl == 0 && dr == 0) {
        if (o->still_ticks < 0xFFFFu) {
            o->still_ticks++;
        }
    } else {
        o->still_ticks = 0u;
        if (o->xy_n == 0u) {
            o->xy_h0 = heading_deg;
        }
        o->xy_sum += dl + dr;
    }
    if ((o->xy_n > 0u || dl != 0 || dr != 0) && o->xy_n < 0xFFu) {
        o->xy_n++;
    }
}

void odom_xy_step(odom_t *o, const odom_geom_t *g, float heading_deg)
{
    /* one X/Y step along the heading at its middle */
    float ds = (float)o->xy_sum * (0.5f * g->mm_per_count); /* mm */
    float c, sn;
    odom_sincos(heading_wrap180_near(o->xy_h0 + 0.5f * heading_wrap180_near(heading_deg - o->xy_h0)), &sn, &c);
    odom_accumulate(&o->x, &o->x_frac, ds * c);
    odom_accumulate(&o->y, &o->y_frac, -ds * sn);
    o->xy_sum = 0;
    o->xy_n = 0u;
}

float odom_distance(const odom_t *o, int32_t ref_l, int32_t ref_r, float mm_per_count)
{
    float cl = (float)odom_counts_since(o->enc_l, ref_l);
    float cr = (float)odom_counts_since(o->enc_r, ref_r);
    return 0.5f * (cl + cr) * mm_per_count;
}

float odom_turn(const odom_t *o, int32_t ref_l, int32_t ref_r, float deg_per_count)
{
    float cl = (float)odom_counts_since(o->enc_l, ref_l);
    float cr = (float)odom_counts_since(o->enc_r, ref_r);
    return (cl - cr) * deg_per_count;
}

void odom_set_xy(odom_t *o, int32_t x, int32_t y)
{
    o->x = x;
    o->y = y;
    o->x_frac = 0.0f;
    o->y_frac = 0.0f;
    o->xy_sum = 0;
    o->xy_h0 = 0.0f;
    o->xy_n = 0u;
}

void odom_micro_cmd(odom_t *o, const navkit_micro_cmd_t *c)
{
    if (c->dg_control & NAVKIT_DG_CONTROL_SET_XY) {
        odom_set_xy(o, c->x_set, c->y_set);
    }
}
