/* excite: open-loop wheel excitation experiments. See excite.h. */
#include "excite.h"

#include <math.h>

#define EXCITE_LFSR_TAPS 0xB400u /* x^16 + x^14 + x^13 + x^11 + 1, Galois form */
#define EXCITE_TWO_PI 6.28318530717958647692f
#define EXCITE_DUTY_PER_RAW 0.001f /* duty per raw unit of excite_amplitude and excite_offset */
#define EXCITE_HZ_PER_RAW 0.01f    /* Hz per raw unit of excite_f0 and excite_f1 */

void excite_reset(excite_t *e)
{
    e->mode = NAVKIT_EXCITE_MODE_NONE; /* idle: excite_start() sets every other field */
}

uint8_t excite_refused(const navkit_micro_cmd_t *c)
{
    if (c->excite_mode == NAVKIT_EXCITE_MODE_NONE) {
        return 0u;
    }
    return (uint8_t)(c->fwd_cmd != NAVKIT_FWD_CMD_NONE || c->turn_cmd != NAVKIT_TURN_CMD_NONE ||
                     c->excite_duration == 0u || (c->excite_mode == NAVKIT_EXCITE_MODE_PRBS && c->excite_seed == 0u));
}

/* ms -> ticks at rate (Hz), rounded to the nearest tick. */
static uint32_t excite_ticks(uint16_t ms, uint16_t rate)
{
    return ((uint32_t)ms * rate + 500u) / 1000u;
}

void excite_start(excite_t *e, const navkit_micro_cmd_t *c, uint16_t control_rate)
{
    float hz_dt = EXCITE_HZ_PER_RAW / (float)control_rate; /* cycles per tick per raw unit of frequency */
    uint32_t total = excite_ticks(c->excite_duration, control_rate);
    uint32_t hold = excite_ticks(c->excite_period, control_rate);
    e->mode = (uint8_t)c->excite_mode;
    e->wheels = (uint8_t)c->excite_wheels;
    e->amplitude = c->excite_amplitude;
    e->offset = c->excite_offset;
    e->total = (total > 0u) ? total : 1u;
    /* PRBS: a bit lasts one tick at least */
    e->hold = (hold == 0u && e->mode == NAVKIT_EXCITE_MODE_PRBS) ? 1u : hold;
    e->bit_left = e->hold;
    e->lfsr = c->excite_seed;
    e->n = 0u;
    e->phase = 0.0f;
    e->f0_dt = hz_dt * (float)c->excite_f0;
    e->df_dt = hz_dt * (float)((int32_t)c->excite_f1 - (int32_t)c->excite_f0) / (float)e->total;
}

void excite_stop(excite_t *e)
{
    e->mode = NAVKIT_EXCITE_MODE_NONE;
}

/* u(n) of the running experiment for its current tick e->n; steps the chirp phase and
   the LFSR for the next one. */
static float excite_u(excite_t *e)
{
    float u = 0.0f;
    uint8_t bit;
    switch (e->mode) {
    case NAVKIT_EXCITE_MODE_STEP:
        u = (e->n >= e->hold) ? 1.0f : 0.0f;
        break;
    case NAVKIT_EXCITE_MODE_CHIRP:
        u = sinf(EXCITE_TWO_PI * e->phase);
        /* the frequency of tick n from n itself (no drift from summing the increments) */
        e->phase += e->f0_dt + e->df_dt * (float)e->n;
        e->phase -= (float)(uint8_t)e->phase; /* keep 0..1: a tick's step is below 20 cycles */
        break;
    default: /* NAVKIT_EXCITE_MODE_PRBS */
        bit = (uint8_t)(e->lfsr & 1u);
        u = bit ? 1.0f : -1.0f;
        if (--e->bit_left == 0u) {
            e->bit_left = e->hold;
            e->lfsr = (uint16_t)((e->lfsr >> 1) ^ (bit ? EXCITE_LFSR_TAPS : 0u));
        }
        break;
    }
    return u;
}

uint8_t excite_tick(excite_t *e, float pwm_limit, float *duty_l, float *duty_r)
{
    float d;
    if (!excite_active(e)) {
        return 0u;
    }
    d = EXCITE_DUTY_PER_RAW * ((float)e->offset + (float)e->amplitude * excite_u(e));
    if (d > pwm_limit) {
        d = pwm_limit;
    } else if (d < -pwm_limit) {
        d = -pwm_limit;
    }
    /* both: d, d; left: d, 0; right: 0, d; spin: d, -d */
    *duty_l = (e->wheels == NAVKIT_EXCITE_WHEELS_RIGHT) ? 0.0f : d;
    *duty_r = (e->wheels == NAVKIT_EXCITE_WHEELS_LEFT) ? 0.0f : (e->wheels == NAVKIT_EXCITE_WHEELS_SPIN) ? -d : d;
    if (++e->n >= e->total) {
        excite_stop(e); /* that was the last tick: the next one is idle */
    }
    return 1u;
}

uint8_t excite_micro_cmd(excite_t *e, const navkit_micro_cmd_t *c, uint16_t control_rate)
{
    if (c->fwd_cmd != NAVKIT_FWD_CMD_NONE || c->turn_cmd != NAVKIT_TURN_CMD_NONE) {
        excite_stop(e);
    }
    if (c->excite_mode == NAVKIT_EXCITE_MODE_NONE) {
        return 0u;
    }
    excite_start(e, c, control_rate);
    return 1u;
}
