/* Whole-firmware tests through the link: frames in through the UART wires, a simple
 * wheel plant (sim_hal) closing the loop, micro_data out. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "sim_hal.h"

static fw_t fw;
static struct hal h;

static void boot(void)
{
    sim_init(&h);
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100); /* gyro calibration */
}

/* The host: repeat command c (same time tag) every 100 ms (control_rate / 10 ticks) for
   `seconds`; before_tick, unless NULL, is called before every tick. */
static void host_run_each(const navkit_micro_cmd_t *c, double seconds, void (*before_tick)(void))
{
    long frames = (long)(seconds * 10.0 + 0.5), f, k;
    for (f = 0; f < frames; f++) {
        sim_cmd(&fw, &h, c);
        for (k = 0; k < (long)fw.cfg.control_rate / 10; k++) {
            if (before_tick != NULL) {
                before_tick();
            }
            sim_run(&fw, &h, 1);
        }
    }
}

/* host_run_each() with nothing before the ticks. */
static void host_run(const navkit_micro_cmd_t *c, double seconds)
{
    host_run_each(c, seconds, NULL);
}

static navkit_micro_data_t data(void)
{
    navkit_micro_data_t d;
    memset(&d, 0, sizeof d);
    CHECK(sim_last_data(&h, &d));
    return d;
}

static uint16_t tag = 100;

static navkit_micro_cmd_t cmd(void)
{
    navkit_micro_cmd_t c;
    sim_cmd_init(&c, ++tag);
    return c;
}

static void test_unconfigured(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    navkit_micro_cfg_geometry_t g;
    uint8_t buf[64];
    boot();
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.distance = 1000;
    host_run(&c, 0.5);
    d = data();
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_CONFIGURED));
    CHECK(d.cmd_rejected == 1 && d.last_reject == 1);
    CHECK(h.duty_l == 0 && h.duty_r == 0 && h.dist_mm == 0.0);
    CHECK(d.spec_hash == NAVKIT_SPEC_HASH && d.fw_version == FW_VERSION);
    CHECK(d.rx_good == 5);
    /* a config from another spec is refused and counted */
    navkit_micro_cfg_geometry_defaults(&g);
    g.spec_hash = 0x12345678u;
    h.tx_len = 0;
    sim_send(&h, buf, navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf));
    fw_link_poll(&fw);
    d = data();
    CHECK(d.rx_schema_mismatch == 1);
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK));
    /* so is one of another spec's length (good CRC over its own length word) */
    {
        size_t n = navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf);
        memset(buf + n, 0, 4);
        navkit_frame_seal(buf, n + 4, NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY);
        sim_send(&h, buf, n + 4);
        sim_send(&h, buf, navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf));
        fw_link_poll(&fw);
    }
    d = data();
    CHECK(d.rx_schema_mismatch == 3 && d.rx_bad_length == 0);
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK));
    /* one with a field outside its spec range: cmd_rejected, last_reject = reject.range | msg_type */
    navkit_micro_cfg_geometry_defaults(&g);
    g.wheel_diameter = 0u;
    sim_send(&h, buf, navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf));
    fw_link_poll(&fw);
    d = data();
    CHECK(d.cmd_rejected == 2 && d.last_reject == (NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY));
    CHECK(d.rx_schema_mismatch == 3 && !(d.status & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK));
    /* the three configs: configured */
    sim_configure(&fw, &h);
    d = data();
    CHECK(d.status & NAVKIT_MICRO_STATUS_CONFIGURED);
    CHECK(h.tx_len == 3u * NAVKIT_MICRO_DATA_BYTES); /* one micro_data per frame */
    /* reset: unconfigured again */
    fw_init(&fw, &h);
    sim_cmd(&fw, &h, &c);
    d = data();
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_CONFIGURED));
}

static void test_forward_move(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    double peak = 0.0;
    int i;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = -200; /* sign ignored */
    c.distance = 1000;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_FWD_PROFILE;
    for (i = 0; i < 75; i++) {
        host_run(&c, 0.1);
        d = data();
        if (d.fwd_speed > peak) {
            peak = d.fwd_speed;
        }
        if (i == 10) {
            CHECK(d.mc_datalog[0] > 150); /* reference speed while accelerating (default 300 mm/s^2) */
            /* 1.1 s in: ~67 mm ramping to 200 mm/s, then cruising: ~850 mm to go */
            CHECK(d.mc_datalog[1] > 780 && d.mc_datalog[1] < 920); /* reference to go, mm */
            CHECK_NEAR(d.mc_datalog[2], d.mc_datalog[1], 30.0);    /* measured to go, mm */
            CHECK(d.mc_datalog[3] == 0x1);                         /* moving only */
        }
    }
    d = data();
    CHECK_NEAR(peak, 200.0, 15.0);
    CHECK_NEAR(h.dist_mm, 1000.0, 5.0);
    CHECK_NEAR(d.distance, 1000.0, 5.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_FWD_DONE);
    CHECK(d.mc_datalog[1] == 0 && abs(d.mc_datalog[2]) <= 5 && d.mc_datalog[3] == 0x2); /* done */
    CHECK_NEAR(d.x, 1000.0, 6.0);
    CHECK_NEAR(d.y, 0.0, 3.0);
    CHECK(d.ack_time_tag == c.time_tag);
    /* a repeated tag is not re-executed: same frame with a changed distance does nothing */
    c.distance = 200;
    host_run(&c, 1.0);
    CHECK_NEAR(h.dist_mm, 1000.0, 5.0);
    /* restart after completion: modify to 1300 from the same reference */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.speed = 200;
    c.distance = 1300;
    host_run(&c, 0.5);
    d = data();
    CHECK(d.fwd_speed > 50); /* moving, but mc_datalog_cmd 0 (none): the words are 0 */
    CHECK(d.mc_datalog[0] == 0 && d.mc_datalog[1] == 0 && d.mc_datalog[2] == 0 && d.mc_datalog[3] == 0);
    host_run(&c, 2.5);
    d = data();
    CHECK_NEAR(h.dist_mm, 1300.0, 5.0);
    CHECK_NEAR(d.distance, 1300.0, 5.0);
}

static void test_modify_reverse(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    double far = 0.0;
    int i;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 300;
    c.accel = 500;
    c.distance = 3000;
    host_run(&c, 2.0);
    d = data();
    CHECK_NEAR(d.fwd_speed, 300.0, 20.0);
    /* slow down */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.speed = 100;
    c.accel = 500;
    c.distance = 3000;
    host_run(&c, 1.0);
    d = data();
    CHECK_NEAR(d.fwd_speed, 100.0, 15.0);
    /* target behind: brake, back up to 200 (reference of the original start) */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.speed = 200;
    c.accel = 500;
    c.distance = 200;
    for (i = 0; i < 100; i++) {
        host_run(&c, 0.1);
        if (h.dist_mm > far) {
            far = h.dist_mm;
        }
    }
    d = data();
    CHECK(far > 600.0);
    CHECK_NEAR(h.dist_mm, 200.0, 5.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_FWD_DONE);
}

static void test_stop_latch(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    double at_stop;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 300;
    c.distance = 2000000000; /* forever */
    host_run(&c, 3.0);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_STOP;
    c.accel = 600;
    host_run(&c, 0.1);
    at_stop = h.dist_mm;
    host_run(&c, 1.5);
    d = data();
    /* v^2/2a = 75 mm from 300 mm/s at 600 mm/s^2 */
    CHECK_NEAR(h.dist_mm - at_stop, 75.0 - 0.1 * 300.0 + 0.5 * 600.0 * 0.01, 15.0);
    CHECK(d.fwd_speed == 0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_FWD_STOP_LATCHED);
    at_stop = h.dist_mm;
    /* modify after a stop: no effect */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.speed = 300;
    c.distance = 2000000000;
    host_run(&c, 1.0);
    CHECK_NEAR(h.dist_mm, at_stop, 2.0);
    /* a new start moves again, from a new reference */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = -300;
    host_run(&c, 4.0);
    d = data();
    CHECK_NEAR(h.dist_mm, at_stop - 300.0, 5.0);
    CHECK_NEAR(d.distance, -300.0, 5.0);
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_FWD_STOP_LATCHED));
}

