/* board_sim.c: the Mega 2560 of firmware/avr/board.h in simavr (board_sim.h).
 *
 * The part models are simavr IRQ clients, timed by simavr cycle timers:
 *   encoders  one timer per encoder steps the A/B pins one Gray-code edge at a time;
 *   ADC       the pin voltages are the ADC input IRQs (mV), read by simavr at each conversion;
 *   TWI       a slave model per part answers the master's address/write/read messages;
 *   sonars    a falling trigger edge schedules the echo pulse (rise 100 us later, width set);
 *   servos    pin edges of PORTA are timed: width = fall - rise;
 *   motors    read from Timer4's registers and the DIR pins when asked;
 *   CAN       the MCP2515 on the SPI and its bus (board_sim_can.c);
 *   UART0     bytes are fed to the RX IRQ one per frame time at the image's baud rate; the
 *             TX IRQ fills the read queue (simavr paces TX by the data-register-empty flag);
 *   profile   writes to GPIOR0 (board.h, BOARD_PROF_*) open and close a timed section;
 *             the stack pointer is checked after every instruction; the tick timer's
 *             interrupt requests (Timer3 compare A) time each tick's lateness.
 * Register addresses come from avr-libc's <avr/iom2560.h> (data-space addresses).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_adc.h>
#include <avr_extint.h>
#include <avr_ioport.h>
#include <avr_twi.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_cycle_timers.h>
#include <sim_elf.h>
#include <sim_hex.h>
#include <sim_io.h>
#include <sim_interrupts.h>
#include <sim_irq.h>

#include "board_sim_regs.h"

#include "board.h"
#include "board_sim.h"
#include "board_sim_can.h"

#define SIM_CYCLES_PER_US (BOARD_SIM_F_CPU_HZ / 1000000u)
#define SIM_ECHO_DELAY_US 100u      /* us: SRF04 trigger fall to echo rise (its burst) */
#define SIM_ECHO_NOOBJECT_US 36000u /* us: the SRF04's echo when nothing answers */
#define SIM_SERVO_STALE_US 100000u  /* us: no pulse for this long = not driven */
#define SIM_QUEUE_MASK (BOARD_SIM_UART_QUEUE - 1u)

/* A byte queue of BOARD_SIM_UART_QUEUE bytes (a power of two). */
typedef struct {
    uint8_t *buf;
    uint32_t head, tail; /* free-running indices */
} sim_queue_t;

/* One quadrature encoder on two pins. */
typedef struct {
    board_sim_t *b;
    avr_irq_t *pin_a, *pin_b;
    int32_t pos;      /* counts the pins show */
    int32_t target;   /* counts asked for */
    uint32_t spacing; /* cycles between edges */
    int armed;        /* its cycle timer is registered */
} sim_enc_t;

/* One SRF04. */
typedef struct {
    board_sim_t *b;
    avr_irq_t *echo;
    uint16_t width_us; /* us: the next echo; 0 = no object */
    uint32_t trig_level;
    int busy; /* an echo is on its way or high */
} sim_sonar_t;

/* One RC servo pin. */
typedef struct {
    board_sim_t *b;
    uint8_t index;
    uint32_t level;
    uint64_t rise;     /* cycle of the last rising edge */
    uint64_t fall;     /* cycle of the last falling edge (0 = none yet) */
    uint16_t width_us; /* us: the last complete pulse */
} sim_servo_t;

/* A TWI part: a register file behind a 7-bit address. */
typedef struct {
    uint8_t addr;
    uint8_t absent; /* 1: does not answer */
    uint8_t regs[128];
} sim_part_t;

struct board_sim {
    avr_t *avr;
    char err[256];
    avr_run_t run_fn; /* simavr's run function: any other means a reset is pending */
    int bootloader_clears_mcusr;
    /* parts */
    sim_enc_t enc[2]; /* 0 left, 1 right */
    avr_irq_t *adc_irq;
    int16_t gyro_raw;
    uint16_t compass;
    sim_part_t gyro, compass_part;
    sim_part_t *twi_sel; /* part addressed in the current transfer */
    int twi_want_reg;    /* the next written byte is the register pointer */
    uint8_t twi_ptr;
    avr_irq_t *twi_in;
    sim_sonar_t sonar[4];
    sim_servo_t servo[8];
    uint16_t dio_in;
    avr_irq_t *dio_pin[12];
    sim_can_t *can;
    /* UART0 */
    avr_irq_t *uart_in;
    sim_queue_t to_avr, from_avr;
    int uart_armed;
    uint32_t uart_full; /* simavr's RX FIFO is full (its XOFF IRQ) */
    uint32_t uart_dropped;
    /* profile */
    uint8_t prof_mark;
    uint64_t prof_start;
    board_sim_profile_t prof;
    uint64_t tick_due_at[256]; /* cycles: requests of the ticks not yet started, a ring */
    uint8_t tick_due_head, tick_due_tail;
};

