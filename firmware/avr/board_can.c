/* board_can.c: the MCP2515 driver (board_can.h). Register and instruction numbers are the
 * MCP2515 datasheet's (DS20001801). */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/delay.h>

#include "board.h"
#include "board_can.h"
#include "navkit/navkit_proto.h"

/* SPI instructions */
#define CAN_OP_RESET 0xC0u
#define CAN_OP_READ 0x03u
#define CAN_OP_WRITE 0x02u
#define CAN_OP_BIT_MODIFY 0x05u
#define CAN_OP_READ_STATUS 0xA0u
#define CAN_OP_LOAD_TXB0 0x40u /* LOAD TX BUFFER from TXB0SIDH */
#define CAN_OP_RTS_TXB0 0x81u  /* REQUEST TO SEND, TXB0 */
#define CAN_OP_READ_RXB0 0x90u /* READ RX BUFFER from RXB0SIDH (RX0IF clears at CS high) */
#define CAN_OP_READ_RXB1 0x94u /* READ RX BUFFER from RXB1SIDH (RX1IF clears at CS high) */
/* registers */
#define CAN_RXF0 0x00u     /* RXF0..RXF2: 0x00, 0x04, 0x08 (SIDH, SIDL, EID8, EID0 each) */
#define CAN_RXF3 0x10u     /* RXF3..RXF5: 0x10, 0x14, 0x18 */
#define CAN_RXM0_REG 0x20u /* RXM0, RXM1: 0x20, 0x24 */
#define CAN_CANSTAT 0x0Eu
#define CAN_CANCTRL 0x0Fu
#define CAN_CNF3 0x28u /* CNF3, CNF2, CNF1, CANINTE, CANINTF follow at 0x28..0x2C */
#define CAN_CANINTF 0x2Cu
#define CAN_EFLG 0x2Du
#define CAN_RXB0CTRL 0x60u
#define CAN_RXB1CTRL 0x70u
/* bits */
#define CAN_INT_RX0 0x01u /* CANINTE/CANINTF: RX0IE/RX0IF, RX1 = 0x02, TX0 = 0x04 */
#define CAN_INT_RX1 0x02u
#define CAN_INT_TX0 0x04u
#define CAN_INT_ERR 0x20u    /* ERRIE/ERRIF: a change in EFLG, e.g. a receive-buffer overflow */
#define CAN_EFLG_RXOVR 0xC0u /* EFLG: RX1OVR (bit 7), RX0OVR (bit 6); the only bits a write changes */
#define CAN_ST_RX0IF 0x01u   /* READ STATUS: RX0IF, RX1IF, TXB0 TXREQ, TX0IF, ... */
#define CAN_ST_RX1IF 0x02u
#define CAN_ST_TX0IF 0x08u
#define CAN_RXB0_BUKT 0x04u /* RXB0CTRL: a frame for a full RXB0 rolls over into RXB1 */
#define CAN_SIDL_IDE 0x08u  /* RXBnSIDL: extended identifier */
#define CAN_SIDL_SRR 0x10u  /* RXBnSIDL: standard remote frame */
#define CAN_DLC_RTR 0x40u   /* RXBnDLC: remote frame (extended) */
#define CAN_MODE_MASK 0xE0u /* CANCTRL.REQOP / CANSTAT.OPMOD */
#define CAN_MODE_NORMAL 0x00u

/* Bit timing (datasheet 5): a time quantum TQ = 2 (BRP + 1) / F_OSC; a bit is
 * 1 (sync) + PRSEG + PHSEG1 + PHSEG2 quanta, 8..25. The smallest BRP whose bit fits 25
 * quanta gives the most quanta a bit; PHSEG2 takes a quarter (sample point ~75 %), PHSEG1
 * and PRSEG share the rest; SJW 1. 8 MHz at 500 kbit/s: BRP 0, 8 TQ = 1 + 2 + 3 + 2;
 * 16 MHz: BRP 0, 16 TQ = 1 + 5 + 6 + 4. */
