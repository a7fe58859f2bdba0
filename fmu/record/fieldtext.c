/* navkit_record: the run log's native message formatter (fieldtext.h). */
#include "fieldtext.h"

#include <stdlib.h>
#include <string.h>

struct fieldtext {
    size_t n_fields;     /* values a message */
    size_t size;         /* message bytes */
    rowtext_lits_t lits; /* n_fields + 1 literals */
    uint32_t *offsets;   /* byte offset of each value */
    char *codes;         /* struct code of each value */
    char *out;           /* the last text */
};

/* Bytes of a value of struct code `c`, 0 for an unknown code. */
static size_t fieldtext_width(char c)
{
    switch (c) {
    case 'b':
    case 'B':
        return 1u;
    case 'h':
    case 'H':
        return 2u;
    case 'i':
    case 'I':
        return 4u;
    case 'q':
    case 'Q':
        return 8u;
    default:
        return 0u;
    }
}

fieldtext_t *fieldtext_new(size_t n_fields, const char *lits, const uint32_t *lit_end, const uint32_t *offsets,
                           const char *codes, size_t size)
{
    if (n_fields == 0 || lits == NULL || lit_end == NULL || offsets == NULL || codes == NULL) {
        return NULL;
    }
    for (size_t i = 0; i < n_fields; i++) {
        const size_t w = fieldtext_width(codes[i]);
        if (w == 0u || offsets[i] + w > size) {
            return NULL;
        }
    }
    fieldtext_t *p = calloc(1, sizeof *p);
    if (p == NULL) {
        return NULL;
    }
    p->offsets = malloc(n_fields * sizeof *p->offsets);
    p->codes = malloc(n_fields);
    p->out = malloc(lit_end[n_fields] + 21u * n_fields); /* 20 digits and a sign a value at most */
    if (rowtext_lits_copy(&p->lits, n_fields, lits, lit_end) != 0 || p->offsets == NULL || p->codes == NULL ||
        p->out == NULL) {
        fieldtext_free(p);
        return NULL;
    }
    memcpy(p->offsets, offsets, n_fields * sizeof *p->offsets);
    memcpy(p->codes, codes, n_fields);
    p->n_fields = n_fields;
    p->size = size;
    return p;
}

void fieldtext_free(fieldtext_t *p)
{
    if (p != NULL) {
        rowtext_lits_free(&p->lits);
        free(p->offsets);
        free(p->codes);
        free(p->out);
        free(p);
    }
}

const char *fieldtext_out(const fieldtext_t *p)
{
    return p == NULL ? NULL : p->out;
}

/* The little-endian unsigned integer of `n` bytes at b. */
static uint64_t fieldtext_le(const uint8_t *b, size_t n)
{
    uint64_t v = 0;
    for (size_t i = n; i-- > 0u;) {
        v = (v << 8) | b[i];
    }
    return v;
}

int fieldtext_run(fieldtext_t *p, const char *data, int offset)
{
    if (p == NULL || data == NULL || offset < 0) {
        return -1;
    }
    const uint8_t *msg = (const uint8_t *)data + offset;
    char *out = p->out;
    size_t n = 0;
    for (size_t i = 0; i < p->n_fields; i++) {
        n += rowtext_lit(&p->lits, i, out + n);
        const char c = p->codes[i];
        const size_t w = fieldtext_width(c);
        uint64_t v = fieldtext_le(msg + p->offsets[i], w);
        int negative = 0;
        if (c >= 'a' && w < 8u && (v >> (8u * w - 1u)) != 0u) {
            v = (1ull << (8u * w)) - v; /* the magnitude of a negative value */
            negative = 1;
        } else if (c == 'q' && (v >> 63) != 0u) {
            v = ~v + 1u;
            negative = 1;
        }
        if (negative) {
            out[n++] = '-';
        }
        n += rowtext_digits(out + n, v, 1);
    }
    return (int)(n + rowtext_lit(&p->lits, p->n_fields, out + n));
}
