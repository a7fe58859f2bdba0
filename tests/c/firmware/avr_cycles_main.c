/* Cycle counts of fw_tick() and fw_link_poll() and the deepest stack on an ATmega2560 at
 * 16 MHz, run in simavr by avr_size.cmake (MODE=cycles). Timer 1 counts CPU clocks; the
 * wires are stubs and a crude plant moves the encoders with the duty and the gyro with
 * the wheel difference.
 *
 * Scenarios, 2000 ticks each after the three configs and 1100 ticks of gyro calibration:
 *   fwd_turn at 400 Hz:   a forward move and an encoder turn at once (both axes busy, both
 *                         braking before the end: the braking curve is an axis's dearest step);
 *   fwd_hdgsel at 400 Hz: a forward move and HdgSel with compass fusion (compass_weight 500).
 * 400 Hz is this build's ceiling (avr_size.cmake compiles it with CONFIG_RATE_MAX=400, as
 * an AVR target would: every tick re-plans both axes in float, which a 16 MHz AVR cannot
 * do in 1 ms); a geometry config above it must be refused, one at it accepted.
 * A micro_cmd arrives through the UART stub every 100 ticks (a start, then modifies of
 * the forward move), so fw_link_poll() decodes it and encodes a micro_data reply (the
 * deepest call chain).
 *
 * The link poll is timed whole, and its parts on the same bytes: frame parsing (with the
 * CRC) in the poll's chunks (LINK_RX_CHUNK bytes, link.h), decoding, the micro_cmd range
 * check, the telemetry snapshot (link_telemetry()) and encoding the reply; the rest is
 * applying the frame plus the UART stub calls and the loop around them. Parsing,
 * decoding, checking and encoding touch only the link's own buffers; applying and the
 * snapshot touch the state the tick uses (docs/firmware.md, AVR budget: how the AVR
 * target runs the two).
 *
 * Printed on UART0 (simavr shows it), parsed by avr_size.cmake:
 *   tick <scenario> <rate> Hz: mean M max X period P fold F xy Y plain Z (P = 16 MHz / rate;
 *     F, Y, Z the worst of the ticks with the heading fold, with the X/Y step, and of the
 *     others: the slow steps of fw.c)
 *   <scenario> <rate> Hz configured: 1 moved: N turned: D (counts, heading deg*10)
 *   ceiling <CONFIG_RATE_MAX> Hz: reset at it T above refused R at accepted A (1 = as it must be)
 *   poll <frame>: max P parse A decode B check C snapshot T encode E rest R snapshot_max S
 *     (the parts of the worst poll P: A + B + C + T + E + R = P; S the largest snapshot
 *     of any poll, the part a pre-empting tick would have to wait for)
 *   heading: update U fold F fuse S (worst cycles of heading_update(), heading_fold(),
 *     heading_fuse() with its fold)
 *   stack bytes: S */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdio.h>

#include "fw.h"

/* mm: the forward move, short enough that it brakes to a stop within the 2 s (300 mm/s,
   300 mm/s^2: 1 s up, 1 s down): the braking curve is the axis's dearest step */
#define FWD_MM 300
#define F_CPU_HZ 16000000ul
/* gyro LSB per count of (right - left) wheel difference in one tick of 1 ms, default
   geometry: 0.157 mm/count over a 300 mm track is 0.030 deg, i.e. 30 deg/s, times 131 LSB
   per deg/s */
#define GYRO_LSB_PER_DIFF_1KHZ 3930L

struct hal {
    int32_t enc_l, enc_r;
    int16_t gyro;
    int16_t gyro_per_diff;  /* LSB per count of wheel difference in one tick */
    int16_t duty_per_count; /* hal_motor units per count moved in one tick */
    int16_t diff_max;       /* counts of wheel difference in one tick above which the gyro saturates */
    uint16_t compass;
    uint8_t rx[4u * NAVKIT_MAX_FRAME_BYTES]; /* frames waiting for fw_link_poll() */
    uint16_t rx_len, rx_pos;
};

extern uint8_t __heap_start; /* first byte above .data/.bss (avr-libc linker symbol) */
#define STACK_PAINT 0xA5u

static struct hal board;
static fw_t fw;

