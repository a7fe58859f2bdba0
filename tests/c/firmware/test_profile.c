/* Unit tests of the trapezoidal profile (profile_*) and seeded property tests.
 *
 * Property run: random moves with random modifications, reversals and stops mid-move;
 * every tick the reference must stay within its acceleration limit (and within its speed
 * limit unless decelerating toward a lowered one), never be NaN, never overshoot a
 * target it could reach without overshoot, and come to rest on the target in bounded
 * time. A second run drives a motion_ axis (profile + re-planning from the measured state)
 * against a plant that lags and may not reach the speed: it must settle within the stop
 * tolerance in bounded time. Seed and count: argv[1], argv[2], or NAVKIT_PROP_SEED /
 * NAVKIT_PROP_COUNT (the second run does a tenth of the count). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

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
    CHECK_NEAR(travelled, 400.0 * 400.0 / 400.0, 0.5); /* v^2 / 2a = 400 mm */
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
    CHECK(profile_track(&p, 1100.0f, 100.0f, 25.0f, 50.0f) == 1u);
    CHECK_NEAR(p.togo, 1075.0, 1e-3);
    CHECK_NEAR(p.vel, 150.0, 1e-3);
    /* within the window: untouched */
    CHECK(profile_track(&p, 1080.0f, 150.0f, 25.0f, 50.0f) == 0u);
    CHECK_NEAR(p.togo, 1075.0, 1e-3);
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