#define CAN_HALF_OSC (BOARD_CAN_OSC_HZ / 2u)
#define CAN_BRP ((CAN_HALF_OSC / NAVKIT_CAN_BITRATE + 24u) / 25u - 1u)
#define CAN_TQ (CAN_HALF_OSC / ((CAN_BRP + 1u) * NAVKIT_CAN_BITRATE))
#define CAN_PS2 ((CAN_TQ / 4u < 2u) ? 2u : CAN_TQ / 4u)
#define CAN_PS1 ((CAN_TQ - 1u - CAN_PS2 + 1u) / 2u)
#define CAN_PROP (CAN_TQ - 1u - CAN_PS2 - CAN_PS1)
typedef char can_rate_exact[(CAN_TQ * (CAN_BRP + 1u) * NAVKIT_CAN_BITRATE == CAN_HALF_OSC) ? 1 : -1];
typedef char
    can_rate_quanta[(CAN_TQ >= 8u && CAN_BRP < 64u && CAN_PS1 <= 8u && CAN_PROP >= 1u && CAN_PROP <= 8u) ? 1 : -1];
/* the INT poll must come round within one frame (111 bits, 8 data bytes, no stuffing) so
   that the two receive buffers never overflow */
typedef char can_poll_in_time[((uint32_t)BOARD_CAN_POLL_US * (NAVKIT_CAN_BITRATE / 1000u) < 111000u) ? 1 : -1];
typedef char can_rings_pow2[((BOARD_CAN_RX_FRAMES & (BOARD_CAN_RX_FRAMES - 1u)) == 0u &&
                             (BOARD_CAN_TX_FRAMES & (BOARD_CAN_TX_FRAMES - 1u)) == 0u)
                                ? 1
                                : -1];
/* Acceptance: RXB0 (two deep: a frame for a full RXB0 rolls over into RXB1) takes every
   burst, micro_cmd's frames by RXF0 and the three configs' by RXF1 under one mask RXM0 that
   ignores the bits in which the configs' identifiers differ; RXB1's own filters (RXF2-5,
   exact) take micro_data's flow control, one frame per reply. The mask lets a few unused
   identifiers through too (0x112/0x114/0x116/0x126 for the spec's ids), which the link's
   ISO-TP ignores as other nodes' traffic; never one the micro sends itself (checked below). */
#define CAN_CFG_SPREAD                                                                                                 \
    ((NAVKIT_CAN_ID_MICRO_CFG_GEOMETRY ^ NAVKIT_CAN_ID_MICRO_CFG_MOTION) |                                             \
     (NAVKIT_CAN_ID_MICRO_CFG_GEOMETRY ^ NAVKIT_CAN_ID_MICRO_CFG_IO))
#define CAN_RXM0 (0x7FFu & ~CAN_CFG_SPREAD)
#define CAN_RXB0_TAKES(id)                                                                                             \
    ((((id) ^ NAVKIT_CAN_ID_MICRO_CMD) & CAN_RXM0) == 0u ||                                                            \
     (((id) ^ NAVKIT_CAN_ID_MICRO_CFG_GEOMETRY) & CAN_RXM0) == 0u)
typedef char
    can_filters_own[(!CAN_RXB0_TAKES(NAVKIT_CAN_ID_MICRO_DATA) && !CAN_RXB0_TAKES(NAVKIT_CAN_FC_ID_MICRO_CMD) &&
                     !CAN_RXB0_TAKES(NAVKIT_CAN_FC_ID_MICRO_CFG_GEOMETRY) &&
                     !CAN_RXB0_TAKES(NAVKIT_CAN_FC_ID_MICRO_CFG_MOTION) &&
                     !CAN_RXB0_TAKES(NAVKIT_CAN_FC_ID_MICRO_CFG_IO) && !CAN_RXB0_TAKES(NAVKIT_CAN_FC_ID_MICRO_DATA) &&
                     CAN_RXB0_TAKES(NAVKIT_CAN_ID_MICRO_CFG_MOTION) && CAN_RXB0_TAKES(NAVKIT_CAN_ID_MICRO_CFG_IO))
                        ? 1
                        : -1];

