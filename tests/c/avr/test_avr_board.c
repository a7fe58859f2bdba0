/* test_avr_board: the navkit image on the simulated Mega 2560 (firmware/avr/sim/board_sim.h).
 *
 *   test_avr_board TEST IMAGE_DIR
 *
 * IMAGE_DIR holds navkit-mega2560.{elf,hex,size.txt}, navkit-mega2560-test.elf (the
 * test image: DIO levels select hang / echo / hold modes, firmware/avr/main.c) and
 * navkit-mega2560-can.{elf,hex,size.txt} (the CAN link on the MCP2515; the can_* tests). Each TEST
 * is one ctest; "footprint" prints the image's flash, static RAM and deepest stack and the
 * cycles of its tick and link poll. Exit 0 = pass; a failure prints the check and exits 1.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "board.h"
#include "board_sim.h"
#include "navkit/navkit_proto.h"
#include "navkit/navkit_wire.h"

#define F_CPU_HZ BOARD_SIM_F_CPU_HZ
#define MS(x) ((uint64_t)(x) * (F_CPU_HZ / 1000u)) /* cycles of x ms */
#define TEST_HANG 0xA5Au                           /* DIO levels of the test image's modes (firmware/avr/main.c) */
#define TEST_ECHO 0x5A5u
#define TEST_HOLD 0x3C3u
#define RX_RING_USABLE 255u /* bytes the image's UART RX ring holds (board.h) */

static const char *image_dir;
static int failures;
static unsigned frames_sent; /* host frames written to the open board */

static void check(int ok, const char *fmt, ...)
{
    va_list ap;
    if (ok) {
        return;
    }
    failures++;
    va_start(ap, fmt);
    fprintf(stderr, "FAIL: ");
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n");
    va_end(ap);
}

static board_sim_t *open_image(const char *name)
{
    char path[1024], err[512];
    board_sim_t *b;
    snprintf(path, sizeof path, "%s/%s", image_dir, name);
    b = board_sim_new(path, err, sizeof err);
    frames_sent = 0u;
    if (b == NULL) {
        fprintf(stderr, "FAIL: %s\n", err);
        exit(1);
    }
    return b;
}

static void run_for(board_sim_t *b, uint64_t cycles)
{
    if (board_sim_run_until(b, board_sim_cycles(b) + cycles) != 0) {
        fprintf(stderr, "FAIL: %s\n", board_sim_error(b));
        exit(1);
    }
}

/* The section sizes (bytes) of an image, from its avr-size -A listing. */
typedef struct {
    unsigned long text, data, bss, noinit;
} image_size_t;

/* Read IMAGE_DIR/name (an avr-size -A listing) into z; a missing file or .text fails the test. */
static void read_size(const char *name, image_size_t *z)
{
    char path[1024], line[256];
    FILE *f;
    snprintf(path, sizeof path, "%s/%s", image_dir, name);
    memset(z, 0, sizeof *z);
    f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "FAIL: %s: cannot open\n", path);
        exit(1);
    }
    while (fgets(line, sizeof line, f) != NULL) {
        char sect[64];
        unsigned long size;
        if (sscanf(line, "%63s %lu", sect, &size) == 2) {
            if (strcmp(sect, ".text") == 0) {
                z->text = size;
            } else if (strcmp(sect, ".data") == 0) {
                z->data = size;
            } else if (strcmp(sect, ".bss") == 0) {
                z->bss = size;
            } else if (strcmp(sect, ".noinit") == 0) {
                z->noinit = size;
            }
        }
    }
    fclose(f);
    check(z->text > 0u, "%s: no .text size", path);
}

/* The profile of a span, from snapshot p0 to p, `span` cycles long: "what: " then fw_tick's
 * and fw_link_poll()'s counts, worst (since the start) and mean cycles and CPU share. */
static void print_span(const char *what, const board_sim_profile_t *p0, const board_sim_profile_t *p, double span)
{
    uint32_t ticks = p->ticks - p0->ticks, polls = p->polls - p0->polls;
    printf("%s: fw_tick %lu ticks, worst %lu mean %lu cycles, CPU %.1f %%; fw_link_poll %lu polls, worst %lu mean %lu "
           "cycles, CPU %.1f %%\n",
           what, (unsigned long)ticks, (unsigned long)p->tick_worst_cycles,
           (unsigned long)((p->tick_total_cycles - p0->tick_total_cycles) / (ticks ? ticks : 1u)),
           100.0 * (double)(p->tick_total_cycles - p0->tick_total_cycles) / span, (unsigned long)polls,
           (unsigned long)p->poll_worst_cycles,
           (unsigned long)((p->poll_total_cycles - p0->poll_total_cycles) / (polls ? polls : 1u)),
           100.0 * (double)(p->poll_total_cycles - p0->poll_total_cycles) / span);
}

/* The sensors of the busy runs: gyro 1310 raw (10 deg/s), compass 90.0 deg, IR/ADC inputs
 * 1000-2500 mV, sonar echoes 2000-5000 us. */
static void set_busy_sensors(board_sim_t *b)
{
    int i;
    board_sim_set_gyro_raw(b, 1310);
    board_sim_set_compass(b, 900u);
    for (i = 0; i < 4; i++) {
        board_sim_set_adc_mv(b, (uint8_t)i, (uint16_t)(1000u + 500u * (unsigned)i));
        board_sim_set_sonar_echo_us(b, (uint8_t)i, (uint16_t)(2000u + 1000u * (unsigned)i));
    }
}

/* The busy runs' micro_cmd before each run's own move and scan limit (param2): defaults,
 * speed 300 mm/s, turn rate 90.0 deg/s, servo 0 at 30.0 deg/s from 30.0 deg, the heading
 * datalog. */
static void busy_cmd_init(navkit_micro_cmd_t *c)
{
    navkit_micro_cmd_defaults(c);
    c->speed = 300;
    c->turn_rate = 900;
    c->rc0_param0 = 300;
    c->rc0_param1 = 300;
    c->mc_datalog_cmd = NAVKIT_MC_DATALOG_HEADING;
}

/* ---------------------------------------------------------------- the link */

typedef struct {
    navkit_parser_t parser;
    navkit_micro_data_t last;
    unsigned frames; /* micro_data frames decoded */
} host_t;

static void host_init(host_t *h)
{
    memset(h, 0, sizeof *h);
    navkit_parser_init(&h->parser, NAVKIT_DIR_TO_HOST);
}

/* Decode every whole frame the parser holds: each good micro_data into *last, counted in
 * *frames. */
static void take_replies(navkit_parser_t *p, navkit_micro_data_t *last, unsigned *frames)
{
    const uint8_t *frame;
    size_t flen;
    while (navkit_parser_next(p, &frame, &flen)) {
        if (navkit_micro_data_decode(frame, flen, last) == NAVKIT_OK) {
            (*frames)++;
        }
    }
}

/* Take every byte the board sent; decode its micro_data frames. */
static void host_drain(host_t *h, board_sim_t *b)
{
    uint8_t buf[512];
    size_t n;
    while ((n = board_sim_uart_read(b, buf, sizeof buf)) > 0u) {
        size_t off = 0u;
        while (off < n) {
            off += navkit_parser_feed(&h->parser, buf + off, n - off);
            take_replies(&h->parser, &h->last, &h->frames);
        }
    }
}

/* Config k of the three, defaults but for: 0 geometry (control_rate rate_hz), 1 motion
 * (pwm_limit in 1e-3 duty), 2 io; time tag k + 1. Encoded into buf (NAVKIT_MAX_FRAME_BYTES):
 * its length in bytes, *msg_type its message type. The serial and the CAN host send these. */
