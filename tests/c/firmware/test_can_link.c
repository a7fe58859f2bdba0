/* The firmware core built with the CAN link (FW_LINK_CAN = 1): a host made of navkit_isotp's
 * sender (and a plain reassembly of micro_data) talks to fw_link_poll() through CAN frame
 * queues in a fake hal. The configs and a micro_cmd go in as ISO-TP messages, micro_data
 * comes back as one; a lost consecutive frame costs that message only (counted by ISO-TP,
 * never seen by the frame parser); a full TX queue delays frames, never breaks them; each kind
 * of ISO-TP refusal or abort, made once, moves its own micro_data counter (can_rx_*,
 * can_tx_*) by one and no other. */
#include <string.h>

#include "check.h"
#include "fw.h"

#define QUEUE 512

typedef struct {
    uint16_t id;
    uint8_t dlc;
    uint8_t data[8];
} qframe_t;

struct hal {
    qframe_t to_micro[QUEUE];
    int to_micro_len, to_micro_pos;
    qframe_t from_micro[QUEUE];
    int from_micro_len;
    uint8_t tx_room; /* frames the micro's TX queue takes per poll */
    uint8_t tx_used;
    uint16_t rx_lost; /* frames the "controller" lost: hal_can_rx_lost() */
};

int32_t hal_enc_left(hal_t *hal)
{
    (void)hal;
    return 0;
}
int32_t hal_enc_right(hal_t *hal)
{
    (void)hal;
    return 0;
}
int16_t hal_gyro_raw(hal_t *hal)
{
    (void)hal;
    return 0;
}
uint16_t hal_compass(hal_t *hal)
{
    (void)hal;
    return 0u;
}
uint16_t hal_adc(hal_t *hal, uint8_t ch)
{
    (void)hal;
    return (uint16_t)(100u + ch);
}
uint16_t hal_sonar_echo(hal_t *hal, uint8_t i)
{
    (void)hal;
    (void)i;
    return 0u;
}
uint16_t hal_dio_in(hal_t *hal)
{
    (void)hal;
    return 0u;
}
uint8_t hal_reset_cause(hal_t *hal)
{
    (void)hal;
    return NAVKIT_RESET_CAUSE_POWER_ON;
}
void hal_motor(hal_t *hal, int16_t l, int16_t r)
{
    (void)hal;
    (void)l;
    (void)r;
}
void hal_servo_pulse(hal_t *hal, uint8_t i, uint16_t us)
{
    (void)hal;
    (void)i;
    (void)us;
}
void hal_dio_write(hal_t *hal, uint16_t dir, uint16_t out)
{
    (void)hal;
    (void)dir;
    (void)out;
}

uint8_t hal_can_read(hal_t *hal, uint16_t *id, uint8_t data[8], uint8_t *dlc)
{
    qframe_t *f;
    if (hal->to_micro_pos >= hal->to_micro_len) {
        hal->to_micro_pos = hal->to_micro_len = 0;
        return 0u;
    }
    f = &hal->to_micro[hal->to_micro_pos++];
    *id = f->id;
    *dlc = f->dlc;
    memcpy(data, f->data, 8u);
    return 1u;
}
uint8_t hal_can_tx_free(hal_t *hal)
{
    return (uint8_t)(hal->tx_room - hal->tx_used);
}
void hal_can_write(hal_t *hal, uint16_t id, const uint8_t data[8])
{
    qframe_t *f = &hal->from_micro[hal->from_micro_len++];
    f->id = id;
    f->dlc = 8u;
    memcpy(f->data, data, 8u);
    hal->tx_used++;
}
uint16_t hal_can_rx_lost(hal_t *hal)
{
    return hal->rx_lost;
}

static fw_t fw;
static struct hal board;
static navkit_isotp_tx_t host_tx; /* the host's sender */
static uint8_t data_buf[NAVKIT_MICRO_DATA_BYTES];
static uint16_t data_have, data_want;
static int data_count; /* micro_data frames reassembled */
static navkit_micro_data_t last_data;

