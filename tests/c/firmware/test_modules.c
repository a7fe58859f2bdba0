/* Unit tests of the firmware modules one by one: heading, odom, wheel, servo, dio,
 * watchdog, motion rules, config; and the tick's schedule of the parts (fw.c). */
#include <string.h>

#include "check.h"
#include "config.h"
#include "dio.h"
#include "heading.h"
#include "motion.h"
#include "odom.h"
#include "servo.h"
#include "sim_hal.h"
#include "turn.h"
#include "watchdog.h"
#include "wheel.h"

static void test_wrap(void)
{
    CHECK_NEAR(heading_wrap180(10.0f - 350.0f), 20.0, 1e-4);  /* 350 -> 10: 20 clockwise */
    CHECK_NEAR(heading_wrap180(350.0f - 10.0f), -20.0, 1e-4); /* 10 -> 350: 20 counter-clockwise */
    CHECK_NEAR(heading_wrap180(0.0f - 359.9f), 0.1, 1e-3);
    CHECK_NEAR(heading_wrap180(360.0f - 0.0f), 0.0, 1e-4);
    CHECK_NEAR(heading_wrap180(-360.0f + 90.0f), 90.0, 1e-4);
    CHECK_NEAR(heading_wrap180(179.0f), 179.0, 1e-4);
    CHECK_NEAR(heading_wrap180(181.0f), -179.0, 1e-4);
    /* the near wrap: one whole turn at most, -180 <= result < 180 at both ends */
    CHECK(heading_wrap180_near(180.0f) == -180.0f);
    CHECK(heading_wrap180_near(-180.0f) == -180.0f);
    CHECK(heading_wrap180_near(179.9f) == 179.9f);
    CHECK_NEAR(heading_wrap180_near(-180.1f), 179.9, 1e-4);
    CHECK_NEAR(heading_wrap180_near(359.9f), -0.1, 1e-4);
    CHECK_NEAR(heading_wrap180_near(-359.9f), 0.1, 1e-4);
    CHECK(heading_wrap180_near(450.0f) == 90.0f);
    CHECK(heading_wrap180_near(-450.0f) == -90.0f);
    CHECK(heading_wrap180_near(0.0f) == 0.0f);
}

/* heading_wrap180_near() agrees with heading_wrap180() over its whole domain, -540..540,
 * in steps of 0.05 deg (the two round the same float the same way away from +/-180). */
static void test_wrap_near_sweep(void)
{
    int i, bad = 0;
    for (i = -10800; i < 10800; i++) {
        float deg = 0.05f * (float)i;
        float near = heading_wrap180_near(deg);
        if (!(near >= -180.0f && near < 180.0f) || fabsf(near - heading_wrap180(deg)) > 1e-4f) {
            bad++;
        }
    }
    CHECK(bad == 0);
}

/* n ticks of heading_update at 1 kHz with a fold every 10th (~10 ms), as fw.c does at 1 kHz. */
static void hdg_ticks(heading_t *h, int16_t raw, uint8_t still, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        heading_update(h, raw, -1.0f / 131.0f, still, 1000u, 0.001f); /* CCW-positive gyro, 131 LSB per deg/s */
        if (i % 10 == 9) {
            heading_fold(h);
        }
    }
}