/* ---------------------------------------------------------------- small helpers */

static void sim_errf(char *err, size_t len, const char *fmt, const char *a)
{
    if (err != NULL && len > 0u) {
        snprintf(err, len, fmt, a);
    }
}

static uint32_t sim_queue_len(const sim_queue_t *q)
{
    return q->head - q->tail;
}

static uint16_t sim_reg16(const board_sim_t *b, uint16_t lo)
{
    return (uint16_t)(b->avr->data[lo] | ((uint16_t)b->avr->data[lo + 1u] << 8));
}

/* ---------------------------------------------------------------- encoders */

/* Put the Gray state of e->pos on the pins: pos mod 4 = 0,1,2,3 -> A B = 00 10 11 01. */
static void sim_enc_show(sim_enc_t *e)
{
    uint32_t p = (uint32_t)e->pos & 3u;
    avr_raise_irq(e->pin_a, (p == 1u || p == 2u) ? 1u : 0u);
    avr_raise_irq(e->pin_b, (p == 2u || p == 3u) ? 1u : 0u);
}

static avr_cycle_count_t sim_enc_step(avr_t *avr, avr_cycle_count_t when, void *param)
{
    sim_enc_t *e = (sim_enc_t *)param;
    (void)avr;
    if (e->pos == e->target) {
        e->armed = 0;
        return 0;
    }
    e->pos += (e->target > e->pos) ? 1 : -1;
    sim_enc_show(e);
    if (e->pos == e->target) {
        e->armed = 0;
        return 0;
    }
    return when + e->spacing;
}

static void sim_enc_aim(board_sim_t *b, sim_enc_t *e, int32_t target, uint64_t by_cycle)
{
    uint64_t now = b->avr->cycle;
    uint32_t n;
    uint64_t spacing = BOARD_SIM_ENC_MIN_EDGE_CYCLES;
    e->target = target;
    if (e->armed) {
        avr_cycle_timer_cancel(b->avr, sim_enc_step, e);
        e->armed = 0;
    }
    if (target == e->pos) {
        return;
    }
    n = (uint32_t)((target > e->pos) ? (int64_t)target - e->pos : (int64_t)e->pos - target);
    if (by_cycle > now && (by_cycle - now) / n > spacing) {
        spacing = (by_cycle - now) / n;
    }
    e->spacing = (uint32_t)((spacing > 0xFFFFFFFFull) ? 0xFFFFFFFFull : spacing);
    e->armed = 1;
    avr_cycle_timer_register(b->avr, e->spacing, sim_enc_step, e);
}

/* ---------------------------------------------------------------- TWI parts */

/* The part at addr7 whether it answers or not (NULL: none there). */
static sim_part_t *sim_twi_part(board_sim_t *b, uint8_t addr7)
{
    if (addr7 == b->gyro.addr) {
        return &b->gyro;
    }
    if (addr7 == b->compass_part.addr) {
        return &b->compass_part;
    }
    return NULL;
}

/* The registers a read returns now, from the inputs. */
static void sim_twi_refresh(board_sim_t *b)
{
    /* MPU-6050: PWR_MGMT_1 bit 6 = sleep (reset value 0x40): asleep, the data registers
       hold 0; GYRO_CONFIG FS_SEL (bits 4:3) halves the sensitivity per step */
    int32_t g = 0;
    uint16_t c = b->compass;
    if (!(b->gyro.regs[BOARD_GYRO_REG_PWR_MGMT_1] & 0x40u)) {
        g = b->gyro_raw >> ((b->gyro.regs[BOARD_GYRO_REG_GYRO_CONFIG] >> 3) & 3u);
    }
    b->gyro.regs[BOARD_GYRO_REG_ZOUT_H] = (uint8_t)((uint16_t)g >> 8);
    b->gyro.regs[BOARD_GYRO_REG_ZOUT_H + 1u] = (uint8_t)g;
    /* CMPS03: register 1 the bearing as a byte (0-255 for a turn), 2/3 as deg*10 */
    b->compass_part.regs[1] = (uint8_t)((uint32_t)c * 256u / 3600u);
    b->compass_part.regs[BOARD_COMPASS_REG_BEARING] = (uint8_t)(c >> 8);
    b->compass_part.regs[BOARD_COMPASS_REG_BEARING + 1u] = (uint8_t)c;
}

