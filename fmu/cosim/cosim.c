/* navkit_cosim: see cosim.h. */
#define _POSIX_C_SOURCE 199309L
#include "cosim.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi3FunctionTypes.h"

#define MAX_LINKS 64 /* connections per (source FMU, type) */
#define MAX_COLS 64  /* recorded truth columns */

/* Values moved from one FMU to the other, of one type. */
typedef struct {
    size_t n;
    fmi3ValueReference src[MAX_LINKS];
    fmi3ValueReference dst[MAX_LINKS];
    double f64[MAX_LINKS];
    int32_t i32[MAX_LINKS];
    double f64_last[MAX_LINKS]; /* values set last time: unchanged values are not set again */
    int32_t i32_last[MAX_LINKS];
    int valid;                            /* *_last hold what the destination has */
    fmi3ValueReference set_vr[MAX_LINKS]; /* this step's changed inputs (scratch) */
    double set_f64[MAX_LINKS];
    int32_t set_i32[MAX_LINKS];
} links_t;

/* Recorded columns read from one FMU, of one type. */
typedef struct {
    size_t n;
    fmi3ValueReference vr[MAX_COLS];
    size_t col[MAX_COLS];
    double f64[MAX_COLS];
    int32_t i32[MAX_COLS];
} cols_t;

/* One FMU's functions, typed. */
typedef struct {
    fmi3Instance inst;
    fmi3GetFloat64TYPE *get_f64;
    fmi3SetFloat64TYPE *set_f64;
    fmi3GetInt32TYPE *get_i32;
    fmi3SetInt32TYPE *set_i32;
    fmi3GetBinaryTYPE *get_bin;
    fmi3SetBinaryTYPE *set_bin;
    fmi3DoStepTYPE *do_step;
} fmu_t;

struct cosim {
    fmu_t fmu[2];
    double step_s, start_s, fw_start_s;
    uint64_t steps, fw_steps; /* fw_steps: firmware steps since its (re)start */
    links_t links[2][2];      /* [source FMU][type] */
    cols_t cols[2][2];        /* [FMU][type] */
    size_t ncols;             /* recorded columns, time excluded */
    uint32_t every;
    int serial; /* serial_rx / serial_tx set */
    fmi3ValueReference rx_vr, tx_vr;
    int rx_pending_clear; /* serial_rx still holds bytes of an earlier step */
    int timing;
    uint64_t ns[2];
    uint64_t dropped; /* bytes / rows lost to full buffers (reported in the error) */
    char err[256];
};

/* Keeps a printf-style message as the last error and returns `code`. */
static int fail(cosim_t *c, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->err, sizeof c->err, fmt, ap);
    va_end(ap);
    return code;
}

/* Monotonic clock in ns (only read when timing is on). */
static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* Converts the untyped function addresses of `in` into `out`. */
static void load_fmu(fmu_t *out, const cosim_fmu_t *in)
{
    out->inst = in->instance;
    /* Object pointer -> function pointer through memcpy: valid on every POSIX target. */
    memcpy(&out->get_f64, &in->get_float64, sizeof(void *));
    memcpy(&out->set_f64, &in->set_float64, sizeof(void *));
    memcpy(&out->get_i32, &in->get_int32, sizeof(void *));
    memcpy(&out->set_i32, &in->set_int32, sizeof(void *));
    memcpy(&out->get_bin, &in->get_binary, sizeof(void *));
    memcpy(&out->set_bin, &in->set_binary, sizeof(void *));
    memcpy(&out->do_step, &in->do_step, sizeof(void *));
}

cosim_t *cosim_new(const cosim_fmu_t *firmware, const cosim_fmu_t *plant, double step_s, double start_s)
{
    cosim_t *c;
    if (!firmware || !plant || !(step_s > 0.0)) {
        return NULL;
    }
    if (!firmware->instance || !firmware->do_step || !plant->instance || !plant->do_step) {
        return NULL;
    }
    c = calloc(1, sizeof *c);
    if (!c) {
        return NULL;
    }
    load_fmu(&c->fmu[COSIM_FIRMWARE], firmware);
    load_fmu(&c->fmu[COSIM_PLANT], plant);
    c->step_s = step_s;
    c->start_s = start_s;
    c->fw_start_s = start_s;
    c->every = 20;
    return c;
}