static size_t config_frame(int k, uint16_t rate_hz, uint16_t pwm_limit, uint8_t *buf, uint16_t *msg_type)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    switch (k) {
    case 0:
        navkit_micro_cfg_geometry_defaults(&g);
        g.time_tag = 1u;
        g.control_rate = rate_hz;
        *msg_type = NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY;
        return navkit_micro_cfg_geometry_encode(&g, buf, NAVKIT_MAX_FRAME_BYTES);
    case 1:
        navkit_micro_cfg_motion_defaults(&m);
        m.time_tag = 2u;
        m.pwm_limit = pwm_limit;
        *msg_type = NAVKIT_MSG_TYPE_MICRO_CFG_MOTION;
        return navkit_micro_cfg_motion_encode(&m, buf, NAVKIT_MAX_FRAME_BYTES);
    default:
        navkit_micro_cfg_io_defaults(&io);
        io.time_tag = 3u;
        *msg_type = NAVKIT_MSG_TYPE_MICRO_CFG_IO;
        return navkit_micro_cfg_io_encode(&io, buf, NAVKIT_MAX_FRAME_BYTES);
    }
}

/* Config k (config_frame) through UART0. */
static void send_config(board_sim_t *b, int k, uint16_t rate_hz, uint16_t pwm_limit)
{
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    uint16_t msg_type;
    board_sim_uart_write(b, buf, config_frame(k, rate_hz, pwm_limit, buf, &msg_type));
    frames_sent++;
}

static void send_cmd(board_sim_t *b, const navkit_micro_cmd_t *c)
{
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    board_sim_uart_write(b, buf, navkit_micro_cmd_encode(c, buf, sizeof buf));
    frames_sent++;
}

/* A micro_cmd with nothing in it but the time tag: asks for a micro_data. */
static void ping(board_sim_t *b, host_t *h, uint16_t tag)
{
    navkit_micro_cmd_t c;
    unsigned before = h->frames;
    int configured = (h->frames > 0u) && (h->last.status & NAVKIT_MICRO_STATUS_CONFIGURED);
    int i;
    navkit_micro_cmd_defaults(&c);
    c.time_tag = tag;
    send_cmd(b, &c);
    /* replies to earlier frames may still be queued: wait for the one that acknowledges
       this command (a configured board acknowledges every command); the board skips a reply
       that finds its TX ring full (hal.h), so the command goes again every 100 ms */
    for (i = 0; i < 100 && (h->frames == before || (configured && h->last.ack_time_tag != tag)); i++) {
        if (i > 0 && i % 20 == 0) {
            send_cmd(b, &c);
        }
        run_for(b, MS(5));
        host_drain(h, b);
    }
    check(h->frames > before, "no micro_data answered micro_cmd %u", tag);
    check(!configured || h->last.ack_time_tag == tag, "no micro_data acknowledged micro_cmd %u", tag);
}

/* The three configs (control_rate rate_hz, pwm_limit in 1e-3 duty), then run until the
 * board reports itself configured (at most 1 s). */
static void configure(board_sim_t *b, host_t *h, uint16_t rate_hz, uint16_t pwm_limit)
{
    int i;
    for (i = 0; i < 3; i++) {
        send_config(b, i, rate_hz, pwm_limit);
    }
    /* a reply that does not fit the TX ring is skipped (hal.h): ask until one says so */
    run_for(b, MS(50));
    for (i = 0; i < 20; i++) {
        ping(b, h, (uint16_t)(60000u + i));
        if (h->last.status & NAVKIT_MICRO_STATUS_CONFIGURED) {
            return;
        }
    }
    check(0, "the board did not report configured within 1 s (%u micro_data frames)", h->frames);
}

/* ---------------------------------------------------------------- tests */

/* micro_cfg / micro_cmd through UART0, answered by micro_data with this spec's hash, from
 * the ELF and from the HEX; then 200 micro_cmds back to back at the line rate: every
 * frame arrives whole (rx_good, no CRC errors, no dropped bytes) and every reply is
 * CRC-good. */
static void test_link(void)
{
    const char *names[2] = {"navkit-mega2560.elf", "navkit-mega2560.hex"};
    int k;
    for (k = 0; k < 2; k++) {
        board_sim_t *b = open_image(names[k]);
        host_t h;
        navkit_micro_cmd_t c;
        uint16_t tag;
        host_init(&h);
        run_for(b, MS(20));
        configure(b, &h, 400u, 1000u);
        check(h.last.spec_hash == NAVKIT_SPEC_HASH, "%s: micro_data spec_hash 0x%08lx, want 0x%08lx", names[k],
              (unsigned long)h.last.spec_hash, (unsigned long)NAVKIT_SPEC_HASH);
        check(h.last.reset_cause == NAVKIT_RESET_CAUSE_POWER_ON, "%s: reset_cause %u, want power-on", names[k],
              h.last.reset_cause);
        /* the reply that said configured may be the io config's, late (the TX ring holds one
           micro_data): the one acknowledging a command counts it too */
        ping(b, &h, 60100u);
        check(h.last.rx_good >= 5u, "%s: rx_good %u after the three configs and two commands", names[k],
              h.last.rx_good);
        navkit_micro_cmd_defaults(&c);
        for (tag = 1u; tag <= 200u; tag++) {
            c.time_tag = tag;
            send_cmd(b, &c);
        }
        run_for(b, MS(2500));
        host_drain(&h, b);
        ping(b, &h, 201u);
        check(h.last.rx_good == frames_sent, "%s: rx_good %u, want every frame sent, %u", names[k], h.last.rx_good,
              frames_sent);
        check(h.last.ack_time_tag == 201u, "%s: ack_time_tag %u, want 201", names[k], h.last.ack_time_tag);
        check(h.last.rx_bad_crc == 0u && h.last.rx_dropped_bytes == 0u && h.last.rx_bad_length == 0u,
              "%s: the board saw damaged frames (bad crc %u, dropped %u, bad length %u)", names[k], h.last.rx_bad_crc,
              h.last.rx_dropped_bytes, h.last.rx_bad_length);
        check(h.parser.stats.bad_crc == 0u && h.parser.stats.dropped_bytes == 0u,
              "%s: damaged micro_data (bad crc %lu, dropped %lu)", names[k], (unsigned long)h.parser.stats.bad_crc,
              (unsigned long)h.parser.stats.dropped_bytes);
        check(h.frames >= 20u, "%s: only %u micro_data frames", names[k], h.frames);
        printf("%s: %u micro_data frames, rx_good %u: every frame of the flood arrived whole\n", names[k], h.frames,
               h.last.rx_good);
        board_sim_free(b);
    }
}

/* UART0 rings under a flood (test image, echo mode): 6000 bytes at the line rate come back
 * complete and in order. Then the hold mode: the RX ring keeps its 255 oldest bytes of a
 * 1000-byte burst and drops the rest; echoed afterwards, exactly those 255 return. */
static void test_uart(void)
{
    board_sim_t *b = open_image("navkit-mega2560-test.elf");
    static uint8_t out[6000], back[8000];
    size_t got = 0u, n, i;
    for (i = 0u; i < sizeof out; i++) {
        out[i] = (uint8_t)(i * 7u + (i >> 8));
    }
    board_sim_set_dio_in(b, TEST_ECHO);
    run_for(b, MS(5));
    board_sim_uart_write(b, out, sizeof out);
    run_for(b, MS(6000u * 10u / 115u + 50u)); /* 10 bits per byte at ~115 kbaud, + margin */
    while ((n = board_sim_uart_read(b, back + got, sizeof back - got)) > 0u) {
        got += n;
    }
    check(got == sizeof out, "echo: %zu bytes back of %zu", got, sizeof out);
    check(got >= sizeof out && memcmp(out, back, sizeof out) == 0, "echo: bytes lost or reordered");
    for (i = 0u; i < got && i < sizeof out && out[i] == back[i]; i++) {
    }
    printf("echo: %zu of %zu bytes back, first difference at %zu\n", got, sizeof out, i);

    board_sim_set_dio_in(b, TEST_HOLD);
    run_for(b, MS(5));
    board_sim_uart_write(b, out, 1000u);
    run_for(b, MS(1000u * 10u / 115u + 20u));
    board_sim_set_dio_in(b, TEST_ECHO);
    run_for(b, MS(100));
    got = 0u;
    while ((n = board_sim_uart_read(b, back + got, sizeof back - got)) > 0u) {
        got += n;
    }
    check(got == RX_RING_USABLE, "overflow: %zu bytes kept, want the ring's %u", got, RX_RING_USABLE);
    check(memcmp(out, back, RX_RING_USABLE) == 0, "overflow: the kept bytes are not the burst's first %u",
          RX_RING_USABLE);
    printf("overflow: a 1000-byte burst into a held RX ring, %zu oldest bytes kept\n", got);
    check(board_sim_uart_dropped(b) == 0u, "the simulator's own queues dropped bytes");
    board_sim_free(b);
}

