/* board_motor.c: PWM + DIR outputs (board_motor.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_motor.h"

void board_motor_init(void)
{
    BOARD_MOTOR_PORT &= (uint8_t) ~(_BV(BOARD_MOTOR_L_PWM_BIT) | _BV(BOARD_MOTOR_R_PWM_BIT) |
                                    _BV(BOARD_MOTOR_L_DIR_BIT) | _BV(BOARD_MOTOR_R_DIR_BIT));
    BOARD_MOTOR_DDR |= (uint8_t)(_BV(BOARD_MOTOR_L_PWM_BIT) | _BV(BOARD_MOTOR_R_PWM_BIT) | _BV(BOARD_MOTOR_L_DIR_BIT) |
                                 _BV(BOARD_MOTOR_R_DIR_BIT));
    TCCR4A = _BV(WGM41);                          /* outputs disconnected until a duty is set */
    TCCR4B = _BV(WGM43) | _BV(WGM42) | _BV(CS40); /* fast PWM, TOP = ICR4, 16 MHz */
    ICR4 = BOARD_MOTOR_PWM_TOP;
    OCR4A = 0u;
    OCR4B = 0u;
}

/* PWM steps (0..TOP+1) for |duty_e4|. */
static uint16_t motor_steps(int16_t d)
{
    uint32_t a = (d < 0) ? (uint32_t)(-(int32_t)d) : (uint32_t)d;
    if (a > 10000u) {
        a = 10000u;
    }
    return (uint16_t)((a * (BOARD_MOTOR_PWM_TOP + 1u) + 5000u) / 10000u);
}

void board_motor_set(int16_t left_e4, int16_t right_e4)
{
    uint16_t nl = motor_steps(left_e4);
    uint16_t nr = motor_steps(right_e4);
    uint8_t a = _BV(WGM41);
    uint8_t s;
    if (nl != 0u) {
        a |= _BV(COM4A1);
    }
    if (nr != 0u) {
        a |= _BV(COM4B1);
    }
    s = SREG;
    cli(); /* 16-bit timer registers share one TEMP byte with the interrupts' */
    OCR4A = (nl != 0u) ? (uint16_t)(nl - 1u) : 0u;
    OCR4B = (nr != 0u) ? (uint16_t)(nr - 1u) : 0u;
    TCCR4A = a;
    if (left_e4 < 0) {
        BOARD_MOTOR_PORT |= _BV(BOARD_MOTOR_L_DIR_BIT);
    } else {
        BOARD_MOTOR_PORT &= (uint8_t)~_BV(BOARD_MOTOR_L_DIR_BIT);
    }
    if (right_e4 < 0) {
        BOARD_MOTOR_PORT |= _BV(BOARD_MOTOR_R_DIR_BIT);
    } else {
        BOARD_MOTOR_PORT &= (uint8_t)~_BV(BOARD_MOTOR_R_DIR_BIT);
    }
    SREG = s;
}

void board_motor_off(void)
{
    TCCR4A = _BV(WGM41);
}
