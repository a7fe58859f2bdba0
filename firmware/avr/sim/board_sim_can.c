/* board_sim_can.c: the MCP2515 and its bus (board_sim_can.h). Register and instruction
 * numbers are the MCP2515 datasheet's (DS20001801). */
#include <stdlib.h>
#include <string.h>

#include <avr_ioport.h>
#include <avr_spi.h>
#include <sim_avr.h>
#include <sim_cycle_timers.h>
#include <sim_io.h>
#include <sim_irq.h>

#include "navkit/navkit_proto.h"

#include "board_sim_regs.h"

#include "board.h"
#include "board_sim_can.h"

#define CAN_QUEUE BOARD_SIM_CAN_QUEUE /* frames each way (a power of two) */
/* registers */
#define R_CANSTAT 0x0Eu
#define R_CANCTRL 0x0Fu
#define R_CNF3 0x28u
#define R_CNF2 0x29u
#define R_CNF1 0x2Au
#define R_CANINTE 0x2Bu
#define R_CANINTF 0x2Cu
#define R_EFLG 0x2Du
#define R_TXB0CTRL 0x30u /* TXBn at 0x30 + 0x10 n: CTRL, SIDH, SIDL, EID8, EID0, DLC, D0..D7 */
#define R_RXB0CTRL 0x60u /* RXBn at 0x60 + 0x10 n: the same layout */
#define R_RXB1CTRL 0x70u
#define MODE_NORMAL 0x00u
#define MODE_CONFIG 0x80u
#define TXREQ 0x08u
#define INTF_RX0 0x01u
#define INTF_RX1 0x02u
#define INTF_TX0 0x04u /* TX1IF 0x08, TX2IF 0x10 */
#define INTF_ERR 0x20u /* ERRIF: EFLG changed (here: a receive-buffer overflow) */
#define EFLG_RX0OVR 0x40u
#define EFLG_RX1OVR 0x80u
#define OVR_BITS (EFLG_RX0OVR | EFLG_RX1OVR)
#define BUKT 0x04u
#define SRC_NONE (-2)
#define SRC_HOST (-1) /* else 0..2: the part's TXBn */

typedef board_sim_can_frame_t can_frame_t; /* the wires' frame, in both queues and on the bus */

struct sim_can {
    avr_t *avr;
    avr_spi_t *spi;  /* simavr's SPI module (its SPDR write is the board's, can_spdr_write) */
    uint8_t spi_out; /* the byte being shifted out */
    avr_irq_t *int_irq;
    uint8_t regs[128];
    /* the SPI transaction under way */
    int selected;
    uint8_t op;       /* its instruction byte */
    uint32_t nbytes;  /* bytes received since CS fell */
    uint8_t addr;     /* register the next byte reads or writes */
    uint8_t bm_mask;  /* BIT MODIFY's mask */
    uint8_t out_next; /* the byte the part shifts out during the next transfer */
    int int_level;    /* the INT pin: 1 high (idle), 0 low */
    int int_held;     /* 1: the AVR sees INT high whatever the part asks (sim_can_hold_int) */
    /* the bus, at the spec's bit rate (NAVKIT_CAN_BITRATE) */
    int busy;
    int src; /* the frame on the bus: SRC_HOST, a TXB, or SRC_NONE (cut off) */
    can_frame_t cur;
    can_frame_t *host_q, *out_q;
    uint32_t host_head, host_tail, out_head, out_tail;
    board_sim_can_stats_t st;
};

/* ---------------------------------------------------------------- registers */

static uint8_t can_mode(const sim_can_t *c)
{
    return (uint8_t)(c->regs[R_CANSTAT] & 0xE0u);
}

/* bit/s of the part's CNF1-3 at BOARD_CAN_OSC_HZ; 0 if the timing is not a valid one */
static uint32_t can_part_bps(const sim_can_t *c)
{
    uint32_t brp = c->regs[R_CNF1] & 0x3Fu;
    uint32_t prop = (c->regs[R_CNF2] & 0x07u) + 1u;
    uint32_t ps1 = ((c->regs[R_CNF2] >> 3) & 0x07u) + 1u;
    uint32_t ps2 = (c->regs[R_CNF2] & 0x80u) ? (c->regs[R_CNF3] & 0x07u) + 1u : ((ps1 > 2u) ? ps1 : 2u);
    uint32_t tq = 1u + prop + ps1 + ps2;
    if (tq < 5u || ps2 < 2u) {
        return 0u;
    }
    return (uint32_t)(BOARD_CAN_OSC_HZ / (2u * (brp + 1u) * tq));
}