static void test_speed_limited_plant(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    int i, limited = 0;
    boot();
    sim_configure(&fw, &h);
    h.speed_cap = 150.0; /* deep rug: cannot reach 400 mm/s */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 400;
    c.distance = 1500;
    for (i = 0; i < 150; i++) {
        host_run(&c, 0.1);
        d = data();
        if (d.status & NAVKIT_MICRO_STATUS_SPEED_LIMITED) {
            limited++;
        }
    }
    d = data();
    CHECK(limited > 10);
    CHECK_NEAR(h.dist_mm, 1500.0, 5.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_FWD_DONE);
}

static void test_turns(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    boot();
    h.gyro_bias = 25; /* estimated during the start-up calibration */
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100);
    sim_configure(&fw, &h);
    /* pivot 90 deg clockwise */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 450;
    c.turn_distance = 900;
    host_run(&c, 4.0);
    d = data();
    CHECK_NEAR(h.yaw_deg, 90.0, 2.0);
    CHECK_NEAR(h.dist_mm, 0.0, 3.0);
    CHECK_NEAR(d.turn_progress, 900.0, 20.0);
    CHECK_NEAR(d.heading, 900.0, 20.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_TURN_DONE);
    /* backing up while turning clockwise: still clockwise */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 150;
    c.distance = -600;
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 200;
    c.turn_distance = 450;
    host_run(&c, 6.0);
    d = data();
    CHECK_NEAR(h.yaw_deg, 135.0, 2.0);
    CHECK_NEAR(d.distance, -600.0, 5.0);
    /* dg_control set_xy alone: X/Y set, the heading (135 deg) kept although dg_set is given */
    c = cmd();
    c.dg_control = NAVKIT_DG_CONTROL_SET_XY;
    c.dg_set = 3500;
    c.x_set = -400;
    c.y_set = 250;
    host_run(&c, 0.2);
    d = data();
    CHECK(d.x == -400 && d.y == 250);
    CHECK_NEAR(d.heading, 1350.0, 20.0);
    /* HdgSel across 0/360: set the heading to 350, select 10 -> 20 deg clockwise */
    c = cmd();
    c.dg_control = NAVKIT_DG_CONTROL_SET_BOTH;
    c.dg_set = 3500;
    c.x_set = 1000;
    c.y_set = -2000;
    host_run(&c, 0.2);
    d = data();
    CHECK_NEAR(d.heading, 3500.0, 2.0);
    CHECK(d.x == 1000 && d.y == -2000);
    {
        double yaw0 = h.yaw_deg;
        c = cmd();
        c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
        c.turn_rate = 300;
        c.turn_distance = 100;
        host_run(&c, 4.0);
        d = data();
        CHECK_NEAR(h.yaw_deg - yaw0, 20.0, 1.0);
        CHECK_NEAR(d.heading, 100.0, 10.0);
        CHECK(d.status & NAVKIT_MICRO_STATUS_HDG_ACTIVE);
        CHECK(d.status & NAVKIT_MICRO_STATUS_HDG_HOLD);
        /* and back the short way: 10 -> 300 is 70 deg counter-clockwise */
        c = cmd();
        c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
        c.turn_rate = 300;
        c.turn_distance = -600; /* -60 = 300 */
        host_run(&c, 5.0);
        d = data();
        CHECK_NEAR(h.yaw_deg - yaw0, 20.0 - 70.0, 1.5);
        CHECK_NEAR(d.heading, 3000.0, 15.0);
    }
    /* unimplemented turn codes are refused whole */
    {
        static const uint16_t codes[] = {13, 15, 20, 23, 25, 7};
        unsigned k;
        for (k = 0; k < sizeof codes / sizeof codes[0]; k++) {
            uint16_t before = data().cmd_rejected;
            double dist0 = h.dist_mm;
            c = cmd();
            c.fwd_cmd = NAVKIT_FWD_CMD_START; /* not half-done either */
            c.distance = 500;
            c.turn_cmd = codes[k];
            host_run(&c, 0.5);
            d = data();
            CHECK(d.cmd_rejected == before + 1 && d.last_reject == codes[k]);
            CHECK_NEAR(h.dist_mm, dist0, 1.0);
        }
    }
    /* a HdgSel heading outside -360..360 deg */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_distance = 3601;
    host_run(&c, 0.1);
    d = data();
    CHECK(d.last_reject == 10);
    CHECK_NEAR(fw.turn.hdg_target, 300.0, 1e-3); /* the HdgSel before it still steers */
    /* a field out of its spec range (dg_set 0..3599) */
    c = cmd();
    c.dg_control = NAVKIT_DG_CONTROL_SET_HEADING;
    c.dg_set = 3600;
    host_run(&c, 0.1);
    d = data();
    CHECK(d.last_reject == (NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CMD));
    /* a turn modify while HdgSel steers: there is no turn 1 to modify */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    c.turn_distance = 100;
    host_run(&c, 0.1);
    d = data();
    CHECK(d.last_reject == NAVKIT_TURN_CMD_MODIFY);
    /* forward codes outside 0/1/3/5 too */
    c = cmd();
    c.fwd_cmd = 2;
    host_run(&c, 0.1);
    CHECK(data().last_reject == 2);
}

