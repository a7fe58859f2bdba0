/* lockstep: one host frame of the co-simulation harness's lockstep loop in native code
 * (tools/navkit/sim/lockstep.py), for the frames where nothing but the frame itself
 * happens: the serial link, the host running, no fault in force. Part of navkit_cosim.
 *
 * A frame is two calls, the harness's Python logging between them and after:
 *
 *   lockstep_host():  bump the planner heartbeat (rcomm); send the tick (frame, simulated
 *                     time in us, bytes written to the host's port since the last tick);
 *                     wait for its done (tx_bytes, flags); read the host's lisp_data
 *                     (rcomm); read exactly tx_bytes from the pty;
 *   lockstep_micro(): the frame's FMU steps (cosim_run) in two chunks, the host's bytes
 *                     arriving at the firmware with the first step; after each chunk the
 *                     firmware's bytes are written to the pty.
 *
 * The tick and done records are docs/internals.md's, with the magics the caller passes
 * (navkit.sim.links.TICK_MAGIC, DONE_MAGIC: navkit.sim.links.Lockstep packs the same
 * records); the reads and writes keep navkit.sim.links.Port's contract, with the waits the
 * caller passes (links.READ_WAIT_S, WRITE_WAIT_S): a read waits at most read_ms for bytes
 * the host reported; a write the host does not drain waits at most write_ms for room, then
 * the rest is dropped and counted.
 */
#ifndef NAVKIT_LOCKSTEP_H
#define NAVKIT_LOCKSTEP_H

#include <stddef.h>
#include <stdint.h>

#include "cosim.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Results of lockstep_host / lockstep_micro. */
enum {
    LOCKSTEP_OK = 0,           /* done: the outputs are in `out` */
    LOCKSTEP_GONE = 1,         /* lockstep_host: EOF or a reset instead of the done (the host went away) */
    LOCKSTEP_BIG = 2,          /* lockstep_host: the done reports more bytes than the host buffer holds: */
                               /* nothing read, the caller reads them (and lisp_data) itself */
    LOCKSTEP_ERR_TIMEOUT = -1, /* no done within the socket's receive timeout (a send's is LOCKSTEP_ERR_OS) */
    LOCKSTEP_ERR_MAGIC = -2,   /* the done's magic is wrong: out[LOCKSTEP_DETAIL] has it */
    LOCKSTEP_ERR_FRAME = -3,   /* the done is for another frame: out[LOCKSTEP_DETAIL] has its number */
    LOCKSTEP_ERR_SHORT = -4,   /* fewer pty bytes than reported within read_ms: out[LOCKSTEP_DETAIL] read */
    LOCKSTEP_ERR_OS = -5,      /* a system call failed: out[LOCKSTEP_ERRNO] has errno */
    LOCKSTEP_ERR_RCOMM = -6,   /* the heartbeat or the lisp_data read returned < 0 (the region is gone) */
    LOCKSTEP_ERR_COSIM = -7    /* cosim_run failed in chunk out[LOCKSTEP_DETAIL] (1 or 2): its code in */
                               /* out[LOCKSTEP_ERRNO], cosim_error() says more; the earlier chunk's */
                               /* outputs are in `out` */
};

/* ns a read of the host's bytes retries (yielding the CPU between tries) before it sleeps
 * in poll(): the kernel moves them from the host's end of the pty to ours on another CPU
 * within microseconds of the done, and a sleep on an otherwise idle CPU ends slowly on a
 * VM (the wake-up of an idle virtual CPU). */
#define LOCKSTEP_SPIN_NS 200000u