/* 1 if the part takes part on the bus: normal mode at the bus's bit rate */
static int can_on_bus(const sim_can_t *c)
{
    return can_mode(c) == MODE_NORMAL && can_part_bps(c) == NAVKIT_CAN_BITRATE;
}

/* The INT pin's level into PINK (simavr 1.6 overwrites an input pin's PIN bit with its
   PORT bit at a write of the port: the sonar triggers share port K). */
static void can_show_int(sim_can_t *c)
{
    uint8_t *pin = &c->avr->data[BOARD_CAN_INT_PIN];
    *pin = (uint8_t)((*pin & ~(1u << BOARD_CAN_INT_BIT)) | ((c->int_level ? 1u : 0u) << BOARD_CAN_INT_BIT));
}

static void can_port_written(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    can_show_int((sim_can_t *)param);
}

static void can_update_int(sim_can_t *c)
{
    int level = (!c->int_held && (c->regs[R_CANINTE] & c->regs[R_CANINTF])) ? 0 : 1;
    if (level != c->int_level) {
        c->int_level = level;
        avr_raise_irq(c->int_irq, (uint32_t)level);
        can_show_int(c);
    }
}

static void can_part_reset(sim_can_t *c)
{
    memset(c->regs, 0, sizeof c->regs);
    c->regs[R_CANSTAT] = MODE_CONFIG;
    c->regs[R_CANCTRL] = 0x87u; /* REQOP configuration, CLKOUT on, /8 */
    if (c->src >= 0) {
        c->src = SRC_NONE; /* its frame on the bus is cut off */
    }
    can_update_int(c);
}

static uint8_t can_reg_read(const sim_can_t *c, uint8_t a)
{
    a &= 0x7Fu;
    if ((a & 0x0Fu) == 0x0Eu) {
        return c->regs[R_CANSTAT]; /* mirrored in every row */
    }
    if ((a & 0x0Fu) == 0x0Fu) {
        return c->regs[R_CANCTRL];
    }
    return c->regs[a];
}

static void can_bus_kick(sim_can_t *c);

static void can_reg_write(sim_can_t *c, uint8_t a, uint8_t v)
{
    a &= 0x7Fu;
    if ((a & 0x0Fu) == 0x0Eu) {
        return; /* CANSTAT: read only */
    }
    if ((a & 0x0Fu) == 0x0Fu) {
        c->regs[R_CANCTRL] = v;
        c->regs[R_CANSTAT] = (uint8_t)((c->regs[R_CANSTAT] & 0x1Fu) | (v & 0xE0u)); /* OPMOD follows REQOP */
        can_bus_kick(c);
        return;
    }
    if (a < 0x30u && a != R_CANINTE && a != R_CANINTF && a != R_EFLG && (a < 0x1Cu || a > 0x1Du)) {
        /* filters, masks, CNF1-3: writable in configuration mode only (TEC/REC: read only) */
        if (can_mode(c) == MODE_CONFIG) {
            c->regs[a] = v;
        }
        return;
    }
    if (a == 0x1Cu || a == 0x1Du) {
        return;
    }
    if (a == R_TXB0CTRL || a == R_TXB0CTRL + 0x10u || a == R_TXB0CTRL + 0x20u) {
        c->regs[a] = (uint8_t)((c->regs[a] & ~0x0Bu) | (v & 0x0Bu)); /* TXREQ, TXP */
        can_bus_kick(c);
        return;
    }
    if (a == R_EFLG) {
        c->regs[a] = (uint8_t)((c->regs[a] & ~OVR_BITS) | (v & OVR_BITS)); /* RXnOVR only: the rest is read only */
        return;
    }
    c->regs[a] = v;
    if (a == R_CANINTE || a == R_CANINTF) {
        can_update_int(c);
    }
}

/* READ STATUS */
static uint8_t can_status(const sim_can_t *c)
{
    uint8_t f = c->regs[R_CANINTF];
    return (uint8_t)((f & 0x03u) | ((c->regs[R_TXB0CTRL] & TXREQ) ? 0x04u : 0u) | ((f & 0x04u) << 1) |
                     ((c->regs[R_TXB0CTRL + 0x10u] & TXREQ) ? 0x10u : 0u) | ((f & 0x08u) << 2) |
                     ((c->regs[R_TXB0CTRL + 0x20u] & TXREQ) ? 0x40u : 0u) | ((f & 0x10u) << 3));
}

