/* main.c: the navkit firmware on the Arduino Mega 2560.
 *
 * Start: reset cause, board peripherals, fw_init(), the tick timer at the core's period,
 * the watchdog, interrupts on. Main loop (hal.h, ordering contract 1): feed the watchdog;
 * run fw_tick() for one due tick (GPIOR0 marks it for the board simulator's profile);
 * when no tick is due and bytes wait on UART0 or the last poll stopped at its one-frame
 * bound (FW_LINK_FRAMES_PER_POLL = 1, fw_link_pending()), fw_link_poll() (marked too) and then
 * follow the tick period the core has now (a config may change the rate); with nothing to
 * do, sleep until an interrupt. A tick that falls due during a long poll runs right after
 * it: none is lost (up to 255 pending).
 * The image built with the CAN link (FW_LINK_CAN = 1, navkit-mega2560-can) polls the link
 * when a CAN frame waits in board_can's RX ring instead of UART0, and once after every tick
 * as well: the micro_data frames ISO-TP still holds go out as the TX queue empties, and the
 * ISO-TP timeouts run, with no frame coming in. Each poll applies one reassembled frame at
 * most (FW_LINK_FRAMES_PER_POLL = 1, as on the UART).
 *
 * BOARD_TEST=1 builds the test image (navkit-mega2560-test): levels set on the DIO pins
 * (inputs from reset) select a test mode checked once per pass: BOARD_TEST_HANG hangs the
 * loop (the watchdog must reset the board), BOARD_TEST_ECHO sends every UART0 byte back
 * instead of polling the link, BOARD_TEST_HOLD stops reading UART0 (the RX ring fills and
 * overflows). The control ticks run in every mode. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "board.h"
#include "board_adc.h"
#include "board_can.h"
#include "board_enc.h"
#include "board_motor.h"
#include "board_reset.h"
#include "board_servo.h"
#include "board_sonar.h"
#include "board_tick.h"
#include "board_twi.h"
#include "board_uart.h"
#include "fw.h"
#include "link.h"

#if FW_LINK_CAN
#define MAIN_LINK_RX_READY() board_can_rx_ready()
#else
#define MAIN_LINK_RX_READY() board_uart_rx_ready()
#endif

#ifndef BOARD_TEST
#define BOARD_TEST 0
#endif
#define BOARD_TEST_HANG 0xA5Au /* DIO levels: hang the main loop */
#define BOARD_TEST_ECHO 0x5A5u /* DIO levels: echo UART0 */
#define BOARD_TEST_HOLD 0x3C3u /* DIO levels: leave UART0 RX unread */

extern struct hal board_hal; /* board_hal.c */
static fw_t board_fw;

#if BOARD_TEST
/* The test mode the DIO pins select; 1 if it took this pass (no link poll). */
static uint8_t main_test_mode(void)
{
    uint16_t m = hal_dio_in(&board_hal);
    if (m == BOARD_TEST_HANG) {
        for (;;) {
        }
    }
    if (m == BOARD_TEST_ECHO) {
        uint8_t buf[16];
        size_t room = board_uart_tx_free();
        size_t n = board_uart_read(buf, (room < sizeof buf) ? room : sizeof buf);
        board_uart_write(buf, n);
        return 1u;
    }
    return (uint8_t)(m == BOARD_TEST_HOLD);
}
#endif

int main(void)
{
    uint8_t poll_after_tick = 0u; /* CAN: one poll is owed to the tick that just ran */
    board_reset_init();
    board_uart_init();
    board_motor_init();
    board_servo_init();
    board_enc_init();
    board_adc_init();
    board_twi_init();
    board_sonar_init();
#if FW_LINK_CAN
    (void)board_can_init(); /* without a part the link stays silent; the rest runs */
#endif
    fw_init(&board_fw, &board_hal);
    board_tick_init(fw_tick_period_us(&board_fw));
    board_reset_watchdog_start();
    set_sleep_mode(SLEEP_MODE_IDLE);
    sei();
    for (;;) {
        board_reset_watchdog_feed();
        if (board_tick_take()) {
            GPIOR0 = BOARD_PROF_TICK;
            fw_tick(&board_fw);
            GPIOR0 = BOARD_PROF_IDLE;
            poll_after_tick = (uint8_t)FW_LINK_CAN;
            continue;
        }
#if BOARD_TEST
        if (main_test_mode()) {
            continue;
        }
#endif
        if (MAIN_LINK_RX_READY() || fw_link_pending(&board_fw) || poll_after_tick) {
            poll_after_tick = 0u;
            GPIOR0 = BOARD_PROF_POLL;
            fw_link_poll(&board_fw);
            GPIOR0 = BOARD_PROF_IDLE;
            board_tick_set_period_us(fw_tick_period_us(&board_fw));
            continue;
        }
        cli();
        if (!board_tick_due() && !MAIN_LINK_RX_READY() && !fw_link_pending(&board_fw)) {
            sleep_enable();
            sei(); /* the instruction after sei runs first: no wake-up is missed */
            sleep_cpu();
            sleep_disable();
        }
        sei();
    }
}