static void test_watchdog_stop(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    double at_trip;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 300;
    c.distance = 2000000000;
    c.dio_command = 0x00F0;
    c.rc3_param0 = 100; /* scan servo 3 at 10 deg/s */
    c.rc3_param1 = 300;
    c.rc3_param2 = -300;
    host_run(&c, 2.0);
    CHECK(h.dio_out == 0x00F0);
    /* the host goes silent (its last frame came 100 ticks ago) */
    sim_run(&fw, &h, 198);
    CHECK(!(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
    sim_run(&fw, &h, 2);
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    CHECK(h.dio_out == 0x0000); /* safe state */
    at_trip = h.dist_mm;
    {
        uint16_t pulse = h.servo_us[3];
        sim_run(&fw, &h, 2000);
        CHECK(h.servo_us[3] == pulse); /* servo holds */
    }
    /* 300 mm/s at 500 mm/s^2: ~90 mm */
    CHECK_NEAR(h.dist_mm - at_trip, 90.0, 20.0);
    CHECK_NEAR(h.v_l, 0.0, 1.0);
    /* the old command repeated, and a modify: no resume */
    c.distance = 2000000001;
    host_run(&c, 0.5);
    {
        navkit_micro_cmd_t m = cmd();
        m.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
        m.speed = 300;
        m.distance = 2000000000;
        host_run(&m, 1.0);
    }
    d = data();
    CHECK_NEAR(h.v_l, 0.0, 1.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    CHECK(d.watchdog_stops == 1);
    /* a new start resumes and clears the flag */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 100;
    c.distance = 100;
    host_run(&c, 2.0);
    d = data();
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
    CHECK_NEAR(d.distance, 100.0, 5.0);
}

/* The configured watchdog_timeout, not the default 300 ms: at 1000 ms and at 150 ms the
   robot goes on until the timeout since the last frame and stops at it (ms = ticks at 1 kHz). */
static void test_watchdog_timeout_config(void)
{
    static const uint16_t timeout[] = {1000u, 150u}; /* ms */
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    navkit_micro_cmd_t c;
    unsigned k;
    for (k = 0; k < sizeof timeout / sizeof timeout[0]; k++) {
        boot();
        sim_cfg_defaults(&g, &m, &io);
        m.watchdog_timeout = timeout[k];
        sim_configure_with(&fw, &h, &g, &m, &io);
        c = cmd();
        c.fwd_cmd = NAVKIT_FWD_CMD_START;
        c.speed = 300;
        c.distance = 2000000000;
        host_run(&c, 1.0); /* a frame every 100 ms: no trip even at 150 ms */
        CHECK(!(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
        /* silence: the last frame came 100 ticks ago */
        sim_run(&fw, &h, (long)timeout[k] - 102);
        CHECK(!(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
        sim_run(&fw, &h, 2);
        CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    }
}

static void test_servo_dio_sensors(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    boot();
    sim_configure(&fw, &h);
    h.dio_in = 0x0F00;
    h.adc[0] = 512;
    h.adc[4] = 800;
    h.sonar[2] = 5800;
    h.compass = 1234;
    c = cmd();
    c.rc2_param0 = 1000; /* seed example: servo 2 to 30 deg at 100 deg/s */
    c.rc2_param1 = 300;
    c.rc2_param2 = 9999;
    c.rc5_param0 = 0; /* no command: servo 5 stays undriven */
    c.rc5_param1 = 300;
    c.rc5_param2 = 9999;
    c.dio_command = 0x0FF9;
    host_run(&c, 0.5);
    d = data();
    CHECK(h.servo_us[2] == 1800u);
    CHECK(d.servo_pos[2] == 300);
    CHECK(h.servo_us[5] == 0u);
    CHECK(h.dio_dir == 0x00FF && h.dio_out == 0x00F9);
    CHECK(d.dio_state == 0x0FF9);
    CHECK(d.adc[0] == 512 && d.adc[4] == 800 && d.sonar_echo[2] == 5800 && d.compass == 1234);
}

/* Ticks of the host frame loop while watching the plant: max distance, min wheel speed. */
typedef struct {
    double max_dist, min_v, max_yaw, min_w; /* mm, mm/s, deg, mm/s (left - right) */
    double min_ref_v, min_ref_w;            /* mm/s, deg/s: the references' lowest */
} watch_t;

static void host_watch(const navkit_micro_cmd_t *c, double seconds, watch_t *w)
{
    long frames = (long)(seconds * 10.0 + 0.5), f, k;
    for (f = 0; f < frames; f++) {
        sim_cmd(&fw, &h, c);
        for (k = 0; k < 100; k++) {
            sim_run(&fw, &h, 1);
            if (h.dist_mm > w->max_dist) {
                w->max_dist = h.dist_mm;
            }
            if (0.5 * (h.v_l + h.v_r) < w->min_v) {
                w->min_v = 0.5 * (h.v_l + h.v_r);
            }
            if (h.yaw_deg > w->max_yaw) {
                w->max_yaw = h.yaw_deg;
            }
            if (h.v_l - h.v_r < w->min_w) {
                w->min_w = h.v_l - h.v_r;
            }
            if (fw.fwd.prof.vel < w->min_ref_v) {
                w->min_ref_v = fw.fwd.prof.vel;
            }
            if (fw.turn.ax.prof.vel < w->min_ref_w) {
                w->min_ref_w = fw.turn.ax.prof.vel;
            }
        }
    }
}

static void test_forever_then_modify(void)
{
    /* fwd 1 to 2e9 mm, then fwd 3 to 1000 mm: no overshoot, no backing */
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    watch_t w = {0, 0, 0, 0, 0, 0};
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 300;
    c.distance = 2000000000;
    host_run(&c, 3.0);
    CHECK(h.dist_mm > 700.0 && h.dist_mm < 900.0);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.speed = 300;
    c.distance = 1000;
    host_watch(&c, 4.0, &w);
    d = data();
    CHECK(d.status & NAVKIT_MICRO_STATUS_FWD_DONE);
    CHECK_NEAR(h.dist_mm, 1000.0, 3.0);
    CHECK(w.max_dist < 1003.0);
    CHECK(w.min_ref_v >= 0.0);           /* never planned back */
    CHECK(w.max_dist - h.dist_mm < 0.5); /* nor backed up */
    /* turn 1 to 2e9 deg*10, then turn 3 to 90 deg: no overshoot, no backing */
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 450;
    c.turn_distance = 2000000000;
    host_run(&c, 1.0);
    CHECK(h.yaw_deg > 20.0 && h.yaw_deg < 50.0);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    c.turn_rate = 450;
    c.turn_distance = 900;
    memset(&w, 0, sizeof w);
    host_watch(&c, 4.0, &w);
    d = data();
    CHECK(d.status & NAVKIT_MICRO_STATUS_TURN_DONE);
    CHECK_NEAR(h.yaw_deg, 90.0, 1.0);
    CHECK(w.max_yaw < 91.0);
    CHECK(w.min_ref_w >= 0.0);          /* never planned back */
    CHECK(w.max_yaw - h.yaw_deg < 0.2); /* nor turned back */
}

/* The reference speed's slope (u/s^2) between t0 and t1 (s, whole 0.1 s) after the
 * command, the host repeating it every 100 ms. */
static double ramp_slope(const navkit_micro_cmd_t *c, const float *vel, double t0, double t1)
{
    double v0;
    host_run(c, t0);
    v0 = *vel;
    host_run(c, t1 - t0);
    return (*vel - v0) / (t1 - t0);
}

static void test_limits_and_signs(void)
{
    navkit_micro_cmd_t c;
    double t0;
    boot();
    sim_configure(&fw, &h);
    /* accel 0 = 300 mm/s^2: the reference ramps at that slope */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 400;
    c.distance = 5000;
    CHECK_NEAR(ramp_slope(&c, &fw.fwd.prof.vel, 0.1, 0.6), 300.0, 6.0);
    /* accel sign ignored: -500 ramps at 500 */
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.accel = -500;
    c.speed = -400; /* sign ignored too: forward, distance gives the direction */
    c.distance = 5000;
    CHECK_NEAR(ramp_slope(&c, &fw.fwd.prof.vel, 0.1, 0.5), 500.0, 10.0);
    host_run(&c, 1.0);
    CHECK_NEAR(fw.fwd.prof.vel, 400.0, 1.0);
    /* fwd 3 speeds up with a new accel: 100 -> 300 mm/s at 600 mm/s^2 */
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.accel = 200;
    c.speed = 100;
    c.distance = 5000;
    host_run(&c, 1.5);
    CHECK_NEAR(fw.fwd.prof.vel, 100.0, 0.5);
    CHECK_NEAR(data().fwd_speed, 100.0, 5.0);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.accel = 600;
    c.speed = 300;
    c.distance = 5000;
    CHECK_NEAR(ramp_slope(&c, &fw.fwd.prof.vel, 0.05, 0.25), 600.0, 12.0);
    host_run(&c, 1.0);
    CHECK_NEAR(data().fwd_speed, 300.0, 10.0);
    /* turn_accel and turn_rate signs ignored: -90 deg/s^2 and -45 deg/s turn clockwise */
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_accel = -900;
    c.turn_rate = -450;
    c.turn_distance = 900;
    t0 = ramp_slope(&c, &fw.turn.ax.prof.vel, 0.1, 0.4);
    CHECK_NEAR(t0, 90.0, 2.0);
    host_run(&c, 3.0);
    CHECK(fw.turn.ax.prof.vmax == 45.0f);
    CHECK_NEAR(h.yaw_deg, 90.0, 1.0);
}

/* A command's 0 takes the configured default (micro_cfg_motion), here not the spec's:
   forward accel 250 mm/s^2 and speed 150 mm/s, turn 120 deg/s^2 and 30 deg/s. */
static void test_zero_takes_configured_default(void)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    navkit_micro_cmd_t c;
    boot();
    sim_cfg_defaults(&g, &m, &io);
    m.default_accel = 250;
    m.default_speed = 150;
    m.default_turn_accel = 1200;
    m.default_turn_rate = 300;
    sim_configure_with(&fw, &h, &g, &m, &io);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.distance = 5000;
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_distance = 3600;
    CHECK_NEAR(ramp_slope(&c, &fw.fwd.prof.vel, 0.1, 0.4), 250.0, 5.0);
    host_run(&c, 1.0);
    CHECK(fw.fwd.prof.vmax == 150.0f && fw.turn.ax.prof.vmax == 30.0f);
    CHECK_NEAR(fw.fwd.prof.vel, 150.0, 0.5);
    boot();
    sim_configure_with(&fw, &h, &g, &m, &io);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_distance = 3600;
    CHECK_NEAR(ramp_slope(&c, &fw.turn.ax.prof.vel, 0.05, 0.2), 120.0, 2.5);
    host_run(&c, 1.0);
    CHECK_NEAR(fw.turn.ax.prof.vel, 30.0, 0.5);
}

static void test_turn_modify_stop_latch(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    watch_t w = {0, 0, 0, 0, 0, 0};
    double at_stop;
    boot();
    sim_configure(&fw, &h);
    /* turn 1 to 360 deg at 45 deg/s, then turn 3: 90 deg/s to 180 deg from the same reference */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 450;
    c.turn_distance = 3600;
    host_run(&c, 1.5);
    CHECK_NEAR(data().yaw_rate, 450.0, 30.0);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    c.turn_rate = 900;
    c.turn_distance = 1800;
    host_watch(&c, 4.0, &w);
    d = data();
    CHECK(w.max_yaw < 181.0);
    CHECK_NEAR(h.yaw_deg, 180.0, 1.0);
    CHECK_NEAR(d.turn_progress, 1800.0, 10.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_TURN_DONE);
    /* restart after done: turn 3 to 270 deg from the same reference */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    c.turn_rate = 450;
    c.turn_distance = 2700;
    host_run(&c, 1.5);
    CHECK(h.yaw_deg > 200.0 && h.yaw_deg < 260.0);
    CHECK(!(data().status & NAVKIT_MICRO_STATUS_TURN_DONE));
    /* reverse while turning: turn 3 to 90 deg, behind: slows, turns back, ends at 90 */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    c.turn_rate = 450;
    c.turn_distance = 900;
    at_stop = h.yaw_deg;
    memset(&w, 0, sizeof w);
    host_watch(&c, 6.0, &w);
    d = data();
    CHECK(w.max_yaw > at_stop + 1.0); /* braked first */
    CHECK(w.min_ref_w < -40.0);       /* then the reference ran back at ~45 deg/s */
    CHECK_NEAR(h.yaw_deg, 90.0, 1.0);
    CHECK_NEAR(d.turn_progress, 900.0, 10.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_TURN_DONE);
    /* turn 1 again, then turn 5 at 180 deg/s^2: stops short, latched */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 900;
    c.turn_distance = -3600;
    host_run(&c, 1.5);
    CHECK_NEAR(data().yaw_rate, -900.0, 40.0);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_STOP;
    c.turn_accel = 1800;
    memset(&w, 0, sizeof w);
    w.min_w = 0.0;
    at_stop = h.yaw_deg;
    host_run(&c, 1.5);
    d = data();
    /* 90 deg/s at 180 deg/s^2: 22.5 deg */
    CHECK_NEAR(at_stop - h.yaw_deg, 22.5, 4.0);
    CHECK(d.yaw_rate == 0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_TURN_STOP_LATCHED);
    at_stop = h.yaw_deg;
    /* a turn 3 after the stop: nothing */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    c.turn_rate = 900;
    c.turn_distance = 0;
    host_run(&c, 1.0);
    CHECK_NEAR(h.yaw_deg, at_stop, 0.2);
    CHECK(data().cmd_rejected == 0);
    /* a turn 1 clears the latch */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_distance = 300;
    host_run(&c, 2.0);
    d = data();
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_TURN_STOP_LATCHED));
    CHECK_NEAR(h.yaw_deg, at_stop + 30.0, 1.0);
}

static void test_watchdog_turn_and_safe_state(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    navkit_micro_data_t d;
    double at_trip;
    boot();
    sim_cfg_defaults(&g, &m, &io);
    io.dio_safe_state = 0x0A5; /* bit 8 and up are inputs: only 0xA5 can show */
    sim_configure_with(&fw, &h, &g, &m, &io);
    sim_run(&fw, &h, 1);
    CHECK(h.dio_dir == 0x00FF);
    CHECK(h.dio_out == 0x00A5); /* safe state once configured */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 900;
    c.turn_distance = 36000;
    c.dio_command = 0x0F0F;
    host_run(&c, 1.5);
    CHECK(h.dio_out == 0x000F);
    CHECK_NEAR(data().yaw_rate, 900.0, 40.0);
    /* silence: the turn stops at the watchdog deceleration (500 mm/s^2 at the wheel) */
    sim_run(&fw, &h, 200);
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    CHECK(h.dio_out == 0x00A5);
    at_trip = h.yaw_deg;
    sim_run(&fw, &h, 2000);
    CHECK(fabs(h.v_l - h.v_r) < 0.5);
    /* 90 deg/s = 235.6 mm/s at the wheel, 500 mm/s^2: 55.5 mm = 21.2 deg */
    CHECK_NEAR(h.yaw_deg - at_trip, 21.2, 5.0);
    CHECK(fw.turn.ax.latched);
    sim_cmd(&fw, &h, &c); /* the same tag again: no resume */
    sim_run(&fw, &h, 500);
    d = data();
    CHECK(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    CHECK(fabs(h.v_l - h.v_r) < 0.5);
}

static void test_hdg_hold_keeps_bias_fresh(void)
{
    /* HdgSel holds its heading; the gyro bias drifts 25 -> 45 LSB: the standstill estimate
       follows (the wheels are at rest although HdgSel is active) and the robot stays put */
    navkit_micro_cmd_t c;
    double yaw0;
    boot();
    h.gyro_bias = 25;
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100);
    sim_configure(&fw, &h);
    CHECK_NEAR(fw.hdg.bias, 25.0, 0.5);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_rate = 450;
    c.turn_distance = 900;
    host_run(&c, 5.0);
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_HDG_HOLD);
    yaw0 = h.yaw_deg;
    h.gyro_bias = 45;
    host_run(&c, 12.0);
    CHECK_NEAR(fw.hdg.bias, 45.0, 1.5);
    CHECK_NEAR(h.yaw_deg, yaw0, 0.3);
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_HDG_ACTIVE);
}

static void test_compass_fusion_closed_loop(void)
{
    /* the heading starts 10 deg off (dg_set 350 while the robot faces north); HdgSel 0
       with compass fusion: the robot ends facing true north, heading and compass agree */
    navkit_micro_cmd_t c;
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    long f;
    boot();
    sim_cfg_defaults(&g, &m, &io);
    g.compass_weight = 500; /* 0.5 per s */
    sim_configure_with(&fw, &h, &g, &m, &io);
    c = cmd();
    c.dg_control = NAVKIT_DG_CONTROL_SET_HEADING;
    c.dg_set = 3500;
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_rate = 300;
    c.turn_distance = 0;
    for (f = 0; f < 200; f++) {
        double yaw = fmod(fmod(h.yaw_deg, 360.0) + 360.0, 360.0);
        h.compass = (uint16_t)((long)(yaw * 10.0 + 0.5) % 3600);
        sim_cmd(&fw, &h, &c);
        sim_run(&fw, &h, 100);
    }
    CHECK_NEAR(h.yaw_deg, 0.0, 0.7);
    CHECK(heading_deg10(&fw.hdg) <= 7u || heading_deg10(&fw.hdg) >= 3593u);
    /* without fusion the same start leaves it 10 deg off */
    boot();
    sim_configure(&fw, &h);
    for (f = 0; f < 50; f++) {
        sim_cmd(&fw, &h, &c);
        sim_run(&fw, &h, 100);
    }
    CHECK_NEAR(h.yaw_deg, 10.0, 0.7);
}

static void test_datalog_selections(void)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    boot();
    h.gyro_bias = 12;
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100);
    sim_configure(&fw, &h);
    /* forward at 200 mm/s while turning at 20 deg/s: wheels differ */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 5000;
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_rate = 200;
    c.turn_distance = 3600;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_WHEEL_LEFT;
    host_run(&c, 2.0);
    d = data();
    /* left = v + w*track/2 = 200 + 20 deg/s * 2.618 mm/deg = 252 mm/s */
    CHECK_NEAR(d.mc_datalog[0], 252.0, 3.0);
    CHECK_NEAR(d.mc_datalog[1], 252.0, 10.0);
    CHECK_NEAR(d.mc_datalog[2], 252.0 * 0.0018 * 10000.0, 400.0); /* duty: mostly feed-forward */
    CHECK_NEAR(d.mc_datalog[2], h.duty_l, 600.0);
    h.compass = 100; /* sampled by the ticks before the heading selection's reply */
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_WHEEL_RIGHT;
    c.time_tag = ++tag;
    c.fwd_cmd = NAVKIT_FWD_CMD_NONE;
    c.turn_cmd = NAVKIT_TURN_CMD_NONE;
    host_run(&c, 0.1);
    d = data();
    CHECK_NEAR(d.mc_datalog[0], 148.0, 3.0);
    CHECK_NEAR(d.mc_datalog[1], 148.0, 10.0);
    CHECK_NEAR(d.mc_datalog[2], h.duty_r, 600.0);
    CHECK(d.mc_datalog[2] < h.duty_l - 1000);
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_TURN_PROFILE;
    c.time_tag = ++tag;
    host_run(&c, 0.1);
    d = data();
    CHECK_NEAR(d.mc_datalog[0], 200.0, 1.0);                 /* reference deg*10/s */
    CHECK(d.mc_datalog[1] > 2500 && d.mc_datalog[1] < 3300); /* to go, deg*10 */
    CHECK_NEAR(d.mc_datalog[2], d.mc_datalog[1], 60.0);
    CHECK((d.mc_datalog[3] & 0x11) == 0x01); /* moving, not HdgSel */
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_HEADING;
    c.time_tag = ++tag;
    host_run(&c, 0.1);
    d = data();
    CHECK(d.mc_datalog[0] == (int16_t)d.heading);
    CHECK_NEAR(d.mc_datalog[1], 200.0, 15.0); /* rate deg*10/s */
    CHECK_NEAR(d.mc_datalog[2], 120.0, 5.0);  /* bias LSB*10 */
    CHECK_NEAR(d.mc_datalog[3], 100 - (int)d.heading + ((int)d.heading > 1900 ? 3600 : 0), 2.0);
    /* HdgSel shows in the turn profile flags */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_distance = 0;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_TURN_PROFILE;
    host_run(&c, 0.1);
    CHECK(data().mc_datalog[3] & 0x10);
}

