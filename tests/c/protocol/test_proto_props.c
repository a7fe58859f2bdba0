/* Seeded property tests of the C protocol code (ruckig-style: seed and count on the
 * command line, `test_proto_props --seed S --count N`).
 *
 * For N random payloads of every serial message:
 *  - round trip: seal random field bytes into a frame, decode, re-encode: same bytes;
 *    _decode_parsed() of the frame gives the struct _decode() gives;
 *  - every single-bit flip of the frame is rejected, and a good frame after it is found;
 *  - every truncation is rejected (never returned as a frame);
 *  - the byte-wise CRC equals the table CRC;
 *  - random garbage between good frames: every good frame is recovered at its stream
 *    offset with its bytes, and every byte is accounted for (frame bytes + dropped +
 *    still buffered = bytes fed);
 *  - a frame of another spec version (hash-carrying type, other length, good CRC) is
 *    counted as schema_mismatch with its hash and offset, consumed whole, and the good
 *    frame after it is found;
 *  - rcomm messages (lisp_cmd, lisp_data, emotion): load/store and pack/unpack of
 *    random bytes give the same bytes and the same struct.
 */
#include "navkit/navkit_proto.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures;
#define CHECK(cond, ...)                                                                                               \
    do {                                                                                                               \
        if (!(cond)) {                                                                                                 \
            failures++;                                                                                                \
            if (failures < 20) {                                                                                       \
                printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);                                                 \
                printf(__VA_ARGS__);                                                                                   \
                printf("\n");                                                                                          \
            }                                                                                                          \
        }                                                                                                              \
    } while (0)

