/* Unit tests of the trapezoidal profile (profile_*) and seeded property tests.
 *
 * Property run: random moves with random modifications, reversals and stops mid-move;
 * every tick the reference must stay within its acceleration limit and within its speed
 * limit (above a lowered limit only while decelerating to it at the full rate:
 * |v| <= max(vmax, |v_prev| - amax*dt)), never be NaN, never overshoot a target it could
 * reach without overshoot, and come to rest on the target in bounded time. A second run
 * drives a motion_ axis (profile + re-planning from the measured state) against a plant
 * that lags and may not reach the speed: the reference keeps the same acceleration and
 * speed limits on every tick it is not pulled back to the plant (motion_t.limited), and
 * the axis must settle within the stop tolerance in bounded time, with stops (which must
 * never reverse), the stop latch, and "forever" targets modified to near ones.
 * Seed and count: --seed N (0..2^64-1) --count MOVES (1..1e9; the second run does a tenth
 * of the count, rounded up, so at least one); --case NAME runs one case (the property runs
 * are the case "property"), --list names them; anything else exits with 2 and a message
 * naming the argument. ctest runs the short default, a long run is the binary run by
 * hand (docs/firmware.md). */
#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "motion.h"
#include "profile.h"

/* ---- shapes ---- */

typedef struct {
    double peak;     /* u/s: largest |vel| */
    double max_dv;   /* u/s: largest |vel change| in one tick */
    double t_end;    /* s: time to rest */
    double t_cruise; /* s: first time at peak */
} shape_t;

static shape_t run_to_rest(profile_t *p, double dt, long max_ticks)
{
    shape_t s = {0, 0, -1, -1};
    double prev = p->vel;
    long k;
    for (k = 1; k <= max_ticks; k++) {
        double v = profile_step(p, (float)dt);
        if (fabs(v - prev) > s.max_dv) {
            s.max_dv = fabs(v - prev);
        }
        if (fabs(v) > s.peak + 1e-4) {
            s.peak = fabs(v);
            s.t_cruise = k * dt;
        }
        prev = v;
        if (!p->moving) {
            s.t_end = k * dt;
            break;
        }
    }
    return s;
}

static void test_trapezoid(void)
{
    profile_t p;
    shape_t s;
    profile_init(&p, 200.0f, 300.0f);
    profile_retarget(&p, 1000.0f, 200.0f, 300.0f);
    s = run_to_rest(&p, 0.001, 100000);
    CHECK_NEAR(s.peak, 200.0, 1e-3);
    CHECK(s.max_dv <= 300.0 * 0.001 * 1.0001);
    CHECK_NEAR(s.t_cruise, 200.0 / 300.0, 0.002);
    /* d/v + v/a */
    CHECK_NEAR(s.t_end, 1000.0 / 200.0 + 200.0 / 300.0, 0.003);
    CHECK_NEAR(p.togo, 0.0, 1e-4);
}

static void test_triangle(void)
{
    profile_t p;
    shape_t s;
    profile_init(&p, 200.0f, 300.0f);
    profile_retarget(&p, -50.0f, 200.0f, 300.0f); /* backwards, too short to cruise */
    s = run_to_rest(&p, 0.001, 100000);
    CHECK_NEAR(s.peak, sqrt(300.0 * 50.0), 0.5);
    CHECK_NEAR(s.t_end, 2.0 * sqrt(50.0 / 300.0), 0.003);
    CHECK_NEAR(p.togo, 0.0, 1e-4);
}

static void test_stop_distance(void)
{
    /* the closed form equals the brute-force sum of the ticks */
    double v, a = 300.0, dt = 0.001;
    for (v = 0.0; v < 1200.0; v += 37.3) {
        double dv = a * dt, sum = 0.0, u = v - dv;
        while (u > 0.0) {
            sum += u * dt;
            u -= dv;
        }
        CHECK_NEAR(profile_stop_distance((float)v, (float)a, (float)dt), sum, 1e-3 + sum * 1e-5);
    }
    /* and it is not truncated: close to v^2/2a - v dt/2 */
    CHECK_NEAR(profile_stop_distance(200.0f, 300.0f, 0.001f), 200.0 * 200.0 / 600.0 - 0.1, 0.01);
}

