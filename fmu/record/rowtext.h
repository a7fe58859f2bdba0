/* navkit_record: the run log's native row formatter (the log worker's /truth messages).
 *
 * The plant's truth rows (doubles, as the coupler records them: simulated time in s, then
 * the recorded values) become JSON text by a row program the harness gives once: for each
 * field the literal text before it, the row column it reads and how it is printed (a fixed
 * number of decimals, exactly as Python's '%.<d>f' prints a float, or an integer masked to
 * a bit width, as Python's int(x) & mask). Each row's text is written as a whole MCAP
 * Message record (MCAP specification, "Message"), so the log worker adds a run of them to
 * the open chunk at once. The program (keys, decimals, columns) is the harness's
 * (navkit.sim.record): this file holds no field of its own.
 */
#ifndef NAVKIT_ROWTEXT_H
#define NAVKIT_ROWTEXT_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__GNUC__)
#define ROWTEXT_API __attribute__((visibility("default")))
#else
#define ROWTEXT_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* How a field is printed: decimals 0..ROWTEXT_MAX_DECIMALS, or ROWTEXT_INT (an integer). */
enum { ROWTEXT_MAX_DECIMALS = 9, ROWTEXT_INT = -1 };
/* Result codes. */
enum { ROWTEXT_ERR_ARG = -1, ROWTEXT_ERR_FULL = -2, ROWTEXT_ERR_VALUE = -3, ROWTEXT_ERR_TIME = -4 };
/* Bytes of an MCAP Message record before its data: opcode, length, channel id, sequence,
 * log time, publish time. */
enum { ROWTEXT_RECORD_HEAD = 31 };
/* The longest text of one field (bytes): '%.9f' of the largest double (309 digits before
 * the point) and its sign, with room to spare. */
enum { ROWTEXT_FIELD_MAX = 340 };

/* The largest |simulated time| of a row, s: its log time in ns fits an int64. */
#define ROWTEXT_MAX_TIME_S 9.2e9

typedef struct rowtext rowtext_t;

/* A row program of `n_fields` fields: field i is the literal text lits[lit_end[i-1] ..
 * lit_end[i]) (from 0 for i = 0) then the value of row column cols[i] (-1: the column is
 * missing, the value is 0.0) printed with decimals[i] decimals (0..9), or, for
 * ROWTEXT_INT, as the integer int(x) & int_mask (x truncated toward zero; Python's & of
 * a negative integer: two's complement; int_mask < 2^52). The text ends with
 * lits[lit_end[n_fields-1] .. lit_end[n_fields]). A value of field `wrap_field` (-1:
 * none) in [wrap_lo, wrap_hi) is printed as 0.0 (a heading that would print as 360 with
 * its decimals). Rows are `width` doubles; column 0 is the simulated time (s), whose log
 * time is round(t * 1e3) ms in ns (ties to even: the coupler's rows lie on a 1 ms grid).
 * All arrays are copied. NULL for bad arguments or no memory. */
ROWTEXT_API rowtext_t *rowtext_new(size_t width, size_t n_fields, const char *lits, const uint32_t *lit_end,
                                   const int32_t *cols, const int32_t *decimals, uint64_t int_mask, int32_t wrap_field,
                                   double wrap_lo, double wrap_hi);

/* Frees a program (NULL is fine). */
ROWTEXT_API void rowtext_free(rowtext_t *p);

/* The program's call block: what rowtext_run() reads (ROWTEXT_SEQ .. ROWTEXT_CHANNEL,
 * set by the caller) and what it leaves (ROWTEXT_OUT_LEN .. ROWTEXT_INDEX_AT), uint64
 * each, so that a call takes four arguments (a ctypes call's cost grows with each).
 * ROWTEXT_SEQ: the sequence number before the first record's; ROWTEXT_OFFSET: where the
 * first record starts in its chunk, bytes; ROWTEXT_CHUNK_SIZE: stop after the first
 * record that ends past it, bytes (the chunk is then full); ROWTEXT_STOP_EVERY_NS: stop
 * after the first row whose log time is a multiple of it (ns; 0: never; the caller adds
 * its own messages after that row); ROWTEXT_CHANNEL: the records' channel id.
 * ROWTEXT_OUT_LEN: the bytes of the records written; ROWTEXT_OUT_AT: their address;
 * ROWTEXT_INDEX_AT: the address of their (log time ns, offset in the chunk) pairs, 2
 * uint64 a record. Both buffers are the program's, valid until its next run. */
