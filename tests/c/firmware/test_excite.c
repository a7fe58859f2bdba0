/* Excitation experiments (excite.c): the module's duty sequences (step, chirp, PRBS exact
 * and bounded, PRBS deterministic per seed), and through the link on the whole firmware
 * with the sim_hal plant (started, ended by its duration, by a stop, by the watchdog,
 * refused out of range, the "wheels" datalog selection). */
#include <math.h>
#include <string.h>

#include "check.h"
#include "excite.h"
#include "sim_hal.h"

#define RATE 1000u /* Hz: control rate of the module tests */
#define TEST_PI 3.14159265358979323846

static navkit_micro_cmd_t excite_cmd(uint16_t mode, uint16_t wheels, int16_t amp, int16_t offset, uint16_t ms,
                                     uint16_t period_ms)
{
    navkit_micro_cmd_t c;
    sim_cmd_init(&c, 1u);
    c.excite_mode = mode;
    c.excite_wheels = wheels;
    c.excite_amplitude = amp;
    c.excite_offset = offset;
    c.excite_duration = ms;
    c.excite_period = period_ms;
    return c;
}

/* Step: offset for `period` ticks, then offset + amplitude, for exactly `duration` ticks;
 * then idle. Both wheels the same; one wheel; spin. */
static void test_step(void)
{
    excite_t e;
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_STEP, NAVKIT_EXCITE_WHEELS_BOTH, 300, 100, 10, 3);
    float l = 9.0f, r = 9.0f;
    int n;
    excite_reset(&e);
    CHECK(!excite_active(&e) && !excite_tick(&e, 1.0f, &l, &r) && l == 9.0f);
    excite_start(&e, &c, RATE);
    for (n = 0; n < 10; n++) {
        CHECK(excite_active(&e));
        CHECK(excite_tick(&e, 1.0f, &l, &r));
        CHECK(l == r && l == (n < 3 ? 0.1f : 0.001f * (100.0f + 300.0f)));
    }
    CHECK(!excite_active(&e) && !excite_tick(&e, 1.0f, &l, &r));
    /* one wheel, the other 0; spin: opposite */
    c.excite_wheels = NAVKIT_EXCITE_WHEELS_RIGHT;
    excite_start(&e, &c, RATE);
    excite_tick(&e, 1.0f, &l, &r);
    CHECK(l == 0.0f && r == 0.1f);
    c.excite_wheels = NAVKIT_EXCITE_WHEELS_LEFT;
    excite_start(&e, &c, RATE);
    excite_tick(&e, 1.0f, &l, &r);
    CHECK(l == 0.1f && r == 0.0f);
    c.excite_wheels = NAVKIT_EXCITE_WHEELS_SPIN;
    excite_start(&e, &c, RATE);
    excite_tick(&e, 1.0f, &l, &r);
    CHECK(l == 0.1f && r == -0.1f);
    /* durations round to whole ticks at the rate: 10 ms at 250 Hz = 2.5 -> 3 ticks (2 at
       the offset: 6 ms -> 1.5 -> 2), a period of 0 steps at once */
    c = excite_cmd(NAVKIT_EXCITE_MODE_STEP, NAVKIT_EXCITE_WHEELS_BOTH, -500, 0, 10, 6);
    excite_start(&e, &c, 250u);
    for (n = 0; n < 3; n++) {
        excite_tick(&e, 1.0f, &l, &r);
        CHECK(l == (n < 2 ? 0.0f : -0.5f));
    }
    CHECK(!excite_active(&e));
    c.excite_period = 0u;
    excite_start(&e, &c, 250u);
    excite_tick(&e, 1.0f, &l, &r);
    CHECK(l == -0.5f);
    /* ended at once */
    excite_stop(&e);
    CHECK(!excite_active(&e) && !excite_tick(&e, 1.0f, &l, &r));
}

