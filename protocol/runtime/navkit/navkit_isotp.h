/* navkit_isotp: ISO 15765-2 (ISO-TP) on classic CAN for the micro link, both ends (the
 * firmware's CAN transport, the host's SLCAN link). Hand-written runtime beside the frame
 * parser (navkit_wire.h); the generated navkit_proto.h includes this header when the spec
 * has a CAN mapping.
 *
 * The spec's [can] mapping (docs/protocol.md, CAN): each serial frame, whole, is one ISO-TP
 * message on its message's 11-bit identifier, every CAN frame padded to 8 data bytes, the
 * receiver's flow control on the message's fc identifier. Portable C99, no heap: each
 * buffer holds the largest frame of either direction (NAVKIT_ISOTP_MAX_BYTES).
 *
 * Receiving (navkit_isotp_rx_*), as ISO 15765-2 defines it and navkit.can does it in Python:
 *   - a single frame (PCI 0x0L, L 1..7) completes a message at once;
 *   - a first frame (0x1L LL, length 8..4095) starts one and asks for a flow control
 *     (continue, NAVKIT_CAN_FC_BLOCK_SIZE, NAVKIT_CAN_FC_ST_MIN), or an overflow when it
 *     is longer than the buffer (counted in overflow);
 *   - consecutive frames (0x2N) must come in sequence (N = 1, 2, .. 15, 0, ..): one out
 *     of sequence (lost, reordered) aborts the message (wrong_sn); one with no message in
 *     progress is ignored (unexpected);
 *   - a first or single frame during a reception aborts it (restarted), then counts as
 *     itself; no consecutive frame for NAVKIT_CAN_N_CR_MS ms aborts it (timeout);
 *   - a frame on a receiving identifier that is no well-formed ISO-TP frame (fewer than
 *     8 data bytes, extended or remote, PCI type 3-15, a bad length) is refused (bad_frame);
 *     frames on other identifiers are other nodes' traffic, ignored.
 * Sending (navkit_isotp_tx_*): one message at a time; the first frame, then the consecutive
 * frames as the flow control allows (block size; STmin in whole ms, a sub-ms STmin taken
 * as 1 ms); a wait flow control restarts the NAVKIT_CAN_N_BS_MS wait, an overflow or an
 * invalid status abandons the message, as does no flow control within that wait. The
 * sender may also abort a message it is sending (navkit_isotp_tx_abort: a stop that must
 * not wait behind an unfinished command); its receiver drops the part it got when the
 * next first or single frame comes (restarted), as ISO 15765-2 lets a new message pre-empt.
 * Times are the caller's ms clock (wrapping uint32 arithmetic). No statics: all state is
 * in the structs, so several can coexist.
 */
#ifndef NAVKIT_ISOTP_H
#define NAVKIT_ISOTP_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Flags a target ORs into a received identifier: such frames are refused. */
#define NAVKIT_ISOTP_EXT 0x8000u     /* an extended (29-bit) identifier frame */
#define NAVKIT_ISOTP_RTR 0x4000u     /* a remote frame */
#define NAVKIT_ISOTP_ID_MASK 0x07FFu /* the 11-bit identifier */

/* bytes: a receive or send buffer, the largest frame of either direction */
#define NAVKIT_ISOTP_MAX_BYTES                                                                                         \
    (NAVKIT_CAN_MAX_TO_MICRO_BYTES > NAVKIT_CAN_MAX_TO_HOST_BYTES ? NAVKIT_CAN_MAX_TO_MICRO_BYTES                      \
                                                                  : NAVKIT_CAN_MAX_TO_HOST_BYTES)

/* One classic CAN data frame as the core sends it: 11-bit identifier, 8 data bytes. */
typedef struct {
    uint16_t id;
    uint8_t data[8];
} navkit_isotp_frame_t;

/* Receiver counters (wrap). */
typedef struct {
    uint16_t good;       /* messages completed */
    uint16_t bad_frame;  /* frames refused */
    uint16_t wrong_sn;   /* messages aborted by a consecutive frame out of sequence */
    uint16_t unexpected; /* consecutive frames with no message in progress, ignored */
    uint16_t restarted;  /* messages aborted by a new first or single frame */
    uint16_t timeout;    /* messages aborted for want of the next consecutive frame (N_Cr) */
    uint16_t overflow;   /* first frames longer than the buffer, answered with an overflow */
} navkit_isotp_rx_stats_t;

