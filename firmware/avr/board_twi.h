/* board_twi: the gyro and the compass read over TWI by an interrupt-driven state machine
 * (prefix board_twi_).
 *
 * The first round wakes the gyro (PWR_MGMT_1 = 0) and sets its range (GYRO_CONFIG = 0:
 * +/-250 deg/s, 131 LSB per deg/s); every round then reads GYRO_ZOUT and the compass
 * bearing. board_twi_round() (from the tick interrupt) starts a round unless one runs;
 * the TWI interrupt runs it to the end. A part that does not answer (NACK, bus error)
 * ends its transfer with a STOP, keeps its last value and counts an error. */
#ifndef NAVKIT_BOARD_TWI_H
#define NAVKIT_BOARD_TWI_H

#include <stdint.h>

/* TWI on at 100 kHz, nothing read yet (gyro 0, compass 0). */
void board_twi_init(void);
/* Start a round unless one is running (the tick interrupt calls it; safe with interrupts on). */
void board_twi_round(void);
/* Latest gyro Z rate, LSB (131 per deg/s, counter-clockwise +). */
int16_t board_twi_gyro(void);
/* Latest compass bearing, deg*10 (as the part reports it). */
uint16_t board_twi_compass(void);
/* Transfers that failed (NACK, arbitration, bus error) since reset (wraps). */
uint16_t board_twi_errors(void);

#endif /* NAVKIT_BOARD_TWI_H */
