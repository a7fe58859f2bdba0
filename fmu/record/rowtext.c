/* navkit_record: the run log's native row formatter (rowtext.h). */
#include "rowtext.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* rowtext_fixed's exact rounding needs each double operation rounded to double as it is
 * written (SSE2, not the x87's extended precision). */
#if !defined(FLT_EVAL_METHOD) || FLT_EVAL_METHOD != 0
#error "rowtext.c needs FLT_EVAL_METHOD 0 (double arithmetic in double precision)"
#endif

struct rowtext {
    size_t width;                    /* doubles a row */
    size_t n_fields;                 /* fields a row's text */
    rowtext_lits_t lits;             /* n_fields + 1 literals */
    int32_t *cols;                   /* row column per field, -1: missing (0.0) */
    int32_t *decimals;               /* 0..9, or ROWTEXT_INT */
    uint64_t int_mask;               /* an integer field's mask (< 2^52) */
    int32_t wrap_field;              /* the field printed as 0.0 in [wrap_lo, wrap_hi), -1: none */
    double wrap_lo, wrap_hi;         /* that range, in the field's unit */
    size_t max_text;                 /* the longest text of a row, bytes */
    uint64_t state[ROWTEXT_N_STATE]; /* the call block */
    uint8_t *out;                    /* the records of the last run */
    size_t out_cap;                  /* bytes */
    uint64_t *index;                 /* their (log time, offset) pairs */
    size_t index_cap;                /* uint64 */
};

static const double rowtext_pow10[ROWTEXT_MAX_DECIMALS + 1] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9};

size_t rowtext_digits(char *out, uint64_t v, int min_digits)
{
    char tmp[24];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (n < min_digits) {
        tmp[n++] = '0';
    }
    for (int i = 0; i < n; i++) {
        out[i] = tmp[n - 1 - i];
    }
    return (size_t)n;
}

size_t rowtext_fixed(char *out, double x, int decimals)
{
    if (isnan(x)) {
        memcpy(out, "nan", 3);
        return 3;
    }
    if (isinf(x)) {
        if (x < 0) {
            memcpy(out, "-inf", 4);
            return 4;
        }
        memcpy(out, "inf", 3);
        return 3;
    }
    if (x == 0.0 && !signbit(x)) {
        /* the most common value of a row (servos at rest, no speed): "0.000..." */
        static const char zeros[] = "0.000000000";
        const size_t n = decimals > 0 ? 2u + (size_t)decimals : 1u;
        memcpy(out, zeros, n);
        return n;
    }
    const double scale = rowtext_pow10[decimals];
    const double s = x * scale;
    if (!(fabs(s) < 0x1p51)) {
        /* few or no fraction digits left in s: glibc's printf rounds the exact value as
         * Python's dtoa does (correctly, ties to even) */
        int n = snprintf(out, ROWTEXT_FIELD_MAX, "%.*f", decimals, x);
        return n < 0 ? 0u : (size_t)n;
    }
    /* r: s rounded to the nearest integer, ties to even (adding and taking away 1.5 *
     * 2^52 rounds away the fraction of any |s| < 2^51 in the default rounding mode).
     * x * 10^d is exactly s + e (the error of a product is a double, fma gives it); only
     * an s halfway between two integers can round the other way: by the sign of e
     * (e == 0: a true tie, r is the even one). Elsewhere |s - r| <= 0.5 - ulp(s) and
     * |e| <= ulp(s) / 2 keep r. */
    double r = (s + 0x1.8p52) - 0x1.8p52;
    const double f = s - r;
    if (f == 0.5 || f == -0.5) {
        const double e = fma(x, scale, -s);
        if (f == 0.5 && e > 0.0) {
            r += 1.0;
        } else if (f == -0.5 && e < 0.0) {
            r -= 1.0;
        }
    }
    size_t n = 0;
    if (signbit(x)) {
        out[n++] = '-';
    }
    const uint64_t v = (uint64_t)fabs(r);
    const uint64_t unit = (uint64_t)scale;
    n += rowtext_digits(out + n, v / unit, 1);
    if (decimals > 0) {
        out[n++] = '.';
        n += rowtext_digits(out + n, v % unit, decimals);
    }
    return n;
}

