/* board_motor: the H-bridge's PWM and DIR pins (prefix board_motor_). */
#ifndef NAVKIT_BOARD_MOTOR_H
#define NAVKIT_BOARD_MOTOR_H

#include <stdint.h>

/* Timer4 at 20 kHz, both outputs off (PWM pins low), DIR pins low. */
void board_motor_init(void);
/* Duty*1e4 of each motor (-10000..10000, beyond is clamped): |duty| on the PWM pin,
 * rounded to the nearest of 800 steps; DIR low for >= 0, high for < 0. */
void board_motor_set(int16_t left_e4, int16_t right_e4);
/* Both motors off now (PWM pins low); safe from an interrupt. */
void board_motor_off(void);

#endif /* NAVKIT_BOARD_MOTOR_H */