static void test_servo_slot_without_command(void)
{
    /* a slot whose param0 is 0 is no command: servo 2 keeps going where it was sent */
    navkit_micro_cmd_t c;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.rc2_param0 = 100;
    c.rc2_param1 = 300;
    c.rc2_param2 = 9999;
    host_run(&c, 0.5);
    c = cmd();
    c.rc2_param0 = 0;
    c.rc2_param1 = -600;
    c.rc2_param2 = 9999;
    host_run(&c, 3.0);
    CHECK(data().servo_pos[2] == 300);
    CHECK(fw.servo[2].goal == 300);
}

static void test_time_tags_across_reset(void)
{
    navkit_micro_cmd_t c, stale;
    navkit_micro_data_t d;
    boot();
    sim_configure(&fw, &h);
    stale = cmd();
    stale.fwd_cmd = NAVKIT_FWD_CMD_START;
    stale.speed = 200;
    stale.distance = 300;
    host_run(&stale, 3.0);
    CHECK_NEAR(h.dist_mm, 300.0, 5.0);
    /* the micro resets; the host repeats its last command, then configures, and repeats
       it again: the stale fwd 1 must not run a second time */
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100);
    host_run(&stale, 0.3);
    d = data();
    CHECK(d.cmd_rejected == 1 && d.last_reject == 1);
    sim_configure(&fw, &h);
    host_run(&stale, 3.0);
    d = data();
    CHECK_NEAR(h.dist_mm, 300.0, 5.0);
    CHECK(d.ack_time_tag == 0 && d.cmd_rejected == 1);
    /* a new command sent while the micro is unconfigured keeps its tag: its repeat runs
       once the configs are in (and runs once) */
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100);
    host_run(&stale, 0.2);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 200;
    host_run(&c, 0.3);
    d = data();
    CHECK(d.cmd_rejected == 2 && d.last_reject == 1);
    CHECK_NEAR(h.dist_mm, 300.0, 5.0);
    sim_configure(&fw, &h);
    host_run(&c, 3.0);
    d = data();
    CHECK(d.ack_time_tag == c.time_tag && d.cmd_rejected == 2);
    CHECK_NEAR(h.dist_mm, 500.0, 5.0);
    /* a content refusal uses up its tag: the repeat is neither run nor counted again */
    c = cmd();
    c.fwd_cmd = 2;
    host_run(&c, 0.5);
    CHECK(data().cmd_rejected == 3);
}