int rowtext_lits_copy(rowtext_lits_t *l, size_t n, const char *lits, const uint32_t *lit_end)
{
    l->text = NULL;
    l->end = NULL;
    for (size_t i = 0; i < n; i++) {
        if (lit_end[i + 1] < lit_end[i]) {
            return -1;
        }
    }
    l->text = malloc((size_t)lit_end[n] + 1u);
    l->end = malloc((n + 1u) * sizeof *l->end);
    if (l->text == NULL || l->end == NULL) {
        rowtext_lits_free(l);
        return -1;
    }
    memcpy(l->text, lits, lit_end[n]);
    memcpy(l->end, lit_end, (n + 1u) * sizeof *l->end);
    return 0;
}

void rowtext_lits_free(rowtext_lits_t *l)
{
    free(l->text);
    free(l->end);
    l->text = NULL;
    l->end = NULL;
}

rowtext_t *rowtext_new(size_t width, size_t n_fields, const char *lits, const uint32_t *lit_end, const int32_t *cols,
                       const int32_t *decimals, uint64_t int_mask, int32_t wrap_field, double wrap_lo, double wrap_hi)
{
    if (width == 0 || n_fields == 0 || lits == NULL || lit_end == NULL || cols == NULL || decimals == NULL ||
        wrap_field >= (int32_t)n_fields || int_mask >= (1ull << 52)) {
        return NULL;
    }
    for (size_t i = 0; i < n_fields; i++) {
        if (cols[i] < -1 || cols[i] >= (int32_t)width || decimals[i] < ROWTEXT_INT ||
            decimals[i] > ROWTEXT_MAX_DECIMALS) {
            return NULL;
        }
    }
    rowtext_t *p = calloc(1, sizeof *p);
    if (p == NULL) {
        return NULL;
    }
    p->cols = malloc(n_fields * sizeof *p->cols);
    p->decimals = malloc(n_fields * sizeof *p->decimals);
    if (rowtext_lits_copy(&p->lits, n_fields, lits, lit_end) != 0 || p->cols == NULL || p->decimals == NULL) {
        rowtext_free(p);
        return NULL;
    }
    memcpy(p->cols, cols, n_fields * sizeof *p->cols);
    memcpy(p->decimals, decimals, n_fields * sizeof *p->decimals);
    p->width = width;
    p->n_fields = n_fields;
    p->int_mask = int_mask;
    p->wrap_field = wrap_field;
    p->wrap_lo = wrap_lo;
    p->wrap_hi = wrap_hi;
    p->max_text = lit_end[n_fields] + n_fields * (size_t)ROWTEXT_FIELD_MAX;
    return p;
}

void rowtext_free(rowtext_t *p)
{
    if (p != NULL) {
        rowtext_lits_free(&p->lits);
        free(p->cols);
        free(p->decimals);
        free(p->out);
        free(p->index);
        free(p);
    }
}

/* Stores v little-endian in `n` bytes at out. */
static void rowtext_le(uint8_t *out, uint64_t v, int n)
{
    for (int i = 0; i < n; i++) {
        out[i] = (uint8_t)(v >> (8 * i));
    }
}

/* Writes the text of `row` into out (at least p->max_text bytes); returns its bytes, or
 * ROWTEXT_ERR_VALUE. */
static long rowtext_row(const rowtext_t *p, const double *row, char *out)
{
    size_t n = 0;
    for (size_t i = 0; i < p->n_fields; i++) {
        n += rowtext_lit(&p->lits, i, out + n);
        double x = p->cols[i] < 0 ? 0.0 : row[p->cols[i]];
        if (p->decimals[i] == ROWTEXT_INT) {
            if (!isfinite(x)) {
                return ROWTEXT_ERR_VALUE;
            }
            /* int(x) & mask, for any finite x: x truncated, taken modulo 2^52 (exact: fmod
             * is, and so is the sum below), as two's complement; int_mask < 2^52 */
            double m = fmod(trunc(x), 0x1p52);
            if (m < 0.0) {
                m += 0x1p52;
            }
            const uint64_t v = (uint64_t)m;
            n += rowtext_digits(out + n, v & p->int_mask, 1);
            continue;
        }
        if ((int32_t)i == p->wrap_field && x >= p->wrap_lo && x < p->wrap_hi) {
            x = 0.0;
        }
        n += rowtext_fixed(out + n, x, p->decimals[i]);
    }
    return (long)(n + rowtext_lit(&p->lits, p->n_fields, out + n));
}

