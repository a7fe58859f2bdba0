/* navkit_isotp: ISO 15765-2 on classic CAN. See navkit/navkit_isotp.h. */
#include "navkit/navkit_isotp.h"

#define ISOTP_SF 0u /* PCI frame types (high nibble of byte 0) */
#define ISOTP_FF 1u
#define ISOTP_CF 2u
#define ISOTP_FC 3u
#define ISOTP_CONTINUE 0u /* flow statuses (low nibble of a flow control) */
#define ISOTP_WAIT 1u
#define ISOTP_OVERFLOW 2u
#define ISOTP_SF_MAX 7u  /* bytes: the most a single frame carries */
#define ISOTP_FF_DATA 6u /* bytes a first frame carries */
#define ISOTP_CF_DATA 7u /* bytes a consecutive frame carries */

/* 1 if time a is at or after time b on a wrapping ms clock. */
static uint8_t navkit_isotp_after(uint32_t a, uint32_t b)
{
    return (uint8_t)((int32_t)(a - b) >= 0);
}

/* n bytes from src to dst (no <string.h>: the firmware core links this and includes none). */
static void navkit_isotp_copy(uint8_t *dst, const uint8_t *src, uint16_t n)
{
    while (n-- > 0u) {
        *dst++ = *src++;
    }
}

/* A frame on id: data copied (n bytes, at most 8), the rest padded. */
static void navkit_isotp_fill(navkit_isotp_frame_t *f, uint16_t id, const uint8_t *data, uint8_t n)
{
    uint8_t i;
    f->id = id;
    for (i = 0u; i < 8u; i++) {
        f->data[i] = (i < n) ? data[i] : (uint8_t)NAVKIT_CAN_PADDING;
    }
}

static void navkit_isotp_flow(navkit_isotp_frame_t *fc, uint16_t fc_id, uint8_t status)
{
    uint8_t pci[3];
    pci[0] = (uint8_t)((ISOTP_FC << 4) | status);
    pci[1] = (status == ISOTP_CONTINUE) ? (uint8_t)NAVKIT_CAN_FC_BLOCK_SIZE : 0u;
    pci[2] = (status == ISOTP_CONTINUE) ? (uint8_t)NAVKIT_CAN_FC_ST_MIN : 0u;
    navkit_isotp_fill(fc, fc_id, pci, 3u);
}

void navkit_isotp_rx_init(navkit_isotp_rx_t *rx, navkit_dir_t dir)
{
    static const navkit_isotp_rx_stats_t zero = {0u, 0u, 0u, 0u, 0u, 0u, 0u};
    rx->have = 0u;
    rx->want = 0u;
    rx->id = 0u;
    rx->deadline_ms = 0u;
    rx->dir = dir;
    rx->active = 0u;
    rx->sn = 0u;
    rx->block = 0u;
    rx->stats = zero;
}

void navkit_isotp_rx_poll(navkit_isotp_rx_t *rx, uint32_t now_ms)
{
    if (rx->active && !navkit_isotp_after(rx->deadline_ms, now_ms)) {
        rx->active = 0u;
        rx->stats.timeout++;
    }
}

/* A new first or single frame: the message in progress, if any, is abandoned. */
static void navkit_isotp_rx_restart(navkit_isotp_rx_t *rx)
{
    if (rx->active) {
        rx->active = 0u;
        rx->stats.restarted++;
    }
}