/* Never above pwm_limit: offset + amplitude beyond it is clamped, both signs. */
static void test_bounded(void)
{
    excite_t e;
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_PRBS, NAVKIT_EXCITE_WHEELS_SPIN, 1000, 500, 2000, 0);
    float l, r, lo = 0.0f, hi = 0.0f;
    int n;
    c.excite_seed = 0xACE1u;
    excite_start(&e, &c, RATE);
    for (n = 0; n < 2000; n++) {
        excite_tick(&e, 0.8f, &l, &r);
        CHECK(fabsf(l) <= 0.8f && fabsf(r) <= 0.8f && r == -l);
        lo = (l < lo) ? l : lo;
        hi = (l > hi) ? l : hi;
    }
    CHECK(hi == 0.8f && lo == -0.5f); /* 1.5 clamped, -0.5 as is */
    c = excite_cmd(NAVKIT_EXCITE_MODE_CHIRP, NAVKIT_EXCITE_WHEELS_BOTH, 1000, -1000, 2000, 0);
    c.excite_f0 = 100u;  /* 1 Hz */
    c.excite_f1 = 1000u; /* 10 Hz */
    excite_start(&e, &c, RATE);
    lo = 0.0f;
    for (n = 0; n < 2000; n++) {
        excite_tick(&e, 0.3f, &l, &r);
        CHECK(l >= -0.3f && l <= 0.0f);
        lo = (l < lo) ? l : lo;
    }
    CHECK(lo == -0.3f);
}

/* Chirp: duty(n) = offset + A sin(2 pi phase(n)), phase(n) = sum_{k<n} (f0 + (f1-f0) k/N) dt,
 * against the same sum in double over 5 s at 1 kHz (N = 5000 ticks). */
static void test_chirp(void)
{
    excite_t e;
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_CHIRP, NAVKIT_EXCITE_WHEELS_BOTH, 400, 200, 5000, 0);
    const double f0 = 0.5, f1 = 20.0, dt = 1.0 / RATE, total = 5000.0;
    double worst = 0.0;
    float l, r;
    int n;
    c.excite_f0 = 50u;
    c.excite_f1 = 2000u;
    excite_start(&e, &c, RATE);
    for (n = 0; n < 5000; n++) {
        double phase = f0 * dt * n + (f1 - f0) * dt / total * (double)n * (n - 1) / 2.0;
        double want = 0.2 + 0.4 * sin(2.0 * TEST_PI * phase);
        CHECK(excite_tick(&e, 1.0f, &l, &r));
        worst = fmax(worst, fabs(l - want));
    }
    CHECK(!excite_active(&e));
    CHECK(worst < 2e-3); /* duty: float phase over 5 s, ~1e-4 cycles */
    printf("chirp: worst duty error %.2e over 5000 ticks\n", worst);
}

/* PRBS: +/-A around the offset, one bit per period, from the 16-bit LFSR x^16+x^14+x^13+x^11+1
 * (Galois, taps 0xB400) started at the seed: the sequence is exactly that LFSR's bit 0,
 * the same for the same seed, another for another seed; balanced like a maximal sequence. */
static void test_prbs(void)
{
    excite_t e, e2;
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_PRBS, NAVKIT_EXCITE_WHEELS_LEFT, 250, 0, 60000, 3);
    uint16_t lfsr = 0x1234u;
    long ones = 0, bits = 0, differ = 0, n;
    float l, r, l2, r2;
    c.excite_seed = lfsr;
    excite_start(&e, &c, RATE);
    c.excite_seed = 0x1235u;
    excite_start(&e2, &c, RATE);
    for (n = 0; n < 60000; n++) {
        float want = (lfsr & 1u) ? 0.25f : -0.25f;
        excite_tick(&e, 1.0f, &l, &r);
        excite_tick(&e2, 1.0f, &l2, &r2);
        CHECK(l == want && r == 0.0f);
        differ += (l != l2);
        if (n % 3 == 2) { /* the bit lasts the period: 3 ticks */
            ones += (lfsr & 1u);
            bits++;
            lfsr = (uint16_t)((lfsr >> 1) ^ ((lfsr & 1u) ? 0xB400u : 0u));
        }
    }
    CHECK(!excite_active(&e));
    CHECK(differ > 20000); /* another seed: another sequence */
    CHECK(labs(2 * ones - bits) < bits / 50);
    /* the same seed again: the same sequence */
    c.excite_seed = 0x1234u;
    excite_start(&e, &c, RATE);
    excite_start(&e2, &c, RATE);
    for (n = 0; n < 5000; n++) {
        excite_tick(&e, 1.0f, &l, &r);
        excite_tick(&e2, 1.0f, &l2, &r2);
        CHECK(l == l2);
    }
}

