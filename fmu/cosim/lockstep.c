/* lockstep: see lockstep.h. */
#define _POSIX_C_SOURCE 200809L
#include "lockstep.h"

#include <errno.h>
#include <poll.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define LOCKSTEP_TICK_BYTES 24u /* magic, frame, sim time us (u64), rx bytes, 0: little-endian */
#define LOCKSTEP_DONE_BYTES 16u /* magic, frame, tx bytes, flags: little-endian */

/* navkit_rcomm.h's handle: only its address passes through here */
struct navkit_rcomm;
/* The types of navkit_rcomm_heartbeat and navkit_rcomm_read_data (a call through another
 * function type is undefined). */
typedef int (*lockstep_beat_fn)(struct navkit_rcomm *r);
typedef int (*lockstep_read_fn)(struct navkit_rcomm *r, int32_t *words);

/* lockstep_new's arguments (see lockstep.h), lockstep_rcomm's and the current frame. */
struct lockstep {
    cosim_t *c;
    int sock, pty;                   /* fds: the lockstep socket, the port's master */
    uint32_t read_ms, write_ms;      /* ms: the longest waits for the host's bytes, for room */
    uint32_t tick_magic, done_magic; /* the records' first words */
    uint64_t frame_us;               /* us: the host frame */
    uint32_t steps, split;           /* FMU steps a frame, of them in the first chunk */
    uint8_t *host, *tx;              /* the host's bytes, the firmware's bytes */
    size_t host_cap, tx_cap;         /* bytes */
    size_t chunk_tx_cap;             /* bytes of tx a chunk may fill */
    size_t rows_cap, width;          /* rows; doubles a row */
    double *rows;                    /* the frame's truth rows */
    uint64_t *out;                   /* LOCKSTEP_OUT_N outputs */
    struct navkit_rcomm *rcomm;      /* NULL: no heartbeat, no lisp_data */
    lockstep_beat_fn beat;           /* navkit_rcomm_heartbeat */
    lockstep_read_fn read_data;      /* navkit_rcomm_read_data */
    int32_t *lisp;                   /* lisp_data's words */
    uint32_t frame;                  /* the frame of the last lockstep_host */
};

/* Monotonic clock, ns. */
static uint64_t lockstep_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* Puts v at p, little-endian (4 bytes of a record). */
static void lockstep_put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* The little-endian u32 at p (4 bytes of a record). */
static uint32_t lockstep_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

lockstep_t *lockstep_new(cosim_t *c, int sock, uint32_t tick_magic, uint32_t done_magic, int pty, uint32_t read_ms,
                         uint32_t write_ms, uint64_t frame_us, uint32_t steps, uint32_t split, uint8_t *host,
                         size_t host_cap, uint8_t *tx, size_t tx_cap, size_t chunk_tx_cap, double *rows,
                         size_t rows_cap, uint64_t *out)
{
    lockstep_t *l;
    if (!c || sock < 0 || pty < 0 || steps < 1u || !host || !tx || !out || (rows_cap && !rows)) {
        return NULL;
    }
    l = calloc(1, sizeof *l);
    if (!l) {
        return NULL;
    }
    l->c = c;
    l->sock = sock;
    l->tick_magic = tick_magic;
    l->done_magic = done_magic;
    l->pty = pty;
    l->read_ms = read_ms;
    l->write_ms = write_ms;
    l->frame_us = frame_us;
    l->steps = steps;
    l->split = split < steps ? split : steps;
    l->host = host;
    l->host_cap = host_cap;
    l->tx = tx;
    l->tx_cap = tx_cap;
    l->chunk_tx_cap = chunk_tx_cap;
    l->rows = rows;
    l->rows_cap = rows_cap;
    l->width = cosim_row_width(c);
    l->out = out;
    memset(out, 0, LOCKSTEP_OUT_N * sizeof *out);
    return l;
}

void lockstep_rcomm(lockstep_t *l, void *handle, void *heartbeat, void *read_data, int32_t *lisp)
{
    if (!l) {
        return;
    }
    l->rcomm = (struct navkit_rcomm *)handle;
    /* object pointer -> function pointer through memcpy: valid on every POSIX target */
    memcpy(&l->beat, &heartbeat, sizeof heartbeat);
    memcpy(&l->read_data, &read_data, sizeof read_data);
    l->lisp = lisp;
    if (!handle || !lisp) {
        l->beat = NULL;
        l->read_data = NULL;
    }
}

void lockstep_port(lockstep_t *l, int pty)
{
    if (l) {
        l->pty = pty;
    }
}

void lockstep_free(lockstep_t *l)
{
    free(l);
}