/* RX STATUS: 7:6 which buffers hold a frame, 4:3 its type (standard data: 0), 2:0 the
   filter hit of the buffer read first */
static uint8_t can_rx_status(const sim_can_t *c)
{
    uint8_t f = c->regs[R_CANINTF] & 0x03u;
    uint8_t hit = (f & 1u) ? (c->regs[R_RXB0CTRL] & 1u) : (uint8_t)(c->regs[R_RXB1CTRL] & 7u);
    return (uint8_t)((f << 6) | hit);
}

/* ---------------------------------------------------------------- SPI */

static void can_cs(avr_irq_t *irq, uint32_t value, void *param)
{
    sim_can_t *c = (sim_can_t *)param;
    (void)irq;
    if (value == 0u) {
        c->selected = 1;
        c->nbytes = 0u;
        c->op = 0u;
        c->out_next = 0xFFu;
        return;
    }
    if (c->selected && c->nbytes > 0u && (c->op & 0xF9u) == 0x90u) {
        /* READ RX BUFFER: the buffer's flag clears as CS goes high */
        c->regs[R_CANINTF] &= (uint8_t) ~((c->op & 0x04u) ? INTF_RX1 : INTF_RX0);
        can_update_int(c);
    }
    c->selected = 0;
}

/* The first byte of a transaction: the instruction. */
static void can_op(sim_can_t *c, uint8_t v)
{
    c->op = v;
    if (v == 0xC0u) { /* RESET */
        can_part_reset(c);
    } else if (v == 0xA0u) {
        c->out_next = can_status(c);
    } else if (v == 0xB0u) {
        c->out_next = can_rx_status(c);
    } else if ((v & 0xF8u) == 0x40u && (v & 7u) <= 5u) { /* LOAD TX BUFFER: a b c */
        c->addr = (uint8_t)(R_TXB0CTRL + 0x10u * ((v & 7u) >> 1) + ((v & 1u) ? 6u : 1u));
    } else if ((v & 0xF8u) == 0x80u) { /* RTS */
        uint8_t n;
        for (n = 0u; n < 3u; n++) {
            if (v & (1u << n)) {
                c->regs[R_TXB0CTRL + 0x10u * n] |= TXREQ;
            }
        }
        can_bus_kick(c);
    } else if ((v & 0xF9u) == 0x90u) { /* READ RX BUFFER: n m */
        c->addr = (uint8_t)(R_RXB0CTRL + ((v & 0x04u) ? 0x10u : 0u) + ((v & 0x02u) ? 6u : 1u));
        c->out_next = can_reg_read(c, c->addr++);
    }
}

/* A byte the AVR shifted out: returns the part's byte of the same transfer (what it
   prepared from the bytes before), then takes v. */
static uint8_t can_spi_byte(sim_can_t *c, uint8_t v)
{
    uint8_t reply = c->out_next;
    uint32_t n;
    if (!c->selected) {
        return 0xFFu; /* MISO floats: the pull of the line */
    }
    c->out_next = 0xFFu;
    n = c->nbytes++;
    if (n == 0u) {
        can_op(c, v);
        return reply;
    }
    switch (c->op) {
    case 0x03u: /* READ addr, then sequential */
        if (n == 1u) {
            c->addr = v;
        }
        c->out_next = can_reg_read(c, c->addr);
        c->addr = (uint8_t)((c->addr + 1u) & 0x7Fu);
        break;
    case 0x02u: /* WRITE addr, data... */
        if (n == 1u) {
            c->addr = v;
        } else {
            can_reg_write(c, c->addr, v);
            c->addr = (uint8_t)((c->addr + 1u) & 0x7Fu);
        }
        break;
    case 0x05u: /* BIT MODIFY addr, mask, data (on any register: as a mask of 0xFF where the
                   part takes only whole writes) */
        if (n == 1u) {
            c->addr = v;
        } else if (n == 2u) {
            c->bm_mask = v;
        } else if (n == 3u) {
            uint8_t old = can_reg_read(c, c->addr);
            can_reg_write(c, c->addr, (uint8_t)((old & ~c->bm_mask) | (v & c->bm_mask)));
        }
        break;
    case 0xA0u:
        c->out_next = can_status(c); /* repeats while CS stays low */
        break;
    case 0xB0u:
        c->out_next = can_rx_status(c);
        break;
    default:
        if ((c->op & 0xF8u) == 0x40u && (c->op & 7u) <= 5u) { /* LOAD TX BUFFER data */
            if ((c->addr & 0x0Fu) <= 0x0Du) {
                c->regs[c->addr++] = v;
            }
        } else if ((c->op & 0xF9u) == 0x90u) { /* READ RX BUFFER data */
            c->out_next = ((c->addr & 0x0Fu) <= 0x0Du) ? can_reg_read(c, c->addr++) : 0xFFu;
        }
        break;
    }
    return reply;
}