/* the TX queue takes a whole micro_data (a first frame of 6 bytes, consecutive frames of
   7) and the flow control the link owes the host meanwhile: hal_can_tx_free() never stops
   a flow control (the link drops one that finds no room, and the host's sender then
   waits its N_Bs) */
typedef char can_tx_room[(BOARD_CAN_TX_FRAMES >= 2u + (NAVKIT_CAN_MAX_TO_HOST_BYTES - 6u + 6u) / 7u) ? 1 : -1];

#define CAN_TIMER2_DIV 32u /* Timer2 prescaler: 0.5 MHz */
#define CAN_TIMER2_OCR ((uint8_t)((uint32_t)BOARD_CAN_POLL_US * (F_CPU / 1000000u) / CAN_TIMER2_DIV - 1u))
typedef char can_poll_fits[((uint32_t)BOARD_CAN_POLL_US * (F_CPU / 1000000u) / CAN_TIMER2_DIV <= 256u) ? 1 : -1];

typedef struct {
    uint16_t id;
    uint8_t dlc;
    uint8_t data[8];
} can_frame_t;

static can_frame_t can_rx[BOARD_CAN_RX_FRAMES];
static volatile uint8_t can_rx_head, can_rx_tail; /* free-running: the poll writes head, main tail */
static volatile uint16_t can_rx_drop;             /* frames: a full RX ring, plus each overflow the part flagged */
static can_frame_t can_tx[BOARD_CAN_TX_FRAMES];
static volatile uint8_t can_tx_head, can_tx_tail; /* main writes head, the poll (or main, locked) tail */
static volatile uint8_t can_tx_busy;              /* TXB0 holds a frame not yet sent */

static void can_select(void)
{
    BOARD_CAN_SPI_PORT &= (uint8_t)~_BV(BOARD_CAN_CS_BIT);
}

static void can_deselect(void)
{
    BOARD_CAN_SPI_PORT |= _BV(BOARD_CAN_CS_BIT);
}

/* One SPI byte each way (0.125 us a bit at 8 MHz: 16 CPU cycles a byte). */
static uint8_t can_spi(uint8_t out)
{
    SPDR = out;
    while (!(SPSR & _BV(SPIF))) {
    }
    return SPDR;
}

static void can_write_regs(uint8_t addr, const uint8_t *v, uint8_t n)
{
    can_select();
    can_spi(CAN_OP_WRITE);
    can_spi(addr);
    while (n-- > 0u) {
        can_spi(*v++);
    }
    can_deselect();
}

static uint8_t can_read_reg(uint8_t addr)
{
    uint8_t v;
    can_select();
    can_spi(CAN_OP_READ);
    can_spi(addr);
    v = can_spi(0u);
    can_deselect();
    return v;
}

static void can_bit_modify(uint8_t addr, uint8_t mask, uint8_t v)
{
    can_select();
    can_spi(CAN_OP_BIT_MODIFY);
    can_spi(addr);
    can_spi(mask);
    can_spi(v);
    can_deselect();
}

/* A standard identifier as SIDH, SIDL, EID8, EID0 (EXIDE 0: a filter matches standard
   frames only). */
static void can_id_regs(uint16_t id, uint8_t r[4])
{
    r[0] = (uint8_t)(id >> 3);
    r[1] = (uint8_t)((id & 7u) << 5);
    r[2] = 0u;
    r[3] = 0u;
}