int32_t hal_enc_left(hal_t *h)
{
    return h->enc_l;
}
int32_t hal_enc_right(hal_t *h)
{
    return h->enc_r;
}
int16_t hal_gyro_raw(hal_t *h)
{
    return h->gyro;
}
uint16_t hal_compass(hal_t *h)
{
    return h->compass;
}
uint16_t hal_adc(hal_t *h, uint8_t ch)
{
    (void)h;
    return ch;
}
uint16_t hal_sonar_echo(hal_t *h, uint8_t i)
{
    (void)h;
    return i;
}
uint16_t hal_dio_in(hal_t *h)
{
    (void)h;
    return 0u;
}
uint8_t hal_reset_cause(hal_t *h)
{
    (void)h;
    return NAVKIT_RESET_CAUSE_POWER_ON;
}
void hal_motor(hal_t *h, int16_t l, int16_t r)
{
    int16_t dl = (int16_t)(l / h->duty_per_count), dr = (int16_t)(r / h->duty_per_count); /* counts this tick */
    int16_t diff = (int16_t)(dr - dl);
    h->enc_l += dl;
    h->enc_r += dr;
    /* counter-clockwise positive: the right wheel ahead turns the robot left */
    h->gyro = (int16_t)((diff > h->diff_max) ? 32000 : (diff < -h->diff_max) ? -32000 : diff * h->gyro_per_diff);
}
void hal_servo_pulse(hal_t *h, uint8_t i, uint16_t us)
{
    (void)h, (void)i, (void)us;
}
void hal_dio_write(hal_t *h, uint16_t dir, uint16_t out)
{
    (void)h, (void)dir, (void)out;
}
size_t hal_uart_read(hal_t *h, uint8_t *buf, size_t cap)
{
    size_t n = 0u;
    while (n < cap && h->rx_pos < h->rx_len) {
        buf[n++] = h->rx[h->rx_pos++];
    }
    return n;
}
size_t hal_uart_tx_free(hal_t *h)
{
    (void)h;
    return 1024u;
}
void hal_uart_write(hal_t *h, const uint8_t *buf, size_t len)
{
    (void)h, (void)buf, (void)len;
}

static int uart_put(char c, FILE *f)
{
    (void)f;
    while (!(UCSR0A & (1 << UDRE0))) {
    }
    UDR0 = (uint8_t)c;
    return 0;
}
static FILE uart = FDEV_SETUP_STREAM(uart_put, NULL, _FDEV_SETUP_WRITE);

/* Per frame kind, the worst poll and its parts as measured with it: parsing, decoding,
   checking, snapshot, encoding, and the rest (applying + glue), which add up to it; and
   the largest snapshot of any poll. */
typedef struct {
    const char *name;
    uint16_t poll, parse, decode, check, snapshot, encode, rest, snapshot_max;
} poll_cost_t;

static poll_cost_t cost_cmd = {"micro_cmd", 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};
static poll_cost_t cost_cfg = {"micro_cfg", 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};

/* the probes' own state, static so it neither counts as core RAM nor deepens the stack */
static navkit_parser_t probe_parser;
static union {
    navkit_micro_cmd_t cmd;
    navkit_micro_cfg_geometry_t geo;
    navkit_micro_cfg_motion_t mot;
    navkit_micro_cfg_io_t io;
} probe_msg;
static navkit_micro_data_t probe_data;
static poll_cost_t probe_cost; /* this poll and its parts */
static uint8_t probe_buf[NAVKIT_MICRO_DATA_BYTES];

static uint16_t max16(uint16_t a, uint16_t b)
{
    return (a > b) ? a : b;
}

/* The heading's three steps, worst cycles each over the whole run: heading_update() (the
   gyro integration of every tick, moving or standing still), heading_fold() and
   heading_fuse() (compass fusion, its fold included), timed on copies of the state the
   next tick starts from, so the run itself is not changed. */
static struct {
    uint16_t update, fold, fuse;
} cost_hdg;
static heading_t probe_hdg;

static void heading_timed(void)
{
    uint16_t t0, dt;
    uint8_t still;
    for (still = 0u; still < 2u; still++) {
        probe_hdg = fw.hdg;
        t0 = TCNT1;
        heading_update(&probe_hdg, board.gyro, fw.cfg.gyro_dps_per_lsb, still, fw.cfg.control_rate, fw.cfg.dt);
        dt = (uint16_t)(TCNT1 - t0);
        cost_hdg.update = max16(cost_hdg.update, dt);
    }
    probe_hdg = fw.hdg;
    t0 = TCNT1;
    heading_fold(&probe_hdg);
    dt = (uint16_t)(TCNT1 - t0);
    cost_hdg.fold = max16(cost_hdg.fold, dt);
    probe_hdg = fw.hdg;
    t0 = TCNT1;
    heading_fuse(&probe_hdg, board.compass, 0.5f, fw.cfg.dt_fold); /* gain 1/s: compass_weight 500 */
    dt = (uint16_t)(TCNT1 - t0);
    cost_hdg.fuse = max16(cost_hdg.fuse, dt);
}