static void test_heading(void)
{
    heading_t h;
    int i;
    heading_reset(&h);
    /* 1 s of standstill with a bias of 50 LSB: calibrated */
    hdg_ticks(&h, 50, 1u, 1000);
    CHECK(!h.calibrating);
    CHECK_NEAR(h.bias, 50.0, 1e-3);
    /* turn clockwise at 90 deg/s for 1 s (gyro reads -90*131 + bias) */
    hdg_ticks(&h, (int16_t)(50 - 90 * 131), 0u, 1000);
    CHECK_NEAR(heading_deg(&h), 90.0, 0.01);
    CHECK(heading_deg10(&h) == 900u);
    /* counter-clockwise 100 deg: wraps through 0 to 350 */
    hdg_ticks(&h, (int16_t)(50 + 100 * 131), 0u, 1000);
    CHECK_NEAR(heading_deg(&h), 350.0, 0.01);
    CHECK(heading_deg10(&h) == 3500u);
    /* standstill bias tracking: the bias moves to 60, the heading does not drift */
    hdg_ticks(&h, 60, 1u, 20000);
    CHECK_NEAR(h.bias, 60.0, 0.1);
    CHECK_NEAR(heading_deg(&h), 350.0, 0.01);
    /* 100 000 ticks (100 s) at 36.3 deg/s, folded every 10th: 3630 deg, no drift (the rate
       from the bias as estimated: the float low-pass settles within ~4e-3 LSB) */
    heading_set(&h, 0.0f);
    hdg_ticks(&h, (int16_t)(60 - 4755), 0u, 100000);
    CHECK_NEAR(heading_deg(&h), fmod((4755.0 - 60.0 + (double)h.bias) / 131.0 * 100.0, 360.0), 1e-3);
    /* compass fusion pulls the shortest way across 0/360 */
    heading_set(&h, 355.0f);
    for (i = 0; i < 5000; i++) {
        heading_fuse(&h, 50u, 1.0f, 0.001f); /* compass 5.0 deg */
    }
    CHECK(heading_deg(&h) < 10.0f && heading_deg(&h) > 4.0f);
    /* a compass reading of whole turns above 3599 is the same bearing: 365.0 = 5.0 deg */
    heading_set(&h, 345.0f);
    heading_fuse(&h, 3650u, 0.5f, 1.0f);
    CHECK_NEAR(heading_deg(&h), 355.0, 1e-3); /* half of the 20 deg clockwise */
    heading_set(&h, -90.0f);
    CHECK(heading_deg10(&h) == 2700u);
    heading_set(&h, 359.99f);
    CHECK(heading_deg10(&h) == 0u); /* rounds to 3600 -> 0, never 3600 */
}

/* Between folds the heading (deg and deg*10) already holds the ticks' turn, across 0/360
   both ways; a fold keeps it; fusion pulls from the heading now, not the last fold. */
static void test_heading_fold(void)
{
    heading_t h;
    heading_reset(&h);
    hdg_ticks(&h, 0, 1u, 1000); /* calibrated, bias 0 */
    heading_set(&h, 359.9f);
    /* 2 ticks clockwise at 90 deg/s, no fold: 359.9 + 0.18 = 0.08 */
    heading_update(&h, -90 * 131, -1.0f / 131.0f, 0u, 1000u, 0.001f);
    heading_update(&h, -90 * 131, -1.0f / 131.0f, 0u, 1000u, 0.001f);
    CHECK_NEAR(heading_deg(&h), 0.08, 1e-4);
    CHECK(heading_deg10(&h) == 1u);
    heading_fold(&h);
    CHECK_NEAR(heading_deg(&h), 0.08, 1e-4);
    CHECK(heading_deg10(&h) == 1u);
    /* 1 tick counter-clockwise at 180 deg/s: 0.08 - 0.18 = 359.9 */
    heading_update(&h, 180 * 131, -1.0f / 131.0f, 0u, 1000u, 0.001f);
    CHECK_NEAR(heading_deg(&h), 359.9, 1e-4);
    CHECK(heading_deg10(&h) == 3599u);
    /* unfolded 90 deg (1 s at 90 deg/s, one fold only at the end of the next step), then
       a full-gain fusion (gain * dt = 1) to a compass of 45.0: the heading is 45 exactly */
    heading_set(&h, 0.0f);
    {
        int i;
        for (i = 0; i < 1000; i++) {
            heading_update(&h, -90 * 131, -1.0f / 131.0f, 0u, 1000u, 0.001f);
        }
    }
    CHECK_NEAR(heading_deg(&h), 90.0, 1e-2);
    heading_fuse(&h, 450u, 1.0f, 1.0f);
    CHECK_NEAR(heading_deg(&h), 45.0, 1e-4);
    CHECK(heading_deg10(&h) == 450u);
}