/* Frame of RX buffer n (0, 1) into the RX ring; its flag clears as CS goes high. */
static void can_rx_take(uint8_t n)
{
    uint8_t head = can_rx_head;
    uint8_t full = (uint8_t)((uint8_t)(head - can_rx_tail) >= BOARD_CAN_RX_FRAMES);
    can_frame_t *f = &can_rx[head & (BOARD_CAN_RX_FRAMES - 1u)];
    uint8_t sidh, sidl, dlc, i;
    can_select();
    can_spi(n ? CAN_OP_READ_RXB1 : CAN_OP_READ_RXB0);
    sidh = can_spi(0u);
    sidl = can_spi(0u);
    can_spi(0u); /* EID8, EID0: the micro receives standard frames only */
    can_spi(0u);
    dlc = can_spi(0u);
    if (full) {
        can_deselect(); /* frees the buffer: the frame is lost */
        can_rx_drop++;
        return;
    }
    f->id = (uint16_t)(((uint16_t)sidh << 3) | (sidl >> 5));
    if (sidl & CAN_SIDL_IDE) {
        f->id |= NAVKIT_ISOTP_EXT;
        if (dlc & CAN_DLC_RTR) {
            f->id |= NAVKIT_ISOTP_RTR;
        }
    } else if (sidl & CAN_SIDL_SRR) {
        f->id |= NAVKIT_ISOTP_RTR;
    }
    dlc &= 0x0Fu;
    if (dlc > 8u) {
        dlc = 8u;
    }
    f->dlc = dlc;
    for (i = 0u; i < dlc; i++) {
        f->data[i] = can_spi(0u);
    }
    can_deselect();
    can_rx_head = (uint8_t)(head + 1u);
}

/* The oldest queued frame into TXB0 and its request to send, or TXB0 idle if none. */
static void can_tx_next(void)
{
    uint8_t tail = can_tx_tail;
    const can_frame_t *f;
    uint8_t r[4], i;
    if (tail == can_tx_head) {
        can_tx_busy = 0u;
        return;
    }
    f = &can_tx[tail & (BOARD_CAN_TX_FRAMES - 1u)];
    can_id_regs(f->id, r);
    can_select();
    can_spi(CAN_OP_LOAD_TXB0);
    for (i = 0u; i < 4u; i++) {
        can_spi(r[i]);
    }
    can_spi(8u); /* DLC */
    for (i = 0u; i < 8u; i++) {
        can_spi(f->data[i]);
    }
    can_deselect();
    can_select();
    can_spi(CAN_OP_RTS_TXB0);
    can_deselect();
    can_tx_tail = (uint8_t)(tail + 1u);
    can_tx_busy = 1u;
}

/* The part's error interrupt: each receive-buffer overflow flag set counts one lost frame
   (the part keeps no count); the flags and ERRIF are cleared. */
static void can_error(void)
{
    uint8_t e = can_read_reg(CAN_EFLG) & CAN_EFLG_RXOVR;
    can_rx_drop = (uint16_t)(can_rx_drop + (e >> 7) + ((e >> 6) & 1u));
    can_bit_modify(CAN_EFLG, CAN_EFLG_RXOVR, 0u);
    can_bit_modify(CAN_CANINTF, CAN_INT_ERR, 0u);
}

/* Serve the part until it asks for nothing: received frames into the RX ring (per status
   read RXB0 before RXB1: a frame rolls over into RXB1 only while RXB0 holds an older one,
   and reading takes far less than a frame's time on the bus), a sent TXB0 refilled, then an
   error interrupt's overflow flags counted. Called with the lock held (the poll's own
   interrupt off) and interrupts on: reading a frame over the SPI takes longer than the
   encoders' edge period at their guaranteed rate (320 cycles, docs/avr.md). */