static void sim_twi_out(avr_irq_t *irq, uint32_t value, void *param)
{
    board_sim_t *b = (board_sim_t *)param;
    avr_twi_msg_irq_t m;
    (void)irq;
    m.u.v = value;
    if (m.u.twi.msg & TWI_COND_STOP) {
        b->twi_sel = NULL;
    }
    if (m.u.twi.msg & TWI_COND_START) {
        b->twi_sel = sim_twi_part(b, (uint8_t)(m.u.twi.addr >> 1));
        if (b->twi_sel != NULL && b->twi_sel->absent) {
            b->twi_sel = NULL;
        }
        b->twi_want_reg = !(m.u.twi.addr & 1u);
        if (b->twi_sel != NULL) {
            sim_twi_refresh(b);
            avr_raise_irq(b->twi_in, avr_twi_irq_msg(TWI_COND_ACK, m.u.twi.addr, 1));
        }
        return;
    }
    if (b->twi_sel == NULL) {
        return; /* nobody answers: the master sees NACK */
    }
    if (m.u.twi.msg & TWI_COND_WRITE) {
        if (b->twi_want_reg) {
            b->twi_ptr = (uint8_t)(m.u.twi.data & 0x7Fu);
            b->twi_want_reg = 0;
        } else {
            b->twi_sel->regs[b->twi_ptr] = m.u.twi.data;
            b->twi_ptr = (uint8_t)((b->twi_ptr + 1u) & 0x7Fu);
        }
        avr_raise_irq(b->twi_in, avr_twi_irq_msg(TWI_COND_ACK, m.u.twi.addr, 1));
    } else if (m.u.twi.msg & TWI_COND_READ) {
        uint8_t v = b->twi_sel->regs[b->twi_ptr];
        b->twi_ptr = (uint8_t)((b->twi_ptr + 1u) & 0x7Fu);
        avr_raise_irq(b->twi_in, avr_twi_irq_msg(TWI_COND_READ, m.u.twi.addr, v));
    }
}

/* ---------------------------------------------------------------- sonars */

static avr_cycle_count_t sim_sonar_fall(avr_t *avr, avr_cycle_count_t when, void *param)
{
    sim_sonar_t *s = (sim_sonar_t *)param;
    (void)avr;
    (void)when;
    avr_raise_irq(s->echo, 0);
    s->busy = 0;
    return 0;
}

static avr_cycle_count_t sim_sonar_rise(avr_t *avr, avr_cycle_count_t when, void *param)
{
    sim_sonar_t *s = (sim_sonar_t *)param;
    uint32_t us = (s->width_us != 0u) ? s->width_us : SIM_ECHO_NOOBJECT_US;
    avr_raise_irq(s->echo, 1);
    avr_cycle_timer_register(avr, (avr_cycle_count_t)us * SIM_CYCLES_PER_US, sim_sonar_fall, s);
    (void)when;
    return 0;
}

static void sim_sonar_trig(avr_irq_t *irq, uint32_t value, void *param)
{
    sim_sonar_t *s = (sim_sonar_t *)param;
    (void)irq;
    value &= 1u;
    if (s->trig_level && !value && !s->busy) { /* the part fires on the falling edge */
        s->busy = 1;
        avr_cycle_timer_register(s->b->avr, SIM_ECHO_DELAY_US * SIM_CYCLES_PER_US, sim_sonar_rise, s);
    }
    s->trig_level = value;
}

/* ---------------------------------------------------------------- servos */

static void sim_servo_pin(avr_irq_t *irq, uint32_t value, void *param)
{
    sim_servo_t *s = (sim_servo_t *)param;
    uint64_t now = s->b->avr->cycle;
    (void)irq;
    value &= 1u;
    if (value && !s->level) {
        s->rise = now;
    } else if (!value && s->level && s->rise != 0u) {
        s->width_us = (uint16_t)((now - s->rise + SIM_CYCLES_PER_US / 2u) / SIM_CYCLES_PER_US);
        s->fall = now;
    }
    s->level = value;
}

/* ---------------------------------------------------------------- UART0 */

/* Cycles per frame (start, 8 data, stop) at the image's UBRR0 and U2X0 now. */
static uint32_t sim_uart_frame_cycles(const board_sim_t *b)
{
    uint32_t ubrr = sim_reg16(b, UBRR0) & 0x0FFFu;
    uint32_t per_bit = ((b->avr->data[UCSR0A] & (1u << U2X0)) ? 8u : 16u) * (ubrr + 1u);
    return 10u * per_bit;
}