/* Send micro_cfg_geometry and micro_cfg_motion (defaults), not micro_cfg_io. */
static void configure_two_of_three(void)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    navkit_micro_cfg_geometry_defaults(&g);
    navkit_micro_cfg_motion_defaults(&m);
    g.time_tag = 1;
    m.time_tag = 2;
    sim_send(&h, buf, navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf));
    sim_send(&h, buf, navkit_micro_cfg_motion_encode(&m, buf, sizeof buf));
    fw_link_poll(&fw);
}

/* Everything of a micro_cmd but motion: servo 2 GoTo 60 deg, heading 100 deg and X/Y
   500/700 mm set, the heading datalog selected. */
static void set_all_but_motion(navkit_micro_cmd_t *c)
{
    c->rc2_param0 = 1000;
    c->rc2_param1 = 600;
    c->rc2_param2 = 9999;
    c->dg_control = NAVKIT_DG_CONTROL_SET_BOTH;
    c->dg_set = 1000;
    c->x_set = 500;
    c->y_set = 700;
    c->mc_datalog_cmd = NAVKIT_MC_DATALOG_HEADING;
}

static void test_unconfigured_refuses_every_command(void)
{
    /* while unconfigured a micro_cmd without fwd_cmd/turn_cmd is refused whole too: no
       servo, DIO, dg_set, x/y or datalog selection runs, and none runs twice */
    navkit_micro_cmd_t first, c;
    navkit_micro_data_t d;
    const uint16_t unconfigured = NAVKIT_REJECT_UNCONFIGURED | NAVKIT_MSG_TYPE_MICRO_CMD;
    int k;
    sim_init(&h);
    h.gyro_bias = 12; /* so the heading datalog's bias word would show (120) */
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1100);
    /* the first command after reset: a servo 4 scan (-90..90 deg) */
    first = cmd();
    first.rc4_param0 = 900;
    first.rc4_param1 = 900;
    first.rc4_param2 = -900;
    host_run(&first, 0.3);
    d = data();
    CHECK(d.cmd_rejected == 1 && d.last_reject == unconfigured);
    CHECK(d.ack_time_tag == 0);
    /* a new one: servo 2 GoTo, DIO, dg_set, x/y, the heading datalog */
    c = cmd();
    set_all_but_motion(&c);
    c.dio_command = 0x00FF;
    host_run(&c, 0.3);
    /* then 5 s of silence: nothing started, so nothing goes on (no watchdog yet) */
    sim_run(&fw, &h, 5000);
    sim_cmd(&fw, &h, &c);
    d = data();
    CHECK(d.cmd_rejected == 2 && d.last_reject == unconfigured && d.ack_time_tag == 0);
    CHECK(h.servo_us[4] == 0u && h.servo_us[2] == 0u && d.servo_pos[4] == 0 && d.servo_pos[2] == 0);
    CHECK(d.heading == 0u && d.x == 0 && d.y == 0);
    CHECK(h.dio_dir == 0u && h.dio_out == 0u);
    for (k = 0; k < 4; k++) {
        CHECK(d.mc_datalog[k] == 0);
    }
    /* with 2 of the 3 configs a motion command is refused with its code, nothing moves */
    configure_two_of_three();
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 100;
    set_all_but_motion(&c);
    host_run(&c, 0.5);
    d = data();
    CHECK(d.status & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK && d.status & NAVKIT_MICRO_STATUS_CFG_MOTION_OK);
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_CONFIGURED));
    CHECK(d.cmd_rejected == 3 && d.last_reject == NAVKIT_FWD_CMD_START && d.ack_time_tag == 0);
    CHECK(h.dist_mm == 0.0 && h.duty_l == 0 && h.servo_us[2] == 0u && d.x == 0);
    /* the third config: the pending command's repeat runs, once */
    sim_configure(&fw, &h);
    host_run(&c, 1.5);
    d = data();
    CHECK(d.ack_time_tag == c.time_tag && d.cmd_rejected == 3);
    CHECK_NEAR(h.dist_mm, 100.0, 5.0);
    CHECK(d.servo_pos[2] == 600 && h.servo_us[4] == 0u);
    CHECK_NEAR(d.mc_datalog[2], 120.0, 5.0);
    CHECK(fw.link.mc_datalog == NAVKIT_MC_DATALOG_HEADING);
    /* the state moves on; the same tag again must not set heading, X/Y or servo 2 back */
    heading_set(&fw.hdg, 45.0f);
    odom_set_xy(&fw.odom, 1234, 4321);
    c.rc2_param1 = -300; /* a changed repeat: still the same tag */
    host_run(&c, 1.0);
    d = data();
    CHECK_NEAR(d.heading, 450.0, 2.0);
    CHECK(d.x == 1234 && d.y == 4321);
    CHECK(d.servo_pos[2] == 600);
    CHECK_NEAR(h.dist_mm, 100.0, 5.0);
    /* the stale first command's tag again, now configured: a new tag (not the last), it runs */
    host_run(&first, 0.2);
    CHECK(fw.servo[4].mode == SERVO_SCAN);
}