/* The refusal rule besides the spec's ranges. */
static void test_refused(void)
{
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_STEP, 0u, 100, 0, 100, 0);
    CHECK(!excite_refused(&c));
    c.fwd_cmd = NAVKIT_FWD_CMD_STOP;
    CHECK(excite_refused(&c));
    c.fwd_cmd = 0u;
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    CHECK(excite_refused(&c));
    c.turn_cmd = 0u;
    c.excite_duration = 0u;
    CHECK(excite_refused(&c));
    c.excite_duration = 100u;
    c.excite_mode = NAVKIT_EXCITE_MODE_PRBS;
    CHECK(excite_refused(&c)); /* seed 0 */
    c.excite_seed = 1u;
    CHECK(!excite_refused(&c));
    c = excite_cmd(NAVKIT_EXCITE_MODE_NONE, 0u, 0, 0, 0, 0);
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    CHECK(!excite_refused(&c)); /* no experiment: nothing to refuse */
}

/* ---- through the link, on the whole firmware ---- */

static fw_t fw;
static struct hal h;
static uint16_t tag = 200;

static navkit_micro_data_t data(void)
{
    navkit_micro_data_t d;
    memset(&d, 0, sizeof d);
    CHECK(sim_last_data(&h, &d));
    return d;
}

static void boot(void)
{
    sim_init(&h);
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100); /* gyro calibration */
    sim_configure(&fw, &h);
}

/* The host: repeat c every 100 ms for n frames. */
static void host_frames(const navkit_micro_cmd_t *c, int n)
{
    int f;
    for (f = 0; f < n; f++) {
        sim_cmd(&fw, &h, c);
        sim_run(&fw, &h, (long)fw.cfg.control_rate / 10);
    }
}

static void test_link_step_and_datalog(void)
{
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_STEP, NAVKIT_EXCITE_WHEELS_BOTH, 400, 0, 1000, 200);
    navkit_micro_data_t d;
    boot();
    c.time_tag = ++tag;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_WHEELS;
    sim_cmd(&fw, &h, &c);
    sim_run(&fw, &h, 100);
    CHECK(h.duty_l == 0 && h.duty_r == 0); /* 200 ms at the offset, 0 */
    sim_cmd(&fw, &h, &c);                  /* the host's repeat: not a new experiment */
    sim_run(&fw, &h, 150);
    CHECK(h.duty_l == 4000 && h.duty_r == 4000); /* duty e4 at the pins */
    sim_cmd(&fw, &h, &c);
    d = data();
    CHECK(d.status & NAVKIT_MICRO_STATUS_EXCITE_ACTIVE);
    CHECK(d.mc_datalog_sel == NAVKIT_MC_DATALOG_WHEELS);
    CHECK(d.mc_datalog[0] == 4000 && d.mc_datalog[2] == 4000);
    CHECK(d.mc_datalog[1] > 100 && d.mc_datalog[1] == d.mc_datalog[3]); /* speed mm/s, both alike */
    CHECK_NEAR(d.mc_datalog[1], fw.odom.v_l, 0.5);
    /* ends by itself after 1 s: duty 0, the bit clear */
    host_frames(&c, 8);
    sim_cmd(&fw, &h, &c);
    d = data();
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_EXCITE_ACTIVE));
    CHECK(h.duty_l == 0 && h.duty_r == 0 && d.mc_datalog[0] == 0);
    CHECK(d.cmd_rejected == 0);
}