/* Both encoders at the guaranteed rate (an edge every BOARD_SIM_ENC_MIN_EDGE_CYCLES on each,
 * both at once, the link busy): exact counts forward and back. */
static void test_encoders(void)
{
    board_sim_t *b = open_image("navkit-mega2560.elf");
    host_t h;
    navkit_micro_cmd_t c;
    int32_t steps[3][2] = {{20000, -20000}, {-5000, 7000}, {3, -1}};
    int32_t pos[2] = {0, 0};
    int k;
    uint16_t tag = 1u;
    host_init(&h);
    run_for(b, MS(20));
    configure(b, &h, 400u, 1000u);
    navkit_micro_cmd_defaults(&c);
    for (k = 0; k < 3; k++) {
        int32_t dl = steps[k][0] - pos[0], dr = steps[k][1] - pos[1];
        uint32_t n = (uint32_t)((labs(dl) > labs(dr)) ? labs(dl) : labs(dr));
        uint64_t until = board_sim_cycles(b) + (uint64_t)n * BOARD_SIM_ENC_MIN_EDGE_CYCLES;
        board_sim_set_encoders(b, steps[k][0], steps[k][1], until);
        while (board_sim_cycles(b) < until) {
            c.time_tag = tag++;
            send_cmd(b, &c); /* the link at its line rate: UART interrupts between the edges */
            run_for(b, MS(10));
            host_drain(&h, b);
        }
        pos[0] = steps[k][0];
        pos[1] = steps[k][1];
        run_for(b, MS(20));
        ping(b, &h, tag++);
        check(h.last.enc_left == pos[0] && h.last.enc_right == pos[1], "encoders: counts %ld/%ld, want %ld/%ld",
              (long)h.last.enc_left, (long)h.last.enc_right, (long)pos[0], (long)pos[1]);
        printf("encoders at %u edges/s each: %ld/%ld (want %ld/%ld)\n", F_CPU_HZ / BOARD_SIM_ENC_MIN_EDGE_CYCLES,
               (long)h.last.enc_left, (long)h.last.enc_right, (long)pos[0], (long)pos[1]);
    }
    board_sim_free(b);
}

/* Servo pulse widths and motor PWM measured at the pins against the commands. */
static void test_outputs(void)
{
    board_sim_t *b = open_image("navkit-mega2560.elf");
    host_t h;
    navkit_micro_cmd_t c;
    int16_t l, r;
    int i, k;
    uint16_t tag = 1u;
    host_init(&h);
    run_for(b, MS(20));
    for (i = 0; i < 8; i++) {
        check(board_sim_servo_pulse_us(b, (uint8_t)i) == 0u, "servo %d pulses before any command", i);
    }
    board_sim_motor_duty(b, &l, &r);
    check(l == 0 && r == 0, "motors driven before any command (%d, %d)", l, r);
    configure(b, &h, 400u, 300u); /* pwm_limit 0.300: the stalled wheels' loops saturate there */
    /* servo 0 GoTo +30.0 deg, servo 3 GoTo -45.0 deg, both at 900 deg/s: 1500 us +/- 10 us/deg */
    navkit_micro_cmd_defaults(&c);
    c.time_tag = tag++;
    c.rc0_param0 = 9000;
    c.rc0_param1 = 300;
    c.rc0_param2 = NAVKIT_SERVO_GOTO_GOTO_FLAG;
    c.rc3_param0 = 9000;
    c.rc3_param1 = -450;
    c.rc3_param2 = NAVKIT_SERVO_GOTO_GOTO_FLAG;
    send_cmd(b, &c);
    run_for(b, MS(500));
    /* within 1 us: the pin edges move by the compare interrupt's entry latency */
    check(abs((int)board_sim_servo_pulse_us(b, 0u) - 1800) <= 1, "servo 0 pulse %u us, want 1800 +/- 1",
          board_sim_servo_pulse_us(b, 0u));
    check(abs((int)board_sim_servo_pulse_us(b, 3u) - 1050) <= 1, "servo 3 pulse %u us, want 1050 +/- 1",
          board_sim_servo_pulse_us(b, 3u));
    check(board_sim_servo_pulse_us(b, 1u) == 0u, "servo 1 pulses without a command");
    printf("servos at the pins: %u us (want 1800), %u us (want 1050)\n", board_sim_servo_pulse_us(b, 0u),
           board_sim_servo_pulse_us(b, 3u));
    /* forward, then reverse, with the wheels held still: duty saturates at +/- pwm_limit */
    for (k = 0; k < 2; k++) {
        int16_t want = (k == 0) ? 3000 : -3000;
        navkit_micro_cmd_defaults(&c);
        c.fwd_cmd = NAVKIT_FWD_CMD_START;
        c.speed = 200;
        c.distance = (k == 0) ? 1000 : -1000;
        c.mc_datalog_cmd = NAVKIT_MC_DATALOG_WHEEL_LEFT;
        c.time_tag = tag++;
        for (i = 0; i < 30; i++) { /* repeated (same tag) within the host watchdog's 300 ms */
            send_cmd(b, &c);
            run_for(b, MS(50));
            host_drain(&h, b);
        }
        board_sim_motor_duty(b, &l, &r);
        check(l == want && r == want, "motor duty at the pins %d/%d, want %d", l, r, want);
        check(h.last.mc_datalog[2] == want, "the firmware's left duty %d, want %d", h.last.mc_datalog[2], want);
        printf("motor duty at the pins: %d/%d (firmware %d)\n", l, r, h.last.mc_datalog[2]);
    }
    board_sim_free(b);
}

/* The sensors as the board reads them: ADC voltages, the gyro and compass parts over TWI,
 * the sonars' echo pulses, the DIO input levels, all reported in micro_data; a gyro that
 * answers only later is woken and read then. */
