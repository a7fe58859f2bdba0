/* navkit wire runtime: hand-written, kept apart from the generated code.
 *
 * What is here: little-endian byte access (no packed-struct casts, no unaligned
 * loads), CRC-16/MCRF4XX, and the incremental frame parser for the serial link.
 * The generated navkit_proto.h includes this header and supplies the message tables
 * (navkit_frame_words()) the parser checks against.
 *
 * Ordering contract of the parser:
 *   1. navkit_parser_feed() copies bytes in; it takes fewer than offered when full.
 *   2. navkit_parser_next() returns at most one frame per call; the frame pointer is
 *      valid until the next call of feed() or next() on the same parser.
 *   3. Every byte is either part of a returned frame or counted in dropped_bytes; each
 *      rejected candidate frame increments exactly one error counter.
 *   4. A candidate (start word at buf[0]) is judged in this order: type known for the
 *      direction (else unknown_type); length word equal to the type's (else see 5);
 *      CRC over that length (else bad_crc). Each of these rejects skips ONE byte and
 *      resyncs on the next start word.
 *   5. Length word not the type's: if the type carries spec_hash (words 4-5, frozen
 *      across spec versions) and the length is within NAVKIT_HASH_WORD + 3 ..
 *      NAVKIT_MAX_FRAME_WORDS, the parser waits for that many words; if the CRC is good
 *      over them it is a frame of another spec version: schema_mismatch counts it,
 *      foreign_hash / foreign_offset keep its hash and stream offset, and all of its
 *      bytes are consumed (counted in dropped_bytes, not resynced inside). Otherwise
 *      (either test fails) bad_length counts it and one byte is skipped.
 * No heap, no statics: all state is in navkit_parser_t, so several can coexist.
 */
#ifndef NAVKIT_WIRE_H
#define NAVKIT_WIRE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Result codes of every navkit_* call that can fail (5 is unused: it was a buffer
 * space code that no call returned). */
enum {
    NAVKIT_OK = 0,
    NAVKIT_ERR_CRC = 1,       /* CRC word does not match the bytes before it */
    NAVKIT_ERR_TYPE = 2,      /* message type unknown, or not for this direction */
    NAVKIT_ERR_LENGTH = 3,    /* length word or buffer length differs from the type's */
    NAVKIT_ERR_RANGE = 4,     /* a field is outside its spec min..max */
    NAVKIT_ERR_START = 6,     /* frame does not begin with the start word */
    NAVKIT_ERR_SCHEMA = 7,    /* a CRC-good frame of another spec version (parser only) */
    NAVKIT_ERR_CONSTRAINT = 8 /* fields within their ranges break a spec constraint (le, nonzero) */
};

/* Short English text of a result code ("bad CRC", "schema mismatch", ...; "?" if unknown),
 * for log lines. */
const char *navkit_error_text(int code);

/* Which serial messages a parser accepts. */
typedef enum {
    NAVKIT_DIR_TO_MICRO = 0, /* host -> micro: commands and config */
    NAVKIT_DIR_TO_HOST = 1   /* micro -> host: micro_data */
} navkit_dir_t;

/* Little-endian stores and loads of 16/32-bit words at any byte address. */
static inline void navkit_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}
static inline void navkit_put_u32(uint8_t *p, uint32_t v)
{
    navkit_put_u16(p, (uint16_t)(v & 0xFFFFu));
    navkit_put_u16(p + 2, (uint16_t)(v >> 16));
}
static inline uint16_t navkit_get_u16(const uint8_t *p)
{
    return (uint16_t)((uint16_t)p[0] | ((uint16_t)p[1] << 8));
}
static inline uint32_t navkit_get_u32(const uint8_t *p)
{
    return (uint32_t)navkit_get_u16(p) | ((uint32_t)navkit_get_u16(p + 2) << 16);
}

/* CRC-16/MCRF4XX: poly 0x1021 reflected (0x8408), init 0xFFFF, no final xor.
 * On the AVR this is avr-libc's _crc_ccitt_update() (util/crc16.h, hand-written
 * assembly); elsewhere the same byte-wise formula in C. check("123456789") = 0x6F91. */