/* Indexes of the outputs in the caller's out[LOCKSTEP_OUT_N] (uint64 each). */
enum {
    LOCKSTEP_TX_BYTES, /* the done's tx_bytes: the host's bytes in the host buffer */
    LOCKSTEP_FLAGS,    /* the done's flags (bit 0: the host quits) */
    LOCKSTEP_LISP,     /* 1: the lisp buffer holds the host's lisp_data; 0: none yet */
    LOCKSTEP_TX1,      /* bytes the firmware sent in the first chunk (tx buffer from 0) */
    LOCKSTEP_ROWS1,    /* truth rows of the first chunk (row buffer from 0) */
    LOCKSTEP_WROTE1,   /* of LOCKSTEP_TX1, bytes written to the pty */
    LOCKSTEP_TX2,      /* bytes of the second chunk (tx buffer after LOCKSTEP_TX1) */
    LOCKSTEP_ROWS2,    /* truth rows of the second chunk (after LOCKSTEP_ROWS1) */
    LOCKSTEP_WROTE2,   /* of LOCKSTEP_TX2, bytes written to the pty */
    LOCKSTEP_NS_HOST,  /* ns from the tick sent to the done read, summed over calls */
    LOCKSTEP_NS_PTY,   /* ns in pty reads and writes, summed */
    LOCKSTEP_NS_FMUS,  /* ns in cosim_run, summed */
    LOCKSTEP_DETAIL,   /* an error's detail (see the result codes) */
    LOCKSTEP_ERRNO,    /* an error's errno or cosim code */
    LOCKSTEP_WAITS,    /* reads of the host's bytes that found them not there yet, summed */
    LOCKSTEP_SLEEPS,   /* of those, reads that slept in poll() after LOCKSTEP_SPIN_NS */
    LOCKSTEP_OUT_N
};

typedef struct lockstep lockstep_t;

/* A frame driver of coupler `c` (not owned): `sock` the lockstep socket (blocking, its
 * SO_RCVTIMEO / SO_SNDTIMEO set by the caller) carrying ticks of `tick_magic` and dones
 * of `done_magic`, `pty` the port's master (non-blocking), `read_ms` / `write_ms` the
 * longest waits (ms) for the host's bytes and for room to write in the pty,
 * `frame_us` the host frame (us), `steps` FMU steps a frame in two chunks of `split` and
 * steps - split (split >= steps: one chunk). `host`/`host_cap`: the buffer of the host's
 * bytes; `tx`/`tx_cap` and `rows`/`rows_cap` (rows of cosim_row_width doubles): the
 * firmware's bytes and the truth rows of a frame, of which a chunk takes at most
 * `chunk_tx_cap` bytes (as cosim_run with that capacity); `out`: LOCKSTEP_OUT_N outputs. The
 * buffers stay the caller's and must outlive the driver. NULL on bad arguments or no memory. */
COSIM_API lockstep_t *lockstep_new(cosim_t *c, int sock, uint32_t tick_magic, uint32_t done_magic, int pty,
                                   uint32_t read_ms, uint32_t write_ms, uint64_t frame_us, uint32_t steps,
                                   uint32_t split, uint8_t *host, size_t host_cap, uint8_t *tx, size_t tx_cap,
                                   size_t chunk_tx_cap, double *rows, size_t rows_cap, uint64_t *out);

/* The planner's end of rcomm (navkit.rcomm's library): `handle` its navkit_rcomm_t,
 * `heartbeat` the address of navkit_rcomm_heartbeat, `read_data` of navkit_rcomm_read_data
 * (which fills `lisp`, the lisp_data's words). Without this call (or with NULLs) no
 * heartbeat is bumped and no lisp_data read. */
COSIM_API void lockstep_rcomm(lockstep_t *l, void *handle, void *heartbeat, void *read_data, int32_t *lisp);

/* The port's master is now `pty` (the harness made a new pty behind the same path). */
COSIM_API void lockstep_port(lockstep_t *l, int pty);

/* The host part of frame `frame` (its tick carries frame * frame_us us and `rx_bytes`).
 * A result code (LOCKSTEP_OK, LOCKSTEP_GONE, LOCKSTEP_BIG or an error). */
COSIM_API int lockstep_host(lockstep_t *l, int frame, int rx_bytes);

/* The FMU part of the frame after lockstep_host: the LOCKSTEP_TX_BYTES bytes in the host
 * buffer reach the firmware with the first step. LOCKSTEP_OK or an error. */
COSIM_API int lockstep_micro(lockstep_t *l);

/* Frees the driver (nothing else). NULL is fine. */
COSIM_API void lockstep_free(lockstep_t *l);

#ifdef __cplusplus
}
#endif
#endif