void cosim_free(cosim_t *c)
{
    free(c);
}

/* 1 if `fmu` has the getter and setter of `type`. */
static int has_type(const fmu_t *f, int type)
{
    return type == COSIM_FLOAT64 ? (f->get_f64 && f->set_f64) : (f->get_i32 && f->set_i32);
}

int cosim_connect(cosim_t *c, int src, int type, uint32_t src_vr, uint32_t dst_vr)
{
    links_t *l;
    if (!c) {
        return COSIM_ERR_ARG;
    }
    if ((src != COSIM_FIRMWARE && src != COSIM_PLANT) || (type != COSIM_FLOAT64 && type != COSIM_INT32)) {
        return fail(c, COSIM_ERR_ARG, "connect: bad FMU %d or type %d", src, type);
    }
    if (!has_type(&c->fmu[src], type) || !has_type(&c->fmu[1 - src], type)) {
        return fail(c, COSIM_ERR_ARG, "connect: an FMU lacks the accessors of type %d", type);
    }
    l = &c->links[src][type];
    if (l->n >= MAX_LINKS) {
        return fail(c, COSIM_ERR_ARG, "connect: more than %d links of one type", MAX_LINKS);
    }
    l->src[l->n] = src_vr;
    l->dst[l->n] = dst_vr;
    l->n++;
    return COSIM_OK;
}

int cosim_serial(cosim_t *c, uint32_t rx_vr, uint32_t tx_vr)
{
    if (!c) {
        return COSIM_ERR_ARG;
    }
    if (!c->fmu[COSIM_FIRMWARE].get_bin || !c->fmu[COSIM_FIRMWARE].set_bin) {
        return fail(c, COSIM_ERR_ARG, "serial: firmware binary accessors missing");
    }
    c->rx_vr = rx_vr;
    c->tx_vr = tx_vr;
    c->serial = 1;
    return COSIM_OK;
}

int cosim_record(cosim_t *c, int fmu, int type, uint32_t vr)
{
    cols_t *g;
    if (!c) {
        return COSIM_ERR_ARG;
    }
    if ((fmu != COSIM_FIRMWARE && fmu != COSIM_PLANT) || (type != COSIM_FLOAT64 && type != COSIM_INT32)) {
        return fail(c, COSIM_ERR_ARG, "record: bad FMU %d or type %d", fmu, type);
    }
    if (!has_type(&c->fmu[fmu], type)) {
        return fail(c, COSIM_ERR_ARG, "record: FMU %d lacks the getter of type %d", fmu, type);
    }
    g = &c->cols[fmu][type];
    if (c->ncols >= MAX_COLS) {
        return fail(c, COSIM_ERR_ARG, "record: more than %d columns", MAX_COLS);
    }
    c->ncols++;
    g->vr[g->n] = vr;
    g->col[g->n] = c->ncols;
    g->n++;
    return (int)c->ncols;
}

int cosim_record_every(cosim_t *c, uint32_t every)
{
    if (!c) {
        return COSIM_ERR_ARG;
    }
    if (every < 1) {
        return fail(c, COSIM_ERR_ARG, "record_every: must be >= 1");
    }
    c->every = every;
    return COSIM_OK;
}

size_t cosim_row_width(const cosim_t *c)
{
    return c ? 1 + c->ncols : 0;
}

/* Names an FMU in error messages. */
static const char *fmu_name(int which)
{
    return which == COSIM_FIRMWARE ? "firmware" : "plant";
}

/* Appends to f->set_vr / `out` (from index k, which it advances) the links of `f` whose
 * value in `vals` differs bit for bit from the last one set, `last` (all of them when
 * !f->valid), and makes `last` hold every value of `vals`. The bits are compared as
 * unsigned integers of the value's width (UT), so -0 differs from +0 and a NaN from
 * itself never hides a change. */