static avr_cycle_count_t sim_uart_feed(avr_t *avr, avr_cycle_count_t when, void *param)
{
    board_sim_t *b = (board_sim_t *)param;
    (void)avr;
    if (sim_queue_len(&b->to_avr) == 0u) {
        b->uart_armed = 0;
        return 0;
    }
    /* the receiver drops bytes while off; simavr's RX FIFO (64 bytes) is emptied at its
       own frame time, which counts 11 bits (a parity bit even without parity): a full
       FIFO waits, so the link runs at 10/11 of the baud rate here */
    if ((b->avr->data[UCSR0B] & (1u << RXEN0)) && !b->uart_full) {
        avr_raise_irq(b->uart_in, b->to_avr.buf[b->to_avr.tail & SIM_QUEUE_MASK]);
        b->to_avr.tail++;
    }
    return when + sim_uart_frame_cycles(b);
}

static void sim_uart_arm(board_sim_t *b)
{
    if (!b->uart_armed && sim_queue_len(&b->to_avr) > 0u) {
        b->uart_armed = 1;
        avr_cycle_timer_register(b->avr, sim_uart_frame_cycles(b), sim_uart_feed, b);
    }
}

static void sim_uart_xoff(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    ((board_sim_t *)param)->uart_full = value;
}

static void sim_uart_out(avr_irq_t *irq, uint32_t value, void *param)
{
    board_sim_t *b = (board_sim_t *)param;
    sim_queue_t *q = &b->from_avr;
    (void)irq;
    if (sim_queue_len(q) == BOARD_SIM_UART_QUEUE) {
        q->tail++; /* full: the oldest goes */
        b->uart_dropped++;
    }
    q->buf[q->head & SIM_QUEUE_MASK] = (uint8_t)value;
    q->head++;
}

/* ---------------------------------------------------------------- profile */

/* One span of d cycles into a total and a worst (the worst saturates at 2^32 - 1 cycles). */
static void sim_prof_add(uint64_t *total, uint32_t *worst, uint64_t d)
{
    *total += d;
    if (d > *worst) {
        *worst = (uint32_t)((d > 0xFFFFFFFFull) ? 0xFFFFFFFFull : d);
    }
}

static void sim_gpior0_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    board_sim_t *b = (board_sim_t *)param;
    uint64_t now = avr->cycle;
    avr->data[addr] = v;
    if (v == b->prof_mark) {
        return;
    }
    if (b->prof_mark == BOARD_PROF_TICK) {
        b->prof.ticks++;
        sim_prof_add(&b->prof.tick_total_cycles, &b->prof.tick_worst_cycles, now - b->prof_start);
    } else if (b->prof_mark == BOARD_PROF_POLL) {
        b->prof.polls++;
        sim_prof_add(&b->prof.poll_total_cycles, &b->prof.poll_worst_cycles, now - b->prof_start);
    }
    if (v == BOARD_PROF_TICK && b->tick_due_tail != b->tick_due_head) {
        sim_prof_add(&b->prof.tick_late_total_cycles, &b->prof.tick_late_worst_cycles,
                     now - b->tick_due_at[b->tick_due_tail++]);
    }
    b->prof_mark = v;
    b->prof_start = now;
}

/* The tick timer's interrupt is requested: a tick falls due now (the image counts it in
 * that interrupt and serves due ticks oldest first, as this ring does). */
static void sim_tick_requested(avr_irq_t *irq, uint32_t value, void *param)
{
    board_sim_t *b = (board_sim_t *)param;
    (void)irq;
    /* simavr signals a compare match also while its interrupt is off (the image programs
       the timer, then clears the flag and enables it): only enabled ones make ticks */
    if (value != 0u && (b->avr->data[TIMSK3] & (1u << OCIE3A)) != 0u &&
        (uint8_t)(b->tick_due_head + 1u) != b->tick_due_tail) {
        b->tick_due_at[b->tick_due_head++] = b->avr->cycle;
    }
}

/* ---------------------------------------------------------------- resets */

/* simavr polls a low INTn pin every cycle while its interrupt might be level-triggered
 * (the reset state); the board uses edge interrupts only, so that polling (a cost on every
 * simulated cycle while the TWI and encoder pins are low) is off. Every reset turns it on
 * again. */
static void sim_no_level_polling(avr_t *avr)
{
    uint8_t n;
    for (n = 0u; n < 8u; n++) {
        avr_extint_set_strict_lvl_trig(avr, n, 0u);
    }
}

/* After a reset of the core (simavr clears the I/O registers and every cycle timer): the
 * pins show the models' levels again, and the models' timers run again. */
