/* excite: open-loop wheel excitation experiments for identification (prefix excite_).
 *
 * A micro_cmd with excite_mode 1-3 (spec enum excite_mode) starts an experiment: for
 * excite_duration the wheel loops are bypassed and the duty of the driven wheels is
 *     duty(n) = clamp(offset + amplitude * u(n), -pwm_limit, +pwm_limit)
 * for tick n = 0, 1, ... counted from the first tick after the command, where u is
 *   step : 0 for the first `hold` ticks (excite_period), then 1;
 *   chirp: sin(2 pi phase(n)), phase(n) = sum over k < n of f(k) * dt (cycles), with the
 *          frequency f(k) = f0 + (f1 - f0) * k / total swept linearly from excite_f0 to
 *          excite_f1 over the experiment's `total` ticks;
 *   PRBS : +1 while bit 0 of a 16-bit Galois LFSR (taps 0xB400: x^16+x^14+x^13+x^11+1,
 *          period 65535) is 1, else -1; the LFSR starts at excite_seed and steps once every
 *          `hold` ticks (excite_period, at least one tick), so a seed gives one sequence.
 * excite_wheels picks both wheels (same duty), one (the other 0) or spin (left +duty, right
 * -duty). After `total` ticks the experiment ends: duty 0, idle. excite_stop() ends it at
 * once (duty 0, no braking profile): any fwd_cmd or turn_cmd, and the watchdog, do that.
 * Durations convert to ticks at the control rate of the start, rounded to the nearest
 * tick (a duration of at least one tick).
 */
#ifndef NAVKIT_EXCITE_H
#define NAVKIT_EXCITE_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

typedef struct {
    uint8_t mode;      /* NAVKIT_EXCITE_MODE_*: NONE while idle */
    uint8_t wheels;    /* NAVKIT_EXCITE_WHEELS_* */
    uint16_t lfsr;     /* PRBS: LFSR state, never 0 */
    int16_t amplitude; /* duty x 1000: A (excite_amplitude) */
    int16_t offset;    /* duty x 1000: the working point (excite_offset) */
    float f0_dt;       /* cycles per tick: chirp frequency at tick 0 times dt */
    float df_dt;       /* cycles per tick per tick: (f1 - f0) * dt / total */
    float phase;       /* cycles, 0..1: chirp phase of the next tick */
    uint32_t n;        /* ticks run so far */
    uint32_t total;    /* ticks of the experiment, >= 1 */
    uint32_t hold;     /* ticks: step delay (0 = at once), or PRBS bit time (>= 1) */
    uint32_t bit_left; /* PRBS: ticks left of the current bit */
} excite_t;

/* Idle (the other fields are set by excite_start()). */
void excite_reset(excite_t *e);
/* 0 if micro_cmd c may start (or leave alone) an experiment, else 1: with excite_mode 1-3,
 * refused unless fwd_cmd and turn_cmd are 0, excite_duration is at least 1 ms and (PRBS)
 * excite_seed is not 0. The spec's ranges are navkit_micro_cmd_check()'s. */
uint8_t excite_refused(const navkit_micro_cmd_t *c);
/* Start the experiment of checked command c (excite_mode 1-3) at control_rate (Hz);
 * replaces a running one. */
void excite_start(excite_t *e, const navkit_micro_cmd_t *c, uint16_t control_rate);
/* The experiment's part of a checked micro_cmd c, at control_rate (Hz): any fwd_cmd or
 * turn_cmd ends a running experiment (excite_stop()); excite_mode 1-3 starts one
 * (excite_start()). Returns 1 if it started one, else 0. */
uint8_t excite_micro_cmd(excite_t *e, const navkit_micro_cmd_t *c, uint16_t control_rate);
/* End at once: idle, so the next tick drives duty 0. */
void excite_stop(excite_t *e);
/* 1 while an experiment runs (inline: fw_tick asks every tick, so an idle experiment
 * costs one compare there). */
static inline uint8_t excite_active(const excite_t *e)
{
    return (uint8_t)(e->mode != NAVKIT_EXCITE_MODE_NONE);
}
/* One control tick: while active, *duty_l and *duty_r (duty, -pwm_limit..pwm_limit,
 * + = wheel forward, before the motor signs) get this tick's duties and 1 is returned (the
 * experiment ends after its last tick); idle: returns 0 and leaves them. pwm_limit in duty,
 * 0 < pwm_limit <= 1. */
uint8_t excite_tick(excite_t *e, float pwm_limit, float *duty_l, float *duty_r);

#endif /* NAVKIT_EXCITE_H */
