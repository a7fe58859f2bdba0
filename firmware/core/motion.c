/* motion: one commanded axis with the seed's command rules. See motion.h. */
#include "motion.h"

#include <math.h>

void motion_reset(motion_t *m, int32_t enc_l, int32_t enc_r)
{
    profile_init(&m->prof, 1.0f, 1.0f);
    m->ref_l = enc_l;
    m->ref_r = enc_r;
    m->target = 0.0f;
    m->meas = 0.0f;
    m->started = 0u;
    m->latched = 0u;
    m->done = 0u;
    m->limited = 0u;
}

void motion_start(motion_t *m, int32_t enc_l, int32_t enc_r, float meas, float target, float vmax, float amax)
{
    /* u: reference position minus measured position, in the old reference's frame */
    float lead = m->prof.moving ? profile_ref_pos(&m->prof, m->target) - meas : 0.0f;
    m->ref_l = enc_l;
    m->ref_r = enc_r;
    m->target = target;
    m->meas = 0.0f; /* the robot is at the new reference */
    profile_set_togo(&m->prof, target, lead);
    m->prof.vmax = vmax;
    m->prof.amax = amax;
    m->started = 1u;
    m->latched = 0u;
    m->done = 0u;
}

motion_result_t motion_modify(motion_t *m, float target, float vmax, float amax)
{
    if (!m->started) {
        return MOTION_NOT_STARTED;
    }
    if (m->latched) {
        return MOTION_LATCHED;
    }
    /* from the reference's position, not by adding target - m->target: near a far target
       ("forever") that difference is coarse in single precision */
    profile_set_togo(&m->prof, target, profile_ref_pos(&m->prof, m->target));
    m->prof.vmax = vmax;
    m->prof.amax = amax;
    m->target = target;
    m->done = 0u;
    return MOTION_OK;
}

void motion_stop(motion_t *m, float amax, float dt)
{
    float ref; /* u: the reference's position */
    m->latched = 1u;
    if (!m->started) {
        return;
    }
    /* the new target is where the reference comes to rest, counted from its position
       (exact also after a far target) */
    ref = profile_ref_pos(&m->prof, m->target);
    profile_stop(&m->prof, amax, dt);
    m->target = ref + m->prof.togo;
    m->done = 0u;
}

float motion_tick(motion_t *m, float meas, float vel_meas, const config_track_t *k, float dt)
{
    float vel, lead; /* u/s: reference velocity; u: reference - measured position */
    if (!motion_active(m)) {
        return motion_tick_idle(m);
    }
    m->meas = meas;
    lead = profile_ref_pos(&m->prof, m->target) - meas;
    if (m->latched && lead * m->prof.vel <= 0.0f) {
        /* stopping, and the robot is ahead of the reference: no pull forward, which
           would leave the reference too little room to stop and make it turn back */
        lead = 0.0f;
    }
    m->limited = profile_track(&m->prof, lead, vel_meas, k->window, k->vwindow);
    if (!m->prof.moving && fabsf(m->target - meas) > k->tol && fabsf(vel_meas) <= k->vtol) {
        if (m->latched) {
            /* a stop ends where the robot came to rest: never back to the stop point */
            m->target = meas;
        } else {
            /* the reference is on the target but the robot came to rest short of it (or
               beyond): plan a new short move from where the robot is */
            profile_set_togo(&m->prof, m->target, meas);
        }
    }
    vel = profile_step(&m->prof, dt);
    if (!m->prof.moving && fabsf(m->target - meas) <= k->tol && fabsf(vel_meas) <= k->vtol) {
        m->done = 1u;
    }
    return vel;
}

float motion_tick_idle(motion_t *m)
{
    m->limited = 0u;
    return 0.0f;
}

float motion_limit(float v, float dflt, float max)
{
    float u = (v > 0.0f) ? v : dflt;
    return (u > max) ? max : u;
}

motion_result_t motion_micro_cmd(motion_t *m, const navkit_micro_cmd_t *c, const odom_t *o, const config_t *cfg)
{
    float accel = motion_limit(fabsf((float)c->accel), cfg->default_accel, 1e9f);           /* mm/s^2 */
    float speed = motion_limit(fabsf((float)c->speed), cfg->default_speed, cfg->max_speed); /* mm/s */
    motion_result_t r = MOTION_OK;
    switch (c->fwd_cmd) {
    case NAVKIT_FWD_CMD_START:
        motion_start(m, o->enc_l, o->enc_r, motion_distance(m, o, cfg->mm_per_count), (float)c->distance, speed, accel);
        r = MOTION_STARTED;
        break;
    case NAVKIT_FWD_CMD_MODIFY:
        r = motion_modify(m, (float)c->distance, speed, accel);
        break;
    case NAVKIT_FWD_CMD_STOP:
        motion_stop(m, accel, cfg->dt);
        break;
    default: /* NAVKIT_FWD_CMD_NONE */
        break;
    }
    if (c->excite_mode != NAVKIT_EXCITE_MODE_NONE) {
        motion_reset(m, o->enc_l, o->enc_r);
    }
    return r;
}