static void sim_after_reset(board_sim_t *b)
{
    avr_t *avr = b->avr;
    int i;
    sim_no_level_polling(avr);
    if (b->bootloader_clears_mcusr) {
        avr->data[MCUSR] = 0u; /* what the stk500v2 bootloader hands the image */
    }
    b->prof_mark = BOARD_PROF_IDLE;
    b->tick_due_head = b->tick_due_tail = 0u; /* the image starts with no tick due */
    for (i = 0; i < 2; i++) {
        sim_enc_t *e = &b->enc[i];
        uint32_t p = (uint32_t)e->pos & 3u;
        uint8_t a_bit = (i == 0) ? 5u : 3u, b_bit = (i == 0) ? 4u : 2u;
        uint16_t pin = (i == 0) ? PINE : PIND;
        avr->data[pin] = (uint8_t)((avr->data[pin] & ~((1u << a_bit) | (1u << b_bit))) |
                                   (((p == 1u || p == 2u) ? 1u : 0u) << a_bit) |
                                   (((p == 2u || p == 3u) ? 1u : 0u) << b_bit));
        e->armed = 0;
        sim_enc_aim(b, e, e->target, 0u);
    }
    for (i = 0; i < 4; i++) {
        b->sonar[i].busy = 0;
        b->sonar[i].trig_level = 0u;
        avr_raise_irq(b->sonar[i].echo, 0);
        avr->data[BOARD_SONAR_ECHO_PIN] &= (uint8_t) ~(1u << (BOARD_SONAR_ECHO_SHIFT + i));
    }
    avr->data[BOARD_DIO_LO_PIN] = (uint8_t)b->dio_in;
    avr->data[BOARD_DIO_HI_PIN] = (uint8_t)((avr->data[BOARD_DIO_HI_PIN] & ~BOARD_DIO_HI_MASK) |
                                            ((b->dio_in >> 8) & BOARD_DIO_HI_MASK));
    for (i = 0; i < 8; i++) {
        b->servo[i].level = 0u;
        b->servo[i].rise = 0u;
    }
    b->uart_armed = 0;
    b->uart_full = 0u;
    sim_uart_arm(b);
    b->twi_sel = NULL;
    sim_can_after_avr_reset(b->can);
}

/* The TWI parts at power-on (the reset pin and the watchdog reset the AVR only). */
static void sim_parts_power_on(board_sim_t *b)
{
    memset(b->gyro.regs, 0, sizeof b->gyro.regs);
    b->gyro.regs[BOARD_GYRO_REG_PWR_MGMT_1] = 0x40u; /* asleep */
    b->gyro.regs[0x75] = BOARD_GYRO_ADDR;            /* WHO_AM_I */
}

/* ---------------------------------------------------------------- loading */

/* simavr's logger for every board of the process: errors and warnings go to stderr; its
 * chatter (an ELF's "Loaded ..." lines, traces) is dropped, since stdout belongs to the
 * program embedding the board (the harness prints its own lines there). A message of a
 * core keeps that core's log level as well. */
static void sim_logger(avr_t *avr, const int level, const char *format, va_list ap)
{
    if (level > LOG_WARNING || (avr != NULL && avr->log < (uint8_t)level)) {
        return;
    }
    vfprintf(stderr, format, ap);
}

static int sim_load(board_sim_t *b, const char *path, char *err, size_t err_len)
{
    FILE *f = fopen(path, "rb");
    unsigned char head[4] = {0, 0, 0, 0};
    size_t got;
    if (f == NULL) {
        sim_errf(err, err_len, "%s: cannot open the image", path);
        return -1;
    }
    got = fread(head, 1, sizeof head, f);
    fclose(f);
    if (got == 4u && head[0] == 0x7Fu && head[1] == 'E' && head[2] == 'L' && head[3] == 'F') {
        /* room beyond the struct: the library may be built with more fields than this header */
        size_t sz = sizeof(elf_firmware_t) + 65536u;
        elf_firmware_t *fw = (elf_firmware_t *)calloc(1, sz);
        if (fw == NULL || elf_read_firmware(path, fw) != 0 || fw->flashsize == 0u) {
            free(fw);
            sim_errf(err, err_len, "%s: not a loadable AVR ELF image", path);
            return -1;
        }
        avr_load_firmware(b->avr, fw);
        free(fw);
        return 0;
    }
    if (got >= 1u && head[0] == ':') {
        ihex_chunk_p chunks = NULL;
        int n = read_ihex_chunks(path, &chunks);
        int i, loaded = 0;
        if (n <= 0) {
            sim_errf(err, err_len, "%s: not a valid Intel HEX file", path);
            return -1;
        }
        for (i = 0; i < n; i++) {
            if (chunks[i].baseaddr + chunks[i].size <= b->avr->flashend + 1u) {
                avr_loadcode(b->avr, chunks[i].data, chunks[i].size, chunks[i].baseaddr);
                loaded = 1;
            }
        }
        free_ihex_chunks(chunks);
        if (!loaded) {
            sim_errf(err, err_len, "%s: no flash data in the HEX file", path);
            return -1;
        }
        return 0;
    }
    sim_errf(err, err_len, "%s: neither an ELF nor an Intel HEX image", path);
    return -1;
}

