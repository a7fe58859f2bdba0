/* profile: one-axis online trapezoidal velocity profile. See profile.h. */
#include "profile.h"

#include <math.h>

/* u: below this the reference is on the target */
#define PROFILE_EPS_POS 1e-4f
/* Largest speed (u/s, >= 0) from which decelerating by k_dvp per tick, one tick at a time
 * of dt, covers exactly d (u, >= 0): the terms are r, r+dv, ..., r+(m-1)dv with
 * 0 < r <= dv and their sum times dt equal to d. */
static float profile_brake_speed(const profile_t *p, float d)
{
    float dv = p->k_dvp;
    float s, m, m1, x;
    if (d <= 0.0f) {
        return 0.0f;
    }
    s = d * p->k_inv_dt; /* u/s: sum of the speed terms */
    /* smallest whole m with dv*m*(m+1)/2 >= s: m >= (sqrt(1 + 8s/dv) - 1)/2, written
       sqrt(1/4 + 2s/dv) - 1/2 (one multiply less) */
    m = ceilf(sqrtf(0.25f + s * p->k_2_dvp) - 0.5f);
    if (m < 1.0f) {
        m = 1.0f;
    }
    /* the smallest term r = x / m, x = s - dv*m*(m-1)/2 (dv/2 is k_half_dvp, exact) */
    m1 = m - 1.0f;
    x = s - p->k_half_dvp * m * m1;
    /* the square root is rounded: m may be one off either way (0 < r <= dv says it is
       right). Checked before the division and corrected by the difference of the sums,
       dv*m, so a tick pays one division however m comes out (a float division is costly on
       the AVR, which has no FPU) */
    if (x > dv * m) {
        x -= dv * m;
        m1 = m;
        m += 1.0f;
    } else if (x <= 0.0f && m > 1.0f) {
        m = m1;
        m1 = m - 1.0f;
        x += dv * m;
    }
    x /= m; /* now r */
    if (x < 0.0f) {
        x = 0.0f;
    } else if (x > dv) {
        x = dv;
    }
    return x + m1 * dv;
}

/* Refresh the per-(amax, dt) constants when either changed. */
static void profile_constants(profile_t *p, float dt)
{
    if (p->amax != p->k_amax || dt != p->k_dt) {
        p->k_amax = p->amax;
        p->k_dt = dt;
        p->k_dv = p->amax * dt;
        p->k_dvp = p->k_dv * (1.0f - PROFILE_BRAKE_MARGIN);
        p->k_half_dvp = 0.5f * p->k_dvp;
        p->k_inv_dt = 1.0f / dt;
        p->k_2_dvp = 2.0f / p->k_dvp;
        p->k_2ap = 2.0f * p->amax * (1.0f - PROFILE_BRAKE_MARGIN);
    }
}

void profile_init(profile_t *p, float vmax, float amax)
{
    p->togo = 0.0f;
    p->togo_c = 0.0f;
    p->vel = 0.0f;
    p->vmax = vmax;
    p->amax = amax;
    p->k_amax = -1.0f; /* constants not computed yet */
    p->k_dt = 0.0f;
    p->moving = 0u;
}

/* Set the distance to go to a - b exactly: togo is the rounded value and togo_c the
   (negated) rounding error, the same convention as the compensated step (true = togo -
   togo_c). Two-sum: no precision is lost however far a is. */
static void profile_set_diff(profile_t *p, float a, float b)
{
    float s = a - b;
    float bb = s - a;  /* the part of -b that made it into s */
    float aa = s - bb; /* the part of a */
    p->togo = s;
    p->togo_c = -((a - aa) + (-b - bb));
}

void profile_set_togo(profile_t *p, float target, float pos)
{
    profile_set_diff(p, target, pos);
    p->moving = 1u;
}

float profile_ref_pos(const profile_t *p, float target)
{
    /* target - togo is exact while togo is within a factor 2 of target (Sterbenz), which
       is where a far target would otherwise lose the reference's position */
    return (target - p->togo) + p->togo_c;
}

void profile_retarget(profile_t *p, float delta, float vmax, float amax)
{
    profile_set_diff(p, p->togo, p->togo_c - delta);
    p->vmax = vmax;
    p->amax = amax;
    p->moving = 1u;
}

float profile_stop_distance(float v, float amax, float dt)
{
    float dv = amax * dt;
    float u = fabsf(v);
    float n;
    if (u <= dv) {
        return 0.0f;
    }
    /* terms u-dv, u-2dv, ..., u-n*dv, all > 0 */
    n = ceilf(u / dv) - 1.0f;
    return dt * (n * u - dv * n * (n + 1.0f) * 0.5f);
}

void profile_stop(profile_t *p, float amax, float dt)
{
    /* at the braking curve's own rate: the curve then asks for exactly this deceleration
       every tick, so rounding cannot carry the reference past the stop point */
    float d = profile_stop_distance(p->vel, amax * (1.0f - PROFILE_BRAKE_MARGIN), dt);
    p->amax = amax;
    p->togo = (p->vel < 0.0f) ? -d : d;
    p->togo_c = 0.0f;
    p->moving = 1u;
}

uint8_t profile_track(profile_t *p, float lead, float vel_meas, float window, float vwindow)
{
    float pull; /* u: how far the reference moves back toward the robot */
    if (lead > window) {
        pull = lead - window;
    } else if (lead < -window) {
        pull = lead + window;
    } else {
        return 0u;
    }
    profile_set_diff(p, p->togo, p->togo_c - pull);
    if (p->vel > vel_meas + vwindow) {
        p->vel = vel_meas + vwindow;
    } else if (p->vel < vel_meas - vwindow) {
        p->vel = vel_meas - vwindow;
    }
    p->moving = 1u;
    return 1u;
}

float profile_step(profile_t *p, float dt)
{
    float dv, u, goal, brake, reach, d;
    uint8_t neg; /* 1: the target is toward smaller positions */

    if (!p->moving) {
        return 0.0f;
    }
    profile_constants(p, dt);
    dv = p->k_dv; /* u/s: the most the velocity may change this tick */
    d = fabsf(p->togo);
    if (d <= PROFILE_EPS_POS && fabsf(p->vel) <= dv) {
        p->togo = 0.0f;
        p->togo_c = 0.0f;
        p->vel = 0.0f;
        p->moving = 0u;
        return 0.0f;
    }
    /* work in the direction of the target: u = speed toward it (a sign flip, not a
       multiply by -1: the same bits) */
    neg = (uint8_t) !(p->togo > 0.0f || (p->togo == 0.0f && p->vel > 0.0f));
    u = neg ? -p->vel : p->vel;
    goal = p->vmax;
    /* the braking curve can only bind within (v + dv)^2 / (2 amax) of the target, v the
       larger of vmax and the present speed: skip its square root while far away */
    reach = ((p->vmax > fabsf(u)) ? p->vmax : fabsf(u)) + dv;
    if (d * p->k_2ap < reach * reach) {
        brake = profile_brake_speed(p, d);
        if (brake < goal) {
            goal = brake;
        }
    }
    if (goal > u + dv) {
        u += dv;
    } else if (goal < u - dv) {
        u -= dv;
    } else {
        u = goal;
    }
    p->vel = neg ? -u : u;
    {
        /* togo -= vel*dt, compensated so thousands of ticks add no drift */
        float y = -p->vel * dt - p->togo_c;
        float t = p->togo + y;
        p->togo_c = (t - p->togo) - y;
        p->togo = t;
    }
    return p->vel;
}