/* The flow control the host answers a micro_data's first frame with. */
enum { FC_CONTINUE, FC_NONE, FC_WAIT_THEN_CONTINUE, FC_OVERFLOW, FC_INVALID };
static int host_fc = FC_CONTINUE;

/* A frame of dlc data bytes (0..8; the rest of the record zero) into the micro's RX queue. */
static void to_micro_dlc(uint16_t id, const uint8_t *data, uint8_t dlc)
{
    qframe_t *f = &board.to_micro[board.to_micro_len++];
    f->id = id;
    f->dlc = dlc;
    memset(f->data, 0, 8u);
    memcpy(f->data, data, dlc);
}

static void to_micro(uint16_t id, const uint8_t *data)
{
    to_micro_dlc(id, data, 8u);
}

/* A flow control of status (0 continue, 1 wait, 2 overflow, 3-15 invalid) for micro_data. */
static void host_flow(uint8_t status)
{
    const uint8_t fc[8] = {(uint8_t)(0x30u | status), 0, 0, 0xCC, 0xCC, 0xCC, 0xCC, 0xCC};
    to_micro(NAVKIT_CAN_FC_ID_MICRO_DATA, fc);
}

/* The host's side of micro_data: flow control after the first frame, plain reassembly. */
static void host_take(const qframe_t *f)
{
    navkit_isotp_tx_frame(&host_tx, f->id, f->data, f->dlc, fw.ms);
    if (f->id != NAVKIT_CAN_ID_MICRO_DATA) {
        return;
    }
    if ((f->data[0] >> 4) == 1u) {
        data_want = (uint16_t)(((f->data[0] & 0x0Fu) << 8) | f->data[1]);
        memcpy(data_buf, f->data + 2, 6u);
        data_have = 6u;
        switch (host_fc) {
        case FC_CONTINUE:
            host_flow(0u);
            break;
        case FC_WAIT_THEN_CONTINUE:
            host_flow(1u);
            host_flow(0u);
            break;
        case FC_OVERFLOW:
            host_flow(2u);
            break;
        case FC_INVALID:
            host_flow(5u);
            break;
        default:
            break; /* FC_NONE: the micro's sender waits N_Bs, then abandons */
        }
    } else if ((f->data[0] >> 4) == 2u && data_have > 0u) {
        uint16_t left = (uint16_t)(data_want - data_have);
        uint16_t n = (left > 7u) ? 7u : left;
        CHECK((f->data[0] & 0x0Fu) == (uint16_t)((data_have - 6u) / 7u + 1u) % 16u);
        memcpy(data_buf + data_have, f->data + 1, n);
        data_have = (uint16_t)(data_have + n);
        if (data_have == data_want) {
            CHECK(navkit_micro_data_decode(data_buf, data_have, &last_data) == NAVKIT_OK);
            data_count++;
            data_have = 0u;
        }
    }
}

/* ms of link polls and ticks; `drop` > 0 drops that frame (1-based) of the host's next message. */
static void run(int ms, int drop)
{
    int i, k, sent = 0;
    navkit_isotp_frame_t f;
    for (i = 0; i < ms; i++) {
        while (navkit_isotp_tx_next(&host_tx, fw.ms, &f)) {
            if (++sent != drop) {
                to_micro(f.id, f.data);
            }
        }
        board.tx_used = 0u;
        fw_link_poll(&fw);
        for (k = 0; k < board.from_micro_len; k++) {
            host_take(&board.from_micro[k]);
        }
        board.from_micro_len = 0;
        fw_tick(&fw);
    }
}

static void host_send(const uint8_t *frame, size_t len, int drop)
{
    memcpy(host_tx.buf, frame, len);
    CHECK(navkit_isotp_tx_start(&host_tx, (uint16_t)len, navkit_frame_type(frame), fw.ms));
    run(20, drop);
}

static void configure(void)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    navkit_micro_cfg_geometry_defaults(&g);
    navkit_micro_cfg_motion_defaults(&m);
    navkit_micro_cfg_io_defaults(&io);
    g.time_tag = 1u;
    m.time_tag = 2u;
    io.time_tag = 3u;
    host_send(buf, navkit_micro_cfg_geometry_encode(&g, buf, sizeof buf), 0);
    host_send(buf, navkit_micro_cfg_motion_encode(&m, buf, sizeof buf), 0);
    host_send(buf, navkit_micro_cfg_io_encode(&io, buf, sizeof buf), 0);
}