static void test_heading_moving_calibration(void)
{
    heading_t h;
    heading_reset(&h);
    heading_update(&h, 40, -1.0f / 131.0f, 1u, 1000u, 0.001f);
    heading_update(&h, 40, -1.0f / 131.0f, 0u, 1000u, 0.001f); /* moves: calibration ends early */
    CHECK(!h.calibrating);
    CHECK_NEAR(h.bias, 40.0, 1e-4);
}

/* One firmware tick of odometry at the full rate: counts, then the X/Y step when due. */
static void odom_tick(odom_t *o, const odom_geom_t *g, int32_t raw_l, int32_t raw_r, float heading_deg)
{
    odom_count(o, g, raw_l, raw_r, heading_deg);
    if (odom_xy_due(o, g)) {
        odom_xy_step(o, g, heading_deg);
    }
}

static odom_geom_t geom(float mpc, int8_t sl, int8_t sr, uint8_t xy_ticks)
{
    odom_geom_t g;
    g.mm_per_count = mpc;
    g.speed_per_count = mpc * 1000.0f;
    g.speed_alpha = 0.001f / (ODOM_SPEED_TAU_S + 0.001f);
    g.turn_deg_per_count = mpc / 300.0f * 57.2957795f;
    g.sign_l = sl;
    g.sign_r = sr;
    g.xy_ticks = xy_ticks;
    return g;
}

static void test_odom(void)
{
    odom_t o;
    odom_geom_t g = geom(0.5f, 1, -1, 10);
    int i;
    odom_reset(&o);
    odom_tick(&o, &g, 1000, -1000, 0.0f); /* primes only */
    CHECK(o.enc_l == 0 && o.enc_r == 0);
    /* straight at heading 0: +X */
    for (i = 1; i <= 100; i++) {
        odom_tick(&o, &g, 1000 + i * 2, -1000 - i * 2, 0.0f);
    }
    CHECK(o.enc_l == 200 && o.enc_r == 200);
    CHECK_NEAR(odom_distance(&o, 0, 0, g.mm_per_count), 100.0, 1e-4);
    CHECK(o.x == 100 && o.y == 0);
    CHECK_NEAR(o.v_l, 1000.0, 1.0); /* 2 counts * 0.5 mm per ms */
    /* heading 90 (clockwise = right): -Y */
    for (i = 101; i <= 200; i++) {
        odom_tick(&o, &g, 1000 + i * 2, -1000 - i * 2, 90.0f);
    }
    CHECK(o.x == 100 && o.y == -100);
    /* X/Y steps use the mid-step heading, across 0/360 too: 350 -> 10 is along 0 */
    odom_set_xy(&o, 0, 0);
    for (i = 1; i <= 10; i++) {
        odom_tick(&o, &g, 1400 + i * 2, -1400 - i * 2, (i <= 5) ? 350.0f : 10.0f);
    }
    CHECK(o.xy_n == 0u);
    CHECK(o.x == 10 && o.y == 0);
    /* encoder wrap at 2^31 is harmless */
    CHECK(odom_counts_since((int32_t)0x80000005l, 0x7FFFFFFBl) == 10);
    CHECK(odom_counts_since(0x7FFFFFFBl, (int32_t)0x80000005l) == -10);
    /* turn angle: left +471 mm, right -471 mm on a 300 mm track */
    g = geom(1.0f, 1, 1, 10);
    odom_reset(&o);
    odom_tick(&o, &g, 0, 0, 0.0f);
    odom_tick(&o, &g, 471, -471, 0.0f);
    CHECK_NEAR(odom_turn(&o, 0, 0, g.turn_deg_per_count), 471.0 * 2.0 / 300.0 * 57.2957795, 1e-3);
    /* X/Y set */
    odom_set_xy(&o, -5000, 7000);
    CHECK(o.x == -5000 && o.y == 7000);
}