/* Hand the one queued frame to fw_link_poll() and time it against its parts, measured on
   the same bytes: before the poll, parsing in the poll's chunks, decoding, and for a
   micro_cmd its range check; after it, a telemetry snapshot and its encoding (as the
   reply's, in the same state). */
static void poll_timed(poll_cost_t *c)
{
    const uint8_t *frame = NULL;
    size_t flen = 0u;
    uint16_t off, n, t0, type;
    int got = 0;
    navkit_parser_init(&probe_parser, NAVKIT_DIR_TO_MICRO);
    t0 = TCNT1;
    for (off = 0u; off < board.rx_len; off = (uint16_t)(off + n)) {
        n = (uint16_t)((board.rx_len - off < LINK_RX_CHUNK) ? board.rx_len - off : LINK_RX_CHUNK);
        (void)navkit_parser_feed(&probe_parser, board.rx + off, n);
        got |= navkit_parser_next(&probe_parser, &frame, &flen);
    }
    probe_cost.parse = (uint16_t)(TCNT1 - t0);
    type = got ? navkit_frame_type(frame) : 0u;
    t0 = TCNT1;
    switch (type) {
    case NAVKIT_MSG_TYPE_MICRO_CMD:
        (void)navkit_micro_cmd_decode(frame, flen, &probe_msg.cmd);
        break;
    case NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY:
        (void)navkit_micro_cfg_geometry_decode(frame, flen, &probe_msg.geo);
        break;
    case NAVKIT_MSG_TYPE_MICRO_CFG_MOTION:
        (void)navkit_micro_cfg_motion_decode(frame, flen, &probe_msg.mot);
        break;
    default:
        (void)navkit_micro_cfg_io_decode(frame, flen, &probe_msg.io);
        break;
    }
    probe_cost.decode = (uint16_t)(TCNT1 - t0);
    probe_cost.check = 0u;
    if (type == NAVKIT_MSG_TYPE_MICRO_CMD) {
        t0 = TCNT1;
        (void)navkit_micro_cmd_check(&probe_msg.cmd, NULL);
        probe_cost.check = (uint16_t)(TCNT1 - t0);
    }
    t0 = TCNT1;
    fw_link_poll(&fw);
    probe_cost.poll = (uint16_t)(TCNT1 - t0);
    t0 = TCNT1;
    link_telemetry(&fw, &probe_data);
    probe_cost.snapshot = (uint16_t)(TCNT1 - t0);
    t0 = TCNT1;
    (void)navkit_micro_data_encode(&probe_data, probe_buf, sizeof probe_buf);
    probe_cost.encode = (uint16_t)(TCNT1 - t0);
    if (!got) {
        printf("no frame in the probe's parser\n");
        return;
    }
    c->snapshot_max = max16(c->snapshot_max, probe_cost.snapshot);
    if (probe_cost.poll > c->poll) { /* the worst poll so far: its own parts, which add up to it */
        probe_cost.rest = (uint16_t)(probe_cost.poll - probe_cost.parse - probe_cost.decode - probe_cost.check -
                                     probe_cost.snapshot - probe_cost.encode);
        probe_cost.name = c->name;
        probe_cost.snapshot_max = c->snapshot_max;
        *c = probe_cost;
    }
}

static void print_cost(const poll_cost_t *c)
{
    printf("poll %s: max %u parse %u decode %u check %u snapshot %u encode %u rest %u snapshot_max %u\n", c->name,
           c->poll, c->parse, c->decode, c->check, c->snapshot, c->encode, c->rest, c->snapshot_max);
}

/* Queue one encoded frame of n bytes (already written at rx + rx_len) for the UART stub. */
static void queue(uint16_t n)
{
    board.rx_len = (uint16_t)(board.rx_len + n);
}

static void queue_reset(void)
{
    board.rx_pos = board.rx_len = 0u;
}

/* 1 in the excitation scenario: send_cmd() sends a chirp on both wheels instead of the
   start (duty 0.3 +/- 0.3, so the wheels move forward, 0.5 -> 20 Hz over 6 s, longer than
   the run) and neutral commands (fwd_cmd and turn_cmd 0: the chirp goes on) instead of the
   modifies, with the "wheels" datalog selection. */