static void test_unconfigured_first_command_never_runs(void)
{
    /* the first command after reset, refused while unconfigured, is repeated after the
       configs: it does not run (possibly stale), whatever it holds */
    navkit_micro_cmd_t first;
    navkit_micro_data_t d;
    boot();
    first = cmd();
    first.dg_control = NAVKIT_DG_CONTROL_SET_XY;
    first.x_set = 500;
    first.y_set = 700;
    first.rc2_param0 = 1000;
    first.rc2_param1 = 600;
    first.rc2_param2 = 9999;
    host_run(&first, 0.3);
    sim_configure(&fw, &h);
    host_run(&first, 1.0);
    d = data();
    CHECK(d.cmd_rejected == 1 && d.ack_time_tag == 0);
    CHECK(d.x == 0 && d.y == 0 && h.servo_us[2] == 0u);
}

/* A command refused while unconfigured, repeated after the configs (same tag) with
   changed content that fails the content check: refused with its code and counted, none
   of it runs (the checked original would have); the tag is used up, so a further repeat is
   neither counted nor run. */
static void pending_repeat_refused(uint16_t code_field, uint16_t expect_reject)
{
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    boot();
    c = cmd();
    host_run(&c, 0.1); /* the first command after reset: never pending */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 100;
    host_run(&c, 0.2);
    sim_configure(&fw, &h);
    d = data();
    CHECK(d.cmd_rejected == 2 && d.ack_time_tag == 0);
    /* the repeat: a heading and a datalog selection besides the move and the failing field */
    c.dg_control = NAVKIT_DG_CONTROL_SET_HEADING;
    c.dg_set = 1200;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_HEADING;
    if (code_field) {
        c.fwd_cmd = code_field; /* not a fwd_cmd the micro implements */
    } else {
        c.mc_datalog_cmd = 77; /* outside the spec's range (0..5) */
    }
    host_run(&c, 1.0);
    d = data();
    CHECK(d.cmd_rejected == 3 && d.last_reject == expect_reject);
    CHECK(d.ack_time_tag == 0);
    CHECK(d.heading == 0u && fw.link.mc_datalog == NAVKIT_MC_DATALOG_NONE);
    CHECK(h.dist_mm == 0.0 && h.duty_l == 0 && !(d.status & NAVKIT_MICRO_STATUS_FWD_DONE));
    /* the tag is used up: its content fixed, the same tag still does not run */
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_HEADING;
    host_run(&c, 1.0);
    d = data();
    CHECK(d.cmd_rejected == 3 && d.ack_time_tag == 0 && h.dist_mm == 0.0 && d.heading == 0u);
}

static void test_pending_repeat_checked(void)
{
    pending_repeat_refused(2u, 2u);
    pending_repeat_refused(0u, NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CMD);
}

static void test_control_rate_change_mid_period(void)
{
    /* a micro_cfg_geometry from 1 kHz (a slow period of 10 ticks) to 250 Hz (2) arriving on
       the last tick of a period: the slow period starts again at its first tick (the fold)
       rather than running past the new period; the move goes on at the new rate */
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cmd_t c;
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    float togo, integ;
    int k;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 1000;
    host_run(&c, 0.5);
    for (k = 0; k < 20 && fw.slow_tick != 9u; k++) {
        sim_run(&fw, &h, 1);
    }
    CHECK(fw.slow_tick == 9u); /* within 20 ticks: the period is 10 */
    navkit_micro_cfg_geometry_defaults(&g);
    g.control_rate = 250;
    g.time_tag = 4;
    sim_send(&h, buf, navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf));
    fw_link_poll(&fw);
    CHECK(fw.cfg.odom.xy_ticks == 2u && fw.slow_tick == 0u);
    togo = fw.fwd.prof.togo;
    integ = fw.wheel_l.integ;
    sim_run(&fw, &h, 1);
    CHECK(fw.fwd.prof.togo < togo - 0.5f); /* mm: 200 mm/s for 4 ms is 0.8 mm */
    CHECK(fw.wheel_l.integ != integ);
    CHECK(fw.slow_tick == 1u);
    /* and the move ends on its target at 250 Hz (a frame every 100 ms: 25 ticks) */
    for (k = 0; k < 80; k++) {
        sim_cmd(&fw, &h, &c);
        sim_run(&fw, &h, 25);
    }
    CHECK_NEAR(h.dist_mm, 1000.0, 5.0);
}