/* One random move; returns 0 when every property held. */
static int prop_case(unsigned long idx)
{
    static const double dts[] = {0.001, 0.0005, 0.002, 0.01};
    profile_t p;
    double dt = dts[rng_next() % 4u];
    double amax = rng_uniform(20.0, 3000.0);
    double vmax = rng_uniform(5.0, 1500.0);
    double pos = 0.0, target = rng_uniform(-3000.0, 3000.0);
    int mods = (int)(rng_next() % 4u);
    long k = 0, limit;
    int bad = 0, feasible = 1;
    double dir0 = 1.0;

    profile_init(&p, (float)vmax, (float)amax);
    profile_retarget(&p, (float)target, (float)vmax, (float)amax);
    for (;;) {
        double prev = p.vel, v, D;
        /* maybe modify mid-move */
        if (mods > 0 && p.moving && (rng_next() % 400u) == 0u) {
            mods--;
            vmax = rng_uniform(5.0, 1500.0);
            amax = rng_uniform(20.0, 3000.0);
            if (rng_next() % 5u == 0u) {
                profile_stop(&p, (float)amax, (float)dt);
                target = pos + p.togo;
            } else {
                double nt = (rng_next() % 3u == 0u) ? pos + rng_uniform(-50.0, 50.0) : rng_uniform(-3000.0, 3000.0);
                profile_retarget(&p, (float)(nt - target), (float)vmax, (float)amax);
                target = nt;
            }
            /* reachable without overshoot? (moving toward it and able to stop in time at
               the planner's braking rate, amax less its 0.2 % margin) */
            dir0 = (p.togo >= 0.0f) ? 1.0 : -1.0;
            feasible = (p.vel * dir0 >= 0.0) &&
                       profile_stop_distance(p.vel, (float)(amax * 0.998), (float)dt) <= fabs(p.togo);
            k = 0;
        }
        if (k == 0) {
            dir0 = (p.togo >= 0.0f) ? 1.0 : -1.0;
            /* time bound for the rest of the move, generous but finite */
            D = fabs(p.togo) + (double)p.vel * p.vel / (2.0 * amax);
            limit = (long)((fabs(p.vel) / amax + D / vmax + 2.0 * vmax / amax + 2.0 * sqrt(D / amax) + 0.05) / dt) +
                    20;
        }
        v = profile_step(&p, (float)dt);
        pos += v * dt;
        k++;
        if (v != v || p.togo != p.togo) {
            bad |= 1; /* NaN */
        }
        /* limit plus single-precision rounding of the velocity itself */
        if (fabs(v - prev) > amax * dt * (1.0 + 1e-4) + 4e-7 * fabs(v) + 1e-6) {
            bad |= 2; /* acceleration limit */
        }
        if (fabs(v) > vmax * (1.0 + 1e-5) + 1e-5 && fabs(v) > fabs(prev)) {
            bad |= 4; /* speed limit (decelerating to a lowered limit is allowed) */
        }
        if (feasible && p.togo * dir0 < -(1e-2 + 1e-6 * fabs(target))) { /* 10 um: far below one encoder count */
            bad |= 8; /* overshoot */
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
    if (bad) {
        fprintf(stderr, "property case %lu failed: mask %d (dt %g amax %g vmax %g target %g pos %g)\n", idx, bad,
                dt, amax, vmax, target, pos);
    }
    return bad;
}

/* One random move of a motion_ axis against a lagging, speed-capped plant; 0 when it
 * settled within tolerance in time. */
static int prop_tracked_case(unsigned long idx)
{
    const double dt = 0.001, tol = 5.0;
    motion_t m;
    double amax = rng_uniform(50.0, 2000.0);
    double vmax = rng_uniform(20.0, 800.0);
    double cap = vmax * rng_uniform(0.3, 1.5);     /* the plant's top speed */
    double tau = rng_uniform(0.0, 0.08);           /* s: the plant's lag */
    double target = rng_uniform(-3000.0, 3000.0);
    double pos = 0.0, vel = 0.0, bound;
    long k, limit;
    int mods = (int)(rng_next() % 3u), bad = 0;

    motion_reset(&m, 0, 0);
    motion_start(&m, 0, 0, 0.0f, (float)target, (float)vmax, (float)amax);
    bound = fabs(target) / (vmax < cap ? vmax : cap) + 2.0 * vmax / amax + 10.0 * tau + 2.0;
    limit = (long)(bound / dt);
    for (k = 0; k < limit; k++) {
        double sp;
        if (mods > 0 && (rng_next() % 2000u) == 0u) {
            mods--;
            target = rng_uniform(-3000.0, 3000.0);
            motion_modify(&m, (float)target, (float)vmax, (float)amax);
            limit = k + (long)((fabs(target - pos) / (vmax < cap ? vmax : cap) + 2.0 * vmax / amax + 10.0 * tau +
                                fabs(vel) / amax + 2.0) / dt);
        }
        sp = motion_tick(&m, (float)pos, (float)vel, 25.0f, 50.0f, (float)tol, 10.0f, (float)dt);
        if (sp != sp) {
            bad |= 1;
            break;
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
    if (!m.done) {
        bad |= 2; /* never settled */
    } else if (fabs(pos - target) > tol + 0.5) {
        bad |= 4; /* settled outside the tolerance */
    }
    if (bad) {
        fprintf(stderr, "tracked case %lu failed: mask %d (amax %g vmax %g cap %g tau %g target %g pos %g)\n", idx,
                bad, amax, vmax, cap, tau, target, pos);
    }
    return bad;
}

int main(int argc, char **argv)
{
    const char *es = getenv("NAVKIT_PROP_SEED");
    const char *ec = getenv("NAVKIT_PROP_COUNT");
    unsigned long long seed = es ? strtoull(es, 0, 0) : 20051018ull;
    unsigned long count = ec ? strtoul(ec, 0, 0) : 20000ul;
    unsigned long i, failed = 0;
    if (argc > 1) {
        seed = strtoull(argv[1], 0, 0);
    }
    if (argc > 2) {
        count = strtoul(argv[2], 0, 0);
    }

    test_trapezoid();
    test_triangle();
    test_stop_distance();
    test_stop();
    test_reverse();
    test_track();

    rng_state = seed;
    for (i = 0; i < count; i++) {
        if (prop_case(i)) {
            failed++;
            if (failed >= 10) {
                break;
            }
        }
    }
    printf("property: seed %llu, %lu moves, %lu failed\n", seed, i, failed);
    CHECK(failed == 0);
    failed = 0;
    for (i = 0; i < count / 10u; i++) {
        if (prop_tracked_case(i)) {
            failed++;
            if (failed >= 10) {
                break;
            }
        }
    }
    printf("tracked property: %lu moves, %lu failed\n", i, failed);
    CHECK(failed == 0);
    CHECK_DONE();
}