static void test_inputs(void)
{
    static const uint16_t mv[5] = {400u, 1250u, 2500u, 4999u, 3700u};
    static const uint16_t echo[4] = {580u, 1000u, 0u, 17400u};
    board_sim_t *b = open_image("navkit-mega2560.elf");
    host_t h;
    int i, k;
    uint16_t tag = 1u;
    host_init(&h);
    run_for(b, MS(20));
    configure(b, &h, 400u, 1000u); /* micro_cfg_io defaults: DIO 0-7 outputs, 8-11 inputs */
    for (k = 0; k < 2; k++) {
        int16_t gyro = (k == 0) ? 1310 : -2620;
        uint16_t compass = (k == 0) ? 450u : 3599u;
        uint16_t dio = (k == 0) ? 0x0A00u : 0x0500u; /* DIO 8-11: inputs by the default direction */
        for (i = 0; i < 5; i++) {
            board_sim_set_adc_mv(b, (uint8_t)i, (uint16_t)(mv[i] / (k + 1)));
        }
        for (i = 0; i < 4; i++) {
            board_sim_set_sonar_echo_us(b, (uint8_t)i, (uint16_t)(echo[i] / (k + 1)));
        }
        board_sim_set_gyro_raw(b, gyro);
        board_sim_set_compass(b, compass);
        board_sim_set_dio_in(b, dio);
        run_for(b, MS(1000)); /* every sonar pinged at least once */
        ping(b, &h, tag++);
        for (i = 0; i < 5; i++) {
            /* 10 bit of the 5.0 V reference: mV * 1024 / 5000, within one count */
            long want = (long)(mv[i] / (k + 1)) * 1024L / 5000L;
            check(labs((long)h.last.adc[i] - want) <= 1, "adc %d: %u counts, want %ld", i, h.last.adc[i], want);
        }
        for (i = 0; i < 4; i++) {
            long want = (long)(echo[i] / (k + 1));
            /* within 20 us (3.4 mm): each edge's pin-change interrupt may wait ~300 cycles
               behind the longest other interrupt and the encoders' (docs/avr.md) */
            check(labs((long)h.last.sonar_echo[i] - want) <= 20, "sonar %d: %u us, want %ld +/- 20", i,
                  h.last.sonar_echo[i], want);
        }
        check(h.last.gyro_raw == gyro, "gyro_raw %d, want %d", h.last.gyro_raw, gyro);
        check(h.last.compass == compass, "compass %u, want %u", h.last.compass, compass);
        check((h.last.dio_state & 0x0F00u) == dio, "dio_state 0x%03x, want inputs 0x%03x", h.last.dio_state, dio);
        printf("inputs: adc %u %u %u %u %u counts, sonar %u %u %u %u us, gyro %d LSB, compass %u, dio 0x%03x\n",
               h.last.adc[0], h.last.adc[1], h.last.adc[2], h.last.adc[3], h.last.adc[4], h.last.sonar_echo[0],
               h.last.sonar_echo[1], h.last.sonar_echo[2], h.last.sonar_echo[3], h.last.gyro_raw, h.last.compass,
               h.last.dio_state);
    }
    board_sim_free(b);

    /* a gyro that does not answer at power-on (its wake-up writes NACKed): gyro_raw stays 0
       while the compass goes on; once it answers, the board wakes it and reads it */
    b = open_image("navkit-mega2560.elf");
    host_init(&h);
    board_sim_set_twi_part_present(b, BOARD_GYRO_ADDR, 0);
    board_sim_set_gyro_raw(b, 655);
    board_sim_set_compass(b, 1234u);
    run_for(b, MS(20));
    configure(b, &h, 400u, 1000u);
    run_for(b, MS(100));
    ping(b, &h, tag++);
    check(h.last.gyro_raw == 0 && h.last.compass == 1234u, "gyro absent: gyro_raw %d (want 0), compass %u (want 1234)",
          h.last.gyro_raw, h.last.compass);
    board_sim_set_twi_part_present(b, BOARD_GYRO_ADDR, 1);
    run_for(b, MS(100));
    ping(b, &h, tag++);
    check(h.last.gyro_raw == 655, "gyro back: gyro_raw %d, want 655 (woken up again)", h.last.gyro_raw);
    printf("gyro absent then back: %d LSB\n", h.last.gyro_raw);
    board_sim_free(b);
}

/* The tick timer: ticks per simulated second at the reset rate (400 Hz) and at 250 Hz. */
static void test_tick_rate(void)
{
    board_sim_t *b = open_image("navkit-mega2560.elf");
    host_t h;
    board_sim_profile_t p0, p1;
    int k;
    host_init(&h);
    for (k = 0; k < 2; k++) {
        uint32_t want = (k == 0) ? 400u : 250u;
        if (k == 1) {
            configure(b, &h, 250u, 1000u);
        }
        run_for(b, MS(50));
        board_sim_profile(b, &p0);
        run_for(b, MS(500));
        board_sim_profile(b, &p1);
        check(p1.ticks - p0.ticks >= want / 2u - 1u && p1.ticks - p0.ticks <= want / 2u + 1u,
              "%lu ticks in half a second, want %lu", (unsigned long)(p1.ticks - p0.ticks), (unsigned long)want / 2u);
        printf("%lu Hz configured: %lu ticks in half a simulated second; worst tick %lu cycles\n", (unsigned long)want,
               (unsigned long)(p1.ticks - p0.ticks), (unsigned long)p1.tick_worst_cycles);
    }
    board_sim_free(b);
}

/* Get a micro_data out of a freshly started image (unconfigured: a config frame). */
static uint16_t reset_cause_now(board_sim_t *b)
{
    host_t h;
    int i;
    host_init(&h);
    run_for(b, MS(20));
    send_config(b, 0, 400u, 1000u);
    for (i = 0; i < 40 && h.frames == 0u; i++) {
        run_for(b, MS(5));
        host_drain(&h, b);
    }
    check(h.frames > 0u, "no micro_data after a start");
    return h.last.reset_cause;
}

/* The hardware watchdog resets a hung main loop, and micro_data says so; with the reset
 * flags visible (no bootloader) and hidden (the stk500v2 clears them): every cause. */
static void test_watchdog(void)
{
    board_sim_t *b = open_image("navkit-mega2560-test.elf");
    board_sim_profile_t p;
    uint16_t rc;
    int boot;
    check(reset_cause_now(b) == NAVKIT_RESET_CAUSE_POWER_ON, "first start: not power-on");
    for (boot = 0; boot < 2; boot++) {
        board_sim_set_bootloader_clears_mcusr(b, boot);
        board_sim_set_dio_in(b, TEST_HANG);
        /* watchdog interrupt after ~64 ms, reset ~64 ms later: release the pins at once,
           before the restarted image reads them */
        do {
            run_for(b, 800u);
            board_sim_profile(b, &p);
        } while (p.watchdog_resets == (uint32_t)boot && board_sim_cycles(b) < MS(2000));
        board_sim_set_dio_in(b, 0u);
        check(p.watchdog_resets == (uint32_t)boot + 1u, "watchdog resets %lu, want %d",
              (unsigned long)p.watchdog_resets, boot + 1);
        rc = reset_cause_now(b);
        check(rc == NAVKIT_RESET_CAUSE_WATCHDOG, "after the watchdog (%s): reset_cause %u, want %u",
              boot ? "flags cleared" : "flags kept", rc, NAVKIT_RESET_CAUSE_WATCHDOG);
        printf("hung loop reset by the watchdog (%s): reset_cause %u\n", boot ? "bootloader cleared MCUSR" : "MCUSR",
               rc);
    }
    {
        static const int causes[3] = {BOARD_SIM_RESET_EXTERNAL, BOARD_SIM_RESET_POWER_ON, BOARD_SIM_RESET_BROWN_OUT};
        static const uint16_t want_flags[3] = {NAVKIT_RESET_CAUSE_EXTERNAL, NAVKIT_RESET_CAUSE_POWER_ON,
                                               NAVKIT_RESET_CAUSE_BROWN_OUT};
        static const uint16_t want_marks[3] = {NAVKIT_RESET_CAUSE_EXTERNAL, NAVKIT_RESET_CAUSE_POWER_ON,
                                               NAVKIT_RESET_CAUSE_EXTERNAL};
        int i;
        for (boot = 0; boot < 2; boot++) {
            board_sim_set_bootloader_clears_mcusr(b, boot);
            for (i = 0; i < 3; i++) {
                uint16_t want = boot ? want_marks[i] : want_flags[i];
                board_sim_reset(b, causes[i]);
                rc = reset_cause_now(b);
                check(rc == want, "reset %d (%s): reset_cause %u, want %u", causes[i],
                      boot ? "flags cleared" : "flags kept", rc, want);
            }
        }
    }
    board_sim_free(b);
}