uint16_t navkit_crc16_update(uint16_t crc, uint8_t byte);
/* CRC of len bytes starting from the init value 0xFFFF. */
uint16_t navkit_crc16(const uint8_t *data, size_t len);

/* Frame words (whole frame incl. start, length and CRC) of a message type for the
 * given direction; 0 if the type is unknown or belongs to the other direction.
 * Generated from the spec (navkit_proto.c). */
uint16_t navkit_frame_words(uint16_t msg_type, navkit_dir_t dir);

/* 1 if msg_type is known for dir and carries spec_hash (uint32 at word
 * NAVKIT_HASH_WORD), else 0. Generated from the spec (navkit_proto.c). */
int navkit_frame_hashed(uint16_t msg_type, navkit_dir_t dir);

/* Write the start word and length word and seal the frame: CRC of bytes [0, len-2)
 * into the last word. len = 2 * frame words. */
void navkit_frame_seal(uint8_t *frame, size_t len, uint16_t msg_type);

/* Check a whole frame: start word, length word, type for dir, CRC. NAVKIT_OK or the
 * reason (NAVKIT_ERR_START/TYPE/LENGTH/CRC). */
int navkit_frame_check(const uint8_t *frame, size_t len, navkit_dir_t dir);

/* Message type of a frame (word 2). */
static inline uint16_t navkit_frame_type(const uint8_t *frame)
{
    return navkit_get_u16(frame + 4);
}

/* Link counters. A rejected candidate frame counts once, in the counter of its reason. */
typedef struct {
    uint32_t good;            /* frames returned */
    uint32_t bad_crc;         /* candidates with a wrong CRC */
    uint32_t unknown_type;    /* candidates with an unknown (or other direction's) type */
    uint32_t bad_length;      /* candidates whose length word is not their type's (and not
                                 a CRC-good frame of another spec version) */
    uint32_t schema_mismatch; /* CRC-good frames of another spec version (contract 5) */
    uint32_t dropped_bytes;   /* bytes discarded (not part of a returned frame) */
} navkit_link_stats_t;

/* Incremental frame parser. Fixed size: a buffer for the longest frame of any spec
 * version (NAVKIT_MAX_FRAME_WORDS words, to judge other versions' frames) plus counters. */
typedef struct navkit_parser {
    uint16_t want; /* bytes: next() found the candidate at buf[0] short; until
                                  `have` reaches this it returns 0 at once, as judging it
                                  again could change nothing (first: a short displacement
                                  for the AVR's stores) */
    uint8_t buf[2u * NAVKIT_MAX_FRAME_WORDS];
    uint16_t have;              /* bytes in buf */
    uint16_t consume;           /* bytes of the frame returned last, dropped on the next call */
    navkit_dir_t dir;           /* which types are accepted */
    uint32_t offset;            /* stream offset (bytes fed so far) of buf[0] */
    int last_error;             /* reason of the last rejected candidate (NAVKIT_ERR_*) */
    uint32_t last_error_offset; /* its stream offset */
    uint32_t foreign_hash;      /* spec hash of the last schema_mismatch frame (0: none yet) */
    uint32_t foreign_offset;    /* its stream offset */
    navkit_link_stats_t stats;
} navkit_parser_t;

/* Reset p to empty with zeroed counters, accepting the types of `accept`. */
void navkit_parser_init(navkit_parser_t *p, navkit_dir_t accept);
/* Copy up to len bytes in; returns how many were taken (call next() to make room). */
size_t navkit_parser_feed(navkit_parser_t *p, const uint8_t *data, size_t len);
/* 1: *frame and *len hold one whole valid frame (valid until the next feed/next call);
 * 0: more bytes are needed. Rejected bytes are counted and skipped. */
int navkit_parser_next(navkit_parser_t *p, const uint8_t **frame, size_t *len);
/* End of a message that carries one frame (an ISO-TP message), once next() has returned 0:
 * the bytes p still holds belong to no later message, so they are counted in
 * stats.dropped_bytes and cleared. */
static inline void navkit_parser_discard(navkit_parser_t *p)
{
    p->stats.dropped_bytes += p->have;
    p->offset += p->have;
    p->have = 0u;
    p->want = 0u;
}

#ifdef __cplusplus
}
#endif
#endif /* NAVKIT_WIRE_H */