/* Writes rows[first .. last) as records into out (`cap` bytes) and their pairs into index
 * (`index_cap` uint64), from sequence number seq + 1 at chunk offset `offset`, stopping
 * as rowtext_run() says; returns the rows written and their bytes in *out_len. */
static long rowtext_records(const rowtext_t *p, const double *rows, size_t first, size_t last, uint16_t channel,
                            uint32_t seq, uint64_t offset, uint64_t chunk_size, int64_t stop_every_ns, uint8_t *out,
                            size_t cap, uint64_t *index, size_t index_cap, size_t *out_len)
{
    size_t at = 0;
    long done = 0;
    *out_len = 0;
    for (size_t k = first; k < last; k++) {
        if (cap - at < ROWTEXT_RECORD_HEAD + p->max_text || 2u * ((size_t)done + 1u) > index_cap) {
            return done > 0 ? done : ROWTEXT_ERR_FULL;
        }
        const double *row = rows + k * p->width;
        if (!(fabs(row[0]) <= ROWTEXT_MAX_TIME_S)) {
            return ROWTEXT_ERR_TIME; /* NaN too: no int64 log time to cast it to */
        }
        const int64_t t_ns = (int64_t)nearbyint(row[0] * 1e3) * 1000000;
        uint8_t *rec = out + at;
        const long len = rowtext_row(p, row, (char *)rec + ROWTEXT_RECORD_HEAD);
        if (len < 0) {
            return len;
        }
        rec[0] = 0x05; /* opcode Message */
        rowtext_le(rec + 1, 22u + (uint64_t)len, 8);
        rowtext_le(rec + 9, channel, 2);
        rowtext_le(rec + 11, seq + (uint32_t)done + 1u, 4);
        rowtext_le(rec + 15, (uint64_t)t_ns, 8);
        rowtext_le(rec + 23, (uint64_t)t_ns, 8);
        index[2 * done] = (uint64_t)t_ns;
        index[2 * done + 1] = offset + at;
        at += ROWTEXT_RECORD_HEAD + (size_t)len;
        done++;
        *out_len = at;
        if (offset + at > chunk_size || (stop_every_ns > 0 && t_ns % stop_every_ns == 0)) {
            break;
        }
    }
    return done;
}

uint64_t *rowtext_state(rowtext_t *p)
{
    return p == NULL ? NULL : p->state;
}

int rowtext_run(rowtext_t *p, const char *rows, int first, int last)
{
    if (p == NULL || rows == NULL || first < 0 || last < first) {
        return ROWTEXT_ERR_ARG;
    }
    const size_t n = (size_t)(last - first);
    const size_t cap = n * (ROWTEXT_RECORD_HEAD + p->max_text);
    if (cap > p->out_cap) {
        uint8_t *out = realloc(p->out, cap);
        if (out == NULL) {
            return ROWTEXT_ERR_FULL;
        }
        p->out = out;
        p->out_cap = cap;
    }
    if (2u * n > p->index_cap) {
        uint64_t *index = realloc(p->index, 2u * n * sizeof *index);
        if (index == NULL) {
            return ROWTEXT_ERR_FULL;
        }
        p->index = index;
        p->index_cap = 2u * n;
    }
    uint64_t *st = p->state;
    size_t out_len = 0;
    const long done = n == 0 ? 0
                             : rowtext_records(p, (const double *)(const void *)rows, (size_t)first, (size_t)last,
                                               (uint16_t)st[ROWTEXT_CHANNEL], (uint32_t)st[ROWTEXT_SEQ],
                                               st[ROWTEXT_OFFSET], st[ROWTEXT_CHUNK_SIZE],
                                               (int64_t)st[ROWTEXT_STOP_EVERY_NS], p->out, p->out_cap, p->index,
                                               p->index_cap, &out_len);
    st[ROWTEXT_OUT_LEN] = out_len;
    st[ROWTEXT_OUT_AT] = (uint64_t)(uintptr_t)p->out;
    st[ROWTEXT_INDEX_AT] = (uint64_t)(uintptr_t)p->index;
    return (int)done;
}
