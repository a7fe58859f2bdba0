/* wheel: one wheel-speed loop. See wheel.h. */
#include "wheel.h"

void wheel_reset(wheel_t *w)
{
    w->integ = 0.0f;
    w->prev_err = 0.0f;
    w->duty = 0.0f;
    w->saturated = 0u;
}

void wheel_gains_set_dt(wheel_gains_t *g, float dt)
{
    g->ki_dt = g->ki * dt;
    g->kd_dt = g->kd / dt;
}

float wheel_update(wheel_t *w, const wheel_gains_t *g, float sp, float meas)
{
    float e = sp - meas;
    float integ = w->integ + g->ki_dt * e;
    float out;

    if (integ > g->i_limit) {
        integ = g->i_limit;
    } else if (integ < -g->i_limit) {
        integ = -g->i_limit;
    }
    /* conditional integration: never wind further into a saturated output */
    if (!(w->saturated && ((w->duty > 0.0f && integ > w->integ) || (w->duty < 0.0f && integ < w->integ)))) {
        w->integ = integ;
    }
    out = g->kff * sp + g->kp * e + w->integ;
    if (g->kd_dt != 0.0f) {
        out += g->kd_dt * (e - w->prev_err);
    }
    w->prev_err = e;
    w->saturated = 0u;
    if (out > g->pwm_limit) {
        out = g->pwm_limit;
        w->saturated = 1u;
    } else if (out < -g->pwm_limit) {
        out = -g->pwm_limit;
        w->saturated = 1u;
    }
    w->duty = out;
    return out;
}