#define COSIM_CHANGED(f, vals, last, out, UT)                                                                          \
    do {                                                                                                               \
        const size_t n_ = (f)->n;                                                                                      \
        size_t j_;                                                                                                     \
        if (!(f)->valid) {                                                                                             \
            for (j_ = 0; j_ < n_; j_++) {                                                                              \
                (f)->set_vr[k] = (f)->dst[j_];                                                                         \
                (out)[k++] = (last)[j_] = (vals)[j_];                                                                  \
            }                                                                                                          \
            break;                                                                                                     \
        }                                                                                                              \
        for (j_ = 0; j_ < n_; j_++) {                                                                                  \
            UT now_, was_;                                                                                             \
            memcpy(&now_, &(vals)[j_], sizeof now_);                                                                   \
            memcpy(&was_, &(last)[j_], sizeof was_);                                                                   \
            if (now_ != was_) {                                                                                        \
                (f)->set_vr[k] = (f)->dst[j_];                                                                         \
                (out)[k] = (last)[j_] = (vals)[j_];                                                                    \
                k++;                                                                                                   \
            }                                                                                                          \
        }                                                                                                              \
    } while (0)

/* Moves the values of the links from FMU `src` into the other FMU: one get per type,
 * then one set per type of only the inputs whose values changed since they were last set
 * (the destination keeps the others; cosim_exchange sets them all). */
static int transfer(cosim_t *c, int src)
{
    const fmu_t *s = &c->fmu[src], *d = &c->fmu[1 - src];
    links_t *f = &c->links[src][COSIM_FLOAT64], *i = &c->links[src][COSIM_INT32];
    size_t k;
    if (f->n) {
        if (s->get_f64(s->inst, f->src, f->n, f->f64, f->n) > fmi3Warning) {
            return fail(c, COSIM_ERR_FMU, "getting Float64 of %s failed at t=%.3f s", fmu_name(src), cosim_time(c));
        }
        k = 0;
        COSIM_CHANGED(f, f->f64, f->f64_last, f->set_f64, uint64_t);
        if (k) {
            f->valid = 1;
            if (d->set_f64(d->inst, f->set_vr, k, f->set_f64, k) > fmi3Warning) {
                f->valid = 0; /* the destination may hold some of them: all go again next time */
                return fail(c, COSIM_ERR_FMU, "setting Float64 of %s failed at t=%.3f s", fmu_name(1 - src),
                            cosim_time(c));
            }
        }
    }
    if (i->n) {
        if (s->get_i32(s->inst, i->src, i->n, i->i32, i->n) > fmi3Warning) {
            return fail(c, COSIM_ERR_FMU, "getting Int32 of %s failed at t=%.3f s", fmu_name(src), cosim_time(c));
        }
        k = 0;
        COSIM_CHANGED(i, i->i32, i->i32_last, i->set_i32, uint32_t);
        if (k) {
            i->valid = 1;
            if (d->set_i32(d->inst, i->set_vr, k, i->set_i32, k) > fmi3Warning) {
                i->valid = 0;
                return fail(c, COSIM_ERR_FMU, "setting Int32 of %s failed at t=%.3f s", fmu_name(1 - src),
                            cosim_time(c));
            }
        }
    }
    return COSIM_OK;
}

int cosim_exchange(cosim_t *c)
{
    int rc, a, b;
    if (!c) {
        return COSIM_ERR_ARG;
    }
    for (a = 0; a < 2; a++) {
        for (b = 0; b < 2; b++) {
            c->links[a][b].valid = 0;
        }
    }
    rc = transfer(c, COSIM_PLANT);
    return rc ? rc : transfer(c, COSIM_FIRMWARE);
}

