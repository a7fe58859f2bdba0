/* board_can: the MCP2515 CAN controller on the SPI (board.h, CAN), the CAN wires of hal.h
 * in the image built with the CAN link (prefix board_can_).
 *
 * Reception: Timer2 interrupts every BOARD_CAN_POLL_US; when the part's INT line is low it
 * reads the part (interrupts on) into an RX ring of BOARD_CAN_RX_FRAMES frames, oldest
 * first (a full ring drops the new frame and counts it); a receive-buffer overflow the part
 * flags (EFLG RXnOVR, through its error interrupt) is counted too. Transmission: frames queue in a
 * TX ring of BOARD_CAN_TX_FRAMES and leave one at a time through the part's TXB0, in the
 * order queued (the part's three buffers would reorder equal-priority frames, and ISO-TP's
 * consecutive frames must keep their order); the next is loaded when TXB0's interrupt
 * flag says the last one went.
 * The part accepts the identifiers the micro receives (the spec's [can.ids]: the frames of
 * micro_cmd and the three configs, the flow control of micro_data) by its masks and
 * filters, every burst two buffers deep (board_can.c says how; a few unused identifiers
 * pass too and the link ignores them), at the spec's bit rate (NAVKIT_CAN_BITRATE) from
 * BOARD_CAN_OSC_HZ. */
#ifndef NAVKIT_BOARD_CAN_H
#define NAVKIT_BOARD_CAN_H

#include <stdint.h>

/* Reset the part, set bit timing, masks and filters, normal mode; start the INT poll.
 * Interrupts off (main() turns them on). Returns 1 if the part answered in normal mode, 0
 * if not (no part on the SPI: the image runs on, every frame it sends stays queued). */
uint8_t board_can_init(void);
/* 1 if a received frame waits in the RX ring. */
uint8_t board_can_rx_ready(void);
/* Take the oldest received frame: 1 with *id (11 bits, ORed with NAVKIT_ISOTP_EXT /
 * NAVKIT_ISOTP_RTR), data[0..*dlc-1], *dlc (0..8); 0 if none waits. Main loop only. */
uint8_t board_can_read(uint16_t *id, uint8_t data[8], uint8_t *dlc);
/* Frames the TX ring can take now. */
uint8_t board_can_tx_free(void);
/* Queue a data frame: 11-bit id, 8 data bytes (the caller checks board_can_tx_free()).
 * Main loop only. */
void board_can_write(uint16_t id, const uint8_t data[8]);
/* Frames lost since init before board_can_read() could return them: those dropped for a
 * full RX ring, plus one for each receive-buffer overflow the part flagged (it keeps a
 * flag per buffer, not a count); wraps. */
uint16_t board_can_rx_lost(void);

#endif /* NAVKIT_BOARD_CAN_H */