static void test_pending_dropped_by_watchdog(void)
{
    /* a command refused while unconfigured, the configs, then 0.3 s of silence: the
       watchdog stops; the pending command's repeat must not run (a repeat never resumes) */
    navkit_micro_cmd_t c;
    navkit_micro_data_t d;
    boot();
    c = cmd();
    host_run(&c, 0.1); /* the first command after reset */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 300;
    host_run(&c, 0.2);
    sim_configure(&fw, &h);
    sim_run(&fw, &h, 400);
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    host_run(&c, 1.0);
    d = data();
    CHECK(h.dist_mm == 0.0 && d.ack_time_tag == 0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    /* a new fwd 1 resumes */
    c = cmd();
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 300;
    host_run(&c, 2.5);
    d = data();
    CHECK_NEAR(h.dist_mm, 300.0, 5.0);
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
}

static void test_watchdog_hdg_sel(void)
{
    /* a watchdog stop during a HdgSel: the repeated HdgSel, a turn 3 and a fwd 3 do not
       resume; a HdgSel with a new tag does (a new start, like turn 1) */
    navkit_micro_cmd_t c, m;
    navkit_micro_data_t d;
    double yaw;
    boot();
    sim_configure(&fw, &h);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_rate = 200; /* 20 deg/s to heading 90 */
    c.turn_distance = 900;
    host_run(&c, 1.5);
    CHECK(h.yaw_deg > 10.0 && h.yaw_deg < 40.0);
    sim_run(&fw, &h, 2300); /* silence: the watchdog stops the turn */
    d = data();
    CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    CHECK(fabs(h.v_l - h.v_r) < 0.5);
    yaw = h.yaw_deg;
    host_run(&c, 1.0); /* the same tag again */
    m = cmd();
    m.turn_cmd = NAVKIT_TURN_CMD_MODIFY;
    m.turn_rate = 200;
    m.turn_distance = 900;
    host_run(&m, 1.0);
    m = cmd();
    m.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    m.speed = 200;
    m.distance = 500;
    host_run(&m, 1.0);
    d = data();
    CHECK_NEAR(h.yaw_deg, yaw, 0.2);
    CHECK_NEAR(h.dist_mm, 0.0, 1.0);
    CHECK(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_HDG_ACTIVE));
    /* a new HdgSel: resumes and clears the flag */
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_rate = 300;
    c.turn_distance = 900;
    host_run(&c, 5.0);
    d = data();
    CHECK(!(d.status & NAVKIT_MICRO_STATUS_WATCHDOG_STOP));
    CHECK(d.status & NAVKIT_MICRO_STATUS_HDG_HOLD);
    CHECK_NEAR(h.yaw_deg, 90.0, 1.0);
    CHECK(d.watchdog_stops == 1);
}

/* Boot, configure at control_rate `rate` (Hz) and cruise: the host sends start command c
   every 100 ms for 2 s. */
static void cruise_at(uint16_t rate, const navkit_micro_cmd_t *c)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    boot();
    sim_cfg_defaults(&g, &m, &io);
    g.control_rate = rate;
    sim_configure_with(&fw, &h, &g, &m, &io);
    host_run(c, 2.0);
}

/* A stop from cruise, tick by tick: the stop command `stop` (fwd 5 or turn 5, repeated
 * every 100 ms), or with stop NULL the host silent until the watchdog stops (within the
 * timeout plus 100 ms). v0 (u/s) is the reference speed *vel before the stop's first tick
 * (the one after the command, or the one the watchdog trips in). From that tick on, while
 * the speed before the tick is above decel*dt (decel in u/s^2), each tick must take
 * decel*dt off it (less the braking curve's margin, PROFILE_BRAKE_MARGIN), and the reference
 * must rest (speed 0) within ceil(v0 / (decel*dt)) + 2 ticks. */
static void stop_braking(const float *vel, double decel, const navkit_micro_cmd_t *stop)
{
    const long per_frame = (long)fw.cfg.control_rate / 10; /* ticks per 100 ms */
    const double dv = decel * fw.cfg.dt;                   /* u/s per tick */
    const double drop = dv * (1.0 - PROFILE_BRAKE_MARGIN); /* u/s per tick, the margin less */
    double v0 = *vel, prev, worst = 0.0;                   /* u/s */
    long n, limit;
    if (stop) {
        sim_cmd(&fw, &h, stop);
        sim_run(&fw, &h, 1);
    } else {
        limit = (long)(fw.cfg.watchdog_timeout_us / 1000u) * fw.cfg.control_rate / 1000 + per_frame;
        for (n = 0; n < limit && !(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP); n++) {
            v0 = *vel;
            sim_run(&fw, &h, 1);
        }
        CHECK(fw_status(&fw) & NAVKIT_MICRO_STATUS_WATCHDOG_STOP);
    }
    CHECK(v0 > 10.0 * dv); /* cruising at the stop */
    limit = (long)ceil(v0 / dv) + 2;
    prev = v0;
    for (n = 1;; n++) { /* n ticks of the stop have run */
        if (prev > dv && fabs(prev - *vel - drop) > worst) {
            worst = fabs(prev - *vel - drop);
        }
        if (n >= limit || *vel == 0.0f) {
            break;
        }
        prev = *vel;
        if (stop && n % per_frame == 0) {
            sim_cmd(&fw, &h, stop);
        }
        sim_run(&fw, &h, 1);
    }
    CHECK_NEAR(worst, 0.0, 5e-4 * dv); /* a quarter of the margin; float rounding stays below 1e-4 u/s */
    CHECK(*vel == 0.0f);
}

static void test_stop_braking_dt(void)
{
    /* a stop plans its braking for the tick's dt, at 1 kHz and at 250 Hz (dt 1 and 4 ms) */
    static const uint16_t rates[] = {1000u, 250u}; /* Hz */
    navkit_micro_cmd_t c, s;
    unsigned k;
    for (k = 0; k < sizeof rates / sizeof rates[0]; k++) {
        /* forward at 300 mm/s: the watchdog stop (500 mm/s^2), then a fwd 5 at 600 mm/s^2 */
        c = cmd();
        c.fwd_cmd = NAVKIT_FWD_CMD_START;
        c.speed = 300;
        c.distance = 2000000000;
        cruise_at(rates[k], &c);
        stop_braking(&fw.fwd.prof.vel, 500.0, NULL);
        cruise_at(rates[k], &c);
        s = cmd();
        s.fwd_cmd = NAVKIT_FWD_CMD_STOP;
        s.accel = 600;
        stop_braking(&fw.fwd.prof.vel, 600.0, &s);
        /* turning at 45 deg/s: a turn 5 at 120 deg/s^2, then the watchdog stop (500 mm/s^2
           at the wheel, half the plant's track from the centre: ~191 deg/s^2) */
        c = cmd();
        c.turn_cmd = NAVKIT_TURN_CMD_TURN;
        c.turn_rate = 450;
        c.turn_distance = 2000000000;
        cruise_at(rates[k], &c);
        s = cmd();
        s.turn_cmd = NAVKIT_TURN_CMD_STOP;
        s.turn_accel = 1200;
        stop_braking(&fw.turn.ax.prof.vel, 120.0, &s);
        cruise_at(rates[k], &c);
        stop_braking(&fw.turn.ax.prof.vel, 500.0 / (0.5 * h.track_mm) * SIM_RAD_TO_DEG, NULL);
    }
}

