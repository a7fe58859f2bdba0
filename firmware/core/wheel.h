/* wheel: one wheel-speed loop, PI(D) with feed-forward (prefix wheel_).
 *
 * duty = kff*sp + kp*e + I + kd*de/dt,  e = sp - meas (mm/s),  I += ki*e*dt, with ki*dt
 * and kd/dt derived per tick length by wheel_gains_set_dt() (no division per tick).
 * Anti-windup: I is clamped to +/-i_limit, and it does not integrate further in the
 * direction that would deepen a saturated output. The output is clamped to +/-pwm_limit.
 */
#ifndef NAVKIT_WHEEL_H
#define NAVKIT_WHEEL_H

#include <stdint.h>

typedef struct {
    float kff;       /* duty/(mm/s): feed-forward */
    float kp;        /* duty/(mm/s): proportional */
    float ki;        /* duty/mm: integral of the speed error */
    float kd;        /* duty/(mm/s^2): derivative of the speed error */
    float i_limit;   /* duty: clamp on the integral term */
    float pwm_limit; /* duty: clamp on the output, 0 < pwm_limit <= 1 */
    float ki_dt;     /* duty/(mm/s): ki * dt for the tick dt, set by wheel_gains_set_dt() */
    float kd_dt;     /* duty/(mm/s): kd / dt for the tick dt, set by wheel_gains_set_dt() */
} wheel_gains_t;

typedef struct {
    float integ;       /* duty: integral term */
    float prev_err;    /* mm/s: speed error of the previous tick (for kd) */
    float duty;        /* duty: last output, -pwm_limit..pwm_limit */
    uint8_t saturated; /* 1 if the last output hit pwm_limit */
} wheel_t;

/* Zero the loop (integral, memory and output). */
void wheel_reset(wheel_t *w);
/* Derive the per-tick gains ki_dt and kd_dt for a tick of dt (s): whenever ki, kd or the
 * tick changes, before the next wheel_update(). */
void wheel_gains_set_dt(wheel_gains_t *g, float dt);
/* One tick of the length given to wheel_gains_set_dt(): speed setpoint sp (mm/s), measured
 * speed meas (mm/s); returns the duty (-pwm_limit..pwm_limit, + = forward). */
float wheel_update(wheel_t *w, const wheel_gains_t *g, float sp, float meas);

#endif /* NAVKIT_WHEEL_H */