static void test_odom_long_run_precision(void)
{
    /* 100 m at 0.3 mm per tick: the X sum keeps sub-mm precision */
    odom_t o;
    odom_geom_t g = geom(0.1f, 1, 1, 10);
    long i;
    odom_reset(&o);
    odom_tick(&o, &g, 0, 0, 0.0f);
    for (i = 1; i <= 333330; i++) {
        odom_tick(&o, &g, (int32_t)(i * 3), (int32_t)(i * 3), 0.0f);
    }
    CHECK_NEAR((double)o.x + o.x_frac, 333330 * 0.3, 1.0);
}

static void test_wheel(void)
{
    wheel_gains_t g = {.kff = 0.0018f, .kp = 0.004f, .ki = 0.04f, .i_limit = 0.5f, .pwm_limit = 0.8f};
    wheel_t w;
    float d;
    int i;
    wheel_gains_set_dt(&g, 0.001f);
    wheel_reset(&w);
    /* feed-forward + P at zero error */
    d = wheel_update(&w, &g, 100.0f, 100.0f);
    CHECK_NEAR(d, 0.18, 1e-5);
    /* saturates at pwm_limit */
    d = wheel_update(&w, &g, 1000.0f, 0.0f);
    CHECK_NEAR(d, 0.8, 1e-6);
    CHECK(w.saturated);
    /* anti-windup: a stalled wheel does not wind the integral while saturated */
    for (i = 0; i < 10000; i++) {
        wheel_update(&w, &g, 1000.0f, 0.0f);
    }
    CHECK(w.integ < 0.05f);
    /* integral clamp */
    wheel_reset(&w);
    for (i = 0; i < 100000; i++) {
        wheel_update(&w, &g, 10.0f, 0.0f);
    }
    CHECK(w.integ <= 0.5f + 1e-6f);
    /* kd: a step in error gives a derivative kick */
    {
        wheel_gains_t gd = {.kd = 0.00001f, .i_limit = 0.5f, .pwm_limit = 1.0f};
        wheel_gains_set_dt(&gd, 0.001f);
        wheel_reset(&w);
        d = wheel_update(&w, &gd, 10.0f, 0.0f);
        CHECK_NEAR(d, 0.00001 * 10.0 / 0.001, 1e-5);
        /* at 250 Hz the same step gives a quarter of the kick */
        wheel_gains_set_dt(&gd, 0.004f);
        wheel_reset(&w);
        d = wheel_update(&w, &gd, 10.0f, 0.0f);
        CHECK_NEAR(d, 0.00001 * 10.0 / 0.004, 1e-5);
    }
}

static const servo_cal_t cal = {1500u, 1000u, -900, 900}; /* 10 us/deg, +/-90 deg */