/* splitmix64: a tiny seeded generator, state passed explicitly. */
static uint64_t rnd(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

typedef struct {
    uint16_t type;
    navkit_dir_t dir;
    size_t bytes;
} msg_t;

static const msg_t MSGS[] = {
    {NAVKIT_MSG_TYPE_MICRO_CMD, NAVKIT_DIR_TO_MICRO, NAVKIT_MICRO_CMD_BYTES},
    {NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY, NAVKIT_DIR_TO_MICRO, NAVKIT_MICRO_CFG_GEOMETRY_BYTES},
    {NAVKIT_MSG_TYPE_MICRO_CFG_MOTION, NAVKIT_DIR_TO_MICRO, NAVKIT_MICRO_CFG_MOTION_BYTES},
    {NAVKIT_MSG_TYPE_MICRO_CFG_IO, NAVKIT_DIR_TO_MICRO, NAVKIT_MICRO_CFG_IO_BYTES},
    {NAVKIT_MSG_TYPE_MICRO_DATA, NAVKIT_DIR_TO_HOST, NAVKIT_MICRO_DATA_BYTES},
};
#define NMSGS (sizeof MSGS / sizeof MSGS[0])

/* Decode the frame `tmp` of message k and encode it again into f. */
static void reencode(size_t k, const uint8_t *tmp, uint8_t *f)
{
    size_t n = MSGS[k].bytes;
    switch (MSGS[k].type) {
    case NAVKIT_MSG_TYPE_MICRO_CMD: {
        navkit_micro_cmd_t m, q;
        memset(&m, 0, sizeof m);
        memset(&q, 0, sizeof q);
        CHECK(navkit_micro_cmd_decode(tmp, n, &m) == NAVKIT_OK, "decode");
        navkit_micro_cmd_decode_parsed(tmp, &q);
        CHECK(memcmp(&m, &q, sizeof m) == 0, "decode_parsed gives what decode gives");
        CHECK(navkit_micro_cmd_encode(&m, f, n) == n, "encode");
        break;
    }
    case NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY: {
        navkit_micro_cfg_geometry_t m, q;
        memset(&m, 0, sizeof m);
        memset(&q, 0, sizeof q);
        CHECK(navkit_micro_cfg_geometry_decode(tmp, n, &m) == NAVKIT_OK, "decode");
        navkit_micro_cfg_geometry_decode_parsed(tmp, &q);
        CHECK(memcmp(&m, &q, sizeof m) == 0, "decode_parsed gives what decode gives");
        CHECK(navkit_micro_cfg_geometry_encode(&m, f, n) == n, "encode");
        break;
    }
    case NAVKIT_MSG_TYPE_MICRO_CFG_MOTION: {
        navkit_micro_cfg_motion_t m, q;
        memset(&m, 0, sizeof m);
        memset(&q, 0, sizeof q);
        CHECK(navkit_micro_cfg_motion_decode(tmp, n, &m) == NAVKIT_OK, "decode");
        navkit_micro_cfg_motion_decode_parsed(tmp, &q);
        CHECK(memcmp(&m, &q, sizeof m) == 0, "decode_parsed gives what decode gives");
        CHECK(navkit_micro_cfg_motion_encode(&m, f, n) == n, "encode");
        break;
    }
    case NAVKIT_MSG_TYPE_MICRO_CFG_IO: {
        navkit_micro_cfg_io_t m, q;
        memset(&m, 0, sizeof m);
        memset(&q, 0, sizeof q);
        CHECK(navkit_micro_cfg_io_decode(tmp, n, &m) == NAVKIT_OK, "decode");
        navkit_micro_cfg_io_decode_parsed(tmp, &q);
        CHECK(memcmp(&m, &q, sizeof m) == 0, "decode_parsed gives what decode gives");
        CHECK(navkit_micro_cfg_io_encode(&m, f, n) == n, "encode");
        break;
    }
    default: {
        navkit_micro_data_t m, q;
        memset(&m, 0, sizeof m);
        memset(&q, 0, sizeof q);
        CHECK(navkit_micro_data_decode(tmp, n, &m) == NAVKIT_OK, "decode");
        navkit_micro_data_decode_parsed(tmp, &q);
        CHECK(memcmp(&m, &q, sizeof m) == 0, "decode_parsed gives what decode gives");
        CHECK(navkit_micro_data_encode(&m, f, n) == n, "encode");
        break;
    }
    }
}

/* A random valid frame of message k: random payload, sealed, then decoded and encoded
 * once so that spare words are 0 as every encoder writes them. */
static void random_frame(uint64_t *s, size_t k, uint8_t *f)
{
    uint8_t tmp[NAVKIT_MAX_FRAME_BYTES];
    size_t i, n = MSGS[k].bytes;
    for (i = 0; i < n; i++) {
        tmp[i] = (uint8_t)rnd(s);
    }
    navkit_frame_seal(tmp, n, MSGS[k].type);
    reencode(k, tmp, f);
}

/* Decode and re-encode f: must give the same bytes (the round-trip property). */
static void check_round_trip(size_t k, const uint8_t *f)
{
    uint8_t again[NAVKIT_MAX_FRAME_BYTES];
    reencode(k, f, again);
    CHECK(memcmp(again, f, MSGS[k].bytes) == 0, "round trip of type %u", MSGS[k].type);
}

#define MAX_FRAMES 64

typedef struct {
    uint32_t frames, frame_bytes;
    uint32_t offset[MAX_FRAMES]; /* stream offset of each frame returned (the first MAX_FRAMES) */
} feed_result_t;

/* Feed n bytes in chunks of `chunk`; count frames returned (each checked valid and
 * compared with the stream bytes at its offset). */
static feed_result_t feed_all(navkit_parser_t *p, const uint8_t *d, size_t n, size_t chunk)
{
    feed_result_t r;
    const uint8_t *frame;
    size_t len, at = 0;
    uint32_t base = p->offset + p->have; /* stream offset of d[0] */
    memset(&r, 0, sizeof r);
    while (at < n) {
        size_t c = n - at < chunk ? n - at : chunk;
        at += navkit_parser_feed(p, d + at, c);
        while (navkit_parser_next(p, &frame, &len)) {
            CHECK(navkit_frame_check(frame, len, p->dir) == NAVKIT_OK, "returned frame invalid");
            if (p->offset >= base) {
                CHECK(memcmp(frame, d + (p->offset - base), len) == 0, "frame bytes differ from the stream's");
            }
            if (r.frames < MAX_FRAMES) {
                r.offset[r.frames] = p->offset;
            }
            r.frames++;
            r.frame_bytes += (uint32_t)len;
        }
    }
    return r;
}

static void check_bit_flips(size_t k, const uint8_t *f)
{
    uint8_t buf[2 * NAVKIT_MAX_FRAME_BYTES + 2 * NAVKIT_MAX_FRAME_WORDS];
    size_t n = MSGS[k].bytes, bit;
    for (bit = 0; bit < 8 * n; bit++) {
        navkit_parser_t p;
        feed_result_t r;
        memcpy(buf, f, n);
        buf[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        memcpy(buf + n, f, n);
        navkit_parser_init(&p, MSGS[k].dir);
        r = feed_all(&p, buf, n, n);
        CHECK(r.frames == 0, "type %u bit %u flipped was accepted", MSGS[k].type, (unsigned)bit);
        /* a flip in the length word of a hash-carrying type may hold the parser until
         * the claimed length has arrived (contract 5): zeros (no start byte) follow */
        memset(buf + 2 * n, 0, sizeof buf - 2 * n);
        r = feed_all(&p, buf + n, sizeof buf - n, 7);
        CHECK(r.frames == 1, "type %u: good frame after bit %u flip lost", MSGS[k].type, (unsigned)bit);
    }
}

static void check_truncations(size_t k, const uint8_t *f)
{
    size_t n = MSGS[k].bytes, cut;
    for (cut = 0; cut < n; cut++) {
        navkit_parser_t p;
        navkit_parser_init(&p, MSGS[k].dir);
        CHECK(feed_all(&p, f, cut, n).frames == 0, "truncation %u accepted", (unsigned)cut);
        CHECK(navkit_frame_check(f, cut, MSGS[k].dir) != NAVKIT_OK, "frame_check of %u bytes", (unsigned)cut);
    }
}

static void check_garbage(uint64_t *s)
{
    uint8_t stream[4096];
    size_t n = 0, k, chunk = 1 + (size_t)(rnd(s) % 64), j;
    uint32_t want = 0, sent[MAX_FRAMES];
    navkit_parser_t p;
    feed_result_t r;
    navkit_dir_t dir = (rnd(s) & 1) ? NAVKIT_DIR_TO_MICRO : NAVKIT_DIR_TO_HOST;
    while (n < sizeof stream - 2 * NAVKIT_MAX_FRAME_BYTES && want < MAX_FRAMES) {
        size_t g = (size_t)(rnd(s) % 40), i;
        for (i = 0; i < g; i++) {
            /* garbage rich in start-word bytes, the hard case for resync */
            uint64_t x = rnd(s);
            stream[n++] = (x & 3) == 0 ? 0xA5 : (x & 3) == 1 ? 0xFF : (uint8_t)(x >> 8);
        }
        k = (size_t)(rnd(s) % NMSGS);
        random_frame(s, k, stream + n);
        if (MSGS[k].dir == dir) {
            sent[want++] = (uint32_t)n;
        }
        n += MSGS[k].bytes;
    }
    navkit_parser_init(&p, dir);
    r = feed_all(&p, stream, n, chunk);
    /* Every frame sent is returned at its offset (feed_all compared its bytes). Garbage
     * could form an extra valid frame only by a 1 in 65536 CRC match; allow that. */
    CHECK(r.frames >= want && r.frames <= MAX_FRAMES, "garbage: %u frames for %u sent", r.frames, want);
    for (j = 0, k = 0; j < want; j++) {
        while (k < r.frames && k < MAX_FRAMES && r.offset[k] < sent[j]) {
            k++;
        }
        CHECK(k < r.frames && k < MAX_FRAMES && r.offset[k] == sent[j], "garbage: frame at offset %u lost",
              (unsigned)sent[j]);
    }
    CHECK(r.frame_bytes + p.stats.dropped_bytes + p.have == n, "byte accounting: %u + %u + %u != %u", r.frame_bytes,
          p.stats.dropped_bytes, p.have, (unsigned)n);
}

/* A frame of another spec version: hash-carrying type k, `words` long, hash h. */
static size_t foreign_frame(uint64_t *s, size_t k, uint16_t words, uint32_t h, uint8_t *f)
{
    size_t i, n = 2u * words;
    for (i = 0; i < n; i++) {
        f[i] = (uint8_t)rnd(s);
    }
    navkit_put_u32(f + 2u * NAVKIT_HASH_WORD, h);
    navkit_frame_seal(f, n, MSGS[k].type);
    return n;
}

static void check_schema_mismatch(uint64_t *s, size_t k, const uint8_t *good)
{
    uint8_t buf[2u * NAVKIT_MAX_FRAME_WORDS + NAVKIT_MAX_FRAME_BYTES];
    uint16_t words;
    uint32_t h = (uint32_t)rnd(s);
    size_t n, chunk = 1 + (size_t)(rnd(s) % 40);
    navkit_parser_t p;
    feed_result_t r;
    if (!navkit_frame_hashed(MSGS[k].type, MSGS[k].dir)) {
        return;
    }
    do {
        words = (uint16_t)(NAVKIT_HASH_WORD + 3u + rnd(s) % (NAVKIT_MAX_FRAME_WORDS - NAVKIT_HASH_WORD - 2u));
    } while (2u * words == MSGS[k].bytes);
    n = foreign_frame(s, k, words, h, buf);
    memcpy(buf + n, good, MSGS[k].bytes);
    navkit_parser_init(&p, MSGS[k].dir);
    r = feed_all(&p, buf, n + MSGS[k].bytes, chunk);
    CHECK(r.frames == 1 && r.offset[0] == n, "type %u: good frame after a %u-word foreign frame", MSGS[k].type,
          (unsigned)words);
    CHECK(p.stats.schema_mismatch == 1 && p.stats.bad_length == 0 && p.stats.dropped_bytes == n,
          "type %u: %u-word foreign frame: mismatch %u, bad length %u, dropped %u", MSGS[k].type, (unsigned)words,
          p.stats.schema_mismatch, p.stats.bad_length, p.stats.dropped_bytes);
    CHECK(p.foreign_hash == h && p.foreign_offset == 0 && p.last_error == NAVKIT_ERR_SCHEMA, "foreign hash");
    /* the same frame with one bit of its CRC flipped is a bad length, skipped byte-wise */
    buf[n - 1] ^= 0x01u;
    navkit_parser_init(&p, MSGS[k].dir);
    r = feed_all(&p, buf, n + MSGS[k].bytes, chunk);
    CHECK(r.frames >= 1 && p.stats.schema_mismatch == 0 && p.stats.bad_length >= 1, "foreign frame, bad CRC");
}

/* rcomm messages: random bytes -> load -> store gives the same bytes; pack -> unpack
 * gives the same struct, and the words are the little-endian bytes. */
#define RCOMM_ROUND_TRIP(name, NAME)                                                                                   \
    do {                                                                                                               \
        uint8_t b[NAVKIT_##NAME##_BYTES], again[NAVKIT_##NAME##_BYTES];                                                \
        int32_t w[NAVKIT_##NAME##_WORDS];                                                                              \
        navkit_##name##_t m, d;                                                                                        \
        size_t j;                                                                                                      \
        for (j = 0; j < sizeof b; j++) {                                                                               \
            b[j] = (uint8_t)rnd(s);                                                                                    \
        }                                                                                                              \
        memset(&m, 0, sizeof m);                                                                                       \
        memset(&d, 0, sizeof d);                                                                                       \
        navkit_##name##_load(b, &m);                                                                                   \
        navkit_##name##_store(&m, again);                                                                              \
        CHECK(memcmp(b, again, sizeof b) == 0, #name " load/store");                                                   \
        navkit_##name##_pack(&m, w);                                                                                   \
        for (j = 0; j < NAVKIT_##NAME##_WORDS; j++) {                                                                  \
            CHECK((uint32_t)w[j] == navkit_get_u32(b + 4 * j), #name " word %u", (unsigned)j);                         \
        }                                                                                                              \
        navkit_##name##_unpack(w, &d);                                                                                 \
        CHECK(memcmp(&m, &d, sizeof m) == 0, #name " pack/unpack");                                                    \
    } while (0)

static void check_rcomm(uint64_t *s)
{
    RCOMM_ROUND_TRIP(lisp_cmd, LISP_CMD);
    RCOMM_ROUND_TRIP(lisp_data, LISP_DATA);
    RCOMM_ROUND_TRIP(emotion, EMOTION);
}

/* An unsigned integer option value (decimal, 0x hex or 0 octal), the whole text, within
 * lo..hi; else a message naming the option and the value, and 0. */
static int props_arg(const char *prog, const char *opt, const char *text, unsigned long long lo, unsigned long long hi,
                     unsigned long long *out)
{
    char *end;
    errno = 0;
    *out = strtoull(text, &end, 0);
    if (text[0] == '\0' || *end != '\0' || strchr(text, '-') != NULL || errno == ERANGE || *out < lo || *out > hi) {
        fprintf(stderr, "%s: %s: '%s' is not an integer in %llu..%llu\n", prog, opt, text, lo, hi);
        return 0;
    }
    return 1;
}

int main(int argc, char **argv)
{
    uint64_t seed = 1, s;
    long count = 1000, i;
    unsigned long long v;
    int a;
    for (a = 1; a + 1 < argc; a += 2) {
        if (strcmp(argv[a], "--seed") == 0) {
            if (!props_arg(argv[0], "--seed", argv[a + 1], 0u, UINT64_MAX, &v)) {
                return 2;
            }
            seed = (uint64_t)v;
        } else if (strcmp(argv[a], "--count") == 0) {
            if (!props_arg(argv[0], "--count", argv[a + 1], 1u, 1000000000u, &v)) {
                return 2;
            }
            count = (long)v;
        } else {
            fprintf(stderr, "usage: %s [--seed S] [--count N]\n", argv[0]);
            return 2;
        }
    }
    if (a != argc) {
        fprintf(stderr, "usage: %s [--seed S] [--count N]\n", argv[0]);
        return 2;
    }
    /* the byte-wise CRC (the AVR's) and navkit_crc16 (a table off the AVR) agree */
    CHECK(navkit_crc16((const uint8_t *)"123456789", 9) == 0x6F91u, "check value");
    s = seed;
    for (i = 0; i < 1000; i++) {
        uint8_t d[64];
        uint16_t crc = 0xFFFFu;
        size_t j, n = (size_t)(rnd(&s) % sizeof d);
        for (j = 0; j < n; j++) {
            d[j] = (uint8_t)rnd(&s);
            crc = navkit_crc16_update(crc, d[j]);
        }
        CHECK(crc == navkit_crc16(d, n), "crc forms differ");
    }
    for (i = 0; i < count; i++) {
        uint8_t f[NAVKIT_MAX_FRAME_BYTES];
        size_t k = (size_t)(i % (long)NMSGS);
        random_frame(&s, k, f);
        check_round_trip(k, f);
        check_rcomm(&s);
        check_schema_mismatch(&s, k, f);
        if (i < (long)(4 * NMSGS)) { /* exhaustive flips and cuts: a few frames each */
            check_bit_flips(k, f);
            check_truncations(k, f);
        }
        if (i % 20 == 0) {
            check_garbage(&s);
        }
    }
    printf("proto props: seed %llu, count %ld: %d failure(s)\n", (unsigned long long)seed, count, failures);
    return failures ? 1 : 0;
}