static uint8_t excite_scenario;

/* Queue a micro_cmd: forward FWD_MM with fwd_code (1 = start, 3 = modify), and turn_code
   with turn_distance (deg*10: encoder turn 1, HdgSel 10 heading, 0 none). */
static void send_cmd(uint16_t tag, uint16_t fwd_code, uint16_t turn_code, int16_t turn_distance)
{
    navkit_micro_cmd_t c;
    navkit_micro_cmd_defaults(&c);
    c.time_tag = tag;
    c.fwd_cmd = fwd_code;
    c.speed = 300;
    c.distance = FWD_MM;
    c.turn_cmd = turn_code;
    c.turn_rate = 450;
    c.turn_distance = turn_distance;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_TURN_PROFILE;
    if (excite_scenario) {
        c.excite_mode = (fwd_code == NAVKIT_FWD_CMD_START) ? NAVKIT_EXCITE_MODE_CHIRP : NAVKIT_EXCITE_MODE_NONE;
        c.fwd_cmd = NAVKIT_FWD_CMD_NONE;
        c.turn_cmd = NAVKIT_TURN_CMD_NONE;
        c.excite_wheels = NAVKIT_EXCITE_WHEELS_BOTH;
        c.excite_amplitude = 300;
        c.excite_offset = 300;
        c.excite_duration = 6000u;
        c.excite_f0 = 50u;
        c.excite_f1 = 2000u;
        c.mc_datalog_cmd = NAVKIT_MC_DATALOG_WHEELS;
    }
    queue_reset();
    queue((uint16_t)navkit_micro_cmd_encode(&c, board.rx, sizeof board.rx));
}

/* Put one encoded frame of len bytes (in board.rx) on the UART and poll it, timed as a config. */
static void poll_cfg(int len)
{
    queue_reset();
    queue((uint16_t)len);
    poll_timed(&cost_cfg);
}

/* Reset, then the three configs, one poll each (compass_weight: 1/1000 per s, rate: Hz),
   then 1100 ticks at rest (the gyro calibration takes 1 s). */
static void configure(uint16_t compass_weight, uint16_t rate)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    uint16_t i;
    fw_init(&fw, &board);
    board.enc_l = board.enc_r = 0;
    board.gyro = 0;
    /* the same plant at any rate: counts per tick and the gyro's LSB per count scale with
       the tick (a duty of 1 is 5 counts a tick at 1 kHz, 0.8 m/s) */
    board.gyro_per_diff = (int16_t)(GYRO_LSB_PER_DIFF_1KHZ * 1000L / (long)rate);
    board.duty_per_count = (int16_t)(2000L * (long)rate / 1000L);
    board.diff_max = (int16_t)(4000L / (long)rate);
    navkit_micro_cfg_geometry_defaults(&g);
    navkit_micro_cfg_motion_defaults(&m);
    navkit_micro_cfg_io_defaults(&io);
    g.compass_weight = compass_weight;
    g.control_rate = rate;
    m.wheel_kd = 10; /* 1e-5 duty/(mm/s^2): the budget covers the wheel loops' derivative term */
    poll_cfg(navkit_micro_cfg_geometry_encode(&g, board.rx, sizeof board.rx));
    poll_cfg(navkit_micro_cfg_motion_encode(&m, board.rx, sizeof board.rx));
    poll_cfg(navkit_micro_cfg_io_encode(&io, board.rx, sizeof board.rx));
    for (i = 0u; i < 1100u; i++) {
        fw_tick(&fw);
    }
}

/* 2000 ticks at rate (Hz) with a micro_cmd every 100 (turn_code/turn_distance with the
   first, forward modifies after it); prints the tick's cycles as a "tick" line that
   avr_size.cmake checks against the budget. */