uint16_t navkit_isotp_rx_frame(navkit_isotp_rx_t *rx, uint16_t id, const uint8_t *data, uint8_t dlc, uint32_t now_ms,
                               navkit_isotp_frame_t *fc, uint8_t *fc_out)
{
    uint16_t msg_type;
    uint16_t n;
    uint8_t kind;
    *fc_out = 0u;
    navkit_isotp_rx_poll(rx, now_ms);
    msg_type = navkit_can_msg_type((uint16_t)(id & NAVKIT_ISOTP_ID_MASK), rx->dir);
    if (msg_type == 0u) {
        return 0u; /* another node's traffic, or a flow control */
    }
    if ((id & (NAVKIT_ISOTP_EXT | NAVKIT_ISOTP_RTR)) != 0u || dlc != 8u) {
        rx->stats.bad_frame++;
        return 0u;
    }
    id &= NAVKIT_ISOTP_ID_MASK;
    kind = (uint8_t)(data[0] >> 4);
    switch (kind) {
    case ISOTP_SF:
        n = (uint16_t)(data[0] & 0x0Fu);
        if (n < 1u || n > ISOTP_SF_MAX) {
            break;
        }
        navkit_isotp_rx_restart(rx);
        navkit_isotp_copy(rx->buf, data + 1, n);
        rx->have = n;
        rx->stats.good++;
        return n;
    case ISOTP_FF:
        n = (uint16_t)(((uint16_t)(data[0] & 0x0Fu) << 8) | data[1]);
        if (n <= ISOTP_SF_MAX) {
            break;
        }
        navkit_isotp_rx_restart(rx);
        *fc_out = 1u;
        if (n > NAVKIT_ISOTP_MAX_BYTES) {
            rx->stats.overflow++;
            navkit_isotp_flow(fc, navkit_can_id(msg_type, 1), ISOTP_OVERFLOW);
            return 0u;
        }
        navkit_isotp_copy(rx->buf, data + 2, ISOTP_FF_DATA);
        rx->have = ISOTP_FF_DATA;
        rx->want = n;
        rx->id = id;
        rx->sn = 1u;
        rx->block = (uint8_t)NAVKIT_CAN_FC_BLOCK_SIZE;
        rx->active = 1u;
        rx->deadline_ms = now_ms + NAVKIT_CAN_N_CR_MS;
        navkit_isotp_flow(fc, navkit_can_id(msg_type, 1), ISOTP_CONTINUE);
        return 0u;
    case ISOTP_CF:
        if (!rx->active || id != rx->id) {
            rx->stats.unexpected++;
            return 0u;
        }
        if ((data[0] & 0x0Fu) != rx->sn) {
            rx->active = 0u;
            rx->stats.wrong_sn++;
            return 0u;
        }
        n = (uint16_t)(rx->want - rx->have);
        if (n > ISOTP_CF_DATA) {
            n = ISOTP_CF_DATA;
        }
        navkit_isotp_copy(rx->buf + rx->have, data + 1, n);
        rx->have = (uint16_t)(rx->have + n);
        rx->sn = (uint8_t)((rx->sn + 1u) & 0x0Fu);
        rx->deadline_ms = now_ms + NAVKIT_CAN_N_CR_MS;
        if (rx->have >= rx->want) {
            rx->active = 0u;
            rx->stats.good++;
            return rx->have;
        }
        if (NAVKIT_CAN_FC_BLOCK_SIZE != 0u && --rx->block == 0u) {
            rx->block = (uint8_t)NAVKIT_CAN_FC_BLOCK_SIZE;
            *fc_out = 1u;
            navkit_isotp_flow(fc, navkit_can_id(msg_type, 1), ISOTP_CONTINUE);
        }
        return 0u;
    default: /* a flow control on a message identifier, or PCI type 4-15 */
        break;
    }
    rx->stats.bad_frame++;
    return 0u;
}

void navkit_isotp_tx_init(navkit_isotp_tx_t *tx)
{
    static const navkit_isotp_tx_stats_t zero = {0u, 0u, 0u, 0u, 0u, 0u, 0u};
    tx->len = 0u;
    tx->done = 0u;
    tx->waiting = 0u;
    tx->stats = zero;
}

uint8_t navkit_isotp_tx_busy(const navkit_isotp_tx_t *tx)
{
    return (uint8_t)(tx->len != 0u);
}

uint8_t navkit_isotp_tx_start(navkit_isotp_tx_t *tx, uint16_t len, uint16_t msg_type, uint32_t now_ms)
{
    uint16_t id = navkit_can_id(msg_type, 0);
    if (tx->len != 0u || len == 0u || len > NAVKIT_ISOTP_MAX_BYTES || id == 0xFFFFu) {
        tx->stats.busy++;
        return 0u;
    }
    tx->len = len;
    tx->done = 0u;
    tx->id = id;
    tx->fc_id = navkit_can_id(msg_type, 1);
    tx->waiting = 0u;
    tx->block = 0u;
    tx->sn = 1u;
    tx->st_ms = 0u;
    tx->next_ms = now_ms;
    tx->deadline_ms = now_ms + NAVKIT_CAN_N_BS_MS;
    return 1u;
}