static void test_servo_goto(void)
{
    servo_t s;
    int i;
    servo_reset(&s);
    CHECK(servo_pulse_us(&s) == 0u); /* not driven before a command */
    servo_update_pulse(&s, &cal);    /* a refresh does not drive it (1500 us at 0 deg) */
    CHECK(servo_pulse_us(&s) == 0u);
    servo_command(&s, &cal, 0, 300, 9999, 1000u); /* param0 = 0: no command */
    CHECK(s.mode == SERVO_OFF && s.goal == 0);
    /* seed example: servo 2 to 30 deg at 100 deg/s */
    servo_command(&s, &cal, 1000, 300, 9999, 1000u);
    CHECK(s.mode == SERVO_GOTO && s.goal == 300);
    for (i = 0; i < 150; i++) {
        servo_step(&s, &cal);
    }
    CHECK(servo_pos10(&s) == 150); /* halfway after 0.15 s */
    for (i = 0; i < 200; i++) {
        servo_step(&s, &cal);
    }
    CHECK(servo_pos10(&s) == 300);
    CHECK(s.mode == SERVO_HOLD);
    servo_update_pulse(&s, &cal);
    CHECK(servo_pulse_us(&s) == 1800u);
    /* a slower tick rate keeps the speed in deg/s */
    servo_command(&s, &cal, 1000, 0, 9999, 1000u);
    servo_retime(&s, 250u);
    for (i = 0; i < 15; i++) {
        servo_step(&s, &cal); /* 60 ms at 250 Hz */
    }
    CHECK(servo_pos10(&s) == 240);
    servo_retime(&s, 1000u);
    servo_command(&s, &cal, 1000, 300, 9999, 1000u);
    for (i = 0; i < 100; i++) {
        servo_step(&s, &cal);
    }
    /* beyond the travel: clamped to max */
    servo_command(&s, &cal, 10000, 1500, 9999, 1000u);
    for (i = 0; i < 1000; i++) {
        servo_step(&s, &cal);
    }
    CHECK(servo_pos10(&s) == 900);
    servo_update_pulse(&s, &cal);
    CHECK(servo_pulse_us(&s) == 2400u);
}

static void test_servo_scan(void)
{
    servo_t s;
    int i, lo = 0, hi = 0, reversals = 0, prev = 0, dir = 0, first_dir = 0;
    servo_reset(&s);
    /* seed example: scan between +80 and -90 deg at 30 deg/s, toward param1 (+80) first */
    servo_command(&s, &cal, 300, 800, -900, 1000u);
    for (i = 0; i < 30000; i++) {
        int p, d;
        servo_step(&s, &cal);
        p = servo_pos10(&s);
        if (p < lo) {
            lo = p;
        }
        if (p > hi) {
            hi = p;
        }
        d = (p > prev) - (p < prev);
        if (d != 0 && dir != 0 && d != dir) {
            reversals++;
        }
        if (d != 0) {
            dir = d;
            if (first_dir == 0) {
                first_dir = d;
            }
        }
        prev = p;
    }
    CHECK(first_dir == 1);
    CHECK(hi == 800 && lo == -900);
    /* 30 s at 30 deg/s over a 170 deg span (first leg 80 deg): about 5 reversals */
    CHECK(reversals >= 4 && reversals <= 6);
    /* hold (watchdog): stops scanning */
    servo_hold(&s);
    {
        int p0 = servo_pos10(&s);
        for (i = 0; i < 500; i++) {
            servo_step(&s, &cal);
        }
        CHECK(servo_pos10(&s) == p0);
    }
    /* scan limits outside the travel are clamped */
    servo_command(&s, &cal, 2000, 1800, -1800, 1000u);
    CHECK(s.right == 900 && s.left == -900);
}

static void test_dio(void)
{
    dio_t d;
    dio_reset(&d);
    d.in = 0x0ABC;
    CHECK(d.dir == 0u && dio_state(&d) == 0x0ABC); /* all inputs before config */
    dio_configure(&d, 0x00FF, 0x0F0F);             /* seed default: bits 0-7 outputs */
    CHECK(d.out == 0x000F);                        /* safe state, output bits only */
    dio_command(&d, 0x0FF9);                       /* input bits ignored */
    CHECK(d.out == 0x00F9);
    CHECK(dio_state(&d) == ((0x00F9 & 0x00FF) | (0x0ABC & 0x0F00)));
    dio_command(&d, 0x0009); /* seed example: bits 0 and 3 high */
    CHECK(d.out == 0x0009);
    dio_safe(&d);
    CHECK(d.out == 0x000F);
}

