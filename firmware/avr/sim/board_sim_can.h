/* board_sim_can.h: the simulated board's MCP2515 and its CAN bus (prefix sim_can_), inside
 * navkit_board_sim: board_sim.c owns one and forwards board_sim_can_* (board_sim.h) here.
 *
 * The part sits on the AVR's SPI (the board times each byte at the SPI clock the image
 * sets: board_sim_can.c, can_spdr_write), its CS on a port pin (PB0) and its INT on
 * another (PK0), as board.h wires them. It models the instructions the driver
 * (firmware/avr/board_can.c) uses and a few more: RESET, READ, WRITE, BIT MODIFY, READ
 * STATUS, RX STATUS, LOAD TX BUFFER, RTS, READ RX BUFFER; configuration and normal mode
 * (REQOP -> OPMOD at once); CNF1-3 bit timing; the acceptance masks and filters, RXB0
 * rollover (BUKT) into RXB1, overflow flags (EFLG RXnOVR, ERRIF); CANINTE/CANINTF and the INT line;
 * TXBnCTRL.TXREQ and the buffer priority. Not modelled: extended frames (the bus carries
 * 11-bit data frames), error counters and states, loopback, listen-only and sleep modes
 * (off the bus like configuration mode), the RXnBF/TXnRTS pins, CLKOUT.
 *
 * The bus: one frame at a time, 47 + 8 x DLC bits (no stuff bits) at the bus bit rate;
 * when it falls idle, the lowest identifier among the next host frame and the part's
 * requested buffers wins (equal: the host's). A frame is taken off its sender only when
 * acknowledged: the part acknowledges (and receives, through its filters) only in normal
 * mode with its bit timing at the bus rate; the host's end acknowledges every frame of the
 * part at the bus rate. So host frames wait while the part is held in reset or
 * configuration, as a real adapter repeats an unacknowledged frame. */
#ifndef NAVKIT_BOARD_SIM_CAN_H
#define NAVKIT_BOARD_SIM_CAN_H

#include <sim_avr.h>

#include "board_sim.h"

typedef struct sim_can sim_can_t;

/* The part (after its power-on reset) wired to avr's SPI, CS and INT pins; the bus at
 * the spec's bit rate (NAVKIT_CAN_BITRATE). NULL if out of memory or avr has no SPI. */
sim_can_t *sim_can_new(avr_t *avr);
/* Free it (NULL is fine). */
void sim_can_free(sim_can_t *c);
/* After a reset of the AVR (simavr cleared its pins and cycle timers): the INT pin shows
 * the part's level again; a frame on the bus is cut off (its sender sends it again). The
 * part itself keeps its state (its own reset is the RESET instruction). */
void sim_can_after_avr_reset(sim_can_t *c);
/* board_sim.h's board_sim_can_* (the same contracts). */
void sim_can_write(sim_can_t *c, uint16_t id, const uint8_t *data, uint8_t dlc);
int sim_can_read(sim_can_t *c, board_sim_can_frame_t *out);
void sim_can_stats(const sim_can_t *c, board_sim_can_stats_t *out);
void sim_can_hold_int(sim_can_t *c, int held);

#endif /* NAVKIT_BOARD_SIM_CAN_H */