/* Flash and static RAM from avr-size -A's listing; the deepest stack from a busy run. */
static void test_footprint(void)
{
    image_size_t z;
    board_sim_t *b;
    host_t h;
    navkit_micro_cmd_t c;
    board_sim_profile_t p0, p;
    uint16_t tag = 1u;
    int i;
    unsigned long ram_end;
    uint64_t c0;
    double busy;
    read_size("navkit-mega2560.size.txt", &z);

    b = open_image("navkit-mega2560.elf");
    host_init(&h);
    run_for(b, MS(20));
    configure(b, &h, 400u, 1000u);
    set_busy_sensors(b);
    busy_cmd_init(&c);
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.distance = 2000;
    c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
    c.turn_distance = 900;
    c.rc0_param2 = -300;
    board_sim_profile(b, &p0);
    c0 = board_sim_cycles(b);
    for (i = 0; i < 300; i++) { /* 3 s: a move with heading select, servo scan, encoders turning */
        c.time_tag = tag++;
        send_cmd(b, &c);
        board_sim_set_encoders(b, 20 * i, 18 * i, board_sim_cycles(b) + MS(10));
        run_for(b, MS(10));
        host_drain(&h, b);
    }
    board_sim_profile(b, &p);
    busy = (double)(board_sim_cycles(b) - c0);
    ram_end = 0x200ul + z.data + z.bss + z.noinit;
    printf("flash %lu B (text %lu + data %lu) of 262144; static RAM %lu B (data %lu + bss %lu + noinit %lu) of 8192; "
           "deepest stack %u B; RAM in use %lu B\n",
           z.text + z.data, z.text, z.data, z.data + z.bss + z.noinit, z.data, z.bss, z.noinit, p.stack_max_bytes,
           z.data + z.bss + z.noinit + p.stack_max_bytes);
    print_span("busy 3 s (a tick: 40000 cycles at 400 Hz)", &p0, &p, busy);
    printf("tick lateness (timer request to fw_tick start): worst %lu mean %lu cycles (%.2f / %.2f tick periods)\n",
           (unsigned long)p.tick_late_worst_cycles,
           (unsigned long)((p.tick_late_total_cycles - p0.tick_late_total_cycles) / (p.ticks - p0.ticks)),
           (double)p.tick_late_worst_cycles / 40000.0,
           (double)(p.tick_late_total_cycles - p0.tick_late_total_cycles) / (double)(p.ticks - p0.ticks) / 40000.0);
    check(ram_end <= 0x1000ul, "static RAM ends at 0x%lx, past the reset markers at 0x1000", ram_end);
    check(p.stack_min_sp > 0x1000u + 8u, "the stack reached 0x%x, into the reset markers at 0x1000", p.stack_min_sp);
    check(h.last.status & NAVKIT_MICRO_STATUS_CONFIGURED, "the busy run lost its configuration");
    check(p.resets == 0u, "the board reset during the busy run");
    board_sim_free(b);
}

/* The host's traffic at 400 Hz: the three configs at start-up, then a micro_cmd every
 * 10 ms (100 Hz, about the line rate: 116 bytes take ~10 ms) for 2 s with a new command
 * (new time tag: a move with heading select, a servo) every 100 ms and repeats in
 * between, encoders turning and every sensor read. No tick may start more than
 * TICK_LATE_MAX_CYCLES after its timer requested it (hal.h, ordering contract 1: a poll
 * handles at most one frame, its reply goes out in the next), and every frame must arrive
 * whole (the simulated line
 * carries 10/11 of the baud rate, so the last frames arrive after the 2 s). */
#define TICK_LATE_MAX_CYCLES 40000u /* cycles: one tick period at 400 Hz (2.5 ms) */
static void test_tick_late(void)
{
    board_sim_t *b = open_image("navkit-mega2560.elf");
    host_t h;
    navkit_micro_cmd_t c;
    board_sim_profile_t p;
    uint16_t tag = 100u;
    int i;
    host_init(&h);
    set_busy_sensors(b);
    run_for(b, MS(20));
    configure(b, &h, 400u, 1000u);
    busy_cmd_init(&c);
    for (i = 0; i < 200; i++) {
        if (i % 10 == 0) { /* a new command every 100 ms */
            c.time_tag = tag++;
            c.fwd_cmd = NAVKIT_FWD_CMD_START;
            c.distance = 2000 + 10 * i;
            c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
            c.turn_distance = (i % 20 == 0) ? 900 : -900;
            c.rc0_param2 = (int16_t)((i % 20 == 0) ? 300 : -300);
        }
        send_cmd(b, &c);
        board_sim_set_encoders(b, 20 * i, 18 * i, board_sim_cycles(b) + MS(10));
        run_for(b, MS(10));
        host_drain(&h, b);
    }
    run_for(b, MS(300));
    host_drain(&h, b);
    ping(b, &h, 50000u); /* the counters after every frame */
    board_sim_profile(b, &p);
    printf(
        "host traffic at 400 Hz: %lu ticks, tick lateness worst %lu mean %lu cycles (bound %u); fw_link_poll %lu polls, "
        "worst %lu mean %lu cycles; fw_tick worst %lu mean %lu cycles\n",
        (unsigned long)p.ticks, (unsigned long)p.tick_late_worst_cycles,
        (unsigned long)(p.tick_late_total_cycles / (p.ticks ? p.ticks : 1u)), TICK_LATE_MAX_CYCLES,
        (unsigned long)p.polls, (unsigned long)p.poll_worst_cycles, (unsigned long)p.poll_mean_cycles,
        (unsigned long)p.tick_worst_cycles, (unsigned long)p.tick_mean_cycles);
    check(p.tick_late_worst_cycles <= TICK_LATE_MAX_CYCLES, "a tick started %lu cycles after it fell due (bound %u)",
          (unsigned long)p.tick_late_worst_cycles, TICK_LATE_MAX_CYCLES);
    check(h.last.rx_good == frames_sent, "the board counted %u good frames of %u sent", h.last.rx_good, frames_sent);
    check(h.last.rx_bad_crc == 0u && h.last.rx_dropped_bytes == 0u, "the link lost bytes: %u bad CRC, %u dropped",
          h.last.rx_bad_crc, h.last.rx_dropped_bytes);
    check(p.resets == 0u, "the board reset");
    board_sim_free(b);
}

/* ---------------------------------------------------------------- CAN (navkit-mega2560-can) */

/* micro_data's field name of d, or -1 if this spec has no such field (the CAN transport's
 * counters, can_rx_*, are the spec's; a spec without them leaves those checks out). */
static long can_counter(const navkit_micro_data_t *d, const char *name)
{
    int i = navkit_micro_data_field_index(name);
    return (i < 0) ? -1L : (long)navkit_micro_data_get(d, i, 0);
}

/* The host's end of the bus: ISO-TP both ways (the firmware's own navkit_isotp), the
 * frame parser on what it reassembles; ISO-TP's clock is the board's, in ms. */
typedef struct {
    navkit_isotp_tx_t tx;
    navkit_isotp_rx_t rx;
    navkit_parser_t parser;
    navkit_micro_data_t last;
    unsigned frames;   /* micro_data decoded */
    unsigned messages; /* host messages started */
    int drop_cf;       /* > 0: leave out this consecutive frame (1 = the first) of the next message */
    int cf_seen;
} can_host_t;

static uint32_t can_ms(board_sim_t *b)
{
    return (uint32_t)(board_sim_cycles(b) / MS(1));
}

static void can_host_init(can_host_t *h)
{
    memset(h, 0, sizeof *h);
    navkit_isotp_tx_init(&h->tx);
    navkit_isotp_rx_init(&h->rx, NAVKIT_DIR_TO_HOST);
    navkit_parser_init(&h->parser, NAVKIT_DIR_TO_HOST);
}

/* Every frame the part sent through ISO-TP (flow controls back at once), then the frames
 * the host's sender lets go. */
static void can_pump(can_host_t *h, board_sim_t *b)
{
    board_sim_can_frame_t f;
    navkit_isotp_frame_t out;
    uint8_t fc_out;
    while (board_sim_can_read(b, &f)) {
        uint16_t n;
        navkit_isotp_tx_frame(&h->tx, f.id, f.data, f.dlc, can_ms(b));
        n = navkit_isotp_rx_frame(&h->rx, f.id, f.data, f.dlc, can_ms(b), &out, &fc_out);
        if (fc_out) {
            board_sim_can_write(b, out.id, out.data, 8u);
        }
        if (n > 0u) {
            (void)navkit_parser_feed(&h->parser, h->rx.buf, n);
            take_replies(&h->parser, &h->last, &h->frames);
        }
    }
    while (navkit_isotp_tx_next(&h->tx, can_ms(b), &out)) {
        if ((out.data[0] >> 4) == 2u && h->drop_cf > 0 && ++h->cf_seen == h->drop_cf) {
            h->drop_cf = 0; /* lost on the bus */
            continue;
        }
        board_sim_can_write(b, out.id, out.data, 8u);
    }
}