static void test_stop(void)
{
    profile_t p;
    long k;
    double travelled = 0.0, prev;
    profile_init(&p, 400.0f, 500.0f);
    profile_retarget(&p, 2e9f, 400.0f, 500.0f); /* forever */
    for (k = 0; k < 2000; k++) {
        profile_step(&p, 0.001f);
    }
    CHECK_NEAR(p.vel, 400.0, 1e-3);
    profile_stop(&p, 200.0f, 0.001f);
    prev = p.vel;
    while (p.moving) {
        double v = profile_step(&p, 0.001f);
        CHECK(fabs(prev - v) <= 200.0 * 0.001 * 1.0001);
        travelled += v * 0.001;
        prev = v;
    }
    /* v^2 / 2a = 400 mm at the braking curve's rate (0.2 % less), less v dt / 2 */
    CHECK_NEAR(travelled, 400.0 * 400.0 / (400.0 * 0.998) - 0.2, 0.05);
}

static void test_stop_never_reverses(void)
{
    /* a gentle stop from speed: 906 mm/s stopped at 28.6 mm/s^2 with a 2 ms tick ends on
       its stop point, never past it (togo >= 0) and never backing up */
    profile_t p;
    double pos = 0.0, stop_at;
    long k, back = 0;
    profile_init(&p, 1082.95f, 2603.18f);
    profile_retarget(&p, 20000.0f, 1082.95f, 2603.18f);
    p.vel = 905.907f;
    profile_stop(&p, 28.6037f, 0.002f);
    stop_at = p.togo;
    CHECK_NEAR(stop_at, 905.907 * 905.907 / (2.0 * 28.6037 * 0.998), 2.0);
    for (k = 0; k < 100000 && p.moving; k++) {
        double v = profile_step(&p, 0.002f);
        pos += v * 0.002;
        back += (v < 0.0);
        CHECK(p.togo >= -1e-3);
    }
    CHECK(!p.moving && back == 0);
    CHECK_NEAR(pos, stop_at, 1e-3);
}

/* A "forever" move (2e9) modified to a near target mid-move: the axis reaches exactly
 * that target, no overshoot and no backing up (single precision coarse near 2e9). */
static double forever_then_modify(double forever, double cruise_s, double near, double vmax, double amax, double dt,
                                  double *maxpos, long *back)
{
    /* u, u/s: window 25, speed window 50, done within 1 at 10 u/s or less */
    const config_track_t track = {25.0f, 50.0f, 1.0f, 10.0f};
    motion_t m;
    double pos = 0.0, vel = 0.0;
    long k;
    *maxpos = 0.0;
    *back = 0;
    motion_reset(&m, 0, 0);
    motion_start(&m, 0, 0, 0.0f, (float)forever, (float)vmax, (float)amax);
    for (k = 0; k < (long)(cruise_s / dt); k++) {
        double sp = motion_tick(&m, (float)pos, (float)vel, &track, (float)dt);
        vel += (sp - vel) * dt / (0.03 + dt);
        pos += vel * dt;
    }
    CHECK(motion_modify(&m, (float)near, (float)vmax, (float)amax) == MOTION_OK);
    for (k = 0; k < (long)(20.0 / dt) && !m.done; k++) {
        double sp = motion_tick(&m, (float)pos, (float)vel, &track, (float)dt);
        *back += (sp < 0.0);
        vel += (sp - vel) * dt / (0.03 + dt);
        pos += vel * dt;
        if (pos > *maxpos) {
            *maxpos = pos;
        }
    }
    CHECK(m.done);
    return pos;
}

static void test_forever_then_modify(void)
{
    double maxpos, pos;
    long back;
    /* forward: 2e9 mm, then 1000 mm (no overshoot, no backing up) */
    pos = forever_then_modify(2e9, 3.0, 1000.0, 300.0, 300.0, 0.001, &maxpos, &back);
    CHECK_NEAR(pos, 1000.0, 1.0);
    CHECK(maxpos < 1001.0 && back == 0);
    /* turn: 2e8 deg (turn_distance 2e9 deg*10), then 90 deg (no overshoot, no backing up) */
    pos = forever_then_modify(2e8, 1.0, 90.0, 45.0, 90.0, 0.001, &maxpos, &back);
    CHECK_NEAR(pos, 90.0, 0.4);
    CHECK(maxpos < 90.4 && back == 0);
}

