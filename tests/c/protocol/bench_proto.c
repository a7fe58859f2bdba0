/* navkit-proto-bench: frames/s of the C codec for micro_cmd, beside a bare memcpy+CRC
 * of the same bytes on the same machine.
 *   navkit-proto-bench [--frames N]    (default 2,000,000)
 * Prints one line per measurement: name, frames/s, ns/frame. */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include "navkit/navkit_proto.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define BENCH_MAX_FRAMES 1000000000L /* frames per measurement at most (~a minute each) */

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void report(const char *what, long n, double dt)
{
    printf("c  %-28s %12.0f frames/s %8.1f ns/frame\n", what, (double)n / dt, 1e9 * dt / (double)n);
}

int main(int argc, char **argv)
{
    long n = 2000000, i;
    volatile uint32_t sink = 0;
    uint8_t frame[NAVKIT_MICRO_CMD_BYTES], copy[NAVKIT_MICRO_CMD_BYTES];
    navkit_micro_cmd_t m;
    navkit_parser_t p;
    double t0;
    if (argc == 3 && strcmp(argv[1], "--frames") == 0) {
        char *end;
        errno = 0;
        n = strtol(argv[2], &end, 0);
        if (argv[2][0] == '\0' || *end != '\0' || errno == ERANGE || n < 1 || n > BENCH_MAX_FRAMES) {
            fprintf(stderr, "%s: --frames: '%s' is not an integer in 1..%ld\n", argv[0], argv[2], BENCH_MAX_FRAMES);
            return 2;
        }
    } else if (argc != 1) {
        fprintf(stderr, "usage: %s [--frames N]\n", argv[0]);
        return 2;
    }
    navkit_micro_cmd_defaults(&m);
    m.fwd_cmd = NAVKIT_FWD_CMD_START;
    m.speed = 200;
    m.distance = 1000;

    t0 = now_s();
    for (i = 0; i < n; i++) {
        m.time_tag = (uint16_t)i;
        sink += (uint32_t)navkit_micro_cmd_encode(&m, frame, sizeof frame);
    }
    report("micro_cmd encode", n, now_s() - t0);

    navkit_parser_init(&p, NAVKIT_DIR_TO_MICRO);
    t0 = now_s();
    for (i = 0; i < n; i++) {
        const uint8_t *f;
        size_t len;
        navkit_micro_cmd_t d;
        navkit_parser_feed(&p, frame, sizeof frame);
        while (navkit_parser_next(&p, &f, &len)) {
            if (navkit_micro_cmd_decode(f, len, &d) == NAVKIT_OK && navkit_micro_cmd_check(&d, NULL) == NAVKIT_OK) {
                sink += d.time_tag;
            }
        }
    }
    report("micro_cmd parse+decode+check", n, now_s() - t0);
    if (p.stats.good != (uint32_t)n) {
        fprintf(stderr, "bench: parsed %u of %ld frames\n", p.stats.good, n);
        return 1;
    }

    t0 = now_s();
    for (i = 0; i < n; i++) {
        frame[2] = (uint8_t)i;
        memcpy(copy, frame, sizeof frame);
        sink += navkit_crc16(copy, sizeof copy);
    }
    report("baseline memcpy+crc16", n, now_s() - t0);
    (void)sink;
    return 0;
}