static void send_cmd(uint16_t tag, int drop)
{
    navkit_micro_cmd_t c;
    uint8_t buf[NAVKIT_MICRO_CMD_BYTES];
    memset(&c, 0, sizeof c);
    c.msg_type = NAVKIT_MSG_TYPE_MICRO_CMD;
    c.time_tag = tag;
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 200;
    c.distance = 1000;
    host_send(buf, navkit_micro_cmd_encode(&c, buf, sizeof buf), drop);
}

/* The CAN counters of micro_data, in the spec's order. */
enum {
    C_BAD_FRAME,
    C_WRONG_SN,
    C_UNEXPECTED,
    C_RESTARTED,
    C_RX_TIMEOUT,
    C_RX_OVERFLOW,
    C_TX_TIMEOUT,
    C_TX_OVERFLOW,
    C_TX_BAD_FC,
    C_TX_WAIT,
    C_RX_LOST,
    C_COUNT
};

static void can_counters(const navkit_micro_data_t *d, uint16_t c[C_COUNT])
{
    c[C_BAD_FRAME] = d->can_rx_bad_frame;
    c[C_WRONG_SN] = d->can_rx_wrong_sn;
    c[C_UNEXPECTED] = d->can_rx_unexpected;
    c[C_RESTARTED] = d->can_rx_restarted;
    c[C_RX_TIMEOUT] = d->can_rx_timeout;
    c[C_RX_OVERFLOW] = d->can_rx_overflow;
    c[C_TX_TIMEOUT] = d->can_tx_timeout;
    c[C_TX_OVERFLOW] = d->can_tx_overflow;
    c[C_TX_BAD_FC] = d->can_tx_bad_fc;
    c[C_TX_WAIT] = d->can_tx_wait;
    c[C_RX_LOST] = d->can_rx_lost;
}

/* The micro_data answering the next whole command (time tag *tag, then + 1) carries counter
   `which` one above `before` and every other as in `before`; `before` becomes it. */
static void expect_one_more(uint16_t before[C_COUNT], int which, uint16_t *tag)
{
    uint16_t now[C_COUNT];
    int k, n = data_count;
    send_cmd(*tag, 0);
    CHECK(data_count == n + 1 && last_data.ack_time_tag == *tag);
    ++*tag;
    can_counters(&last_data, now);
    for (k = 0; k < C_COUNT; k++) {
        if ((uint16_t)(before[k] + (k == which)) != now[k]) {
            fprintf(stderr, "counter %d: %u before, %u now (expected to move: %d)\n", k, before[k], now[k], which);
            check_failures++;
        }
        before[k] = now[k];
    }
}