static void test_reverse(void)
{
    /* cruising toward +1000; the target moves behind: slow to zero, go back, stop there */
    profile_t p;
    long k;
    double pos = 0.0, maxpos = 0.0;
    profile_init(&p, 200.0f, 300.0f);
    profile_retarget(&p, 1000.0f, 200.0f, 300.0f);
    for (k = 0; k < 2000; k++) {
        pos += profile_step(&p, 0.001f) * 0.001;
    }
    profile_retarget(&p, -1000.0f + 100.0f, 200.0f, 300.0f); /* new target 100 mm */
    while (p.moving) {
        pos += profile_step(&p, 0.001f) * 0.001;
        if (pos > maxpos) {
            maxpos = pos;
        }
    }
    CHECK(maxpos > 300.0); /* it had to brake first */
    CHECK_NEAR(pos, 100.0, 1e-2);
}

static void test_track(void)
{
    profile_t p;
    profile_init(&p, 200.0f, 300.0f);
    profile_retarget(&p, 1000.0f, 200.0f, 300.0f);
    p.vel = 200.0f;
    /* the robot is 100 mm behind the reference and slower: pulled back */
    CHECK(profile_track(&p, 100.0f, 100.0f, 25.0f, 50.0f) == 1u);
    CHECK_NEAR(p.togo, 1075.0, 1e-3);
    CHECK_NEAR(p.vel, 150.0, 1e-3);
    /* within the window: untouched */
    CHECK(profile_track(&p, 5.0f, 150.0f, 25.0f, 50.0f) == 0u);
    CHECK_NEAR(p.togo, 1075.0, 1e-3);
    /* far target: the pull and the reference position stay exact */
    profile_init(&p, 200.0f, 300.0f);
    profile_set_togo(&p, 2e9f, 3.25f); /* reference at 3.25 */
    CHECK_NEAR(profile_ref_pos(&p, 2e9f), 3.25, 1e-6);
    CHECK(profile_track(&p, 30.0f, 0.0f, 25.0f, 50.0f) == 1u); /* robot at -26.75 */
    CHECK_NEAR(profile_ref_pos(&p, 2e9f), -1.75, 1e-6);
}

/* ---- properties ---- */

