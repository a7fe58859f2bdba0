/* The core built as a 16 MHz AVR target builds it, with the control_rate ceiling
 * CONFIG_RATE_MAX=400 (tests/c/firmware/CMakeLists.txt), run on the host with the sim_hal
 * plant: after reset it ticks at the ceiling (not the spec's default 1 kHz, which it would
 * refuse), a geometry config above the ceiling is refused whole, and a move configured at
 * the ceiling ends on target. */
#include <math.h>

#include "check.h"
#include "sim_hal.h"

static fw_t fw;
static struct hal h;

#if CONFIG_RATE_MAX != 400
#error "this test is built with CONFIG_RATE_MAX=400"
#endif

/* Reset: the spec defaults with the rate capped at the ceiling, a sane tick everywhere. */
static void test_reset_at_ceiling(void)
{
    long n;
    sim_init(&h);
    fw_init(&fw, &h);
    CHECK(fw.cfg.control_rate == 400u && fw_tick_period_us(&fw) == 2500u);
    CHECK_NEAR(fw.cfg.dt, 0.0025, 1e-9);
    CHECK(fw.cfg.odom.xy_ticks == 4u && fw.cfg.still_ticks == 100u);
    CHECK(isfinite(fw.cfg.wheel.kd_dt) && isfinite(fw.cfg.dt_fold) && fw.cfg.dt_fold > 0.0f);
    /* the gyro calibration takes its 1 s: 400 ticks, not one sample */
    for (n = 0; n < 1000 && fw.hdg.calibrating; n++) {
        sim_run(&fw, &h, 1);
    }
    CHECK(n >= 390 && n <= 410);
    CHECK(fw.ms >= 970u && fw.ms <= 1030u); /* uptime, ms, counts 2.5 ms a tick */
}

/* 1000 Hz (the spec default) refused as out of range, nothing changed; 400 Hz accepted. */
static void test_config_above_ceiling(void)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    navkit_micro_data_t d;
    navkit_micro_cmd_t c;
    sim_init(&h);
    fw_init(&fw, &h);
    sim_run(&fw, &h, 450); /* gyro calibration */
    sim_cfg_defaults(&g, &m, &io);
    sim_configure_with(&fw, &h, &g, &m, &io); /* control_rate 1000: refused */
    CHECK(!(fw_status(&fw) & NAVKIT_MICRO_STATUS_CONFIGURED));
    CHECK(!(fw.cfg.received & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK) && fw.cfg.control_rate == 400u);
    CHECK(fw.link.last_reject == (NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY));
    g.control_rate = 400;
    sim_configure_with(&fw, &h, &g, &m, &io);
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_CONFIGURED);
    /* a 1 m move at 400 Hz ends on target */
    sim_cmd_init(&c, 10u);
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 300;
    c.distance = 1000;
    for (int f = 0; f < 60; f++) { /* 6 s, the host's frame every 100 ms (40 ticks) */
        sim_cmd(&fw, &h, &c);
        sim_run(&fw, &h, 40);
    }
    CHECK(sim_last_data(&h, &d));
    CHECK(d.status & NAVKIT_MICRO_STATUS_FWD_DONE);
    CHECK_NEAR(h.dist_mm, 1000.0, 5.0);
}

static const check_case_t cases[] = {
    CHECK_CASE(reset_at_ceiling),
    CHECK_CASE(config_above_ceiling),
};

int main(int argc, char **argv)
{
    return check_main(argc, argv, cases, sizeof cases / sizeof cases[0], NULL);
}
