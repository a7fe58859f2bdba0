/* link: the micro link, between control ticks (prefix link_).
 *
 * The link frames, checks and dispatches: it owns the parser, the counters, the checks of
 * a micro_cmd, the configured/unconfigured and time-tag rules below, and micro_data; each
 * module executes its own part of a micro_cmd (heading_, odom_, motion_, turn_, excite_,
 * dio_, servo_micro_cmd()), config_ checks and applies a config and fw_config_applied()
 * brings the modules' state along.
 *
 * Bytes from hal_uart_read() go through the generated frame parser. Per valid frame:
 *   - micro_cmd: feeds the watchdog; a new time tag is handled once (executed, or
 *     refused and counted), a repeated one is not re-executed; one refused only because
 *     the micro is unconfigured is handled once more at its first repeat after the configs,
 *     as that repeat holds it (checked like a new command: refused and counted if it
 *     fails, else run), unless it was the first micro_cmd since reset (maybe a stale
 *     repeat of what ran before the reset; never runs) or a watchdog stop came in
 *     between (not run: a repeat never resumes motion);
 *   - micro_cfg_*: feeds the watchdog; applied, or refused (wrong spec_hash: counted in
 *     rx_schema_mismatch; out of range: counted in cmd_rejected); a frame of another
 *     spec's length never reaches here: the parser counts it in its schema_mismatch,
 *     which rx_schema_mismatch adds in;
 *   - then one micro_data goes back (if the TX FIFO has room for the whole frame): there
 *     is no other request mechanism, a received frame is the request for telemetry.
 * A micro_cmd is executed whole or not at all: it is refused (cmd_rejected + 1,
 * last_reject = the code, as the spec's flags `reject` describe it) for an unknown or
 * unimplemented fwd_cmd or turn_cmd, for a HdgSel heading outside -3600..3600 (deg*10;
 * last_reject = 10), for a field out of its spec range (last_reject =
 * NAVKIT_REJECT_RANGE | 1), and, every micro_cmd, while unconfigured (last_reject =
 * fwd_cmd, or turn_cmd when fwd_cmd is 0, or NAVKIT_REJECT_UNCONFIGURED | 1 when both
 * are 0: servos, DIO, dg_control and the datalog selection wait for the configs too).
 * A refused config counts in cmd_rejected with last_reject =
 * NAVKIT_REJECT_RANGE | its msg_type (or in rx_schema_mismatch for a wrong spec_hash).
 * A fwd_cmd/turn_cmd 3 with no 1 to modify is refused with its code; a 3 after a stop
 * latch is ignored without counting (the latch shows in the status).
 */
#ifndef NAVKIT_LINK_H
#define NAVKIT_LINK_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

/* The transport of the micro link, chosen by the build: 0 the UART (hal_uart_*), 1 CAN
   (hal_can_*: each frame one ISO-TP message, navkit/navkit_isotp.h, which navkit_proto.h
   includes). Above the transport all is the same:
   the reassembled frames go through the same parser, counters and rules. */
#ifndef FW_LINK_CAN
#define FW_LINK_CAN 0
#endif
struct fw;

/* bytes: the most link_poll() asks of one hal_uart_read() call (its buffer on the stack);
   it reads chunk after chunk until the UART is empty, so this bounds the stack, not the
   bytes per poll */
#define LINK_RX_CHUNK 16u

/* frames: the most one link_poll() handles on the UART (hal.h, ordering contract 1); 0 =
   no bound: it drains the UART, handles every complete frame and answers each at once. A
   target whose frame takes a large share of its tick period sets 1 (the AVR image): the
   bytes after that frame stay in the UART's RX (and the parser) for the next poll, the
   frame's micro_data goes out in the next poll (before any later frame is handled), and
   link_pending() says when a poll is due although the UART may be empty. On CAN (one
   ISO-TP message is one frame) the bound is one message a poll, its reply built in the
   next (link.c). */
#ifndef FW_LINK_FRAMES_PER_POLL
#define FW_LINK_FRAMES_PER_POLL 0u
#endif

typedef struct {
    navkit_parser_t parser;   /* frame parser and its counters */
    uint16_t last_tag;        /* time tag of the last handled micro_cmd */
    uint16_t ack_tag;         /* time tag of the last executed micro_cmd */
    uint16_t tx_tag;          /* micro_data sequence number */
    uint16_t schema_mismatch; /* configs refused for spec_hash */
    uint16_t cmd_rejected;    /* commands refused */
    uint16_t last_reject;     /* code of the last refused command */
    uint16_t mc_datalog;      /* NAVKIT_MC_DATALOG_* selection */
    uint8_t have_tag;         /* a micro_cmd was handled since reset */
    uint8_t tag_pending;      /* last_tag was refused only for want of the configs (never ran): its repeat runs */
    uint8_t more;             /* the last poll stopped at FW_LINK_FRAMES_PER_POLL: the parser may hold a frame */
    uint8_t reply_due;        /* a micro_data is still to go out: with a bound, the last frame's (next poll);
                                over CAN, one asked while the last was going out (once the sender is free) */
#if FW_LINK_CAN
    navkit_isotp_rx_t can_rx; /* ISO-TP reception of host -> micro frames (and its counters) */
    navkit_isotp_tx_t can_tx; /* ISO-TP transmission of micro_data */
#endif
} link_t;

/* Empty parser, zero counters, no time tag seen. */
void link_reset(link_t *l);
/* Drain the UART (or, with FW_LINK_CAN, the CAN RX, and send what ISO-TP lets go) and
 * handle every complete frame; with FW_LINK_FRAMES_PER_POLL, at most that many frames,
 * the UART read only up to the last of them, or only the reply left due by the poll
 * before (see the contract in hal.h). */
void link_poll(struct fw *fw);
/* 1 if the last link_poll() stopped at its frame bound (FW_LINK_FRAMES_PER_POLL) or left a
 * reply due: call it again even with the UART empty (the bytes it has read may hold
 * another frame; the reply goes out then). */
uint8_t link_pending(const struct fw *fw);
/* Fill d with the current telemetry (what the next micro_data will carry, except its
 * own time tag). */
void link_telemetry(const struct fw *fw, navkit_micro_data_t *d);

#endif /* NAVKIT_LINK_H */