static void test_link_ended_by_stop_and_watchdog(void)
{
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_CHIRP, NAVKIT_EXCITE_WHEELS_SPIN, 300, 0, 30000, 0);
    navkit_micro_cmd_t stop;
    navkit_micro_data_t d;
    boot();
    c.excite_f0 = 100u;
    c.excite_f1 = 100u;
    c.time_tag = ++tag;
    host_frames(&c, 3);
    CHECK(excite_active(&fw.excite));
    sim_cmd_init(&stop, ++tag);
    stop.fwd_cmd = NAVKIT_FWD_CMD_STOP;
    sim_cmd(&fw, &h, &stop);
    sim_run(&fw, &h, 1);
    CHECK(!excite_active(&fw.excite) && h.duty_l == 0 && h.duty_r == 0);
    /* again, then silence: the watchdog (300 ms) ends it */
    c.time_tag = ++tag;
    host_frames(&c, 2);
    CHECK(excite_active(&fw.excite) && h.duty_l != 0);
    sim_run(&fw, &h, 190); /* 290 ms since the last command */
    CHECK(excite_active(&fw.excite));
    sim_run(&fw, &h, 20);
    CHECK(!excite_active(&fw.excite) && h.duty_l == 0 && h.duty_r == 0);
    sim_cmd(&fw, &h, &c); /* its repeat after the stop: no new experiment */
    sim_run(&fw, &h, 10);
    d = data();
    CHECK(!excite_active(&fw.excite) && d.watchdog_stops == 1 && (d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
    /* a new one clears the watchdog stop; a start of the forward axis ends it */
    c.time_tag = ++tag;
    sim_cmd(&fw, &h, &c);
    sim_run(&fw, &h, 5);
    d = data();
    CHECK(excite_active(&fw.excite) && !(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
    sim_cmd_init(&stop, ++tag);
    stop.fwd_cmd = NAVKIT_FWD_CMD_START;
    stop.distance = 100;
    sim_cmd(&fw, &h, &stop);
    CHECK(!excite_active(&fw.excite) && motion_active(&fw.fwd));
}

static void test_link_refused(void)
{
    navkit_micro_cmd_t c = excite_cmd(NAVKIT_EXCITE_MODE_STEP, NAVKIT_EXCITE_WHEELS_BOTH, 400, 0, 1000, 0);
    navkit_micro_data_t d;
    const uint16_t range = (uint16_t)(NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CMD);
    boot();
    /* with a fwd_cmd */
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.time_tag = ++tag;
    host_frames(&c, 1);
    d = data();
    CHECK(d.cmd_rejected == 1 && d.last_reject == range && !excite_active(&fw.excite) && !motion_active(&fw.fwd));
    /* out of the spec's ranges: mode 4, amplitude above 1000, wheels 4 */
    c.fwd_cmd = 0u;
    c.excite_mode = 4u;
    c.time_tag = ++tag;
    host_frames(&c, 1);
    c.excite_mode = NAVKIT_EXCITE_MODE_STEP;
    c.excite_amplitude = 1001;
    c.time_tag = ++tag;
    host_frames(&c, 1);
    c.excite_amplitude = 400;
    c.excite_wheels = 4u;
    c.time_tag = ++tag;
    host_frames(&c, 1);
    /* PRBS without a seed */
    c.excite_wheels = 0u;
    c.excite_mode = NAVKIT_EXCITE_MODE_PRBS;
    c.time_tag = ++tag;
    host_frames(&c, 1);
    d = data();
    CHECK(d.cmd_rejected == 5 && d.last_reject == range && !excite_active(&fw.excite));
    CHECK(h.duty_l == 0 && h.duty_r == 0);
    /* the same with a seed runs */
    c.excite_seed = 7u;
    c.time_tag = ++tag;
    host_frames(&c, 1);
    CHECK(excite_active(&fw.excite) && data().cmd_rejected == 5);
}

static const check_case_t cases[] = {
    CHECK_CASE(step),
    CHECK_CASE(bounded),
    CHECK_CASE(chirp),
    CHECK_CASE(prbs),
    CHECK_CASE(refused),
    CHECK_CASE(link_step_and_datalog),
    CHECK_CASE(link_ended_by_stop_and_watchdog),
    CHECK_CASE(link_refused),
};

int main(int argc, char **argv)
{
    return check_main(argc, argv, cases, sizeof cases / sizeof cases[0], NULL);
}
