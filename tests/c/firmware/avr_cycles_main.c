/* Cycle count of fw_tick() and the deepest stack on an ATmega2560 at 16 MHz, run in simavr
 * by avr_size.cmake (MODE=cycles). Timer 1 counts CPU clocks; the wires are stubs and a
 * crude plant moves the encoders with the duty. The three configs and then micro_cmd
 * frames (a forward move and a turn at once: both axes busy, the worst case) arrive through
 * the UART stub every 100 ticks, so fw_link_poll() decodes them and encodes a micro_data
 * reply (the deepest call chain). Mean and max cycles of fw_tick over 2000 ticks, and the
 * stack depth (bytes below RAMEND ever written, found by painting the free RAM first) go
 * out on UART0, which simavr prints. */
#include <avr/io.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stdio.h>

#include "fw.h"

struct hal {
    int32_t enc_l, enc_r;
    int16_t gyro;
    uint8_t rx[4u * NAVKIT_MAX_FRAME_BYTES]; /* frames waiting for fw_link_poll() */
    uint16_t rx_len, rx_pos;
};

extern uint8_t __heap_start; /* first byte above .data/.bss (avr-libc linker symbol) */
#define STACK_PAINT 0xA5u

static struct hal board;
static fw_t fw;

int32_t hal_enc_left(hal_t *h) { return h->enc_l; }
int32_t hal_enc_right(hal_t *h) { return h->enc_r; }
int16_t hal_gyro_raw(hal_t *h) { return h->gyro; }
uint16_t hal_compass(hal_t *h) { (void)h; return 0u; }
uint16_t hal_adc(hal_t *h, uint8_t ch) { (void)h; return ch; }
uint16_t hal_sonar_echo(hal_t *h, uint8_t i) { (void)h; return i; }
uint16_t hal_dio_in(hal_t *h) { (void)h; return 0u; }
void hal_motor(hal_t *h, int16_t l, int16_t r)
{
    h->enc_l += l / 2000;
    h->enc_r += r / 2000;
}
void hal_servo_pulse(hal_t *h, uint8_t i, uint16_t us) { (void)h, (void)i, (void)us; }
void hal_dio_write(hal_t *h, uint16_t dir, uint16_t out) { (void)h, (void)dir, (void)out; }
size_t hal_uart_read(hal_t *h, uint8_t *buf, size_t cap)
{
    size_t n = 0u;
    while (n < cap && h->rx_pos < h->rx_len) {
        buf[n++] = h->rx[h->rx_pos++];
    }
    return n;
}
size_t hal_uart_tx_free(hal_t *h) { (void)h; return 1024u; }
void hal_uart_write(hal_t *h, const uint8_t *buf, size_t len) { (void)h, (void)buf, (void)len; }

static int uart_put(char c, FILE *f)
{
    (void)f;
    while (!(UCSR0A & (1 << UDRE0))) {
    }
    UDR0 = (uint8_t)c;
    return 0;
}
static FILE uart = FDEV_SETUP_STREAM(uart_put, NULL, _FDEV_SETUP_WRITE);

/* Queue one encoded frame for the UART stub. */
static void send(uint16_t n)
{
    board.rx_len = (uint16_t)(board.rx_len + n);
}

/* Queue a micro_cmd: forward 1000 mm and turn 90 deg at once (1 = start, 3 = modify). */
static void send_cmd(uint16_t tag, uint16_t code)
{
    navkit_micro_cmd_t c;
    navkit_micro_cmd_defaults(&c);
    c.time_tag = tag;
    c.fwd_cmd = code;
    c.speed = 300;
    c.distance = 1000;
    c.turn_cmd = code;
    c.turn_rate = 450;
    c.turn_distance = 900;
    c.mc_datalog_cmd = NAVKIT_MC_DATALOG_TURN_PROFILE;
    board.rx_pos = board.rx_len = 0u;
    send((uint16_t)navkit_micro_cmd_encode(&c, board.rx, sizeof board.rx));
}

int main(void)
{
    uint16_t i, t0, dt, max = 0u;
    uint32_t sum = 0u;
    uint8_t *p;
    /* paint the free RAM between .bss and this frame; what is not paint later was stack */
    for (p = &__heap_start; p < (uint8_t *)SP - 32; p++) {
        *p = STACK_PAINT;
    }
    UCSR0B = (1 << TXEN0);
    stdout = &uart;
    TCCR1B = 1; /* timer 1 at the CPU clock */
    fw_init(&fw, &board);
    {
        navkit_micro_cfg_geometry_t g;
        navkit_micro_cfg_motion_t m;
        navkit_micro_cfg_io_t io;
        navkit_micro_cfg_geometry_defaults(&g);
        navkit_micro_cfg_motion_defaults(&m);
        navkit_micro_cfg_io_defaults(&io);
        send((uint16_t)navkit_micro_cfg_geometry_encode(&g, board.rx, sizeof board.rx));
        send((uint16_t)navkit_micro_cfg_motion_encode(&m, board.rx + board.rx_len, sizeof board.rx - board.rx_len));
        send((uint16_t)navkit_micro_cfg_io_encode(&io, board.rx + board.rx_len, sizeof board.rx - board.rx_len));
    }
    fw_link_poll(&fw);
    for (i = 0u; i < 1100u; i++) {
        fw_tick(&fw);
    }
    send_cmd(1u, NAVKIT_FWD_CMD_START);
    for (i = 0u; i < 2000u; i++) {
        if (i % 100u == 0u) {
            send_cmd((uint16_t)(2u + i / 100u), (i == 0u) ? NAVKIT_FWD_CMD_START : NAVKIT_FWD_CMD_MODIFY);
        }
        fw_link_poll(&fw);
        board.gyro = (int16_t)(i & 7u);
        t0 = TCNT1;
        fw_tick(&fw);
        dt = (uint16_t)(TCNT1 - t0);
        sum += dt;
        if (dt > max) {
            max = dt;
        }
    }
    for (p = &__heap_start; *p == STACK_PAINT; p++) {
    }
    printf("fw_tick cycles: mean %lu max %u\n", (unsigned long)(sum / 2000u), max);
    printf("stack bytes: %u\n", (unsigned)((uint8_t *)RAMEND + 1 - p));
    printf("configured: %u moved: %ld\n", (unsigned)((fw_status(&fw) & NAVKIT_MICRO_STATUS_CONFIGURED) != 0u),
           (long)board.enc_l);
    cli();
    sleep_mode(); /* simavr ends the run here */
    return 0;
}
