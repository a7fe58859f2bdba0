/* hal.h: the one seam between the portable firmware core and a target.
 *
 * A target (the AVR board, the firmware FMU, a unit-test fake) defines `struct hal`
 * and every function below; the core never touches a register or a global. The
 * functions are explicit "wires", one per signal, in the style of simavr's IRQs.
 *
 * Ordering contract (the core keeps it; a target may rely on it):
 *   1. The target calls fw_link_poll() between control ticks: never inside one, and a
 *      tick never pre-empts it (the poll applies commands and configs to the state the
 *      tick uses and reads that state for micro_data). Only fw_link_poll() calls
 *      hal_uart_*; it reads the UART RX until hal_uart_read() returns 0, and writes a
 *      whole micro_data frame only when hal_uart_tx_free() says it fits (otherwise that
 *      frame is skipped, never half-sent). Bound: a build with FW_LINK_FRAMES_PER_POLL
 *      = N (link.h; the AVR image: 1) handles at most N complete frames per call,
 *      returns after the Nth with the later bytes left in the RX (and its parser), and
 *      sends that frame's micro_data in the next call, which does nothing else (each
 *      frame's reply still goes out before the next frame is handled); while
 *      fw_link_pending() is 1 the target calls fw_link_poll() again, after any due tick,
 *      even with the RX empty. Without it (0, the default) a call handles every frame
 *      there is and answers each at once. So with N = 1 a due tick waits for one piece
 *      of link work at most (one frame decoded and applied, or one micro_data built and
 *      sent), never for a backlog of frames. A slow target (a 16 MHz AVR at 400 Hz,
 *      where a tick takes most of its period) counts due ticks in its timer interrupt
 *      and runs fw_tick() for each from its main loop, fw_link_poll() when none is due;
 *      a delayed tick then runs late, none lost (docs/firmware.md, AVR budget;
 *      docs/avr.md, tick lateness).
 *   2. The target calls fw_tick() once per control period (fw_tick_period_us()).
 *      fw_tick() calls every input wire (hal_enc_*, hal_gyro_raw, hal_compass,
 *      hal_adc, hal_sonar_echo, hal_dio_in) at its start, exactly once each, and the
 *      output wires at its end, at most once each: hal_motor every tick;
 *      hal_servo_pulse(i) and hal_dio_write on the first tick after fw_init() and then
 *      on each tick whose value differs from the one they last got, so the target holds
 *      the last value of each (an output is a level, not an event). Inputs are therefore
 *      one consistent sample per tick and outputs change only at tick boundaries.
 *   3. Every function returns at once (no waiting) and is called with the `hal`
 *      pointer given to fw_init().
 */
#ifndef NAVKIT_HAL_H
#define NAVKIT_HAL_H

#include <stddef.h>
#include <stdint.h>

typedef struct hal hal_t; /* defined by the target */

/* ---- input wires: sampled at the start of each tick ---- */

/* Left wheel encoder, quadrature x4 counts since power-up, raw sign (the core applies
 * enc_left_sign); wraps modulo 2^32. */
int32_t hal_enc_left(hal_t *hal);
/* Right wheel encoder, counts, raw sign; wraps modulo 2^32. */
int32_t hal_enc_right(hal_t *hal);
/* Yaw-rate gyro, LSB (sensitivity gyro_lsb_per_dps), counter-clockwise positive. */
int16_t hal_gyro_raw(hal_t *hal);
/* Compass bearing, deg*10, 0..3599, clockwise from north. */
uint16_t hal_compass(hal_t *hal);
/* ADC channel ch (0..FW_ADC_CHANNELS-1 = 0..4: IR 0-3, battery), counts 0..1023 (10 bit,
 * 5.0 V reference). The firmware reads no other channel. */
uint16_t hal_adc(hal_t *hal, uint8_t ch);
/* SRF04 sonar i (0..3): last echo pulse width, us; 0 = no echo. */
uint16_t hal_sonar_echo(hal_t *hal, uint8_t i);
/* DIO pin levels, bit n = pin n (12 bits), as read from the port. */
uint16_t hal_dio_in(hal_t *hal);

/* ---- the start: read once, by fw_init() ---- */

/* Why the board last started, a NAVKIT_RESET_CAUSE_* code (power-on, external reset,
 * watchdog, brown-out, unknown), reported in micro_data.reset_cause. */
uint8_t hal_reset_cause(hal_t *hal);

/* ---- output wires: written at the end of a tick (servo pulses and DIO only when they
 * change: the target holds each; ordering contract 2) ---- */

/* Motor PWM duty, units of 1e-4 (-10000..10000), + drives the wheel forward after the
 * motor sign from config has been applied by the core. */
void hal_motor(hal_t *hal, int16_t left_duty_e4, int16_t right_duty_e4);
/* RC servo i (0..7) pulse width, us; 0 = not driven. */
void hal_servo_pulse(hal_t *hal, uint8_t i, uint16_t pulse_us);
/* DIO: dir bit = 1 makes the pin an output; out = levels of the output pins (12 bits). */
void hal_dio_write(hal_t *hal, uint16_t dir, uint16_t out);

/* ---- UART (the micro link): only from fw_link_poll() ---- */

/* Copy up to cap received bytes into buf; returns how many (0 = RX empty). */
size_t hal_uart_read(hal_t *hal, uint8_t *buf, size_t cap);
/* Bytes the TX FIFO can take now. */
size_t hal_uart_tx_free(hal_t *hal);
/* Queue len bytes for sending; the core never passes more than hal_uart_tx_free(). */
void hal_uart_write(hal_t *hal, const uint8_t *buf, size_t len);

/* ---- CAN (the micro link of a build with FW_LINK_CAN = 1, instead of the UART): only
 * from fw_link_poll(), which reads the RX until hal_can_read() returns 0 (with
 * FW_LINK_FRAMES_PER_POLL, until it has one whole message: the bound above) and writes a
 * frame only when hal_can_tx_free() is above 0 (a serial build never calls these, and its
 * target need not define them) ---- */

/* Take the oldest received frame: 1 with *id (the 11-bit identifier, ORed with
 * NAVKIT_ISOTP_EXT for an extended frame, NAVKIT_ISOTP_RTR for a remote one: navkit/navkit_isotp.h), data[0..*dlc-1]
 * and *dlc (data bytes, 0..8); 0 if none is waiting. */
uint8_t hal_can_read(hal_t *hal, uint16_t *id, uint8_t data[8], uint8_t *dlc);
/* Frames the TX queue can take now. */
uint8_t hal_can_tx_free(hal_t *hal);
/* Queue a classic data frame: 11-bit identifier, 8 data bytes. */
void hal_can_write(hal_t *hal, uint16_t id, const uint8_t data[8]);
/* Frames lost since start before hal_can_read() could return them (a full receive queue,
 * a receive-buffer overflow of the CAN controller: each overflow it flags counts once),
 * wraps; 0 for a target that loses none. micro_data.can_rx_lost. */
uint16_t hal_can_rx_lost(hal_t *hal);

#endif /* NAVKIT_HAL_H */