static uint64_t rng_state;
static uint64_t rng_next(void)
{
    /* splitmix64 */
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static double rng_uniform(double lo, double hi)
{
    return lo + (hi - lo) * (double)(rng_next() >> 11) * (1.0 / 9007199254740992.0);
}

/* Figures of the whole run, reported at the end. */
static struct {
    double accel_excess; /* largest (|dv| - amax dt) / (amax dt) */
    double speed_excess; /* largest (|v| - limit) / limit, limit = max(vmax, |v_prev| - amax dt) */
    double final_err;    /* u: largest |position - target| at rest */
    double tracked_err;  /* u: the same for the tracked run */
} prop_stats;

static void prop_note_final(double err)
{
    if (err > prop_stats.final_err) {
        prop_stats.final_err = err;
    }
}

static void prop_note_tracked(double err)
{
    if (err > prop_stats.tracked_err) {
        prop_stats.tracked_err = err;
    }
}

/* u/s: the most |v| may be after a tick from prev (u/s) with limit vmax (u/s) and velocity
   step dv = amax*dt (u/s): vmax, or less than |prev| by dv when above it. */
static double prop_speed_limit(double vmax, double prev, double dv)
{
    double decel = fabs(prev) - dv;
    return (decel > vmax) ? decel : vmax;
}

/* 1 when a velocity step from prev to v (u/s) breaks the acceleration limit dv = amax*dt
   (u/s), allowing for single-precision rounding of the velocity itself. */
static int prop_accel_broken(double prev, double v, double dv)
{
    return fabs(v - prev) > dv * (1.0 + 1e-4) + 4e-7 * fabs(v) + 1e-6;
}

/* One random move; returns 0 when every property held. */
static int prop_case(unsigned long idx)
{
    /* s: 0.001 is the firmware's default tick (1 kHz), 0.004 250 Hz */
    static const double dts[] = {0.001, 0.0005, 0.002, 0.004, 0.01};
    profile_t p;
    double dt = dts[rng_next() % 5u];
    double amax = rng_uniform(20.0, 3000.0);
    double vmax = rng_uniform(5.0, 1500.0);
    double pos = 0.0, target = rng_uniform(-3000.0, 3000.0);
    int mods = (int)(rng_next() % 4u);
    long k = 0, limit = 0;
    int bad = 0, feasible = 1, stopped = 0;
    double dir0 = 1.0, stop_dir = 0.0;

    profile_init(&p, (float)vmax, (float)amax);
    profile_retarget(&p, (float)target, (float)vmax, (float)amax);
    for (;;) {
        double prev = p.vel, v, D, vlim;
        /* maybe modify or stop mid-move */
        if (mods > 0 && p.moving && (rng_next() % 400u) == 0u) {
            mods--;
            amax = rng_uniform(20.0, 3000.0);
            if (rng_next() % 5u == 0u) {
                /* a stop changes only the deceleration: vmax stays the profile's */
                profile_stop(&p, (float)amax, (float)dt);
                target = pos + p.togo;
                stopped = 1;
                stop_dir = (p.vel > 0.0f) ? 1.0 : (p.vel < 0.0f) ? -1.0 : 0.0;
                feasible = 1; /* a stop must never overshoot */
            } else {
                double nt = (rng_next() % 3u == 0u) ? pos + rng_uniform(-50.0, 50.0) : rng_uniform(-3000.0, 3000.0);
                vmax = rng_uniform(5.0, 1500.0);
                profile_retarget(&p, (float)(nt - target), (float)vmax, (float)amax);
                target = nt;
                stopped = 0;
                /* reachable without overshoot? (moving toward it and able to stop in time
                   at the planner's braking rate, amax less its 0.2 % margin) */
                dir0 = (p.togo >= 0.0f) ? 1.0 : -1.0;
                feasible = (p.vel * dir0 >= 0.0) &&
                           profile_stop_distance(p.vel, (float)(amax * 0.998), (float)dt) <= fabs(p.togo);
            }
            k = 0;
        }
        if (k == 0) {
            dir0 = (p.togo > 0.0f) ? 1.0 : (p.togo < 0.0f) ? -1.0 : (p.vel >= 0.0f ? 1.0 : -1.0);
            /* time bound for the rest of the move, generous but finite */
            D = fabs(p.togo) + (double)p.vel * p.vel / (2.0 * amax);
            limit = (long)((fabs(p.vel) / amax + D / vmax + 2.0 * vmax / amax + 2.0 * sqrt(D / amax) + 0.05) / dt) + 20;
        }
        v = profile_step(&p, (float)dt);
        pos += v * dt;
        k++;
        if (v != v || p.togo != p.togo) {
            bad |= 1; /* NaN */
        }
        if (prop_accel_broken(prev, v, amax * dt)) {
            bad |= 2; /* acceleration limit */
        }
        if ((fabs(v - prev) - amax * dt) / (amax * dt) > prop_stats.accel_excess) {
            prop_stats.accel_excess = (fabs(v - prev) - amax * dt) / (amax * dt);
        }
        /* speed limit on every tick: above a lowered vmax only while decelerating to it by
           the full amax*dt, so holding a speed above the limit fails */
        vlim = prop_speed_limit(p.vmax, prev, amax * dt);
        if ((fabs(v) - vlim) / vlim > prop_stats.speed_excess) {
            prop_stats.speed_excess = (fabs(v) - vlim) / vlim;
        }
        if (fabs(v) > vlim * (1.0 + 1e-5) + 1e-5) {
            bad |= 4;
        }
        if (feasible && p.togo * dir0 < -(1e-2 + 1e-6 * fabs(target))) { /* 10 um: far below one encoder count */
            bad |= 8;                                                    /* overshoot */
        }
        if (stopped && v * stop_dir < 0.0) {
            bad |= 64; /* a stop reversed */
        }
        if (!p.moving) {
            if (fabs(pos - target) > 1e-2 + 1e-5 * fabs(target)) {
                bad |= 16; /* final error */
            }
            break;
        }
        if (k > limit) {
            bad |= 32; /* never arrives */
            break;
        }
    }
    prop_note_final(fabs(pos - target));
    if (bad) {
        fprintf(stderr, "property case %lu failed: mask %d (dt %g amax %g vmax %g target %g pos %g)\n", idx, bad, dt,
                amax, vmax, target, pos);
    }
    return bad;
}

/* One random move of a motion_ axis against a lagging, speed-capped plant, with random
 * modifications, stops (and modifications after them, which the stop latch ignores) and
 * sometimes a "forever" start modified to a near target; 0 when it settled within
 * tolerance in time and a stop never reversed. */
static int prop_tracked_case(unsigned long idx)
{
    static const double dts[] = {0.001, 0.002, 0.004};
    const double tol = 5.0;
    /* u, u/s: window 25, speed window 50, done within tol at 10 u/s or less */
    const config_track_t track = {25.0f, 50.0f, (float)tol, 10.0f};
    motion_t m;
    double dt = dts[rng_next() % 3u];
    double amax = rng_uniform(50.0, 2000.0);
    double vmax = rng_uniform(20.0, 800.0);
    double cap = vmax * rng_uniform(0.3, 1.5); /* the plant's top speed */
    double tau = rng_uniform(0.0, 0.08);       /* s: the plant's lag */
    int forever = (rng_next() % 4u) == 0u;
    double target = forever ? ((rng_next() & 1u) ? 2e9 : -2e9) : rng_uniform(-3000.0, 3000.0);
    double pos = 0.0, vel = 0.0, bound, vc = (vmax < cap ? vmax : cap);
    double stop_dir = 0.0;
    long k, limit;
    int mods = (int)(rng_next() % 3u) + forever, bad = 0, latched = 0;

    motion_reset(&m, 0, 0);
    motion_start(&m, 0, 0, 0.0f, (float)target, (float)vmax, (float)amax);
    bound = forever ? 1e9 : fabs(target) / vc + 2.0 * vmax / amax + 10.0 * tau + 2.0;
    limit = (long)(bound / dt);
    for (k = 0; k < limit; k++) {
        double sp, ref_prev; /* u/s: reference speed out, and before the tick */
        if (mods > 0 && (rng_next() % 2000u) == 0u) {
            mods--;
            if (!latched && (rng_next() % 4u) == 0u) {
                /* stop: decelerate to rest and latch */
                amax = rng_uniform(50.0, 2000.0);
                motion_stop(&m, (float)amax, (float)dt);
                latched = 1;
                forever = 0;
                target = m.target;
                stop_dir = (m.prof.vel > 0.0f) ? 1.0 : (m.prof.vel < 0.0f) ? -1.0 : 0.0;
                limit = k + (long)((fabs(vel) / amax * 2.0 + 10.0 * tau + 2.0) / dt);
            } else {
                double nt = rng_uniform(-3000.0, 3000.0);
                motion_result_t r = motion_modify(&m, (float)nt, (float)vmax, (float)amax);
                if (r != (latched ? MOTION_LATCHED : MOTION_OK)) {
                    bad |= 8; /* the stop latch rule */
                }
                if (!latched) {
                    target = nt;
                    forever = 0;
                    limit = k +
                            (long)((fabs(target - pos) / vc + 2.0 * vmax / amax + 10.0 * tau + fabs(vel) / amax + 2.0) /
                                   dt);
                }
            }
        }
        if (forever && k * dt > 2.0) {
            /* a "forever" move always ends in a modify to a near target */
            target = pos + rng_uniform(-500.0, 500.0);
            motion_modify(&m, (float)target, (float)vmax, (float)amax);
            forever = 0;
            limit = k +
                    (long)((fabs(target - pos) / vc + 2.0 * vmax / amax + 10.0 * tau + fabs(vel) / amax + 2.0) / dt);
        }
        ref_prev = m.prof.vel;
        sp = motion_tick(&m, (float)pos, (float)vel, &track, (float)dt);
        if (sp != sp) {
            bad |= 1;
            break;
        }
        /* the reference's own limits, on every tick it was not pulled back to the plant */
        if (!m.limited) {
            double dv = (double)m.prof.amax * dt;
            if (prop_accel_broken(ref_prev, m.prof.vel, dv)) {
                bad |= 32;
            }
            if (fabs(m.prof.vel) > prop_speed_limit(m.prof.vmax, ref_prev, dv) * (1.0 + 1e-5) + 1e-5) {
                bad |= 64;
            }
        }
        if (latched && sp * stop_dir < 0.0) {
            bad |= 16; /* a stop sent the robot back */
        }
        if (sp > cap) {
            sp = cap;
        } else if (sp < -cap) {
            sp = -cap;
        }
        vel += (sp - vel) * dt / (tau + dt);
        pos += vel * dt;
        if (m.done) {
            break;
        }
    }
    if (latched) {
        target = m.target; /* a stop ends where the robot comes to rest */
    }
    if (!m.done) {
        bad |= 2; /* never settled */
    } else if (fabs(pos - target) > tol + 0.5) {
        bad |= 4; /* settled outside the tolerance */
    }
    prop_note_tracked(fabs(pos - target));
    if (bad) {
        fprintf(stderr, "tracked case %lu failed: mask %d (dt %g amax %g vmax %g cap %g tau %g target %g pos %g)\n",
                idx, bad, dt, amax, vmax, cap, tau, target, pos);
    }
    return bad;
}

#define PROP_COUNT_MAX 1000000000ul /* moves per run at most */

/* An unsigned integer option value (decimal, 0x hex or 0 octal), the whole text, starting
 * with a digit (no sign, no blank), within lo..hi; else a message naming the option and
 * the value, and 0. */
static int prop_arg(const char *prog, const char *opt, const char *text, unsigned long long lo, unsigned long long hi,
                    unsigned long long *out)
{
    char *end;
    errno = 0;
    *out = strtoull(text, &end, 0);
    if (text[0] < '0' || text[0] > '9' || *end != '\0' || errno == ERANGE || *out < lo || *out > hi) {
        fprintf(stderr, "%s: %s: '%s' is not an integer in %llu..%llu\n", prog, opt, text, lo, hi);
        return 0;
    }
    return 1;
}

/* The property runs' seed (--seed) and moves (--count). */
static unsigned long long prop_seed = 20051018ull;
static unsigned long prop_count = 20000ul;

/* Parse "--seed N" (0..2^64-1), "--count N" (1..PROP_COUNT_MAX moves) and "--case NAME"
   (*name: one case alone, else NULL); returns 0, or prints what is wrong and returns 1. */
static int parse_args(int argc, char **argv, const char **name)
{
    int i;
    unsigned long long v;
    for (i = 1; i < argc; i += 2) {
        if (i + 1 >= argc ||
            (strcmp(argv[i], "--seed") != 0 && strcmp(argv[i], "--count") != 0 && strcmp(argv[i], "--case") != 0)) {
            fprintf(stderr, "%s: argument %d '%s': usage: %s [--list | --case NAME] [--seed N] [--count MOVES]\n",
                    argv[0], i, argv[i], argv[0]);
            return 1;
        }
        if (strcmp(argv[i], "--case") == 0) {
            *name = argv[i + 1];
        } else if (strcmp(argv[i], "--seed") == 0) {
            if (!prop_arg(argv[0], "--seed", argv[i + 1], 0u, ULLONG_MAX, &v)) {
                return 1;
            }
            prop_seed = v;
        } else {
            if (!prop_arg(argv[0], "--count", argv[i + 1], 1u, PROP_COUNT_MAX, &v)) {
                return 1;
            }
            prop_count = (unsigned long)v;
        }
    }
    return 0;
}

/* The property runs: prop_count random moves from prop_seed, then the tracked axis. */
static void test_property(void)
{
    unsigned long i, failed = 0;
    clock_t t0 = clock();
    rng_state = prop_seed;
    for (i = 0; i < prop_count; i++) {
        if (prop_case(i)) {
            failed++;
            if (failed >= 10) {
                break;
            }
        }
    }
    printf("property: seed %llu, %lu moves, %lu failed; max |accel| excess %.3g of amax, max speed excess %.3g "
           "of the limit, max final error %.3g u\n",
           prop_seed, i, failed, prop_stats.accel_excess, prop_stats.speed_excess, prop_stats.final_err);
    CHECK(failed == 0);
    failed = 0;
    /* a tenth as many tracked moves, rounded up: every count runs at least one */
    for (i = 0; i < (prop_count + 9u) / 10u; i++) {
        if (prop_tracked_case(i)) {
            failed++;
            if (failed >= 10) {
                break;
            }
        }
    }
    printf("tracked property: %lu moves, %lu failed; max final error %.3g u (tolerance 5); %.1f s in all\n", i, failed,
           prop_stats.tracked_err, (double)(clock() - t0) / CLOCKS_PER_SEC);
    CHECK(failed == 0);
}

static const check_case_t cases[] = {
    CHECK_CASE(trapezoid),
    CHECK_CASE(triangle),
    CHECK_CASE(stop_distance),
    CHECK_CASE(stop),
    CHECK_CASE(stop_never_reverses),
    CHECK_CASE(reverse),
    CHECK_CASE(track),
    CHECK_CASE(forever_then_modify),
    CHECK_CASE(property),
};

int main(int argc, char **argv)
{
    const char *name = NULL;
    if (argc == 2 && strcmp(argv[1], "--list") == 0) {
        check_list(cases, sizeof cases / sizeof cases[0]);
        return EXIT_SUCCESS;
    }
    if (parse_args(argc, argv, &name)) {
        return 2;
    }
    return check_run(argv[0], name, cases, sizeof cases / sizeof cases[0]);
}
