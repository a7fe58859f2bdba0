/* Test-only shim: the C parser behind a handle, for the Python differential fuzz
 * (navkit.proto_fuzz), which loads this library with ctypes. */
#include "navkit/navkit_proto.h"

#include <stdlib.h>
#include <string.h>

/* A new parser accepting dir (0 to micro, 1 to host), or NULL. */
navkit_parser_t *shim_new(int dir);
/* Feed len bytes in chunks of `chunk`; write the byte offset of each frame returned to
 * offsets (at most max) and return how many frames there were. */
int shim_feed(navkit_parser_t *p, const uint8_t *data, size_t len, size_t chunk, uint32_t *offsets, int max);
/* Copy the counters (good, bad_crc, unknown_type, bad_length, schema_mismatch,
 * dropped_bytes), then foreign_hash and foreign_offset. */
void shim_stats(const navkit_parser_t *p, uint32_t out[8]);
/* Free a parser from shim_new. */
void shim_free(navkit_parser_t *p);

navkit_parser_t *shim_new(int dir)
{
    navkit_parser_t *p = malloc(sizeof *p);
    if (p) {
        navkit_parser_init(p, dir ? NAVKIT_DIR_TO_HOST : NAVKIT_DIR_TO_MICRO);
    }
    return p;
}

int shim_feed(navkit_parser_t *p, const uint8_t *data, size_t len, size_t chunk, uint32_t *offsets, int max)
{
    size_t at = 0;
    int n = 0;
    while (at < len) {
        const uint8_t *f;
        size_t flen, c = len - at < chunk ? len - at : chunk;
        at += navkit_parser_feed(p, data + at, c);
        while (navkit_parser_next(p, &f, &flen)) {
            if (n < max) {
                offsets[n] = p->offset;
            }
            n++;
        }
    }
    return n;
}

void shim_stats(const navkit_parser_t *p, uint32_t out[8])
{
    out[0] = p->stats.good;
    out[1] = p->stats.bad_crc;
    out[2] = p->stats.unknown_type;
    out[3] = p->stats.bad_length;
    out[4] = p->stats.schema_mismatch;
    out[5] = p->stats.dropped_bytes;
    out[6] = p->foreign_hash;
    out[7] = p->foreign_offset;
}

void shim_free(navkit_parser_t *p)
{
    free(p);
}