/* An OS error: errno into out, LOCKSTEP_ERR_OS. */
static int lockstep_os(lockstep_t *l)
{
    l->out[LOCKSTEP_ERRNO] = (uint64_t)errno;
    return LOCKSTEP_ERR_OS;
}

/* Reads exactly n bytes from the pty into buf, waiting at most read_ms for them
 * (an EIO, the host re-opening its port, is waited out like no bytes). */
static int lockstep_read_exact(lockstep_t *l, uint8_t *buf, size_t n)
{
    size_t got = 0;
    int64_t deadline = -1;
    uint64_t spin_end = 0;
    while (got < n) {
        ssize_t r = read(l->pty, buf + got, n - got);
        int64_t left;
        struct pollfd p;
        if (r > 0) {
            got += (size_t)r;
            continue;
        }
        if (r < 0 && errno == EINTR) {
            continue;
        }
        if (r < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EIO) {
            return lockstep_os(l);
        }
        if (spin_end == 0u) {
            l->out[LOCKSTEP_WAITS]++;
            spin_end = lockstep_ns() + LOCKSTEP_SPIN_NS;
        }
        if (lockstep_ns() < spin_end) {
            (void)sched_yield(); /* the kernel's pty work may be waiting for this CPU */
            continue;
        }
        if (deadline < 0) {
            l->out[LOCKSTEP_SLEEPS]++;
            deadline = (int64_t)(lockstep_ns() / 1000000u) + (int64_t)l->read_ms;
        }
        left = deadline - (int64_t)(lockstep_ns() / 1000000u);
        if (left <= 0) {
            l->out[LOCKSTEP_DETAIL] = got;
            return LOCKSTEP_ERR_SHORT;
        }
        p.fd = l->pty;
        p.events = POLLIN;
        p.revents = 0;
        (void)poll(&p, 1, left < 100 ? (int)left : 100);
    }
    return LOCKSTEP_OK;
}

int lockstep_host(lockstep_t *l, int frame, int rx_bytes)
{
    uint8_t tick[LOCKSTEP_TICK_BYTES], done[LOCKSTEP_DONE_BYTES];
    uint64_t sim_us, t0, t1;
    uint32_t magic, done_frame, tx_bytes;
    size_t got = 0;
    int rc;
    if (!l) {
        return LOCKSTEP_ERR_OS;
    }
    l->out[LOCKSTEP_LISP] = 0;
    if (l->beat && l->beat(l->rcomm) < 0) {
        return LOCKSTEP_ERR_RCOMM;
    }
    l->frame = (uint32_t)frame;
    sim_us = (uint64_t)(uint32_t)frame * l->frame_us;
    lockstep_put32(tick, l->tick_magic);
    lockstep_put32(tick + 4, l->frame);
    lockstep_put32(tick + 8, (uint32_t)sim_us);
    lockstep_put32(tick + 12, (uint32_t)(sim_us >> 32));
    lockstep_put32(tick + 16, (uint32_t)rx_bytes);
    lockstep_put32(tick + 20, 0u);
    t0 = lockstep_ns();
    while (got < sizeof tick) {
        ssize_t n = send(l->sock, tick + got, sizeof tick - got, MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            return lockstep_os(l); /* a send timeout too: Lockstep.frame's sendall raises it */
        }
        got += (size_t)n;
    }
    got = 0;
    while (got < sizeof done) {
        ssize_t n = recv(l->sock, done + got, sizeof done - got, 0);
        if (n == 0) {
            return LOCKSTEP_GONE;
        }
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno == ECONNRESET) {
                return LOCKSTEP_GONE;
            }
            return (errno == EAGAIN || errno == EWOULDBLOCK) ? LOCKSTEP_ERR_TIMEOUT : lockstep_os(l);
        }
        got += (size_t)n;
    }
    t1 = lockstep_ns();
    l->out[LOCKSTEP_NS_HOST] += t1 - t0;
    magic = lockstep_get32(done);
    done_frame = lockstep_get32(done + 4);
    tx_bytes = lockstep_get32(done + 8);
    l->out[LOCKSTEP_TX_BYTES] = tx_bytes;
    l->out[LOCKSTEP_FLAGS] = lockstep_get32(done + 12);
    if (magic != l->done_magic) {
        l->out[LOCKSTEP_DETAIL] = magic;
        return LOCKSTEP_ERR_MAGIC;
    }
    if (done_frame != l->frame) {
        l->out[LOCKSTEP_DETAIL] = done_frame;
        return LOCKSTEP_ERR_FRAME;
    }
    if (tx_bytes > l->host_cap) {
        return LOCKSTEP_BIG;
    }
    /* lisp_data first: the host does not run again before the next tick, so it reads the
       same either way, and the kernel gets that long to move the host's bytes (a read
       before they are moved waits for it) */
    if (l->read_data) {
        int n = l->read_data(l->rcomm, l->lisp);
        if (n < 0) {
            return LOCKSTEP_ERR_RCOMM;
        }
        l->out[LOCKSTEP_LISP] = n > 0;
    }
    t1 = lockstep_ns();
    rc = lockstep_read_exact(l, l->host, tx_bytes);
    l->out[LOCKSTEP_NS_PTY] += lockstep_ns() - t1;
    return rc;
}