static void sim_sleep_none(avr_t *avr, avr_cycle_count_t howLong)
{
    (void)avr; /* simulated time only: never wait for the wall clock */
    (void)howLong;
}

/* ---------------------------------------------------------------- API */

board_sim_t *board_sim_new(const char *image_path, char *err, size_t err_len)
{
    board_sim_t *b = (board_sim_t *)calloc(1, sizeof *b);
    avr_t *avr;
    uint32_t flags = 0u;
    int i;
    if (b == NULL) {
        sim_errf(err, err_len, "%s: out of memory", image_path);
        return NULL;
    }
    b->to_avr.buf = (uint8_t *)malloc(BOARD_SIM_UART_QUEUE);
    b->from_avr.buf = (uint8_t *)malloc(BOARD_SIM_UART_QUEUE);
    avr_global_logger_set(sim_logger);
    avr = avr_make_mcu_by_name(BOARD_MCU_NAME);
    if (b->to_avr.buf == NULL || b->from_avr.buf == NULL || avr == NULL) {
        sim_errf(err, err_len, "%s: simavr has no atmega2560 core (or out of memory)", image_path);
        board_sim_free(b);
        return NULL;
    }
    b->avr = avr;
    avr_init(avr);
    sim_no_level_polling(avr);
    avr->log = LOG_NONE;
    if (sim_load(b, image_path, err, err_len) != 0) {
        board_sim_free(b);
        return NULL;
    }
    avr->frequency = BOARD_SIM_F_CPU_HZ;
    avr->vcc = avr->avcc = avr->aref = BOARD_ADC_REF_MV;
    avr->sleep = sim_sleep_none;
    avr->pc = 0u;
    b->run_fn = avr->run;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags); /* no console echo, no polling sleep */

    /* encoders */
    b->enc[0].pin_a = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_ENC_L_PORT_NAME), BOARD_ENC_L_SHIFT + 1);
    b->enc[0].pin_b = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_ENC_L_PORT_NAME), BOARD_ENC_L_SHIFT);
    b->enc[1].pin_a = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_ENC_R_PORT_NAME), BOARD_ENC_R_SHIFT + 1);
    b->enc[1].pin_b = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_ENC_R_PORT_NAME), BOARD_ENC_R_SHIFT);
    for (i = 0; i < 2; i++) {
        b->enc[i].b = b;
        sim_enc_show(&b->enc[i]);
    }
    /* ADC: hal channel ch is ADCch */
    b->adc_irq = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0);
    for (i = 0; i < (int)BOARD_ADC_CHANNELS; i++) {
        avr_raise_irq(b->adc_irq + i, 0);
    }
    /* TWI parts */
    b->gyro.addr = BOARD_GYRO_ADDR;
    b->compass_part.addr = BOARD_COMPASS_ADDR;
    b->compass_part.regs[0] = 15u; /* software revision */
    b->twi_in = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), sim_twi_out, b);
    /* sonars */
    for (i = 0; i < 4; i++) {
        sim_sonar_t *s = &b->sonar[i];
        s->b = b;
        s->echo = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_SONAR_ECHO_PORT_NAME), BOARD_SONAR_ECHO_SHIFT + i);
        avr_irq_register_notify(
            avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_SONAR_TRIG_PORT_NAME), BOARD_SONAR_TRIG_SHIFT + i),
            sim_sonar_trig, s);
    }
    /* servos */
    for (i = 0; i < 8; i++) {
        b->servo[i].b = b;
        b->servo[i].index = (uint8_t)i;
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_SERVO_PORT_NAME), i), sim_servo_pin,
                                &b->servo[i]);
    }
    /* DIO inputs */
    for (i = 0; i < 12; i++) {
        b->dio_pin[i] = (i < 8) ? avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_DIO_LO_PORT_NAME), i)
                                : avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(BOARD_DIO_HI_PORT_NAME), i - 8);
    }
    /* UART0 */
    b->uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), sim_uart_out, b);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), sim_uart_xoff, b);
    /* CAN */
    b->can = sim_can_new(avr);
    if (b->can == NULL) {
        sim_errf(err, err_len, "%s: out of memory", image_path);
        board_sim_free(b);
        return NULL;
    }
    /* profile */
    avr_register_io_write(avr, GPIOR0, sim_gpior0_write, b);
    avr_irq_register_notify(avr_get_interrupt_irq(avr, TIMER3_COMPA_vect_num) + AVR_INT_IRQ_PENDING, sim_tick_requested,
                            b);
    b->prof.stack_min_sp = BOARD_RAMEND;
    /* a power-on start */
    avr->data[MCUSR] = (uint8_t)(1u << PORF);
    sim_parts_power_on(b);
    sim_after_reset(b);
    return b;
}

