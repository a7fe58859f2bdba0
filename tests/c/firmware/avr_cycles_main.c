/* Cycle count of fw_tick() on an ATmega2560 at 16 MHz, run in simavr by avr_size.cmake
 * (MODE=cycles). Timer 1 counts CPU clocks; the wires are stubs and a crude plant moves
 * the encoders with the duty. After the gyro calibration, a forward move and a turn run
 * at once (both axes busy: the worst case); mean and max over 2000 ticks go out on UART0,
 * which simavr prints. */
#include <avr/io.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stdio.h>

#include "fw.h"

struct hal {
    int32_t enc_l, enc_r;
    int16_t gyro;
};

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
size_t hal_uart_read(hal_t *h, uint8_t *buf, size_t cap) { (void)h, (void)buf, (void)cap; return 0u; }
size_t hal_uart_tx_free(hal_t *h) { (void)h; return 0u; }
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

int main(void)
{
    uint16_t i, t0, dt, max = 0u;
    uint32_t sum = 0u;
    UCSR0B = (1 << TXEN0);
    stdout = &uart;
    TCCR1B = 1; /* timer 1 at the CPU clock */
    fw_init(&fw, &board);
    fw.cfg.received = NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK | NAVKIT_MICRO_STATUS_CFG_MOTION_OK |
                      NAVKIT_MICRO_STATUS_CFG_IO_OK; /* spec defaults, as if sent */
    for (i = 0u; i < 1100u; i++) {
        fw_tick(&fw);
    }
    motion_start(&fw.fwd, 0, 0, 0.0f, 1000.0f, 300.0f, 300.0f);
    turn_start(&fw.turn, 0, 0, 0.0f, 90.0f, 45.0f, 90.0f);
    for (i = 0u; i < 2000u; i++) {
        board.gyro = (int16_t)(i & 7u);
        t0 = TCNT1;
        fw_tick(&fw);
        dt = (uint16_t)(TCNT1 - t0);
        sum += dt;
        if (dt > max) {
            max = dt;
        }
    }
    printf("fw_tick cycles: mean %lu max %u\n", (unsigned long)(sum / 2000u), max);
    cli();
    sleep_mode(); /* simavr ends the run here */
    return 0;
}