static void can_run(can_host_t *h, board_sim_t *b, uint64_t cycles)
{
    uint64_t end = board_sim_cycles(b) + cycles;
    while (board_sim_cycles(b) < end) {
        uint64_t step = end - board_sim_cycles(b);
        run_for(b, (step < MS(1)) ? step : MS(1));
        can_pump(h, b);
    }
}

/* One serial frame (bytes buf[0..len-1] of msg_type) as an ISO-TP message, once the
 * sender is free (at most 100 ms). */
static void can_send(can_host_t *h, board_sim_t *b, const uint8_t *buf, size_t len, uint16_t msg_type)
{
    int i;
    for (i = 0; i < 100 && navkit_isotp_tx_busy(&h->tx); i++) {
        can_run(h, b, MS(1));
    }
    check(!navkit_isotp_tx_busy(&h->tx), "the host's ISO-TP sender stayed busy 100 ms");
    memcpy(h->tx.buf, buf, len);
    check(navkit_isotp_tx_start(&h->tx, (uint16_t)len, msg_type, can_ms(b)) == 1u, "ISO-TP refused a message");
    h->cf_seen = 0;
    h->messages++;
    can_pump(h, b);
}

static void can_send_cmd(can_host_t *h, board_sim_t *b, const navkit_micro_cmd_t *c)
{
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    can_send(h, b, buf, navkit_micro_cmd_encode(c, buf, sizeof buf), NAVKIT_MSG_TYPE_MICRO_CMD);
}

/* A micro_cmd with only its time tag; run until a micro_data acknowledges it (1 s at most). */
static void can_ping(can_host_t *h, board_sim_t *b, uint16_t tag)
{
    navkit_micro_cmd_t c;
    int i;
    navkit_micro_cmd_defaults(&c);
    c.time_tag = tag;
    can_send_cmd(h, b, &c);
    for (i = 0; i < 200 &&
                !(h->frames > 0u && h->last.ack_time_tag == tag && (h->last.status & NAVKIT_MICRO_STATUS_CONFIGURED));
         i++) {
        can_run(h, b, MS(5));
    }
}

/* The three configs at rate_hz over CAN, then pings until a micro_data says configured. */
static void can_configure(can_host_t *h, board_sim_t *b, uint16_t rate_hz)
{
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    uint16_t msg_type;
    int k;
    for (k = 0; k < 3; k++) {
        size_t len = config_frame(k, rate_hz, 1000u, buf, &msg_type);
        can_send(h, b, buf, len, msg_type);
    }
    can_ping(h, b, 60000u);
    check(h->frames > 0u && (h->last.status & NAVKIT_MICRO_STATUS_CONFIGURED),
          "the CAN image did not report configured (%u micro_data over CAN)", h->frames);
}

/* The CAN image (ELF and HEX) with the MCP2515 model: the part set to the spec's bit rate in
 * normal mode, the three configs and micro_cmds as ISO-TP answered by micro_data over CAN
 * with this spec's hash, and a move command driving both motors forward. */
static void test_can_link(void)
{
    const char *names[2] = {"navkit-mega2560-can.elf", "navkit-mega2560-can.hex"};
    int k;
    for (k = 0; k < 2; k++) {
        board_sim_t *b = open_image(names[k]);
        can_host_t h;
        navkit_micro_cmd_t c;
        board_sim_can_stats_t st;
        int16_t l = 0, r = 0;
        can_host_init(&h);
        run_for(b, MS(20));
        board_sim_can_stats(b, &st);
        check(st.normal_mode == 1u, "%s: the MCP2515 is not in normal mode", names[k]);
        check(st.part_bps == NAVKIT_CAN_BITRATE, "%s: the MCP2515's bit timing gives %lu bit/s, want %lu", names[k],
              (unsigned long)st.part_bps, (unsigned long)NAVKIT_CAN_BITRATE);
        can_configure(&h, b, 400u);
        check(h.last.spec_hash == NAVKIT_SPEC_HASH, "%s: micro_data spec_hash 0x%08lx", names[k],
              (unsigned long)h.last.spec_hash);
        navkit_micro_cmd_defaults(&c);
        c.time_tag = 7u;
        c.fwd_cmd = NAVKIT_FWD_CMD_START;
        c.speed = 300;
        c.accel = 1000;
        c.distance = 5000;
        can_send_cmd(&h, b, &c);
        can_run(&h, b, MS(300));
        board_sim_motor_duty(b, &l, &r);
        can_ping(&h, b, 8u);
        check(l > 0 && r > 0, "%s: the move over CAN drives the motors at %d / %d e-4", names[k], l, r);
        check(h.last.ack_time_tag == 8u, "%s: ack_time_tag %u, want 8", names[k], h.last.ack_time_tag);
        check(h.last.rx_good == h.messages, "%s: rx_good %u, want every message sent, %u", names[k], h.last.rx_good,
              h.messages);
        check(h.last.cmd_rejected == 0u, "%s: %u commands refused", names[k], h.last.cmd_rejected);
        check(h.parser.stats.bad_crc == 0u && h.rx.stats.wrong_sn == 0u && h.rx.stats.bad_frame == 0u,
              "%s: damaged micro_data over CAN", names[k]);
        board_sim_can_stats(b, &st);
        printf(
            "%s: %u messages to the micro, %u micro_data back; bus: %lu frames to the part, %lu from it; motors %d / %d "
            "e-4\n",
            names[k], h.messages, h.frames, (unsigned long)st.to_part, (unsigned long)st.from_part, l, r);
        board_sim_free(b);
    }
}

/* Frames on identifiers the micro does not receive (other nodes' traffic, the micro's own
 * micro_data identifier, the flow controls it sends) never reach the image: the part's
 * filters drop them (none in a buffer), and the link's counters do not move. */
static void test_can_filter(void)
{
    static const uint16_t other[] = {0x000u, 0x100u, 0x111u, 0x121u, 0x123u, 0x125u, 0x180u, 0x7FFu, 0x1A0u, 0x130u};
    board_sim_t *b = open_image("navkit-mega2560-can.elf");
    can_host_t h;
    board_sim_can_stats_t s0, s1;
    navkit_micro_data_t before;
    uint8_t sf[8] = {0x01u, 0x00u, 0xCCu, 0xCCu, 0xCCu, 0xCCu, 0xCCu, 0xCCu};
    size_t i;
    int rep;
    can_host_init(&h);
    run_for(b, MS(20));
    can_configure(&h, b, 400u);
    before = h.last;
    board_sim_can_stats(b, &s0);
    for (rep = 0; rep < 10; rep++) {
        for (i = 0u; i < sizeof other / sizeof other[0]; i++) {
            board_sim_can_write(b, other[i], sf, 8u);
        }
    }
    can_run(&h, b, MS(50));
    board_sim_can_stats(b, &s1);
    can_ping(&h, b, 9u);
    check(s1.filtered - s0.filtered == 10u * (sizeof other / sizeof other[0]),
          "the part's filters dropped %lu of %u foreign frames", (unsigned long)(s1.filtered - s0.filtered),
          (unsigned)(10u * (sizeof other / sizeof other[0])));
    check(s1.accepted == s0.accepted, "%lu foreign frames reached a receive buffer",
          (unsigned long)(s1.accepted - s0.accepted));
    check(h.last.rx_good == before.rx_good + 1u, "rx_good went from %u to %u for one message", before.rx_good,
          h.last.rx_good);
    check(can_counter(&h.last, "can_rx_bad_frame") <= 0 && can_counter(&h.last, "can_rx_unexpected") <= 0,
          "the link saw foreign frames");
    printf("%lu foreign frames dropped by the filters\n", (unsigned long)(s1.filtered - s0.filtered));
    board_sim_free(b);
}

