/* libFuzzer target for the frame parser (preset `fuzz`: clang, ASan+UBSan).
 * Input: byte 0 picks the direction and the feed chunk size; the rest is the stream.
 * Invariants: every returned frame passes navkit_frame_check and decodes; every byte
 * is accounted for (frame bytes + dropped + still buffered = bytes fed). */
#include "navkit/navkit_proto.h"

#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

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
            if (dir == NAVKIT_DIR_TO_HOST) {
                navkit_micro_data_t d;
                if (navkit_micro_data_decode(f, len, &d) != NAVKIT_OK) {
                    abort();
                }
            }
            frame_bytes += len;
        }
    }
    if (frame_bytes + p.stats.dropped_bytes + p.have != size - 1) {
        abort();
    }
    return 0;
}