static void test_watchdog(void)
{
    watchdog_t w;
    int i, trips = 0;
    watchdog_reset(&w);
    for (i = 0; i < 299; i++) {
        trips += watchdog_tick(&w, 1000u, 300000u);
    }
    CHECK(trips == 0);
    trips += watchdog_tick(&w, 1000u, 300000u);
    CHECK(trips == 1 && w.tripped);
    for (i = 0; i < 1000; i++) {
        trips += watchdog_tick(&w, 1000u, 300000u);
    }
    CHECK(trips == 1); /* once per silence */
    watchdog_feed(&w);
    CHECK(!w.tripped);
    for (i = 0; i < 299; i++) {
        trips += watchdog_tick(&w, 1000u, 300000u);
    }
    CHECK(trips == 1);
}

static void test_motion_rules(void)
{
    /* mm, mm/s: window 25, speed window 50, done within 1 mm at 10 mm/s or less */
    const config_track_t track = {25.0f, 50.0f, 1.0f, 10.0f};
    motion_t m;
    float pos = 0.0f;
    int i;
    motion_reset(&m, 0, 0);
    CHECK(motion_modify(&m, 100.0f, 100.0f, 100.0f) == MOTION_NOT_STARTED);
    motion_start(&m, 0, 0, 0.0f, 100.0f, 100.0f, 300.0f);
    for (i = 0; i < 5000; i++) {
        pos += motion_tick(&m, pos, 0.0f, &track, 0.001f) * 0.001f;
    }
    CHECK(m.done);
    CHECK_NEAR(pos, 100.0, 0.01);
    /* restart after completion with a modify */
    CHECK(motion_modify(&m, 150.0f, 100.0f, 300.0f) == MOTION_OK);
    CHECK(!m.done && motion_active(&m));
    for (i = 0; i < 5000; i++) {
        pos += motion_tick(&m, pos, 0.0f, &track, 0.001f) * 0.001f;
    }
    CHECK_NEAR(pos, 150.0, 0.01);
    /* stop latches: modify is ignored until a new start */
    motion_stop(&m, 300.0f, 0.001f);
    CHECK(motion_modify(&m, 500.0f, 100.0f, 300.0f) == MOTION_LATCHED);
    CHECK_NEAR(m.target, 150.0, 0.01);
    motion_start(&m, 0, 0, pos, 10.0f, 100.0f, 300.0f);
    CHECK(!m.latched);
    CHECK(motion_modify(&m, 20.0f, 100.0f, 300.0f) == MOTION_OK);
}

static void test_turn_hdg_shortest(void)
{
    /* from heading 350 to 10: +20 deg (clockwise), not -340 */
    turn_t t;
    turn_reset(&t, 0, 0);
    turn_hdg_select(&t, 0, 0, 0.0f, 10.0f, 350.0f, 45.0f, 90.0f);
    CHECK(t.hdg);
    CHECK_NEAR(t.ax.target, 20.0, 1e-4);
    /* from 10 to 350: -20 */
    turn_hdg_select(&t, 0, 0, 0.0f, 350.0f, 10.0f, 45.0f, 90.0f);
    CHECK_NEAR(t.ax.target, -20.0, 1e-4);
    /* target given as -90 means 270; from 0 that is -90 */
    turn_hdg_select(&t, 0, 0, 0.0f, -90.0f, 0.0f, 45.0f, 90.0f);
    CHECK_NEAR(t.hdg_target, 270.0, 1e-4);
    CHECK_NEAR(t.ax.target, -90.0, 1e-4);
    /* 360 is 0 */
    turn_hdg_select(&t, 0, 0, 0.0f, 360.0f, 0.0f, 45.0f, 90.0f);
    CHECK_NEAR(t.ax.target, 0.0, 1e-4);
    /* HdgSel has no turn 1 to modify */
    CHECK(turn_modify(&t, 10.0f, 10.0f, 10.0f) == MOTION_NOT_STARTED);
    turn_stop(&t, 90.0f, 0.001f);
    CHECK(!t.hdg && t.ax.latched);
}