void board_sim_free(board_sim_t *b)
{
    if (b == NULL) {
        return;
    }
    if (b->avr != NULL) {
        avr_terminate(b->avr);
        free(b->avr);
    }
    sim_can_free(b->can);
    free(b->to_avr.buf);
    free(b->from_avr.buf);
    free(b);
}

/* A cycle timer that only ends a sleep: the core, asleep, skips to the next timer, so one
 * at the target keeps board_sim_run_until() from running past it. */
static avr_cycle_count_t sim_stop_at(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    (void)when;
    (void)param;
    return 0;
}

int board_sim_run_until(board_sim_t *b, uint64_t cycle)
{
    avr_t *avr = b->avr;
    if (avr->cycle < cycle) {
        avr_cycle_timer_register(avr, (avr_cycle_count_t)(cycle - avr->cycle), sim_stop_at, b);
    }
    while (avr->cycle < cycle) {
        int state;
        uint16_t sp;
        if (avr->run != b->run_fn) { /* simavr's watchdog queued a reset for this call */
            b->prof.resets++;
            b->prof.watchdog_resets++;
            avr_run(avr);
            sim_after_reset(b);
            if (avr->cycle < cycle) { /* the reset cleared every cycle timer, this one too */
                avr_cycle_timer_register(avr, (avr_cycle_count_t)(cycle - avr->cycle), sim_stop_at, b);
            }
            continue;
        }
        state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            snprintf(b->err, sizeof b->err, "the AVR core stopped at cycle %llu, pc 0x%05x (%s)",
                     (unsigned long long)avr->cycle, (unsigned)avr->pc,
                     (state == cpu_Done) ? "sleep with interrupts off" : "crashed");
            return -1;
        }
        sp = (uint16_t)(avr->data[R_SPL] | ((uint16_t)avr->data[R_SPH] << 8));
        if (sp < b->prof.stack_min_sp) {
            b->prof.stack_min_sp = sp;
        }
    }
    return 0;
}

uint64_t board_sim_cycles(const board_sim_t *b)
{
    return b->avr->cycle;
}

const char *board_sim_error(const board_sim_t *b)
{
    return b->err;
}

void board_sim_set_encoders(board_sim_t *b, int32_t left_counts, int32_t right_counts, uint64_t by_cycle)
{
    sim_enc_aim(b, &b->enc[0], left_counts, by_cycle);
    sim_enc_aim(b, &b->enc[1], right_counts, by_cycle);
}

void board_sim_set_adc_mv(board_sim_t *b, uint8_t ch, uint16_t mv)
{
    if (ch < BOARD_ADC_CHANNELS) {
        avr_raise_irq(b->adc_irq + ch, (mv > BOARD_ADC_REF_MV) ? BOARD_ADC_REF_MV : mv);
    }
}

void board_sim_set_gyro_raw(board_sim_t *b, int16_t lsb)
{
    b->gyro_raw = lsb;
}

void board_sim_set_compass(board_sim_t *b, uint16_t deg10)
{
    b->compass = (uint16_t)(deg10 % 3600u);
}

void board_sim_set_sonar_echo_us(board_sim_t *b, uint8_t i, uint16_t us)
{
    if (i < 4u) {
        b->sonar[i].width_us = us;
    }
}

void board_sim_set_twi_part_present(board_sim_t *b, uint8_t addr7, int on)
{
    sim_part_t *p = sim_twi_part(b, addr7);
    if (p != NULL) {
        p->absent = (uint8_t)!on;
    }
}

void board_sim_set_dio_in(board_sim_t *b, uint16_t levels)
{
    int i;
    b->dio_in = (uint16_t)(levels & 0x0FFFu);
    for (i = 0; i < 12; i++) {
        avr_raise_irq(b->dio_pin[i], (levels >> i) & 1u);
    }
}

void board_sim_motor_duty(const board_sim_t *b, int16_t *left_e4, int16_t *right_e4)
{
    const uint8_t *d = b->avr->data;
    uint32_t top = (uint32_t)sim_reg16(b, ICR4) + 1u;
    uint8_t com = d[TCCR4A];
    uint8_t dir = d[BOARD_MOTOR_PORT];
    uint32_t l = (com & (1u << COM4A1)) ? ((uint32_t)sim_reg16(b, OCR4A) + 1u) : 0u;
    uint32_t r = (com & (1u << COM4B1)) ? ((uint32_t)sim_reg16(b, OCR4B) + 1u) : 0u;
    if (l > top) {
        l = top;
    }
    if (r > top) {
        r = top;
    }
    l = (l * 10000u + top / 2u) / top;
    r = (r * 10000u + top / 2u) / top;
    *left_e4 = (int16_t)((dir & (1u << BOARD_MOTOR_L_DIR_BIT)) ? -(int32_t)l : (int32_t)l);
    *right_e4 = (int16_t)((dir & (1u << BOARD_MOTOR_R_DIR_BIT)) ? -(int32_t)r : (int32_t)r);
}