int cosim_sample(cosim_t *c, double *row)
{
    int w, t;
    if (!c || !row) {
        return COSIM_ERR_ARG;
    }
    row[0] = cosim_time(c);
    for (w = 0; w < 2; w++) {
        const fmu_t *f = &c->fmu[w];
        for (t = 0; t < 2; t++) {
            cols_t *g = &c->cols[w][t];
            size_t k;
            if (!g->n) {
                continue;
            }
            if (t == COSIM_FLOAT64) {
                if (f->get_f64(f->inst, g->vr, g->n, g->f64, g->n) > fmi3Warning) {
                    return fail(c, COSIM_ERR_FMU, "recording %s Float64 failed", fmu_name(w));
                }
                for (k = 0; k < g->n; k++) {
                    row[g->col[k]] = g->f64[k];
                }
            } else {
                if (f->get_i32(f->inst, g->vr, g->n, g->i32, g->n) > fmi3Warning) {
                    return fail(c, COSIM_ERR_FMU, "recording %s Int32 failed", fmu_name(w));
                }
                for (k = 0; k < g->n; k++) {
                    row[g->col[k]] = (double)g->i32[k];
                }
            }
        }
    }
    return COSIM_OK;
}

/* One doStep of FMU `which` from `t` by `h`. */
static int step_one(cosim_t *c, int which, double t)
{
    fmi3Boolean event = fmi3False, term = fmi3False, early = fmi3False;
    fmi3Float64 last = t;
    const fmu_t *f = &c->fmu[which];
    fmi3Status st = f->do_step(f->inst, t, c->step_s, fmi3True, &event, &term, &early, &last);
    if (st > fmi3Warning) {
        return fail(c, COSIM_ERR_FMU, "%s doStep failed at t=%.3f s (status %d)", fmu_name(which), t, (int)st);
    }
    if (term) {
        return fail(c, COSIM_ERR_TERMINATED, "%s asked to terminate at t=%.3f s", fmu_name(which), t);
    }
    return COSIM_OK;
}

/* Sets the firmware's serial_rx to `len` bytes at `data`. */
static int set_rx(cosim_t *c, const uint8_t *data, size_t len)
{
    const fmu_t *f = &c->fmu[COSIM_FIRMWARE];
    static const uint8_t empty[1] = {0};
    fmi3Binary v = len ? data : empty;
    if (f->set_bin(f->inst, &c->rx_vr, 1, &len, &v, 1) > fmi3Warning) {
        return fail(c, COSIM_ERR_FMU, "setting serial_rx failed at t=%.3f s", cosim_time(c));
    }
    return COSIM_OK;
}

/* Appends the firmware's serial_tx to tx. */
static int get_tx(cosim_t *c, uint8_t *tx, size_t cap, size_t *len)
{
    const fmu_t *f = &c->fmu[COSIM_FIRMWARE];
    size_t size = 0, room;
    fmi3Binary v = NULL;
    if (f->get_bin(f->inst, &c->tx_vr, 1, &size, &v, 1) > fmi3Warning) {
        return fail(c, COSIM_ERR_FMU, "reading serial_tx failed at t=%.3f s", cosim_time(c));
    }
    if (!size || !v) {
        return COSIM_OK;
    }
    room = cap - *len;
    if (size > room) {
        c->dropped += size - room;
        if (room) {
            memcpy(tx + *len, v, room);
        }
        *len = cap;
        return fail(c, COSIM_ERR_FULL, "tx buffer full at t=%.3f s", cosim_time(c));
    }
    memcpy(tx + *len, v, size);
    *len += size;
    return COSIM_OK;
}