static void test_config(void)
{
    config_t c;
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    config_reset(&c);
    CHECK(!config_complete(&c));
    CHECK(c.tick_us == 1000u);
    CHECK_NEAR(c.default_accel, 300.0, 1e-6);
    navkit_micro_cfg_geometry_defaults(&g);
    g.spec_hash ^= 1u;
    CHECK(config_geometry(&c, &g) == CONFIG_ERR_HASH);
    g.spec_hash ^= 1u;
    g.enc_left_sign = 0;
    CHECK(config_geometry(&c, &g) == CONFIG_ERR_RANGE);
    g.enc_left_sign = -1;
    g.control_rate = 500;
    CHECK(config_geometry(&c, &g) == CONFIG_OK);
    CHECK(c.tick_us == 2000u && c.odom.sign_l == -1 && c.odom.xy_ticks == 5u && c.still_ticks == 125u);
    /* the build's ceiling (the spec's 2000 here; firmware.rate_ceiling.* and the AVR cycles
       test build a 400 Hz one) */
    g.control_rate = (uint16_t)(CONFIG_RATE_MAX + 1u);
    CHECK(config_geometry(&c, &g) == CONFIG_ERR_RANGE && c.control_rate == 500u && c.tick_us == 2000u);
    g.control_rate = CONFIG_RATE_MAX;
    CHECK(config_geometry(&c, &g) == CONFIG_OK && c.control_rate == CONFIG_RATE_MAX);
    g.control_rate = 500;
    CHECK(config_geometry(&c, &g) == CONFIG_OK);
    navkit_micro_cfg_motion_defaults(&m);
    m.watchdog_timeout = 5; /* below its minimum */
    CHECK(config_motion(&c, &m) == CONFIG_ERR_RANGE);
    m.watchdog_timeout = 300;
    m.wheel_kd = 10; /* 1e-5 duty/(mm/s^2) */
    CHECK(config_motion(&c, &m) == CONFIG_OK);
    CHECK_NEAR(c.wheel.kd_dt, 1e-5 * 500.0, 1e-9); /* kd / dt at 500 Hz */
    CHECK_NEAR(c.wheel.ki_dt, 0.04 / 500.0, 1e-9); /* ki * dt (ki 400 = 0.04 duty/mm) */
    g.control_rate = 250;
    CHECK(config_geometry(&c, &g) == CONFIG_OK);
    CHECK_NEAR(c.wheel.kd_dt, 1e-5 * 250.0, 1e-9); /* a new rate re-derives both */
    CHECK_NEAR(c.wheel.ki_dt, 0.04 / 250.0, 1e-9);
    CHECK(!config_complete(&c));
    navkit_micro_cfg_io_defaults(&io);
    io.servo_min[3] = 100;
    io.servo_max[3] = 50;
    CHECK(config_io(&c, &io) == CONFIG_ERR_RANGE);
    io.servo_max[3] = 500;
    CHECK(config_io(&c, &io) == CONFIG_OK);
    CHECK(config_complete(&c));
    CHECK(c.dio_direction == 0x00FFu);
}

/* The tick's schedule (fw.c): the forward axis, the turn axis and the wheel loops run every
   tick (each re-plans from the measured state: the reference speed moves by accel * dt
   every tick); of the slow steps, the heading fold runs on tick 0 of the ~10 ms slow period
   (odom.xy_ticks ticks: 10 at 1 kHz, 5 at 500 Hz, 2 at 250 Hz, 1 at 100 Hz) and the X/Y step
   on the others (both every tick when the period is one tick). */
