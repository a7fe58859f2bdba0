/* board_servo.c: sequential servo pulses (board_servo.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_servo.h"

#define SERVO_COUNTS_PER_US 2u /* Timer1 at 16 MHz / 8 */

static volatile uint16_t servo_counts[8]; /* 0.5 us counts of each pulse, 0 = none */
static uint8_t servo_slot;  /* slot in progress */
static uint8_t servo_high;  /* 1 while its pulse is high */
static uint16_t servo_cur;  /* counts of the pulse in progress */

void board_servo_init(void)
{
    uint8_t i;
    for (i = 0u; i < 8u; i++) {
        servo_counts[i] = 0u;
    }
    BOARD_SERVO_PORT = 0u;
    BOARD_SERVO_DDR = 0xFFu;
    servo_slot = 7u;
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

ISR(TIMER1_COMPA_vect)
{
    if (servo_high) {
        BOARD_SERVO_PORT &= (uint8_t)~(1u << servo_slot);
        servo_high = 0u;
        OCR1A = (uint16_t)(BOARD_SERVO_SLOT_US * SERVO_COUNTS_PER_US - servo_cur - 1u);
    } else {
        uint16_t c;
        servo_slot = (uint8_t)((servo_slot + 1u) & 7u);
        c = servo_counts[servo_slot];
        if (c != 0u) {
            BOARD_SERVO_PORT |= (uint8_t)(1u << servo_slot);
            servo_high = 1u;
            servo_cur = c;
            OCR1A = (uint16_t)(c - 1u);
        } else {
            OCR1A = (uint16_t)(BOARD_SERVO_SLOT_US * SERVO_COUNTS_PER_US - 1u);
        }
    }
}
