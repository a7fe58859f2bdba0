/* dio: the 12 discrete I/O bits (prefix dio_).
 * Bit n is pin n (bit 0 = DIO0.0; bits 0-3 port DIO0, 4-7 DIO1, 8-11 DIO2). */
#ifndef NAVKIT_DIO_H
#define NAVKIT_DIO_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

#define DIO_MASK 0x0FFFu /* the 12 bits */

typedef struct {
    uint16_t dir;  /* bitmask: 1 = output */
    uint16_t out;  /* bitmask: levels driven on output pins (only dir bits are ever set) */
    uint16_t safe; /* bitmask: output levels of the safe state */
    uint16_t in;   /* bitmask: last pin levels read */
} dio_t;

/* All pins inputs, nothing driven (the state before cfg_io). */
void dio_reset(dio_t *d);
/* New directions dir and safe levels safe (bitmasks); outputs go to the safe state. */
void dio_configure(dio_t *d, uint16_t dir, uint16_t safe);
/* Drive the output pins to cmd (bitmask; bits of input pins are ignored). */
void dio_command(dio_t *d, uint16_t cmd);
/* The DIO's part of a checked micro_cmd c: the outputs go to dio_command (bitmask), as
 * dio_command(). */
void dio_micro_cmd(dio_t *d, const navkit_micro_cmd_t *c);
/* Outputs to the safe state (watchdog). */
void dio_safe(dio_t *d);
/* Level of every bit: outputs as driven, inputs as read (bitmask, 12 bits). */
uint16_t dio_state(const dio_t *d);

#endif /* NAVKIT_DIO_H */
