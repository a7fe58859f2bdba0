/* navkit wire runtime: CRC, frame sealing and checking, the incremental parser.
 * See navkit_wire.h for the ordering contract. */
#include "navkit/navkit_proto.h"

#include <string.h>

uint16_t navkit_crc16_update(uint16_t crc, uint8_t byte)
{
    /* Byte-wise form of the reflected 0x1021 polynomial (as avr-libc's
     * _crc_ccitt_update): no table, so it costs no RAM on the AVR. */
    uint8_t x = (uint8_t)(byte ^ (uint8_t)(crc & 0xFFu));
    x = (uint8_t)(x ^ (uint8_t)(x << 4));
    return (uint16_t)(((uint16_t)x << 8 | (crc >> 8)) ^ (uint8_t)(x >> 4) ^ ((uint16_t)x << 3));
}

uint16_t navkit_crc16(const uint8_t *data, size_t len)
{
    uint16_t crc = 0xFFFFu;
    size_t i;
    for (i = 0; i < len; i++) {
        crc = navkit_crc16_update(crc, data[i]);
    }
    return crc;
}

void navkit_frame_seal(uint8_t *frame, size_t len, uint16_t msg_type)
{
    navkit_put_u16(frame, NAVKIT_START_WORD);
    navkit_put_u16(frame + 4, msg_type);
    navkit_put_u16(frame + 2u * NAVKIT_LENGTH_WORD, (uint16_t)(len / 2u));
    navkit_put_u16(frame + len - 2u, navkit_crc16(frame, len - 2u));
}

int navkit_frame_check(const uint8_t *frame, size_t len, navkit_dir_t dir)
{
    uint16_t words;
    if (len < 2u * (NAVKIT_LENGTH_WORD + 2u)) {
        return NAVKIT_ERR_LENGTH;
    }
    if (navkit_get_u16(frame) != NAVKIT_START_WORD) {
        return NAVKIT_ERR_START;
    }
    words = navkit_frame_words(navkit_frame_type(frame), dir);
    if (words == 0u) {
        return NAVKIT_ERR_TYPE;
    }
    if (navkit_get_u16(frame + 2u * NAVKIT_LENGTH_WORD) != words || len != 2u * words) {
        return NAVKIT_ERR_LENGTH;
    }
    if (navkit_get_u16(frame + len - 2u) != navkit_crc16(frame, len - 2u)) {
        return NAVKIT_ERR_CRC;
    }
    return NAVKIT_OK;
}

void navkit_parser_init(navkit_parser_t *p, navkit_dir_t accept)
{
    memset(p, 0, sizeof(*p));
    p->dir = accept;
}

/* Drop n bytes from the front of the buffer. */
static void parser_drop(navkit_parser_t *p, uint16_t n)
{
    memmove(p->buf, p->buf + n, (size_t)(p->have - n));
    p->have = (uint16_t)(p->have - n);
    p->offset += n;
}

/* Reject the candidate at buf[0]: count its reason, skip its first byte. */
static void parser_reject(navkit_parser_t *p, int reason, uint32_t *counter)
{
    (*counter)++;
    p->last_error = reason;
    p->last_error_offset = p->offset;
    p->stats.dropped_bytes++;
    parser_drop(p, 1u);
}

size_t navkit_parser_feed(navkit_parser_t *p, const uint8_t *data, size_t len)
{
    size_t room;
    if (p->consume) {
        parser_drop(p, p->consume);
        p->consume = 0;
    }
    room = sizeof(p->buf) - p->have;
    if (len > room) {
        len = room;
    }
    memcpy(p->buf + p->have, data, len);
    p->have = (uint16_t)(p->have + len);
    return len;
}

int navkit_parser_next(navkit_parser_t *p, const uint8_t **frame, size_t *len)
{
    const uint8_t start_lo = (uint8_t)(NAVKIT_START_WORD & 0xFFu);
    const uint8_t start_hi = (uint8_t)(NAVKIT_START_WORD >> 8);
    if (p->consume) {
        parser_drop(p, p->consume);
        p->consume = 0;
    }
    for (;;) {
        uint16_t i = 0, words, n;
        /* Skip to the first possible start word. */
        while (i < p->have && p->buf[i] != start_lo) {
            i++;
        }
        if (i) {
            p->stats.dropped_bytes += i;
            parser_drop(p, i);
        }
        if (p->have < 2u) {
            return 0;
        }
        if (p->buf[1] != start_hi) {
            p->stats.dropped_bytes++;
            parser_drop(p, 1u);
            continue;
        }
        if (p->have < 2u * (NAVKIT_LENGTH_WORD + 1u)) {
            return 0;
        }
        words = navkit_frame_words(navkit_frame_type(p->buf), p->dir);
        if (words == 0u) {
            parser_reject(p, NAVKIT_ERR_TYPE, &p->stats.unknown_type);
            continue;
        }
        if (navkit_get_u16(p->buf + 2u * NAVKIT_LENGTH_WORD) != words) {
            parser_reject(p, NAVKIT_ERR_LENGTH, &p->stats.bad_length);
            continue;
        }
        n = (uint16_t)(2u * words);
        if (p->have < n) {
            return 0;
        }
        if (navkit_get_u16(p->buf + n - 2u) != navkit_crc16(p->buf, n - 2u)) {
            parser_reject(p, NAVKIT_ERR_CRC, &p->stats.bad_crc);
            continue;
        }
        p->stats.good++;
        p->consume = n;
        *frame = p->buf;
        *len = n;
        return 1;
    }
}