static void can_service(void)
{
    for (;;) {
        uint8_t st;
        can_select();
        can_spi(CAN_OP_READ_STATUS);
        st = can_spi(0u);
        can_deselect();
        if (st & CAN_ST_RX0IF) {
            can_rx_take(0u);
            if (st & CAN_ST_RX1IF) {
                can_rx_take(1u);
            }
        } else if (st & CAN_ST_RX1IF) {
            can_rx_take(1u);
        } else if (st & CAN_ST_TX0IF) {
            can_bit_modify(CAN_CANINTF, CAN_INT_TX0, 0u);
            can_tx_next();
        } else {
            if (!(BOARD_CAN_INT_PIN & _BV(BOARD_CAN_INT_BIT))) {
                can_error(); /* INT low with no RX or TX flag: ERRIF, the one other enabled */
            }
            return;
        }
    }
}

/* The lock between the main loop's SPI use and the poll: the poll's interrupt off. */
static void can_lock(void)
{
    TIMSK2 &= (uint8_t)~_BV(OCIE2A);
}

/* Serve the part, locked and with interrupts on, until INT is high. What it asks for after
   the last INT check waits for the next poll, one BOARD_CAN_POLL_US at most (within a
   frame: the buffers do not overflow). */
static void can_serve(void)
{
    while (!(BOARD_CAN_INT_PIN & _BV(BOARD_CAN_INT_BIT))) {
        can_service();
    }
}

/* The main loop's unlock (interrupts on): what the part asked for meanwhile is served now,
   still locked (a poll due during the lock is not left to the next period: simavr 1.6
   drops a timer interrupt that falls due while it is masked, where the AVR would run it at
   the unlock). */
static void can_unlock(void)
{
    can_serve();
    TIMSK2 |= _BV(OCIE2A);
}

uint8_t board_can_init(void)
{
    uint8_t r[8];
    can_rx_head = can_rx_tail = 0u;
    can_rx_drop = 0u;
    can_tx_head = can_tx_tail = 0u;
    can_tx_busy = 0u;
    BOARD_CAN_INT_DDR &= (uint8_t)~_BV(BOARD_CAN_INT_BIT); /* no pull-up: the part drives INT both ways */
    BOARD_CAN_SPI_PORT |= _BV(BOARD_CAN_CS_BIT);
    BOARD_CAN_SPI_DDR |= (uint8_t)(_BV(BOARD_CAN_CS_BIT) | _BV(BOARD_CAN_SCK_BIT) | _BV(BOARD_CAN_MOSI_BIT));
    BOARD_CAN_SPI_DDR &= (uint8_t)~_BV(BOARD_CAN_MISO_BIT);
    SPCR = (uint8_t)(_BV(SPE) | _BV(MSTR)); /* mode 0,0, MSB first */
    SPSR = _BV(SPI2X);                      /* F_CPU / 2 = 8 MHz */
    can_select();
    can_spi(CAN_OP_RESET);
    can_deselect();
    _delay_us(50); /* the part's oscillator start-up after a reset: 128 of its cycles */
    /* CNF3, CNF2, CNF1, CANINTE */
    r[0] = (uint8_t)(CAN_PS2 - 1u);
    r[1] = (uint8_t)(0x80u | ((CAN_PS1 - 1u) << 3) | (CAN_PROP - 1u)); /* BTLMODE: PHSEG2 from CNF3 */
    r[2] = (uint8_t)CAN_BRP;                                           /* SJW 1 */
    r[3] = (uint8_t)(CAN_INT_RX0 | CAN_INT_RX1 | CAN_INT_TX0 | CAN_INT_ERR);
    can_write_regs(CAN_CNF3, r, 4u);
    /* the acceptance above: RXF0, RXF1 under RXM0; RXF2..RXF5 all micro_data's flow
       control under RXM1 (all 11 bits) */
    can_id_regs(NAVKIT_CAN_ID_MICRO_CMD, &r[0]);
    can_id_regs(NAVKIT_CAN_ID_MICRO_CFG_GEOMETRY, &r[4]);
    can_write_regs(CAN_RXF0, r, 8u);
    can_id_regs(NAVKIT_CAN_FC_ID_MICRO_DATA, &r[0]);
    can_id_regs(NAVKIT_CAN_FC_ID_MICRO_DATA, &r[4]);
    can_write_regs((uint8_t)(CAN_RXF0 + 8u), r, 4u);
    can_write_regs(CAN_RXF3, r, 8u);
    can_write_regs((uint8_t)(CAN_RXF3 + 8u), r, 4u);
    can_id_regs(CAN_RXM0, &r[0]);
    can_id_regs(0x7FFu, &r[4]);
    can_write_regs(CAN_RXM0_REG, r, 8u);
    can_bit_modify(CAN_RXB0CTRL, 0x64u, CAN_RXB0_BUKT); /* RXM 00: by the filters; BUKT */
    can_bit_modify(CAN_RXB1CTRL, 0x60u, 0u);
    can_bit_modify(CAN_CANCTRL, CAN_MODE_MASK, CAN_MODE_NORMAL);
    /* the INT poll: Timer2 CTC */
    TCCR2A = _BV(WGM21);
    TCCR2B = (uint8_t)(_BV(CS21) | _BV(CS20)); /* F_CPU / 32 */
    OCR2A = CAN_TIMER2_OCR;
    TIFR2 = _BV(OCF2A);
    TIMSK2 = _BV(OCIE2A);
    return (uint8_t)((can_read_reg(CAN_CANSTAT) & CAN_MODE_MASK) == CAN_MODE_NORMAL);
}