/* The SPI master's transfer. simavr 1.6 completes every byte a fixed 100 us after the
   write of SPDR whatever the clock; the board takes over that write: the byte completes
   after 8 SPI clocks at the rate SPCR/SPSR set (F_CPU/2 .. F_CPU/128), then SPDR holds the
   part's byte and SPIF is set (simavr's own vector: its interrupt if SPIE is on). A write
   with SPE or MSTR off (slave mode: not modelled) only stores the byte. */
static avr_cycle_count_t can_spi_done(avr_t *avr, avr_cycle_count_t when, void *param)
{
    sim_can_t *c = (sim_can_t *)param;
    (void)when;
    uint8_t in = can_spi_byte(c, c->spi_out);
    c->spi->input_data_register = in; /* what simavr's read of SPDR returns */
    avr->data[c->spi->r_spdr] = in;
    avr_raise_interrupt(avr, &c->spi->spi);
    return 0;
}

static void can_spdr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    static const uint8_t div[4] = {4u, 16u, 64u, 128u};
    sim_can_t *c = (sim_can_t *)param;
    avr_spi_t *spi = c->spi;
    uint32_t d;
    avr->data[addr] = v;
    avr_regbit_clear(avr, spi->spi.raised); /* SPIF: cleared by the access to SPDR */
    if (!avr_regbit_get(avr, spi->spe) || !avr_regbit_get(avr, spi->mstr)) {
        return;
    }
    d = div[avr->data[spi->r_spcr] & 3u];
    if (avr_regbit_get(avr, spi->spr[2])) {
        d >>= 1; /* SPI2X */
    }
    c->spi_out = v;
    avr_cycle_timer_register(avr, 8u * d, can_spi_done, c);
}

/* ---------------------------------------------------------------- the bus */

static uint32_t can_filter_id(const sim_can_t *c, uint8_t a)
{
    return ((uint32_t)c->regs[a] << 3) | (c->regs[a + 1u] >> 5);
}

/* 1 if a standard frame id passes filter f (0..5) under its buffer's mask */
static int can_filter_hit(const sim_can_t *c, uint16_t id, uint8_t f)
{
    uint8_t fa = (uint8_t)((f < 3u) ? f * 4u : 0x10u + (f - 3u) * 4u);
    uint8_t ma = (uint8_t)((f < 2u) ? 0x20u : 0x24u);
    if (c->regs[fa + 1u] & 0x08u) {
        return 0; /* EXIDE: the filter takes extended frames only */
    }
    return ((id ^ can_filter_id(c, fa)) & can_filter_id(c, ma)) == 0u;
}

static void can_store(sim_can_t *c, uint8_t n, const can_frame_t *f, uint8_t hit)
{
    uint8_t base = (uint8_t)(R_RXB0CTRL + 0x10u * n);
    uint8_t filhit = n ? 0x07u : 0x01u; /* RXB0CTRL: FILHIT0 (bit 2 is BUKT); RXB1CTRL: FILHIT2:0 */
    c->regs[base] = (uint8_t)((c->regs[base] & ~filhit) | (hit & filhit));
    c->regs[base + 1u] = (uint8_t)(f->id >> 3);
    c->regs[base + 2u] = (uint8_t)((f->id & 7u) << 5);
    c->regs[base + 3u] = 0u;
    c->regs[base + 4u] = 0u;
    c->regs[base + 5u] = f->dlc;
    memcpy(&c->regs[base + 6u], f->data, 8u);
    c->regs[R_CANINTF] |= (uint8_t)(n ? INTF_RX1 : INTF_RX0);
    c->st.accepted++;
    can_update_int(c);
}