/* Ticks on which the check below found the forward axis, the turn axis, a servo idle
   (work the tick skips) or busy. */
static long idle_seen[3], busy_seen[3];

/* What fw_tick() skips must be work without effect, checked on copies before a tick: an
   axis that is not motion_active() (the turn axis: not turn_ticking()), ticked in full
   with NaN measurements it must not read, returns 0 and ends exactly as
   motion_tick_idle() leaves it; a servo that is not servo_moving() is left as it is by
   servo_step(). */
static void check_idle_work(void)
{
    const config_t *c = &fw.cfg;
    motion_t m1, m2;
    turn_t t1, t2;
    servo_t s1, s2;
    uint8_t i;
    memcpy(&m1, &fw.fwd, sizeof m1);
    memcpy(&m2, &fw.fwd, sizeof m2);
    if (!motion_active(&fw.fwd)) {
        CHECK(motion_tick(&m1, NAN, NAN, &c->fwd_track, c->dt) == 0.0f);
        CHECK(motion_tick_idle(&m2) == 0.0f);
        CHECK(memcmp(&m1, &m2, sizeof m1) == 0);
        idle_seen[0]++;
    } else {
        busy_seen[0]++;
    }
    memcpy(&t1, &fw.turn, sizeof t1);
    memcpy(&t2, &fw.turn, sizeof t2);
    if (!turn_ticking(&fw.turn)) {
        CHECK(turn_tick(&t1, NAN, NAN, NAN, c->heading_kp, &c->turn_track, c->dt) == 0.0f);
        CHECK(motion_tick_idle(&t2.ax) == 0.0f);
        CHECK(memcmp(&t1, &t2, sizeof t1) == 0);
        idle_seen[1]++;
    } else {
        busy_seen[1]++;
    }
    for (i = 0u; i < SERVO_COUNT; i++) {
        memcpy(&s1, &fw.servo[i], sizeof s1);
        memcpy(&s2, &fw.servo[i], sizeof s2);
        if (!servo_moving(&fw.servo[i])) {
            servo_step(&s1, &c->servo[i]);
            CHECK(memcmp(&s1, &s2, sizeof s1) == 0);
            idle_seen[2]++;
        } else {
            busy_seen[2]++;
        }
    }
}

static void test_idle_work_skipped(void)
{
    navkit_micro_cmd_t c;
    long k;
    boot();
    sim_configure(&fw, &h);
    c = cmd(); /* forward with a servo scanning and one going to 30 deg */
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.distance = 500;
    c.speed = 400;
    c.rc1_param0 = 900;
    c.rc1_param1 = 300;
    c.rc1_param2 = -300;
    c.rc4_param0 = 1000;
    c.rc4_param1 = 300;
    c.rc4_param2 = 9999;
    host_run_each(&c, 3.0, check_idle_work);
    c = cmd(); /* an encoder turn, then a stop of it */
    c.turn_cmd = NAVKIT_TURN_CMD_TURN;
    c.turn_distance = 900;
    host_run_each(&c, 0.5, check_idle_work);
    c = cmd();
    c.turn_cmd = NAVKIT_TURN_CMD_STOP;
    host_run_each(&c, 1.5, check_idle_work);
    c = cmd(); /* HdgSel with a forward move: it holds its heading after arriving */
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.distance = 300;
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_distance = -450;
    host_run_each(&c, 4.0, check_idle_work);
    /* silence: the watchdog stops both axes and holds the servos */
    for (k = 0; k < (long)fw.cfg.control_rate * 2; k++) {
        check_idle_work();
        sim_run(&fw, &h, 1);
    }
    CHECK(fw.watchdog_stops == 1u);
    for (k = 0; k < 3; k++) {
        CHECK(idle_seen[k] > 0 && busy_seen[k] > 0);
    }
}

/* The target holds what it got (hal.h, ordering contract 2): after every tick each servo
   output and the DIO hold exactly what the firmware outputs, though the firmware writes
   them on its first tick and then only when they change. */
static void check_outputs_held(void)
{
    uint8_t i;
    for (i = 0u; i < SERVO_COUNT; i++) {
        CHECK(h.servo_us[i] == servo_pulse_us(&fw.servo[i]));
    }
    CHECK(h.dio_dir == fw.dio.dir && h.dio_out == fw.dio.out);
}

static void test_outputs_written_when_changed(void)
{
    navkit_micro_cmd_t c;
    long k, f, writes;
    boot(); /* 1100 ticks: the first wrote every output, no other one wrote any */
    CHECK(h.servo_writes == (long)SERVO_COUNT && h.dio_writes == 1);
    sim_configure(&fw, &h); /* the IO config makes the DIO outputs safe: one write */
    sim_run(&fw, &h, 10);
    CHECK(h.dio_writes == 2 && h.dio_dir == 0x00FFu);
    c = cmd(); /* servo 2 to 30 deg at 100 deg/s, servo 6 scanning, DIO outputs set */
    c.rc2_param0 = 1000;
    c.rc2_param1 = 300;
    c.rc2_param2 = 9999;
    c.rc6_param0 = 2000;
    c.rc6_param1 = 200;
    c.rc6_param2 = -200;
    c.dio_command = 0x0015;
    writes = h.servo_writes;
    for (f = 0; f < 10; f++) {
        sim_cmd(&fw, &h, &c);
        for (k = 0; k < 100; k++) {
            sim_run(&fw, &h, 1);
            check_outputs_held();
        }
    }
    CHECK(h.servo_us[2] == 1800u && h.dio_out == 0x0015u && h.dio_writes == 3);
    /* only the two driven servos were written: each refresh is one tick in 8 */
    CHECK(h.servo_writes - writes <= 2 * 1000 / 8 && h.servo_writes - writes > 10);
    /* a reset (the target's outputs not cleared) writes every output again on its first tick */
    h.servo_us[2] = 1234u;
    h.dio_out = 0x0FFFu;
    fw_init(&fw, &h);
    sim_run(&fw, &h, 1);
    check_outputs_held();
    CHECK(h.servo_us[2] == 0u && h.dio_out == 0u);
}

static const check_case_t cases[] = {
    CHECK_CASE(unconfigured),
    CHECK_CASE(forward_move),
    CHECK_CASE(modify_reverse),
    CHECK_CASE(stop_latch),
    CHECK_CASE(speed_limited_plant),
    CHECK_CASE(turns),
    CHECK_CASE(watchdog_stop),
    CHECK_CASE(watchdog_timeout_config),
    CHECK_CASE(servo_dio_sensors),
    CHECK_CASE(forever_then_modify),
    CHECK_CASE(limits_and_signs),
    CHECK_CASE(zero_takes_configured_default),
    CHECK_CASE(turn_modify_stop_latch),
    CHECK_CASE(watchdog_turn_and_safe_state),
    CHECK_CASE(hdg_hold_keeps_bias_fresh),
    CHECK_CASE(compass_fusion_closed_loop),
    CHECK_CASE(datalog_selections),
    CHECK_CASE(servo_slot_without_command),
    CHECK_CASE(time_tags_across_reset),
    CHECK_CASE(unconfigured_refuses_every_command),
    CHECK_CASE(unconfigured_first_command_never_runs),
    CHECK_CASE(pending_repeat_checked),
    CHECK_CASE(control_rate_change_mid_period),
    CHECK_CASE(pending_dropped_by_watchdog),
    CHECK_CASE(watchdog_hdg_sel),
    CHECK_CASE(stop_braking_dt),
    CHECK_CASE(idle_work_skipped),
    CHECK_CASE(outputs_written_when_changed),
};

int main(int argc, char **argv)
{
    return check_main(argc, argv, cases, sizeof cases / sizeof cases[0], NULL);
}