static void test_fw_schedule(void)
{
    static fw_t fw;
    static struct hal h;
    static const uint16_t rate[4] = {1000u, 500u, 250u, 100u}; /* Hz */
    static const uint8_t period_ticks[4] = {10u, 5u, 2u, 1u};  /* odom.xy_ticks */
    static const int n[4] = {60, 60, 60, 20}; /* ticks, all accelerating (the plant keeps up: no re-plan pull) */
    int k, i;
    for (k = 0; k < 4; k++) {
        navkit_micro_cfg_geometry_t g;
        navkit_micro_cfg_motion_t m;
        navkit_micro_cfg_io_t io;
        navkit_micro_cmd_t c;
        float dt = 1.0f / (float)rate[k]; /* s */
        int n_fwd = 0, n_turn = 0, n_wheels = 0, n_fold = 0, n_xy = 0, n_first = 0;
        sim_init(&h);
        fw_init(&fw, &h);
        sim_cfg_defaults(&g, &m, &io);
        g.control_rate = rate[k];
        sim_configure_with(&fw, &h, &g, &m, &io);
        CHECK(fw.cfg.odom.xy_ticks == period_ticks[k]);
        CHECK_NEAR(fw.cfg.dt_fold, period_ticks[k] * dt, 1e-9);
        sim_run(&fw, &h, rate[k]); /* 1 s: gyro calibration */
        sim_cmd_init(&c, 10u);
        c.fwd_cmd = NAVKIT_FWD_CMD_START;
        c.distance = 1000;
        c.speed = 300;
        c.accel = 300;
        c.turn_cmd = NAVKIT_TURN_CMD_TURN;
        c.turn_distance = 900;
        c.turn_rate = 450;
        c.turn_accel = 900;
        sim_cmd(&fw, &h, &c);
        for (i = 0; i < n[k]; i++) {
            uint8_t slow_tick = fw.slow_tick;
            float v = fw.fwd.prof.vel, w = fw.turn.ax.prof.vel; /* mm/s, deg/s */
            int16_t duty = fw.duty_l;
            int32_t q = fw.hdg.q;
            float x_frac = fw.odom.x_frac;
            sim_run(&fw, &h, 1);
            if (fw.fwd.prof.vel != v) {
                CHECK_NEAR(fw.fwd.prof.vel - v, 300.0 * dt, 1e-3); /* accelerating */
                n_fwd++;
            }
            if (fw.turn.ax.prof.vel != w) {
                CHECK_NEAR(fw.turn.ax.prof.vel - w, 90.0 * dt, 1e-3);
                n_turn++;
            }
            if (fw.duty_l != duty) {
                n_wheels++;
            }
            if (slow_tick == 0u) {
                n_first++;
            }
            if (fw.hdg.q != q) {
                CHECK(slow_tick == 0u);
                n_fold++;
            }
            if (fw.odom.x_frac != x_frac) {
                CHECK(slow_tick != 0u || period_ticks[k] == 1u);
                n_xy++;
            }
        }
        CHECK(n_fwd == n[k] && n_turn == n[k] && n_wheels >= n[k] - 2);
        /* a fold on every period's first tick but the very first (the turn had not yet
           moved the heading by one fixed-point step) */
        CHECK(n_first == n[k] / period_ticks[k] && n_fold >= n_first - 1 && n_xy >= 2);
    }
}

static const check_case_t cases[] = {
    CHECK_CASE(wrap),
    CHECK_CASE(wrap_near_sweep),
    CHECK_CASE(heading),
    CHECK_CASE(heading_moving_calibration),
    CHECK_CASE(heading_fold),
    CHECK_CASE(odom),
    CHECK_CASE(odom_long_run_precision),
    CHECK_CASE(wheel),
    CHECK_CASE(servo_goto),
    CHECK_CASE(servo_scan),
    CHECK_CASE(dio),
    CHECK_CASE(watchdog),
    CHECK_CASE(motion_rules),
    CHECK_CASE(turn_hdg_shortest),
    CHECK_CASE(config),
    CHECK_CASE(fw_schedule),
};

int main(int argc, char **argv)
{
    return check_main(argc, argv, cases, sizeof cases / sizeof cases[0], NULL);
}