/* A micro_cmd whose fifth consecutive frame is lost on the bus is not applied (the motors
 * stay off, it is not acknowledged, rx_good does not count it) and counted (micro_data's
 * can_rx_wrong_sn, then the rest of its frames can_rx_unexpected); the next command is. */
static void test_can_lost(void)
{
    board_sim_t *b = open_image("navkit-mega2560-can.elf");
    can_host_t h;
    navkit_micro_cmd_t c;
    int16_t l = 0, r = 0;
    long wrong_sn, unexpected;
    can_host_init(&h);
    run_for(b, MS(20));
    can_configure(&h, b, 400u);
    navkit_micro_cmd_defaults(&c);
    c.time_tag = 20u;
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 300;
    c.distance = 5000;
    h.drop_cf = 5;
    can_send_cmd(&h, b, &c);
    can_run(&h, b, MS(100));
    board_sim_motor_duty(b, &l, &r);
    can_ping(&h, b, 21u); /* ack 21: the ping ran, the lost command never did */
    check(h.last.ack_time_tag == 21u, "ack_time_tag %u after the ping, want 21", h.last.ack_time_tag);
    wrong_sn = can_counter(&h.last, "can_rx_wrong_sn");
    unexpected = can_counter(&h.last, "can_rx_unexpected");
    check(wrong_sn < 0 || wrong_sn == 1, "can_rx_wrong_sn %ld, want 1", wrong_sn);
    /* the consecutive frames after the lost one: the first aborts (wrong_sn), the rest are unexpected */
    check(unexpected < 0 || unexpected == (long)((NAVKIT_MICRO_CMD_BYTES - 6u + 6u) / 7u) - 5 - 1,
          "can_rx_unexpected %ld, want %ld (the frames after the gap)", unexpected,
          (long)((NAVKIT_MICRO_CMD_BYTES - 6u + 6u) / 7u) - 5 - 1);
    check(h.last.rx_good == h.messages - 1u, "rx_good %u, want %u (all but the broken one)", h.last.rx_good,
          h.messages - 1u);
    check(l == 0 && r == 0, "the broken move command ran: motors %d / %d e-4", l, r);
    printf("lost consecutive frame: the command not applied; can_rx_wrong_sn %ld, can_rx_unexpected %ld (-1: not in "
           "this spec)\n",
           wrong_sn, unexpected);
    board_sim_free(b);
}

/* Frames lost before the link saw them reach micro_data's can_rx_lost: with the part's INT
 * held high (the driver's poll held off) a flood on micro_cmd's identifier fills both
 * receive buffers and overflows RXB0 (EFLG RX0OVR: one count however many frames it lost);
 * a second flood overflows both buffers (RX0OVR and RX1OVR: two). The buffered frames still
 * reach the link (PCI type 15: each counted once in can_rx_bad_frame). */
static void test_can_rx_lost(void)
{
    static const uint8_t junk[8] = {0xF0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};
    board_sim_t *b = open_image("navkit-mega2560-can.elf");
    can_host_t h;
    board_sim_can_stats_t s0, s1, s2;
    long lost0, lost1, lost2, bad0;
    int i;
    can_host_init(&h);
    run_for(b, MS(20));
    can_configure(&h, b, 400u);
    lost0 = can_counter(&h.last, "can_rx_lost");
    bad0 = can_counter(&h.last, "can_rx_bad_frame");
    check(lost0 == 0, "can_rx_lost %ld before any flood, want 0", lost0);
    board_sim_can_stats(b, &s0);
    board_sim_can_hold_int(b, 1);
    for (i = 0; i < 12; i++) {
        board_sim_can_write(b, NAVKIT_CAN_ID_MICRO_CMD, junk, 8u);
    }
    can_run(&h, b, MS(5)); /* 12 frames of 111 bits at 500 kbit/s: 2.7 ms */
    board_sim_can_hold_int(b, 0);
    can_ping(&h, b, 30u);
    board_sim_can_stats(b, &s1);
    lost1 = can_counter(&h.last, "can_rx_lost");
    check(h.last.ack_time_tag == 30u, "ack_time_tag %u after the flood, want 30", h.last.ack_time_tag);
    check(s1.overflowed - s0.overflowed == 10u, "the part lost %lu frames of 12, want 10 (2 buffered)",
          (unsigned long)(s1.overflowed - s0.overflowed));
    check(lost1 == 1, "can_rx_lost %ld after RXB0 overflowed, want 1", lost1);
    check(can_counter(&h.last, "can_rx_bad_frame") - bad0 == 2, "can_rx_bad_frame moved by %ld, want 2 (the buffered)",
          can_counter(&h.last, "can_rx_bad_frame") - bad0);
    board_sim_can_hold_int(b, 1);
    for (i = 0; i < 12; i++) { /* RXB0 then RXB1 (rollover) take the first two; then both overflow */
        board_sim_can_write(b, (i >= 2 && i % 2) ? NAVKIT_CAN_FC_ID_MICRO_DATA : NAVKIT_CAN_ID_MICRO_CMD, junk, 8u);
    }
    can_run(&h, b, MS(5));
    board_sim_can_hold_int(b, 0);
    can_ping(&h, b, 31u);
    board_sim_can_stats(b, &s2);
    lost2 = can_counter(&h.last, "can_rx_lost");
    check(h.last.ack_time_tag == 31u, "ack_time_tag %u after the second flood, want 31", h.last.ack_time_tag);
    check(s2.overflowed - s1.overflowed == 10u, "the part lost %lu frames of 12, want 10",
          (unsigned long)(s2.overflowed - s1.overflowed));
    check(lost2 == 3, "can_rx_lost %ld after both buffers overflowed, want 3", lost2);
    printf("flooded with INT held: the part lost %lu frames in two floods; can_rx_lost %ld, then %ld\n",
           (unsigned long)(s2.overflowed - s0.overflowed), lost1, lost2);
    board_sim_free(b);
}

/* The CAN image's footprint (flash, static RAM, deepest stack) and its tick lateness under
 * CAN traffic at 400 Hz: the configs, then a micro_cmd every CAN_LATE_CMD_MS (17 frames in,
 * a micro_data back for each) for 2 s, a new command every 100 ms, encoders turning, every
 * sensor read. No tick may start more than one period late (hal.h: a poll applies one
 * reassembled message at most, builds one reply at most), every command arrives and is
 * answered. 25 Hz is 2.5 times the host's shipped rate, within the CPU the 16 MHz AVR has
 * left at 400 Hz (docs/avr.md, CAN, has the budget). */