typedef struct {
    uint8_t buf[NAVKIT_ISOTP_MAX_BYTES]; /* the message being received, or the one just completed */
    uint16_t have;                       /* bytes in buf */
    uint16_t want;                       /* bytes of the message in progress */
    uint16_t id;                         /* its identifier */
    uint32_t deadline_ms;                /* ms: abort unless the next consecutive frame comes by then */
    navkit_dir_t dir;                    /* the messages accepted: those travelling towards dir */
    uint8_t active;                      /* 1 while a message is in progress */
    uint8_t sn;                          /* sequence number of the next consecutive frame, 0..15 */
    uint8_t block;                       /* consecutive frames left in this block (0: no block size) */
    navkit_isotp_rx_stats_t stats;
} navkit_isotp_rx_t;

/* Sender counters (wrap). */
typedef struct {
    uint16_t sent;     /* messages sent whole */
    uint16_t busy;     /* starts refused while a message was being sent */
    uint16_t timeout;  /* messages abandoned for want of a flow control (N_Bs) */
    uint16_t overflow; /* messages abandoned on an overflow flow control */
    uint16_t bad_fc;   /* malformed flow controls, and messages abandoned on an invalid status */
    uint16_t wait;     /* wait flow controls */
    uint16_t aborted;  /* messages the caller abandoned unfinished (navkit_isotp_tx_abort) */
} navkit_isotp_tx_stats_t;

typedef struct {
    uint8_t buf[NAVKIT_ISOTP_MAX_BYTES]; /* the message: the caller writes it, then navkit_isotp_tx_start() */
    uint16_t len;                        /* bytes of the message (0: idle) */
    uint16_t done;                       /* bytes sent so far */
    uint16_t id;                         /* identifier of its frames */
    uint16_t fc_id;                      /* identifier of its receiver's flow control */
    uint32_t deadline_ms;                /* ms: while waiting, abandon unless a flow control comes by then */
    uint32_t next_ms;                    /* ms: when the next consecutive frame may go */
    uint8_t st_ms;                       /* ms between consecutive frames (the flow control's STmin) */
    uint8_t waiting;                     /* 1: the first frame went, no flow control yet */
    uint8_t block;                       /* consecutive frames left before the next flow control (0: all) */
    uint8_t sn;                          /* sequence number of the next consecutive frame */
    navkit_isotp_tx_stats_t stats;
} navkit_isotp_tx_t;

/* Empty receiver for the messages travelling towards dir, zero counters. */
void navkit_isotp_rx_init(navkit_isotp_rx_t *rx, navkit_dir_t dir);
/* Handle one received frame (id: 11-bit identifier | NAVKIT_ISOTP_EXT/NAVKIT_ISOTP_RTR; dlc 0..8 data
 * bytes) at now_ms. Returns the bytes of the message it completes (in rx->buf, valid until
 * the next call), else 0. Sets *fc_out = 1 and fills *fc when a flow control must go out. */
uint16_t navkit_isotp_rx_frame(navkit_isotp_rx_t *rx, uint16_t id, const uint8_t *data, uint8_t dlc, uint32_t now_ms,
                               navkit_isotp_frame_t *fc, uint8_t *fc_out);
/* Abort a message whose next consecutive frame is overdue at now_ms (N_Cr). */
void navkit_isotp_rx_poll(navkit_isotp_rx_t *rx, uint32_t now_ms);

/* Idle sender, zero counters. */
void navkit_isotp_tx_init(navkit_isotp_tx_t *tx);
/* 1 while a message is being sent. */
uint8_t navkit_isotp_tx_busy(const navkit_isotp_tx_t *tx);
/* Send the len bytes (1..NAVKIT_ISOTP_MAX_BYTES) the caller wrote into tx->buf, as the frames of
 * message type msg_type, from now_ms. Returns 1, or 0 (counted in busy) while another
 * message is being sent or for a bad len or msg_type. */
uint8_t navkit_isotp_tx_start(navkit_isotp_tx_t *tx, uint16_t len, uint16_t msg_type, uint32_t now_ms);
/* Abandon the message being sent, if any (counted in aborted): the sender is idle at once,
 * and the next navkit_isotp_tx_start() begins a new message with its first or single frame.
 * Returns 1 if a message was abandoned, 0 if none was being sent. */
uint8_t navkit_isotp_tx_abort(navkit_isotp_tx_t *tx);
/* Take a frame seen on the bus: a flow control for the message being sent (others are ignored). */
void navkit_isotp_tx_frame(navkit_isotp_tx_t *tx, uint16_t id, const uint8_t *data, uint8_t dlc, uint32_t now_ms);
/* The next frame due at now_ms into *out: 1, or 0 when none is (abandons a message whose
 * flow control is overdue). Call until 0 while the bus takes frames. */
uint8_t navkit_isotp_tx_next(navkit_isotp_tx_t *tx, uint32_t now_ms, navkit_isotp_frame_t *out);

#ifdef __cplusplus
}
#endif
#endif /* NAVKIT_ISOTP_H */