uint8_t navkit_isotp_tx_abort(navkit_isotp_tx_t *tx)
{
    if (tx->len == 0u) {
        return 0u;
    }
    tx->len = 0u;
    tx->waiting = 0u;
    tx->stats.aborted++;
    return 1u;
}

void navkit_isotp_tx_frame(navkit_isotp_tx_t *tx, uint16_t id, const uint8_t *data, uint8_t dlc, uint32_t now_ms)
{
    uint8_t st;
    if (tx->len == 0u || !tx->waiting || id != tx->fc_id) {
        return;
    }
    if (dlc != 8u || (data[0] >> 4) != ISOTP_FC) {
        tx->stats.bad_fc++;
        return;
    }
    switch (data[0] & 0x0Fu) {
    case ISOTP_CONTINUE:
        tx->waiting = 0u;
        tx->block = data[1];
        st = data[2];
        /* STmin in whole ms: 0xF1-0xF9 (100-900 us) round up to 1 ms, reserved values
           count as 127 ms (ISO 15765-2) */
        tx->st_ms = (st <= 0x7Fu) ? st : (st >= 0xF1u && st <= 0xF9u) ? 1u : 0x7Fu;
        if (!navkit_isotp_after(tx->next_ms, now_ms)) {
            tx->next_ms = now_ms; /* STmin holds across a flow control too: never earlier */
        }
        break;
    case ISOTP_WAIT:
        tx->stats.wait++;
        tx->deadline_ms = now_ms + NAVKIT_CAN_N_BS_MS;
        break;
    case ISOTP_OVERFLOW:
        tx->stats.overflow++;
        tx->len = 0u;
        break;
    default: /* an invalid flow status abandons the message */
        tx->stats.bad_fc++;
        tx->len = 0u;
        break;
    }
}

uint8_t navkit_isotp_tx_next(navkit_isotp_tx_t *tx, uint32_t now_ms, navkit_isotp_frame_t *out)
{
    uint8_t pci[8];
    uint16_t n;
    if (tx->len == 0u) {
        return 0u;
    }
    if (tx->done == 0u) { /* the single or first frame */
        if (tx->len <= ISOTP_SF_MAX) {
            pci[0] = (uint8_t)tx->len;
            navkit_isotp_copy(pci + 1, tx->buf, tx->len);
            navkit_isotp_fill(out, tx->id, pci, (uint8_t)(tx->len + 1u));
            tx->len = 0u;
            tx->stats.sent++;
            return 1u;
        }
        pci[0] = (uint8_t)((ISOTP_FF << 4) | (tx->len >> 8));
        pci[1] = (uint8_t)(tx->len & 0xFFu);
        navkit_isotp_copy(pci + 2, tx->buf, ISOTP_FF_DATA);
        navkit_isotp_fill(out, tx->id, pci, 8u);
        tx->done = ISOTP_FF_DATA;
        tx->waiting = 1u;
        tx->deadline_ms = now_ms + NAVKIT_CAN_N_BS_MS;
        return 1u;
    }
    if (tx->waiting) {
        if (!navkit_isotp_after(tx->deadline_ms, now_ms)) {
            tx->stats.timeout++;
            tx->len = 0u;
        }
        return 0u;
    }
    if (!navkit_isotp_after(now_ms, tx->next_ms)) {
        return 0u;
    }
    n = (uint16_t)(tx->len - tx->done);
    if (n > ISOTP_CF_DATA) {
        n = ISOTP_CF_DATA;
    }
    pci[0] = (uint8_t)((ISOTP_CF << 4) | tx->sn);
    navkit_isotp_copy(pci + 1, tx->buf + tx->done, n);
    navkit_isotp_fill(out, tx->id, pci, (uint8_t)(n + 1u));
    tx->done = (uint16_t)(tx->done + n);
    tx->sn = (uint8_t)((tx->sn + 1u) & 0x0Fu);
    tx->next_ms = now_ms + tx->st_ms;
    if (tx->done >= tx->len) {
        tx->len = 0u;
        tx->stats.sent++;
    } else if (tx->block != 0u && --tx->block == 0u) {
        tx->waiting = 1u;
        tx->deadline_ms = now_ms + NAVKIT_CAN_N_BS_MS;
    }
    return 1u;
}
