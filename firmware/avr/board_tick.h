/* board_tick: the control-tick timer (prefix board_tick_).
 *
 * Timer3 interrupts once per tick period and counts a due tick (up to 255 pending);
 * the main loop takes them one by one (hal.h, ordering contract 1). The same interrupt
 * starts the background sensor work of the tick: an ADC sweep, a TWI round and a sonar
 * step. */
#ifndef NAVKIT_BOARD_TICK_H
#define NAVKIT_BOARD_TICK_H

#include <stdint.h>

/* Timer3 at period_us (us, 100..32767), no tick due. */
void board_tick_init(uint32_t period_us);
/* Change the period, us; a change restarts the period from now. */
void board_tick_set_period_us(uint32_t period_us);
/* 1 and one due tick consumed if a tick is due, else 0. */
uint8_t board_tick_take(void);
/* 1 if a tick is due (interrupts off: the caller's check before sleeping). */
uint8_t board_tick_due(void);
/* Ticks that arrived while 255 were already due (lost), since reset (wraps). */
uint16_t board_tick_overruns(void);

#endif /* NAVKIT_BOARD_TICK_H */