/* Each refusal and abort kind, made once on the bus, counted once in micro_data. */
static void test_each_kind_counted_once(uint16_t tag)
{
    /* a micro_cmd's first frame (116 bytes) and frames of its reception */
    static const uint8_t ff[8] = {0x10, 0x74, 0xA5, 0xFF, 0x07, 0x00, 0x01, 0x00};
    static const uint8_t cf2[8] = {0x22, 0, 0, 0, 0, 0, 0, 0};
    static const uint8_t cf1[8] = {0x21, 0, 0, 0, 0, 0, 0, 0};
    static const uint8_t sf[8] = {0x03, 0xA5, 0xFF, 0x01, 0xCC, 0xCC, 0xCC, 0xCC};
    static const uint8_t ff_long[8] = {0x1F, 0xFF, 0xA5, 0xFF, 0x07, 0x00, 0x01, 0x00};
    uint16_t c[C_COUNT];
    can_counters(&last_data, c);
    to_micro_dlc(NAVKIT_CAN_ID_MICRO_CMD, sf, 5u); /* short: fewer than 8 data bytes */
    run(2, 0);
    expect_one_more(c, C_BAD_FRAME, &tag);
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, ff); /* consecutive frame 2 where 1 was due */
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, cf2);
    run(2, 0);
    expect_one_more(c, C_WRONG_SN, &tag);
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, cf1); /* a consecutive frame with no message in progress */
    run(2, 0);
    expect_one_more(c, C_UNEXPECTED, &tag);
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, ff); /* a single frame during a reception: it starts anew */
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, sf);
    run(2, 0);
    expect_one_more(c, C_RESTARTED, &tag);
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, ff); /* no consecutive frame within N_Cr */
    run((int)NAVKIT_CAN_N_CR_MS + 10, 0);
    expect_one_more(c, C_RX_TIMEOUT, &tag);
    to_micro(NAVKIT_CAN_ID_MICRO_CMD, ff_long); /* 4095 bytes: more than its buffer */
    run(2, 0);
    CHECK(fw.link.can_rx.stats.overflow == 1u);
    expect_one_more(c, C_RX_OVERFLOW, &tag);
    /* the micro's sender: the host's flow control for the reply to one command */
    host_fc = FC_NONE;
    send_cmd(tag++, 0);
    host_fc = FC_CONTINUE;
    run((int)NAVKIT_CAN_N_BS_MS + 10, 0);
    expect_one_more(c, C_TX_TIMEOUT, &tag);
    host_fc = FC_OVERFLOW;
    send_cmd(tag++, 0);
    host_fc = FC_CONTINUE;
    expect_one_more(c, C_TX_OVERFLOW, &tag);
    host_fc = FC_INVALID;
    send_cmd(tag++, 0);
    host_fc = FC_CONTINUE;
    expect_one_more(c, C_TX_BAD_FC, &tag);
    host_fc = FC_WAIT_THEN_CONTINUE; /* the reply goes whole after the wait */
    send_cmd(tag++, 0);
    host_fc = FC_CONTINUE;
    CHECK(last_data.ack_time_tag == tag - 1u);
    expect_one_more(c, C_TX_WAIT, &tag);
    board.rx_lost++; /* the target's own count of frames lost before the link saw them */
    expect_one_more(c, C_RX_LOST, &tag);
}

int main(void)
{
    board.tx_room = 2u; /* a small TX queue (the MCP2515 has 3 buffers): frames wait, never break */
    fw_init(&fw, &board);
    navkit_isotp_tx_init(&host_tx);
    configure();
    CHECK(data_count == 3);
    CHECK((last_data.status & NAVKIT_MICRO_STATUS_CONFIGURED) != 0u);
    CHECK(last_data.rx_good == 3u && last_data.adc[1] == 101u && last_data.spec_hash == NAVKIT_SPEC_HASH);
    send_cmd(7u, 0);
    CHECK(data_count == 4 && last_data.ack_time_tag == 7u && last_data.rx_good == 4u);
    /* the 5th frame of the next command is lost: ISO-TP aborts it, the parser never sees it */
    send_cmd(8u, 5);
    CHECK(data_count == 4 && fw.link.can_rx.stats.wrong_sn == 1u);
    CHECK(fw.link.can_rx.stats.unexpected > 0u && fw.link.parser.stats.dropped_bytes == 0u);
    send_cmd(9u, 0);
    CHECK(data_count == 5 && last_data.ack_time_tag == 9u && last_data.rx_good == 5u && last_data.rx_bad_crc == 0u);
    CHECK(fw.link.can_rx.stats.good == 5u && host_tx.stats.sent == 6u && fw.link.can_tx.stats.sent == 5u);
    /* a message that is no whole frame (a peer's garbage single frame): the parser counts it as
       dropped bytes, and the next message is judged on its own */
    {
        static const uint8_t sf[8] = {0x03, 0xA5, 0xFF, 0x01, 0xCC, 0xCC, 0xCC, 0xCC};
        to_micro(NAVKIT_CAN_ID_MICRO_CMD, sf);
        run(2, 0);
        CHECK(fw.link.parser.stats.dropped_bytes == 3u);
        send_cmd(10u, 0);
        CHECK(data_count == 6 && last_data.ack_time_tag == 10u);
    }
    test_each_kind_counted_once(11u);
    CHECK_DONE();
}
