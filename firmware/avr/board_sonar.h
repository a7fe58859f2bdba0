/* board_sonar: four SRF04 sonars pinged one at a time (prefix board_sonar_).
 *
 * board_sonar_tick() (from the tick interrupt) steps the sequence: trigger high for one
 * tick, trigger low (the part fires), then wait for the echo; the echo's edges are timed
 * in the pin-change interrupt on Timer5 (0.5 us). Results and timeouts: board.h, Sonars.
 * Timer5 runs free with its overflow counted, a 32-bit 0.5 us clock. */
#ifndef NAVKIT_BOARD_SONAR_H
#define NAVKIT_BOARD_SONAR_H

#include <stdint.h>

/* Trigger pins low outputs, echo pins inputs with pin-change interrupts, Timer5 running,
 * every result 0, sonar 0 first. */
void board_sonar_init(void);
/* One step of the ping sequence (the tick interrupt calls it, interrupts on). */
void board_sonar_tick(void);
/* Last echo width of sonar i (0..3), us; 0 = no echo (or none measured yet). */
uint16_t board_sonar_get(uint8_t i);

#endif /* NAVKIT_BOARD_SONAR_H */