int cosim_run(cosim_t *c, uint32_t n_steps, const uint8_t *rx, size_t rx_len, uint8_t *tx, size_t tx_cap,
              size_t *tx_len, double *rows, size_t rows_cap, size_t *n_rows)
{
    uint32_t k, to_row;
    int rc = COSIM_OK, full = 0;
    size_t width;
    if (!c || !tx_len || !n_rows || (rx_len && !rx) || (tx_cap && !tx) || (rows_cap && !rows)) {
        return COSIM_ERR_ARG;
    }
    /* steps until the next truth row, which falls where steps % every == 0: counted down,
       so the step loop has no division */
    to_row = c->every - (uint32_t)(c->steps % c->every);
    *tx_len = 0;
    *n_rows = 0;
    width = cosim_row_width(c);
    c->err[0] = '\0';
    if (c->serial && rx_len) {
        if ((rc = set_rx(c, rx, rx_len)) != COSIM_OK) {
            return rc;
        }
        c->rx_pending_clear = 1;
    }
    for (k = 0; k < n_steps; k++) {
        double t = c->start_s + (double)c->steps * c->step_s;
        double tf = c->fw_start_s + (double)c->fw_steps * c->step_s;
        /* timing samples one step in COSIM_TIMING_EVERY (cosim.h) */
        int timed = c->timing && c->steps % COSIM_TIMING_EVERY == 0;
        uint64_t t0 = timed ? now_ns() : 0, t1;
        if ((rc = transfer(c, COSIM_PLANT)) != COSIM_OK) {
            return rc;
        }
        if ((rc = step_one(c, COSIM_FIRMWARE, tf)) != COSIM_OK) {
            return rc;
        }
        c->fw_steps++;
        if (c->serial) {
            if (c->rx_pending_clear && k + 1 < n_steps) {
                /* the bytes went in with this step: later steps get none */
                if ((rc = set_rx(c, NULL, 0)) != COSIM_OK) {
                    return rc;
                }
                c->rx_pending_clear = 0;
            }
            rc = get_tx(c, tx, tx_cap, tx_len);
            if (rc == COSIM_ERR_FULL) {
                full = 1;
            } else if (rc != COSIM_OK) {
                return rc;
            }
        }
        if ((rc = transfer(c, COSIM_FIRMWARE)) != COSIM_OK) {
            return rc;
        }
        if (timed) {
            t1 = now_ns();
            c->ns[COSIM_FIRMWARE] += (t1 - t0) * COSIM_TIMING_EVERY;
            t0 = t1;
        }
        if ((rc = step_one(c, COSIM_PLANT, t)) != COSIM_OK) {
            return rc;
        }
        c->steps++;
        if (timed) {
            c->ns[COSIM_PLANT] += (now_ns() - t0) * COSIM_TIMING_EVERY;
        }
        if (--to_row == 0u) {
            to_row = c->every;
            if (width > 1) { /* a row only when some column is recorded */
                if (*n_rows < rows_cap) {
                    if ((rc = cosim_sample(c, rows + *n_rows * width)) != COSIM_OK) {
                        return rc;
                    }
                    (*n_rows)++;
                } else {
                    c->dropped++;
                    full = 1;
                }
            }
        }
    }
    /* a run of one step leaves its bytes in serial_rx: clear them before the next run */
    if (c->serial && c->rx_pending_clear && n_steps > 0) {
        if ((rc = set_rx(c, NULL, 0)) != COSIM_OK) {
            return rc;
        }
        c->rx_pending_clear = 0;
    }
    if (full) {
        return fail(c, COSIM_ERR_FULL, "a buffer was full: %llu bytes/rows dropped so far",
                    (unsigned long long)c->dropped);
    }
    return COSIM_OK;
}

double cosim_time(const cosim_t *c)
{
    return c ? c->start_s + (double)c->steps * c->step_s : 0.0;
}

uint64_t cosim_steps(const cosim_t *c)
{
    return c ? c->steps : 0;
}

void cosim_firmware_restart(cosim_t *c, double firmware_start_s)
{
    if (!c) {
        return;
    }
    c->fw_start_s = firmware_start_s;
    c->fw_steps = 0;
    c->rx_pending_clear = 0;
}

uint64_t cosim_fmu_ns(const cosim_t *c, int which)
{
    if (!c || (which != COSIM_FIRMWARE && which != COSIM_PLANT)) {
        return 0;
    }
    return c->ns[which];
}

void cosim_timing(cosim_t *c, int on)
{
    if (c) {
        c->timing = on != 0;
    }
}

const char *cosim_error(const cosim_t *c)
{
    return c ? c->err : "no coupler";
}
