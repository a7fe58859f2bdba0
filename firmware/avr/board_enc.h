/* board_enc: the two quadrature encoders, x4 decoded in their pin interrupts (prefix board_enc_).
 *
 * Every edge of A or B raises its external interrupt (INT2-INT5, any edge); the interrupt
 * reads both pins of that encoder and steps the count by the Gray-code transition from the
 * last state (+1 A leading B). A transition that skips a state (both pins changed: an edge
 * was missed) does not count. */
#ifndef NAVKIT_BOARD_ENC_H
#define NAVKIT_BOARD_ENC_H

#include <stdint.h>

/* Pins as inputs, counts 0 from the current pin states, interrupts on. */
void board_enc_init(void);
/* Left count, x4 counts since reset (wraps modulo 2^32). Main loop only (it folds the
 * interrupt's accumulator); call at least every 0.6 s. */
int32_t board_enc_left(void);
/* Right count, x4 counts since reset. */
int32_t board_enc_right(void);

#endif /* NAVKIT_BOARD_ENC_H */