static void run(const char *name, uint16_t rate, uint16_t turn_code, int16_t turn_distance)
{
    uint16_t i, t0, dt, max = 0u, kind_max[3] = {0u, 0u, 0u}; /* fold, X/Y, plain */
    uint32_t sum = 0u;
    uint8_t kind, xy_n;
    for (i = 0u; i < 2000u; i++) {
        if (i % 100u == 0u) {
            if (i == 0u) {
                send_cmd(1u, NAVKIT_FWD_CMD_START, turn_code, turn_distance);
            } else {
                send_cmd((uint16_t)(1u + i / 100u), NAVKIT_FWD_CMD_MODIFY, NAVKIT_TURN_CMD_NONE, 0);
            }
            poll_timed(&cost_cmd);
        }
        board.gyro = (int16_t)(board.gyro + (int16_t)(i & 7u)); /* noise */
        heading_timed();
        kind = (uint8_t)((fw.slow_tick == 0u) ? 0u : 2u);
        xy_n = fw.odom.xy_n;
        t0 = TCNT1;
        fw_tick(&fw);
        dt = (uint16_t)(TCNT1 - t0);
        if (kind == 2u && xy_n + 1u >= fw.cfg.odom.xy_ticks && fw.odom.xy_n == 0u) {
            kind = 1u; /* the X/Y step ran (it zeroes xy_n) */
        }
        sum += dt;
        max = max16(max, dt);
        kind_max[kind] = max16(kind_max[kind], dt);
    }
    printf("tick %s %u Hz: mean %lu max %u period %lu fold %u xy %u plain %u\n", name, rate,
           (unsigned long)(sum / 2000u), max, F_CPU_HZ / rate, kind_max[0], kind_max[1], kind_max[2]);
    printf("%s %u Hz configured: %u moved: %ld turned: %u\n", name, rate,
           (unsigned)((fw_status(&fw) & NAVKIT_MICRO_STATUS_CONFIGURED) != 0u), (long)board.enc_l,
           heading_deg10(&fw.hdg));
}

/* After a reset the firmware ticks at CONFIG_RATE_MAX (the spec's default 1 kHz capped);
   a micro_cfg_geometry with control_rate one above it must be refused whole (not received,
   the rate unchanged, last_reject = range | its type), then one at it accepted. */
static void check_ceiling(void)
{
    navkit_micro_cfg_geometry_t g;
    uint8_t reset_ok, refused, accepted;
    fw_init(&fw, &board);
    reset_ok = (uint8_t)(fw.cfg.control_rate == CONFIG_RATE_MAX &&
                         fw_tick_period_us(&fw) == (1000000ul + CONFIG_RATE_MAX / 2u) / CONFIG_RATE_MAX);
    navkit_micro_cfg_geometry_defaults(&g);
    g.control_rate = (uint16_t)(CONFIG_RATE_MAX + 1u);
    poll_cfg(navkit_micro_cfg_geometry_encode(&g, board.rx, sizeof board.rx));
    refused = (uint8_t)((fw.cfg.received & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK) == 0u &&
                        fw.cfg.control_rate == CONFIG_RATE_MAX &&
                        fw.link.last_reject == (NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY));
    g.control_rate = CONFIG_RATE_MAX;
    poll_cfg(navkit_micro_cfg_geometry_encode(&g, board.rx, sizeof board.rx));
    accepted = (uint8_t)((fw.cfg.received & NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK) != 0u &&
                         fw.cfg.control_rate == CONFIG_RATE_MAX);
    printf("ceiling %u Hz: reset at it %u above refused %u at accepted %u\n", (unsigned)CONFIG_RATE_MAX, reset_ok,
           refused, accepted);
}

int main(void)
{
    uint8_t *p;
    /* paint the free RAM between .bss and this frame; what is not paint later was stack */
    for (p = &__heap_start; p < (uint8_t *)SP - 32; p++) {
        *p = STACK_PAINT;
    }
    UCSR0B = (1 << TXEN0);
    stdout = &uart;
    TCCR1B = 1; /* timer 1 at the CPU clock */

    board.compass = 0u;
    configure(0u, 400u);
    run("fwd_turn", 400u, NAVKIT_TURN_CMD_TURN, 450); /* turn 45 deg clockwise: done in ~1.5 s */
    board.compass = 100u;                             /* 10 deg: fusion has an error to pull */
    configure(500u, 400u);
    run("fwd_hdgsel", 400u, NAVKIT_TURN_CMD_HDG_SEL, 450); /* HdgSel 45 deg */
    board.compass = 0u;
    configure(0u, 400u);
    excite_scenario = 1u;
    run("excite_chirp", 400u, NAVKIT_TURN_CMD_NONE, 0); /* open loop: the wheel loops idle */
    excite_scenario = 0u;
    check_ceiling();

    for (p = &__heap_start; *p == STACK_PAINT; p++) {
    }
    print_cost(&cost_cmd);
    print_cost(&cost_cfg);
    printf("heading: update %u fold %u fuse %u\n", cost_hdg.update, cost_hdg.fold, cost_hdg.fuse);
    printf("stack bytes: %u\n", (unsigned)((uint8_t *)RAMEND + 1 - p));
    cli();
    sleep_mode(); /* simavr ends the run here */
    return 0;
}