/* A frame for a full buffer is lost: its EFLG overflow bit and ERRIF set. */
static void can_overflow(sim_can_t *c, uint8_t eflg_bit)
{
    c->regs[R_EFLG] |= eflg_bit;
    c->regs[R_CANINTF] |= INTF_ERR;
    c->st.overflowed++;
    can_update_int(c);
}

/* A host frame the part acknowledged: through its masks and filters into a buffer. */
static void can_receive(sim_can_t *c, const can_frame_t *f)
{
    uint8_t rxm0 = (uint8_t)((c->regs[R_RXB0CTRL] >> 5) & 3u), rxm1 = (uint8_t)((c->regs[R_RXB1CTRL] >> 5) & 3u);
    int hit = -1;
    uint8_t i;
    if (rxm0 == 3u) {
        hit = 0;
    }
    for (i = 0u; hit < 0 && i < 2u; i++) {
        if (can_filter_hit(c, f->id, i)) {
            hit = i;
        }
    }
    if (hit >= 0) {
        if (!(c->regs[R_CANINTF] & INTF_RX0)) {
            can_store(c, 0u, f, (uint8_t)hit);
        } else if ((c->regs[R_RXB0CTRL] & BUKT) && !(c->regs[R_CANINTF] & INTF_RX1)) {
            can_store(c, 1u, f, (uint8_t)hit);
        } else {
            can_overflow(c, EFLG_RX0OVR);
        }
        return;
    }
    if (rxm1 == 3u) {
        hit = 2;
    }
    for (i = 2u; hit < 0 && i < 6u; i++) {
        if (can_filter_hit(c, f->id, i)) {
            hit = i;
        }
    }
    if (hit < 0) {
        c->st.filtered++;
    } else if (!(c->regs[R_CANINTF] & INTF_RX1)) {
        can_store(c, 1u, f, (uint8_t)hit);
    } else {
        can_overflow(c, EFLG_RX1OVR);
    }
}

static avr_cycle_count_t can_bus_done(avr_t *avr, avr_cycle_count_t when, void *param)
{
    sim_can_t *c = (sim_can_t *)param;
    (void)avr;
    c->busy = 0;
    if (c->src == SRC_HOST) {
        c->host_tail++;
        c->st.to_part++;
        can_receive(c, &c->cur);
    } else if (c->src >= 0) {
        uint8_t ctrl = (uint8_t)(R_TXB0CTRL + 0x10u * (uint8_t)c->src);
        c->regs[ctrl] &= (uint8_t)~TXREQ;
        c->regs[R_CANINTF] |= (uint8_t)(INTF_TX0 << c->src);
        c->cur.cycle = when;
        if (c->out_head - c->out_tail < CAN_QUEUE) {
            c->out_q[c->out_head++ & (CAN_QUEUE - 1u)] = c->cur;
        } else {
            c->st.dropped++;
        }
        c->st.from_part++;
        can_update_int(c);
    }
    c->src = SRC_NONE;
    can_bus_kick(c);
    return 0;
}

/* The bus is idle: the next frame (the lowest identifier) starts, if any may go. */
static void can_bus_kick(sim_can_t *c)
{
    int best = SRC_NONE, n;
    uint16_t best_id = 0xFFFFu;
    uint8_t best_prio = 0u;
    uint32_t bits;
    if (c->busy || !can_on_bus(c)) {
        return;
    }
    if (c->host_head != c->host_tail) {
        best = SRC_HOST;
        best_id = c->host_q[c->host_tail & (CAN_QUEUE - 1u)].id;
    }
    for (n = 2; n >= 0; n--) { /* equal TXP: the higher buffer number first */
        uint8_t ctrl = c->regs[R_TXB0CTRL + 0x10u * (unsigned)n];
        uint16_t id;
        if (!(ctrl & TXREQ)) {
            continue;
        }
        id = (uint16_t)can_filter_id(c, (uint8_t)(R_TXB0CTRL + 0x10u * (unsigned)n + 1u));
        if (id < best_id || (best >= 0 && id == best_id && (ctrl & 3u) > best_prio)) {
            best = n;
            best_id = id;
            best_prio = (uint8_t)(ctrl & 3u);
        }
    }
    if (best == SRC_NONE) {
        return;
    }
    if (best == SRC_HOST) {
        c->cur = c->host_q[c->host_tail & (CAN_QUEUE - 1u)];
    } else {
        uint8_t b = (uint8_t)(R_TXB0CTRL + 0x10u * (unsigned)best);
        c->cur.id = best_id;
        c->cur.dlc = (uint8_t)(c->regs[b + 5u] & 0x0Fu);
        if (c->cur.dlc > 8u) {
            c->cur.dlc = 8u;
        }
        memset(c->cur.data, 0, 8u);
        memcpy(c->cur.data, &c->regs[b + 6u], c->cur.dlc);
    }
    c->src = best;
    c->busy = 1;
    bits = 47u + 8u * c->cur.dlc;
    avr_cycle_timer_register(c->avr, (avr_cycle_count_t)bits * c->avr->frequency / NAVKIT_CAN_BITRATE, can_bus_done, c);
}

