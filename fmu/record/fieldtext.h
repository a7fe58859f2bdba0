/* navkit_record: the run log's native message formatter (the protocol's messages as JSON).
 *
 * A message's little-endian bytes (a serial frame, an rcomm slot) become its JSON text by
 * a field program made from the generated codec (navkit_json: each message's template and
 * the byte offset and struct code of each value in it): the literal text before each
 * value, the value as a decimal integer, then the text after the last. The program is the
 * generated codec's (navkit.sim.record builds it from navkit_json): this file holds no
 * message of its own.
 */
#ifndef NAVKIT_FIELDTEXT_H
#define NAVKIT_FIELDTEXT_H

#include <stddef.h>
#include <stdint.h>

#include "rowtext.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct fieldtext fieldtext_t;

/* A field program of `n_fields` values of a `size`-byte message: value i is preceded by
 * the literal text lits[lit_end[i-1] .. lit_end[i]) (from 0 for i = 0) and read at byte
 * offset offsets[i] as codes[i], a struct code: 'b' int8, 'B' uint8, 'h' int16, 'H'
 * uint16, 'i' int32, 'I' uint32, 'q' int64, 'Q' uint64 (little-endian), printed in
 * decimal as Python's %d. The text ends with lits[lit_end[n_fields-1] ..
 * lit_end[n_fields]). All arrays are copied. NULL for bad arguments (a value past `size`,
 * an unknown code) or no memory. */
ROWTEXT_API fieldtext_t *fieldtext_new(size_t n_fields, const char *lits, const uint32_t *lit_end,
                                       const uint32_t *offsets, const char *codes, size_t size);

/* Frees a program (NULL is fine). */
ROWTEXT_API void fieldtext_free(fieldtext_t *p);

/* The program's text buffer: the text of its last run (not NUL-terminated). */
ROWTEXT_API const char *fieldtext_out(const fieldtext_t *p);

/* Writes the text of the message at data + offset (at least the program's `size` bytes
 * there: the caller checks) into the text buffer; returns its bytes, or -1 for bad
 * arguments. */
ROWTEXT_API int fieldtext_run(fieldtext_t *p, const char *data, int offset);

#ifdef __cplusplus
}
#endif

#endif