ISR(TIMER2_COMPA_vect)
{
    if (BOARD_CAN_INT_PIN & _BV(BOARD_CAN_INT_BIT)) {
        return; /* INT high: nothing asked */
    }
    can_lock();
    sei(); /* the SPI work may wait for the encoders */
    can_serve();
    cli(); /* the poll's interrupt back on with interrupts off: it never nests in itself */
    TIMSK2 |= _BV(OCIE2A);
}

uint8_t board_can_rx_ready(void)
{
    return (uint8_t)(can_rx_head != can_rx_tail);
}

uint8_t board_can_read(uint16_t *id, uint8_t data[8], uint8_t *dlc)
{
    uint8_t tail = can_rx_tail;
    const can_frame_t *f;
    uint8_t i;
    if (tail == can_rx_head) {
        return 0u;
    }
    f = &can_rx[tail & (BOARD_CAN_RX_FRAMES - 1u)];
    *id = f->id;
    *dlc = f->dlc;
    for (i = 0u; i < f->dlc; i++) {
        data[i] = f->data[i];
    }
    can_rx_tail = (uint8_t)(tail + 1u);
    return 1u;
}

uint8_t board_can_tx_free(void)
{
    return (uint8_t)(BOARD_CAN_TX_FRAMES - (uint8_t)(can_tx_head - can_tx_tail));
}

/* The frame joins the queue without the lock (the poll only takes from it); only when TXB0
   is idle does the main loop load it, locked. If the poll finds the queue empty just
   before the frame joins, it leaves TXB0 idle, which this check then sees. */
void board_can_write(uint16_t id, const uint8_t data[8])
{
    uint8_t head = can_tx_head;
    can_frame_t *f;
    uint8_t i;
    if ((uint8_t)(head - can_tx_tail) >= BOARD_CAN_TX_FRAMES) {
        return;
    }
    f = &can_tx[head & (BOARD_CAN_TX_FRAMES - 1u)];
    f->id = id;
    f->dlc = 8u;
    for (i = 0u; i < 8u; i++) {
        f->data[i] = data[i];
    }
    can_tx_head = (uint8_t)(head + 1u);
    if (!can_tx_busy) {
        can_lock();
        if (!can_tx_busy) {
            can_tx_next();
        }
        can_unlock();
    }
}

uint16_t board_can_rx_lost(void)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = can_rx_drop;
    SREG = s;
    return v;
}