enum {
    ROWTEXT_SEQ,
    ROWTEXT_OFFSET,
    ROWTEXT_CHUNK_SIZE,
    ROWTEXT_STOP_EVERY_NS,
    ROWTEXT_CHANNEL,
    ROWTEXT_OUT_LEN,
    ROWTEXT_OUT_AT,
    ROWTEXT_INDEX_AT,
    ROWTEXT_N_STATE
};

/* The call block of `p` (ROWTEXT_N_STATE uint64), zeroed by rowtext_new. */
ROWTEXT_API uint64_t *rowtext_state(rowtext_t *p);

/* Writes rows first .. last - 1 of `rows` (`width` doubles each) as MCAP Message records
 * of the call block's channel, sequence numbers ROWTEXT_SEQ + 1, + 2, ..., log and
 * publish time the row's log time (ns), stopping as the call block says (or at `last`).
 * Returns the rows written (>= 1 if first < last), or ROWTEXT_ERR_VALUE for an integer
 * field that is not finite (as Python's int() refuses it), ROWTEXT_ERR_TIME for a time
 * without a log time (not finite, or |t| past ROWTEXT_MAX_TIME_S), ROWTEXT_ERR_FULL if out
 * of memory, ROWTEXT_ERR_ARG for bad arguments. */
ROWTEXT_API int rowtext_run(rowtext_t *p, const char *rows, int first, int last);

/* Writes x into `out` (at least ROWTEXT_FIELD_MAX bytes) with `decimals` decimals (0..9)
 * as Python's '%.<decimals>f' % x does: correctly rounded, ties to even, a '-' for every
 * x with its sign bit set (-0.0 and negatives that round to 0 too), "nan", "inf",
 * "-inf". Returns the bytes written (no NUL). */
ROWTEXT_API size_t rowtext_fixed(char *out, double x, int decimals);

/* A program's literal texts (of a row or a field program): n + 1 of them back to back,
 * literal i being text[end[i-1] .. end[i]) (from 0 for i = 0). */
typedef struct rowtext_lits {
    char *text;    /* the literals back to back */
    uint32_t *end; /* n + 1 ends in text, bytes */
} rowtext_lits_t;

/* Copies the n + 1 literals lits[lit_end[i-1] .. lit_end[i]) into l; returns 0, or -1
 * (l then holds nothing) if lit_end decreases or there is no memory. Not exported. */
int rowtext_lits_copy(rowtext_lits_t *l, size_t n, const char *lits, const uint32_t *lit_end);

/* Frees what rowtext_lits_copy() gave l (an l of NULLs is fine). Not exported. */
void rowtext_lits_free(rowtext_lits_t *l);

/* Writes literal i of l into out (the one program loop of rowtext.c and fieldtext.c:
 * literal i, value i, ..., literal n); returns its bytes (no NUL). */
static inline size_t rowtext_lit(const rowtext_lits_t *l, size_t i, char *out)
{
    const uint32_t from = i == 0u ? 0u : l->end[i - 1u];
    memcpy(out, l->text + from, l->end[i] - from);
    return l->end[i] - from;
}

/* Writes the decimal digits of v (at least `min_digits`, at most 20, zero-padded)
 * into out; returns the bytes written (no NUL). The library's one integer printer, for
 * rowtext.c and fieldtext.c (not exported). */
size_t rowtext_digits(char *out, uint64_t v, int min_digits);

#ifdef __cplusplus
}
#endif

#endif
