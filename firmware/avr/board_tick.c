/* board_tick.c: Timer3 control tick (board_tick.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_adc.h"
#include "board_sonar.h"
#include "board_tick.h"
#include "board_twi.h"

static volatile uint8_t tick_due; /* written by this interrupt and, interrupts off, by the main loop */
static volatile uint16_t tick_lost;
static uint32_t tick_period_us; /* us: the period Timer3 runs at */

/* Program Timer3 for period_us, counting from 0 now. */
static void tick_program(uint32_t period_us)
{
    uint8_t s;
    uint32_t c;
    if (period_us < 100u) {
        period_us = 100u;
    } else if (period_us > 32767u) {
        period_us = 32767u;
    }
    tick_period_us = period_us;
    c = period_us * BOARD_TICK_COUNTS_PER_US - 1u;
    s = SREG;
    cli(); /* 16-bit timer registers share one TEMP byte with the interrupts' */
    OCR3A = (uint16_t)c;
    TCNT3 = 0u;
    SREG = s;
}

void board_tick_init(uint32_t period_us)
{
    tick_due = 0u;
    tick_lost = 0u;
    TCCR3A = 0u;
    TCCR3B = _BV(WGM32) | _BV(CS31); /* CTC on OCR3A, 16 MHz / 8 */
    tick_program(period_us);
    TIFR3 = _BV(OCF3A);
    TIMSK3 = _BV(OCIE3A);
}

void board_tick_set_period_us(uint32_t period_us)
{
    if (period_us != tick_period_us) {
        tick_program(period_us);
    }
}

/* Nestable (interrupts on from its first instruction): the encoder interrupts must not
 * wait for the sensor starts below. The Timer3 flag is cleared on entry, so it cannot nest
 * in itself; the callees guard what they share with other interrupts. */
ISR(TIMER3_COMPA_vect, ISR_NOBLOCK)
{
    if (tick_due != 255u) {
        tick_due++;
    } else {
        tick_lost++;
    }
    board_adc_sweep();
    board_twi_round();
    board_sonar_tick();
}

uint8_t board_tick_take(void)
{
    uint8_t s = SREG;
    uint8_t r = 0u;
    cli();
    if (tick_due != 0u) {
        tick_due--;
        r = 1u;
    }
    SREG = s;
    return r;
}

uint8_t board_tick_due(void)
{
    return (uint8_t)(tick_due != 0u);
}

uint16_t board_tick_overruns(void)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = tick_lost;
    SREG = s;
    return v;
}
