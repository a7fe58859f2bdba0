/* board_servo.c: sequential servo pulses (board_servo.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_servo.h"

#define SERVO_COUNTS_PER_US 2u /* Timer1 at 16 MHz / 8 */

static volatile uint16_t servo_counts[8]; /* 0.5 us counts of each pulse, 0 = none */
static uint8_t servo_slot;                /* slot in progress, or the next one while the last ends */
static uint8_t servo_pin;                 /* its PORTA bit */
static uint8_t servo_high;                /* 1 while its pulse is high */
static uint16_t servo_cur;                /* counts of its pulse (taken when the slot before ended) */

void board_servo_init(void)
{
    uint8_t i;
    for (i = 0u; i < 8u; i++) {
        servo_counts[i] = 0u;
    }
    BOARD_SERVO_PORT = 0u;
    BOARD_SERVO_DDR = 0xFFu;
    servo_slot = 7u;
    servo_pin = 0x80u;
    servo_high = 0u;
    servo_cur = 0u;
    TCCR1A = 0u;
    TCCR1B = _BV(WGM12) | _BV(CS11); /* CTC on OCR1A, 16 MHz / 8 */
    TCNT1 = 0u;
    OCR1A = (uint16_t)(BOARD_SERVO_SLOT_US * SERVO_COUNTS_PER_US - 1u);
    TIFR1 = _BV(OCF1A);
    TIMSK1 = _BV(OCIE1A);
}

void board_servo_set(uint8_t i, uint16_t us)
{
    uint16_t c;
    uint8_t s;
    if (us != 0u) {
        if (us < BOARD_SERVO_MIN_US) {
            us = BOARD_SERVO_MIN_US;
        } else if (us > BOARD_SERVO_MAX_US) {
            us = BOARD_SERVO_MAX_US;
        }
    }
    c = (uint16_t)(us * SERVO_COUNTS_PER_US);
    s = SREG;
    cli();
    servo_counts[i & 7u] = c;
    SREG = s;
}

/* Take the next slot's servo and width (after a slot's pulse, or its empty slot). */
static inline void servo_next(void)
{
    servo_slot = (uint8_t)((servo_slot + 1u) & 7u);
    servo_pin = (uint8_t)((servo_pin << 1) | (servo_pin >> 7)); /* 1 << slot, without a shift loop */
    servo_cur = servo_counts[servo_slot];
}

/* Both edges are the first thing their branch does, so they move by the same entry
 * latency and the width stays exact; the next slot is prepared after the falling edge. */
ISR(TIMER1_COMPA_vect)
{
    if (servo_high) {
        BOARD_SERVO_PORT &= (uint8_t)~servo_pin;
        servo_high = 0u;
        OCR1A = (uint16_t)(BOARD_SERVO_SLOT_US * SERVO_COUNTS_PER_US - servo_cur - 1u);
        servo_next();
    } else if (servo_cur != 0u) {
        BOARD_SERVO_PORT |= servo_pin;
        servo_high = 1u;
        OCR1A = (uint16_t)(servo_cur - 1u);
    } else {
        OCR1A = (uint16_t)(BOARD_SERVO_SLOT_US * SERVO_COUNTS_PER_US - 1u);
        servo_next();
    }
}