/* ---------------------------------------------------------------- API */

sim_can_t *sim_can_new(avr_t *avr)
{
    sim_can_t *c = (sim_can_t *)calloc(1, sizeof *c);
    avr_io_t *port;
    if (c == NULL) {
        return NULL;
    }
    c->host_q = (can_frame_t *)calloc(CAN_QUEUE, sizeof *c->host_q);
    c->out_q = (can_frame_t *)calloc(CAN_QUEUE, sizeof *c->out_q);
    if (c->host_q == NULL || c->out_q == NULL) {
        sim_can_free(c);
        return NULL;
    }
    c->avr = avr;
    c->src = SRC_NONE;
    c->int_level = -1;
    for (port = avr->io_port; port != NULL; port = port->next) {
        if (strcmp(port->kind, "spi") == 0) {
            c->spi = (avr_spi_t *)port; /* avr_spi_t starts with its avr_io_t */
        }
    }
    if (c->spi == NULL) {
        sim_can_free(c);
        return NULL;
    }
    avr->io[AVR_DATA_TO_IO(c->spi->r_spdr)].w.c = can_spdr_write;
    avr->io[AVR_DATA_TO_IO(c->spi->r_spdr)].w.param = c;
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_CAN_SPI_PORT_NAME), BOARD_CAN_CS_BIT),
                            can_cs, c);
    c->int_irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_CAN_INT_PORT_NAME), BOARD_CAN_INT_BIT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_CAN_INT_PORT_NAME), IOPORT_IRQ_PIN_ALL),
                            can_port_written, c);
    can_part_reset(c);
    return c;
}

void sim_can_free(sim_can_t *c)
{
    if (c == NULL) {
        return;
    }
    free(c->host_q);
    free(c->out_q);
    free(c);
}

void sim_can_after_avr_reset(sim_can_t *c)
{
    can_show_int(c);
    c->selected = 0;
    c->busy = 0; /* the reset cleared the bus's timer: the frame is sent again */
    c->src = SRC_NONE;
    can_bus_kick(c);
}

void sim_can_write(sim_can_t *c, uint16_t id, const uint8_t *data, uint8_t dlc)
{
    can_frame_t *f;
    if (c->host_head - c->host_tail >= CAN_QUEUE) {
        c->st.dropped++;
        return;
    }
    f = &c->host_q[c->host_head & (CAN_QUEUE - 1u)];
    f->id = (uint16_t)(id & 0x7FFu);
    f->dlc = (dlc > 8u) ? 8u : dlc;
    memset(f->data, 0, 8u);
    memcpy(f->data, data, f->dlc);
    f->cycle = 0u;
    c->host_head++;
    can_bus_kick(c);
}

int sim_can_read(sim_can_t *c, board_sim_can_frame_t *out)
{
    if (c->out_head == c->out_tail) {
        return 0;
    }
    *out = c->out_q[c->out_tail++ & (CAN_QUEUE - 1u)];
    return 1;
}

void sim_can_stats(const sim_can_t *c, board_sim_can_stats_t *out)
{
    *out = c->st;
    out->part_bps = can_part_bps(c);
    out->normal_mode = (uint8_t)(can_mode(c) == MODE_NORMAL);
    out->host_waiting = c->host_head - c->host_tail;
}

void sim_can_hold_int(sim_can_t *c, int held)
{
    c->int_held = held ? 1 : 0;
    can_update_int(c);
}