#define CAN_LATE_CMD_MS 40u
static void test_can_late(void)
{
    image_size_t z;
    board_sim_t *b;
    can_host_t h;
    navkit_micro_cmd_t c;
    board_sim_profile_t p0, p;
    board_sim_can_stats_t st;
    uint16_t tag = 100u;
    uint64_t c0;
    double busy;
    int i;
    read_size("navkit-mega2560-can.size.txt", &z);
    b = open_image("navkit-mega2560-can.elf");
    can_host_init(&h);
    set_busy_sensors(b);
    run_for(b, MS(20));
    can_configure(&h, b, 400u);
    busy_cmd_init(&c);
    board_sim_profile(b, &p0);
    c0 = board_sim_cycles(b);
    for (i = 0; i < (int)(2000u / CAN_LATE_CMD_MS); i++) {
        if (i % (int)(100u / CAN_LATE_CMD_MS) == 0) { /* a new command every 100 ms or so */
            c.time_tag = tag++;
            c.fwd_cmd = NAVKIT_FWD_CMD_START;
            c.distance = 2000 + 10 * i;
            c.turn_cmd = NAVKIT_TURN_CMD_HDG_SEL;
            c.turn_distance = (tag % 2u) ? 900 : -900;
            c.rc0_param2 = (int16_t)((tag % 2u) ? 300 : -300);
        }
        can_send_cmd(&h, b, &c);
        board_sim_set_encoders(b, 80 * i, 72 * i, board_sim_cycles(b) + MS(CAN_LATE_CMD_MS));
        can_run(&h, b, MS(CAN_LATE_CMD_MS));
    }
    board_sim_profile(b, &p);
    busy = (double)(board_sim_cycles(b) - c0);
    can_ping(&h, b, 50000u);
    board_sim_can_stats(b, &st);
    printf("CAN image: flash %lu B (text %lu + data %lu); static RAM %lu B (data %lu + bss %lu + noinit %lu); deepest "
           "stack %u B\n",
           z.text + z.data, z.text, z.data, z.data + z.bss + z.noinit, z.data, z.bss, z.noinit, p.stack_max_bytes);
    print_span("CAN traffic 2 s at 400 Hz", &p0, &p, busy);
    printf("tick lateness: worst %lu mean %lu cycles (bound %u)\n", (unsigned long)p.tick_late_worst_cycles,
           (unsigned long)((p.tick_late_total_cycles - p0.tick_late_total_cycles) / (p.ticks - p0.ticks)),
           TICK_LATE_MAX_CYCLES);
    printf("bus: %lu frames to the part (%lu overflowed), %lu from it; %u micro_data for %u messages\n",
           (unsigned long)st.to_part, (unsigned long)st.overflowed, (unsigned long)st.from_part, h.frames, h.messages);
    check(p.tick_late_worst_cycles <= TICK_LATE_MAX_CYCLES, "a tick started %lu cycles after it fell due (bound %u)",
          (unsigned long)p.tick_late_worst_cycles, TICK_LATE_MAX_CYCLES);
    check(h.last.rx_good == h.messages, "the board counted %u good messages of %u sent", h.last.rx_good, h.messages);
    check(st.overflowed == 0u, "%lu frames found the part's buffers full", (unsigned long)st.overflowed);
    check(h.last.ack_time_tag == 50000u, "the last ping was not acknowledged");
    check(h.frames + 2u >= h.messages, "only %u micro_data for %u messages", h.frames, h.messages);
    check(0x200ul + z.data + z.bss + z.noinit <= 0x1000ul, "static RAM ends past the reset markers at 0x1000");
    check(p.stack_min_sp > 0x1000u + 8u, "the stack reached 0x%x, into the reset markers at 0x1000", p.stack_min_sp);
    check(p.resets == 0u, "the board reset");
    board_sim_free(b);
}

/* Both encoders at the guaranteed rate (BOARD_SIM_ENC_MIN_EDGE_CYCLES apart on each, both at
 * once) on the CAN image while frames arrive: exact counts forward and back. The frames
 * (PCI type 15 on micro_cmd's identifier: each counted in can_rx_bad_frame, none applied)
 * come in pairs, back to back (8 data bytes: 111 bits, 3552 cycles apart), a pair every
 * CAN_ENC_GAP_CYCLES: ten INT poll periods and 13 cycles, so that the second frame's end
 * sweeps across the phases of the poll that serves the first, also just after its last
 * status read (a driver that read that frame over the SPI with interrupts off would hold
 * the encoders longer than their edge period: both would lose counts). ~1000 frames/s, all
 * of which the link takes under this load (none lost). */
#define CAN_ENC_GAP_CYCLES ((uint64_t)10u * BOARD_CAN_POLL_US * (F_CPU_HZ / 1000000u) + 13u)
static void test_can_encoders(void)
{
    static const uint8_t junk[8] = {0xF0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};
    board_sim_t *b = open_image("navkit-mega2560-can.elf");
    can_host_t h;
    board_sim_can_stats_t s0, s1;
    int32_t steps[3][2] = {{20000, -20000}, {-5000, 7000}, {3, -1}};
    int32_t pos[2] = {0, 0};
    long bad0, lost0, bad, lost;
    unsigned sent = 0u;
    int k;
    uint16_t tag = 1u;
    can_host_init(&h);
    run_for(b, MS(20));
    can_configure(&h, b, 400u);
    bad0 = can_counter(&h.last, "can_rx_bad_frame");
    lost0 = can_counter(&h.last, "can_rx_lost");
    board_sim_can_stats(b, &s0);
    for (k = 0; k < 3; k++) {
        int32_t dl = steps[k][0] - pos[0], dr = steps[k][1] - pos[1];
        uint32_t n = (uint32_t)((labs(dl) > labs(dr)) ? labs(dl) : labs(dr));
        uint64_t until = board_sim_cycles(b) + (uint64_t)n * BOARD_SIM_ENC_MIN_EDGE_CYCLES;
        board_sim_set_encoders(b, steps[k][0], steps[k][1], until);
        while (board_sim_cycles(b) < until) {
            board_sim_can_write(b, NAVKIT_CAN_ID_MICRO_CMD, junk, 8u);
            board_sim_can_write(b, NAVKIT_CAN_ID_MICRO_CMD, junk, 8u);
            sent += 2u;
            can_run(&h, b, CAN_ENC_GAP_CYCLES);
        }
        pos[0] = steps[k][0];
        pos[1] = steps[k][1];
        can_run(&h, b, MS(20));
        can_ping(&h, b, tag++);
        check(h.last.enc_left == pos[0] && h.last.enc_right == pos[1], "CAN encoders: counts %ld/%ld, want %ld/%ld",
              (long)h.last.enc_left, (long)h.last.enc_right, (long)pos[0], (long)pos[1]);
        printf("CAN image, encoders at %u edges/s each under CAN frames: %ld/%ld (want %ld/%ld)\n",
               F_CPU_HZ / BOARD_SIM_ENC_MIN_EDGE_CYCLES, (long)h.last.enc_left, (long)h.last.enc_right, (long)pos[0],
               (long)pos[1]);
    }
    board_sim_can_stats(b, &s1);
    bad = can_counter(&h.last, "can_rx_bad_frame") - bad0;
    lost = can_counter(&h.last, "can_rx_lost") - lost0;
    check(h.last.ack_time_tag == (uint16_t)(tag - 1u), "the last ping was not acknowledged");
    check(s1.overflowed == s0.overflowed, "%lu frames found the part's buffers full",
          (unsigned long)(s1.overflowed - s0.overflowed));
    check(bad0 < 0 || (bad == (long)sent && lost == 0), "the link saw %ld of %u frames, %ld lost", bad, sent, lost);
    printf("bus: %u frames sent, %lu to the part in all; can_rx_bad_frame +%ld, can_rx_lost +%ld (-1: not in this "
           "spec)\n",
           sent, (unsigned long)(s1.to_part - s0.to_part), bad0 < 0 ? -1L : bad, lost0 < 0 ? -1L : lost);
    board_sim_free(b);
}

int main(int argc, char **argv)
{
    static const struct {
        const char *name;
        void (*fn)(void);
    } tests[] = {{"link", test_link},
                 {"uart", test_uart},
                 {"encoders", test_encoders},
                 {"outputs", test_outputs},
                 {"inputs", test_inputs},
                 {"tick_rate", test_tick_rate},
                 {"watchdog", test_watchdog},
                 {"footprint", test_footprint},
                 {"tick_late", test_tick_late},
                 {"can_link", test_can_link},
                 {"can_filter", test_can_filter},
                 {"can_lost", test_can_lost},
                 {"can_rx_lost", test_can_rx_lost},
                 {"can_late", test_can_late},
                 {"can_encoders", test_can_encoders}};
    size_t i;
    if (argc != 3) {
        fprintf(stderr, "usage: %s TEST IMAGE_DIR\n", argv[0]);
        return 2;
    }
    image_dir = argv[2];
    for (i = 0u; i < sizeof tests / sizeof tests[0]; i++) {
        if (strcmp(argv[1], tests[i].name) == 0) {
            tests[i].fn();
            if (failures != 0) {
                fprintf(stderr, "%s: %d check(s) failed\n", argv[1], failures);
                return 1;
            }
            printf("%s: ok\n", argv[1]);
            return 0;
        }
    }
    fprintf(stderr, "%s: unknown test '%s'\n", argv[0], argv[1]);
    return 2;
}