/* Waits at most write_ms for room in the pty, a signal's interruption
 * resuming the wait (as Python's select does): 1 room, 0 none (or poll failed). */
static int lockstep_wait_room(lockstep_t *l)
{
    uint64_t end = lockstep_ns() + (uint64_t)l->write_ms * 1000000u, now;
    struct pollfd p;
    int ready;
    p.fd = l->pty;
    p.events = POLLOUT;
    do {
        now = lockstep_ns();
        p.revents = 0;
        ready = poll(&p, 1, now < end ? (int)((end - now + 999999u) / 1000000u) : 0);
    } while (ready < 0 && errno == EINTR);
    return ready > 0;
}

/* Writes len bytes of data to the pty; *wrote gets how many went: all, as a rule; when the
 * host does not drain the port, what went before write_ms passed without room
 * (an EIO, the slave closed, ends the write too). LOCKSTEP_OK or LOCKSTEP_ERR_OS. */
static int lockstep_write(lockstep_t *l, const uint8_t *data, size_t len, uint64_t *wrote)
{
    size_t done = 0;
    while (done < len) {
        ssize_t n = write(l->pty, data + done, len - done);
        if (n > 0) {
            done += (size_t)n;
            continue;
        }
        if (n < 0 && errno == EINTR) {
            continue;
        }
        if (n < 0 && errno == EIO) {
            break;
        }
        if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
            *wrote = done;
            return lockstep_os(l);
        }
        if (!lockstep_wait_room(l)) {
            break;
        }
    }
    *wrote = done;
    return LOCKSTEP_OK;
}

/* One chunk of n steps (rx: the host's bytes for its first step, or none) appending to the
 * tx and row buffers after `tx_at` bytes and `row_at` rows; the bytes the firmware sent go
 * to the pty. Outputs at out[len_i], out[rows_i], out[wrote_i]; `chunk` (1, 2) names it in
 * an error. */
static int lockstep_chunk(lockstep_t *l, uint32_t n, const uint8_t *rx, size_t rx_len, size_t tx_at, size_t row_at,
                          int len_i, int rows_i, int wrote_i, int chunk)
{
    size_t tx_len = 0, n_rows = 0, room = l->tx_cap - tx_at;
    uint64_t t0 = lockstep_ns(), t1;
    int rc = cosim_run(l->c, n, rx, rx_len, l->tx + tx_at, room < l->chunk_tx_cap ? room : l->chunk_tx_cap, &tx_len,
                       l->rows ? l->rows + row_at * l->width : NULL, l->rows_cap - row_at, &n_rows);
    t1 = lockstep_ns();
    l->out[LOCKSTEP_NS_FMUS] += t1 - t0;
    l->out[len_i] = tx_len;
    l->out[rows_i] = n_rows;
    l->out[wrote_i] = 0;
    if (rc != COSIM_OK) {
        l->out[LOCKSTEP_DETAIL] = (uint64_t)chunk;
        l->out[LOCKSTEP_ERRNO] = (uint64_t)(int64_t)rc;
        return LOCKSTEP_ERR_COSIM;
    }
    if (tx_len) {
        rc = lockstep_write(l, l->tx + tx_at, tx_len, &l->out[wrote_i]);
        l->out[LOCKSTEP_NS_PTY] += lockstep_ns() - t1;
    }
    return rc;
}

int lockstep_micro(lockstep_t *l)
{
    int rc;
    if (!l) {
        return LOCKSTEP_ERR_OS;
    }
    l->out[LOCKSTEP_TX2] = l->out[LOCKSTEP_ROWS2] = l->out[LOCKSTEP_WROTE2] = 0;
    rc = lockstep_chunk(l, l->split, l->host, (size_t)l->out[LOCKSTEP_TX_BYTES], 0, 0, LOCKSTEP_TX1, LOCKSTEP_ROWS1,
                        LOCKSTEP_WROTE1, 1);
    if (rc != LOCKSTEP_OK || l->split >= l->steps) {
        return rc;
    }
    return lockstep_chunk(l, l->steps - l->split, NULL, 0, (size_t)l->out[LOCKSTEP_TX1], (size_t)l->out[LOCKSTEP_ROWS1],
                          LOCKSTEP_TX2, LOCKSTEP_ROWS2, LOCKSTEP_WROTE2, 2);
}
