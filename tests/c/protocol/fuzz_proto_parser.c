/* libFuzzer target for the frame parser (preset `fuzz`: clang, ASan+UBSan).
 * Input: byte 0 picks the direction (bit 0: 1 = to host) and the feed chunk size
 * (1 + byte0 >> 1); the rest is the stream. Seeds: the golden streams
 * (`python -m navkit.vectors --fuzz-corpus DIR`, done by `make fuzz-short`).
 * Invariants: every returned frame passes navkit_frame_check and decodes as its type
 * (both directions); every byte is accounted for (frame bytes + dropped + still
 * buffered = bytes fed); a schema mismatch leaves its stream offset behind the parser. */
#include "navkit/navkit_proto.h"

#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Decode a returned frame as its type; abort if that fails. */
static void decode_or_abort(const uint8_t *f, size_t len, navkit_dir_t dir)
{
    int rc;
    if (dir == NAVKIT_DIR_TO_HOST) {
        navkit_micro_data_t d;
        rc = navkit_micro_data_decode(f, len, &d);
    } else {
        switch (navkit_frame_type(f)) {
        case NAVKIT_MSG_TYPE_MICRO_CMD: {
            navkit_micro_cmd_t m;
            rc = navkit_micro_cmd_decode(f, len, &m);
            break;
        }
        case NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY: {
            navkit_micro_cfg_geometry_t m;
            rc = navkit_micro_cfg_geometry_decode(f, len, &m);
            break;
        }
        case NAVKIT_MSG_TYPE_MICRO_CFG_MOTION: {
            navkit_micro_cfg_motion_t m;
            rc = navkit_micro_cfg_motion_decode(f, len, &m);
            break;
        }
        case NAVKIT_MSG_TYPE_MICRO_CFG_IO: {
            navkit_micro_cfg_io_t m;
            rc = navkit_micro_cfg_io_decode(f, len, &m);
            break;
        }
        default: /* a to-micro type this target does not know: update the switch */
            rc = -1;
            break;
        }
    }
    if (rc != NAVKIT_OK) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    navkit_parser_t p;
    size_t at = 1, chunk, frame_bytes = 0;
    navkit_dir_t dir;
    if (size < 1) {
        return 0;
    }
    dir = (data[0] & 1) ? NAVKIT_DIR_TO_HOST : NAVKIT_DIR_TO_MICRO;
    chunk = 1 + (data[0] >> 1);
    navkit_parser_init(&p, dir);
    while (at < size) {
        const uint8_t *f;
        size_t len, c = size - at < chunk ? size - at : chunk;
        at += navkit_parser_feed(&p, data + at, c);
        while (navkit_parser_next(&p, &f, &len)) {
            if (navkit_frame_check(f, len, dir) != NAVKIT_OK) {
                abort();
            }
            decode_or_abort(f, len, dir);
            frame_bytes += len;
        }
    }
    if (frame_bytes + p.stats.dropped_bytes + p.have != size - 1) {
        abort();
    }
    if (p.stats.schema_mismatch && p.foreign_offset + 2u * (NAVKIT_HASH_WORD + 3u) > p.offset) {
        abort();
    }
    return 0;
}
