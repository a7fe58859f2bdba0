/* board_hal.c: the wires of firmware/core/hal.h on the Mega 2560 (board.h names the pins).
 *
 * Inputs return the latest value the background work (interrupts) measured, at once;
 * outputs go to the timers and ports at once. The DIO pins are read and written here. The
 * image built with the CAN link (FW_LINK_CAN = 1) has the CAN wires (board_can), the serial
 * one the UART's only. */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_adc.h"
#include "board_can.h"
#include "board_enc.h"
#include "board_motor.h"
#include "board_reset.h"
#include "board_servo.h"
#include "board_sonar.h"
#include "board_twi.h"
#include "board_uart.h"
#include "hal.h"
#include "link.h"

struct hal {
    uint8_t unused; /* the board's state lives in its modules (their interrupts share it) */
};

int32_t hal_enc_left(hal_t *hal)
{
    (void)hal;
    return board_enc_left();
}
int32_t hal_enc_right(hal_t *hal)
{
    (void)hal;
    return board_enc_right();
}
int16_t hal_gyro_raw(hal_t *hal)
{
    (void)hal;
    return board_twi_gyro();
}
uint16_t hal_compass(hal_t *hal)
{
    uint16_t c = board_twi_compass();
    (void)hal;
    return (c > 3599u) ? (uint16_t)(c % 3600u) : c;
}
uint16_t hal_adc(hal_t *hal, uint8_t ch)
{
    (void)hal;
    return board_adc_get(ch);
}
uint16_t hal_sonar_echo(hal_t *hal, uint8_t i)
{
    (void)hal;
    return board_sonar_get(i);
}
uint16_t hal_dio_in(hal_t *hal)
{
    (void)hal;
    return (uint16_t)(BOARD_DIO_LO_PIN | ((uint16_t)(BOARD_DIO_HI_PIN & BOARD_DIO_HI_MASK) << 8));
}
uint8_t hal_reset_cause(hal_t *hal)
{
    (void)hal;
    return board_reset_cause();
}
void hal_motor(hal_t *hal, int16_t left_duty_e4, int16_t right_duty_e4)
{
    (void)hal;
    board_motor_set(left_duty_e4, right_duty_e4);
}
void hal_servo_pulse(hal_t *hal, uint8_t i, uint16_t pulse_us)
{
    (void)hal;
    board_servo_set(i, pulse_us);
}
void hal_dio_write(hal_t *hal, uint16_t dir, uint16_t out)
{
    uint8_t hi_dir = (uint8_t)((dir >> 8) & BOARD_DIO_HI_MASK);
    uint8_t hi_out = (uint8_t)((out >> 8) & hi_dir);
    (void)hal;
    /* levels first, then directions: a pin turning output starts at its level; inputs get
       no pull-up (PORT bit 0) */
    BOARD_DIO_LO_PORT = (uint8_t)(out & dir);
    BOARD_DIO_LO_DDR = (uint8_t)dir;
    /* PORTL/DDRL bits 4-7 are not ours: only the main loop writes these registers */
    BOARD_DIO_HI_PORT = (uint8_t)((BOARD_DIO_HI_PORT & (uint8_t)~BOARD_DIO_HI_MASK) | hi_out);
    BOARD_DIO_HI_DDR = (uint8_t)((BOARD_DIO_HI_DDR & (uint8_t)~BOARD_DIO_HI_MASK) | hi_dir);
}
size_t hal_uart_read(hal_t *hal, uint8_t *buf, size_t cap)
{
    (void)hal;
    return board_uart_read(buf, cap);
}
size_t hal_uart_tx_free(hal_t *hal)
{
    (void)hal;
    return board_uart_tx_free();
}
void hal_uart_write(hal_t *hal, const uint8_t *buf, size_t len)
{
    (void)hal;
    board_uart_write(buf, len);
}

#if FW_LINK_CAN
uint8_t hal_can_read(hal_t *hal, uint16_t *id, uint8_t data[8], uint8_t *dlc)
{
    (void)hal;
    return board_can_read(id, data, dlc);
}
uint8_t hal_can_tx_free(hal_t *hal)
{
    (void)hal;
    return board_can_tx_free();
}
void hal_can_write(hal_t *hal, uint16_t id, const uint8_t data[8])
{
    (void)hal;
    board_can_write(id, data);
}
uint16_t hal_can_rx_lost(hal_t *hal)
{
    (void)hal;
    return board_can_rx_lost();
}
#endif

/* The one board instance main() gives the core. */
struct hal board_hal;