uint16_t board_sim_servo_pulse_us(const board_sim_t *b, uint8_t i)
{
    const sim_servo_t *s;
    if (i >= 8u) {
        return 0u;
    }
    s = &b->servo[i];
    if (s->fall == 0u || b->avr->cycle - s->fall > (uint64_t)SIM_SERVO_STALE_US * SIM_CYCLES_PER_US) {
        return 0u;
    }
    return s->width_us;
}

void board_sim_dio(const board_sim_t *b, uint16_t *dir, uint16_t *levels)
{
    const uint8_t *d = b->avr->data;
    uint16_t ddr = (uint16_t)(d[BOARD_DIO_LO_DDR] | ((uint16_t)(d[BOARD_DIO_HI_DDR] & BOARD_DIO_HI_MASK) << 8));
    uint16_t port = (uint16_t)(d[BOARD_DIO_LO_PORT] | ((uint16_t)(d[BOARD_DIO_HI_PORT] & BOARD_DIO_HI_MASK) << 8));
    *dir = ddr;
    *levels = (uint16_t)((port & ddr) | (b->dio_in & (uint16_t)~ddr));
}

void board_sim_uart_write(board_sim_t *b, const uint8_t *buf, size_t len)
{
    sim_queue_t *q = &b->to_avr;
    size_t i;
    for (i = 0u; i < len; i++) {
        if (sim_queue_len(q) == BOARD_SIM_UART_QUEUE) {
            b->uart_dropped += (uint32_t)(len - i);
            break;
        }
        q->buf[q->head & SIM_QUEUE_MASK] = buf[i];
        q->head++;
    }
    sim_uart_arm(b);
}

size_t board_sim_uart_read(board_sim_t *b, uint8_t *buf, size_t cap)
{
    sim_queue_t *q = &b->from_avr;
    size_t n = 0u;
    while (n < cap && sim_queue_len(q) > 0u) {
        buf[n++] = q->buf[q->tail & SIM_QUEUE_MASK];
        q->tail++;
    }
    return n;
}

uint32_t board_sim_uart_dropped(const board_sim_t *b)
{
    return b->uart_dropped;
}

void board_sim_can_write(board_sim_t *b, uint16_t id, const uint8_t *data, uint8_t dlc)
{
    sim_can_write(b->can, id, data, dlc);
}

int board_sim_can_read(board_sim_t *b, board_sim_can_frame_t *out)
{
    return sim_can_read(b->can, out);
}

void board_sim_can_stats(const board_sim_t *b, board_sim_can_stats_t *out)
{
    sim_can_stats(b->can, out);
}

void board_sim_can_hold_int(board_sim_t *b, int held)
{
    sim_can_hold_int(b->can, held);
}

void board_sim_profile(const board_sim_t *b, board_sim_profile_t *out)
{
    *out = b->prof;
    out->tick_mean_cycles = (b->prof.ticks != 0u) ? (uint32_t)(b->prof.tick_total_cycles / b->prof.ticks) : 0u;
    out->poll_mean_cycles = (b->prof.polls != 0u) ? (uint32_t)(b->prof.poll_total_cycles / b->prof.polls) : 0u;
    out->stack_max_bytes = (uint16_t)(BOARD_RAMEND - b->prof.stack_min_sp);
}

void board_sim_reset(board_sim_t *b, int cause)
{
    avr_t *avr = b->avr;
    uint8_t flag = (uint8_t)(1u << EXTRF);
    if (cause == BOARD_SIM_RESET_POWER_ON) {
        /* SRAM comes up with arbitrary contents */
        uint32_t x = 0x2545F491u;
        uint32_t a;
        for (a = 0x200u; a <= BOARD_RAMEND; a++) {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            avr->data[a] = (uint8_t)x;
        }
        flag = (uint8_t)(1u << PORF);
        sim_parts_power_on(b);
    } else if (cause == BOARD_SIM_RESET_BROWN_OUT) {
        flag = (uint8_t)(1u << BORF);
    }
    avr_reset(avr);
    avr->data[MCUSR] = flag;
    b->prof.resets++;
    sim_after_reset(b);
}

void board_sim_set_bootloader_clears_mcusr(board_sim_t *b, int on)
{
    b->bootloader_clears_mcusr = on;
}
