/* board_servo: eight RC servo pulses from Timer1, one after the other (prefix board_servo_).
 *
 * Each servo owns a BOARD_SERVO_SLOT_US slot of the 20 ms frame: its pin goes high at the
 * slot's start for the pulse width, then low for the rest. Timer1 runs in CTC mode and the
 * compare interrupt sets the next interval, so the widths are exact counts of 0.5 us; the
 * pin edges move only by the interrupt's entry latency. */
#ifndef NAVKIT_BOARD_SERVO_H
#define NAVKIT_BOARD_SERVO_H

#include <stdint.h>

/* Servo pins low outputs, no pulses, Timer1 running. */
void board_servo_init(void);
/* Pulse width of servo i (0..7), us: 0 = none (pin stays low), else clamped to
 * BOARD_SERVO_MIN_US..BOARD_SERVO_MAX_US. Takes effect at that servo's next slot. */
void board_servo_set(uint8_t i, uint16_t us);

#endif /* NAVKIT_BOARD_SERVO_H */
