/* navkit wire runtime: CRC, frame sealing and checking, the incremental parser.
 * See navkit_wire.h for the ordering contract. */
#include "navkit/navkit_proto.h"

#include <string.h>

#if defined(__AVR__)
#include <util/crc16.h>
#endif

const char *navkit_error_text(int code)
{
    switch (code) {
    case NAVKIT_OK:
        return "ok";
    case NAVKIT_ERR_CRC:
        return "bad CRC";
    case NAVKIT_ERR_TYPE:
        return "unknown type";
    case NAVKIT_ERR_LENGTH:
        return "bad length";
    case NAVKIT_ERR_RANGE:
        return "out of range";
    case NAVKIT_ERR_START:
        return "no start word";
    case NAVKIT_ERR_SCHEMA:
        return "schema mismatch";
    case NAVKIT_ERR_CONSTRAINT:
        return "constraint broken";
    default:
        return "?";
    }
}

#if defined(__AVR__)
/* The CRC of len bytes from crc on: the one call of avr-libc's _crc_ccitt_update (same
 * polynomial, hand-written asm), so the compiler inlines it into the loop, with no call per
 * byte (the link checks and seals every frame with it). */
static uint16_t crc16_run(uint16_t crc, const uint8_t *data, size_t len)
{
    const uint8_t *end = data + len;
    while (data != end) {
        crc = _crc_ccitt_update(crc, *data++);
    }
    return crc;
}

uint16_t navkit_crc16_update(uint16_t crc, uint8_t byte)
{
    return crc16_run(crc, &byte, 1u);
}
#else
uint16_t navkit_crc16_update(uint16_t crc, uint8_t byte)
{
    /* Byte-wise form of the reflected 0x1021 polynomial (the C equivalent of avr-libc's
     * _crc_ccitt_update): no table. */
    uint8_t x = (uint8_t)(byte ^ (uint8_t)(crc & 0xFFu));
    x = (uint8_t)(x ^ (uint8_t)(x << 4));
    return (uint16_t)(((uint16_t)x << 8 | (crc >> 8)) ^ (uint8_t)(x >> 4) ^ ((uint16_t)x << 3));
}
#endif

#if defined(__AVR__)
uint16_t navkit_crc16(const uint8_t *data, size_t len)
{
    return crc16_run(0xFFFFu, data, len);
}
#else
/* Off the AVR, tables are cheap and much faster than the bit-wise form:
 * CRC_TABLE[b] is the CRC register after shifting byte b through 8 steps. */
static const uint16_t CRC_TABLE[256] = {
    0x0000, 0x1189, 0x2312, 0x329B, 0x4624, 0x57AD, 0x6536, 0x74BF, 0x8C48, 0x9DC1, 0xAF5A, 0xBED3, 0xCA6C, 0xDBE5,
    0xE97E, 0xF8F7, 0x1081, 0x0108, 0x3393, 0x221A, 0x56A5, 0x472C, 0x75B7, 0x643E, 0x9CC9, 0x8D40, 0xBFDB, 0xAE52,
    0xDAED, 0xCB64, 0xF9FF, 0xE876, 0x2102, 0x308B, 0x0210, 0x1399, 0x6726, 0x76AF, 0x4434, 0x55BD, 0xAD4A, 0xBCC3,
    0x8E58, 0x9FD1, 0xEB6E, 0xFAE7, 0xC87C, 0xD9F5, 0x3183, 0x200A, 0x1291, 0x0318, 0x77A7, 0x662E, 0x54B5, 0x453C,
    0xBDCB, 0xAC42, 0x9ED9, 0x8F50, 0xFBEF, 0xEA66, 0xD8FD, 0xC974, 0x4204, 0x538D, 0x6116, 0x709F, 0x0420, 0x15A9,
    0x2732, 0x36BB, 0xCE4C, 0xDFC5, 0xED5E, 0xFCD7, 0x8868, 0x99E1, 0xAB7A, 0xBAF3, 0x5285, 0x430C, 0x7197, 0x601E,
    0x14A1, 0x0528, 0x37B3, 0x263A, 0xDECD, 0xCF44, 0xFDDF, 0xEC56, 0x98E9, 0x8960, 0xBBFB, 0xAA72, 0x6306, 0x728F,
    0x4014, 0x519D, 0x2522, 0x34AB, 0x0630, 0x17B9, 0xEF4E, 0xFEC7, 0xCC5C, 0xDDD5, 0xA96A, 0xB8E3, 0x8A78, 0x9BF1,
    0x7387, 0x620E, 0x5095, 0x411C, 0x35A3, 0x242A, 0x16B1, 0x0738, 0xFFCF, 0xEE46, 0xDCDD, 0xCD54, 0xB9EB, 0xA862,
    0x9AF9, 0x8B70, 0x8408, 0x9581, 0xA71A, 0xB693, 0xC22C, 0xD3A5, 0xE13E, 0xF0B7, 0x0840, 0x19C9, 0x2B52, 0x3ADB,
    0x4E64, 0x5FED, 0x6D76, 0x7CFF, 0x9489, 0x8500, 0xB79B, 0xA612, 0xD2AD, 0xC324, 0xF1BF, 0xE036, 0x18C1, 0x0948,
    0x3BD3, 0x2A5A, 0x5EE5, 0x4F6C, 0x7DF7, 0x6C7E, 0xA50A, 0xB483, 0x8618, 0x9791, 0xE32E, 0xF2A7, 0xC03C, 0xD1B5,
    0x2942, 0x38CB, 0x0A50, 0x1BD9, 0x6F66, 0x7EEF, 0x4C74, 0x5DFD, 0xB58B, 0xA402, 0x9699, 0x8710, 0xF3AF, 0xE226,
    0xD0BD, 0xC134, 0x39C3, 0x284A, 0x1AD1, 0x0B58, 0x7FE7, 0x6E6E, 0x5CF5, 0x4D7C, 0xC60C, 0xD785, 0xE51E, 0xF497,
    0x8028, 0x91A1, 0xA33A, 0xB2B3, 0x4A44, 0x5BCD, 0x6956, 0x78DF, 0x0C60, 0x1DE9, 0x2F72, 0x3EFB, 0xD68D, 0xC704,
    0xF59F, 0xE416, 0x90A9, 0x8120, 0xB3BB, 0xA232, 0x5AC5, 0x4B4C, 0x79D7, 0x685E, 0x1CE1, 0x0D68, 0x3FF3, 0x2E7A,
    0xE70E, 0xF687, 0xC41C, 0xD595, 0xA12A, 0xB0A3, 0x8238, 0x93B1, 0x6B46, 0x7ACF, 0x4854, 0x59DD, 0x2D62, 0x3CEB,
    0x0E70, 0x1FF9, 0xF78F, 0xE606, 0xD49D, 0xC514, 0xB1AB, 0xA022, 0x92B9, 0x8330, 0x7BC7, 0x6A4E, 0x58D5, 0x495C,
    0x3DE3, 0x2C6A, 0x1EF1, 0x0F78,
};

/* CRC_TABLE2[b] is the register after byte b and then a zero byte: two bytes go in
 * one step (the 16-bit register is all taken up by them, and the CRC is linear). */
static const uint16_t CRC_TABLE2[256] = {
    0x0000, 0x19D8, 0x33B0, 0x2A68, 0x6760, 0x7EB8, 0x54D0, 0x4D08, 0xCEC0, 0xD718, 0xFD70, 0xE4A8, 0xA9A0, 0xB078,
    0x9A10, 0x83C8, 0x9591, 0x8C49, 0xA621, 0xBFF9, 0xF2F1, 0xEB29, 0xC141, 0xD899, 0x5B51, 0x4289, 0x68E1, 0x7139,
    0x3C31, 0x25E9, 0x0F81, 0x1659, 0x2333, 0x3AEB, 0x1083, 0x095B, 0x4453, 0x5D8B, 0x77E3, 0x6E3B, 0xEDF3, 0xF42B,
    0xDE43, 0xC79B, 0x8A93, 0x934B, 0xB923, 0xA0FB, 0xB6A2, 0xAF7A, 0x8512, 0x9CCA, 0xD1C2, 0xC81A, 0xE272, 0xFBAA,
    0x7862, 0x61BA, 0x4BD2, 0x520A, 0x1F02, 0x06DA, 0x2CB2, 0x356A, 0x4666, 0x5FBE, 0x75D6, 0x6C0E, 0x2106, 0x38DE,
    0x12B6, 0x0B6E, 0x88A6, 0x917E, 0xBB16, 0xA2CE, 0xEFC6, 0xF61E, 0xDC76, 0xC5AE, 0xD3F7, 0xCA2F, 0xE047, 0xF99F,
    0xB497, 0xAD4F, 0x8727, 0x9EFF, 0x1D37, 0x04EF, 0x2E87, 0x375F, 0x7A57, 0x638F, 0x49E7, 0x503F, 0x6555, 0x7C8D,
    0x56E5, 0x4F3D, 0x0235, 0x1BED, 0x3185, 0x285D, 0xAB95, 0xB24D, 0x9825, 0x81FD, 0xCCF5, 0xD52D, 0xFF45, 0xE69D,
    0xF0C4, 0xE91C, 0xC374, 0xDAAC, 0x97A4, 0x8E7C, 0xA414, 0xBDCC, 0x3E04, 0x27DC, 0x0DB4, 0x146C, 0x5964, 0x40BC,
    0x6AD4, 0x730C, 0x8CCC, 0x9514, 0xBF7C, 0xA6A4, 0xEBAC, 0xF274, 0xD81C, 0xC1C4, 0x420C, 0x5BD4, 0x71BC, 0x6864,
    0x256C, 0x3CB4, 0x16DC, 0x0F04, 0x195D, 0x0085, 0x2AED, 0x3335, 0x7E3D, 0x67E5, 0x4D8D, 0x5455, 0xD79D, 0xCE45,
    0xE42D, 0xFDF5, 0xB0FD, 0xA925, 0x834D, 0x9A95, 0xAFFF, 0xB627, 0x9C4F, 0x8597, 0xC89F, 0xD147, 0xFB2F, 0xE2F7,
    0x613F, 0x78E7, 0x528F, 0x4B57, 0x065F, 0x1F87, 0x35EF, 0x2C37, 0x3A6E, 0x23B6, 0x09DE, 0x1006, 0x5D0E, 0x44D6,
    0x6EBE, 0x7766, 0xF4AE, 0xED76, 0xC71E, 0xDEC6, 0x93CE, 0x8A16, 0xA07E, 0xB9A6, 0xCAAA, 0xD372, 0xF91A, 0xE0C2,
    0xADCA, 0xB412, 0x9E7A, 0x87A2, 0x046A, 0x1DB2, 0x37DA, 0x2E02, 0x630A, 0x7AD2, 0x50BA, 0x4962, 0x5F3B, 0x46E3,
    0x6C8B, 0x7553, 0x385B, 0x2183, 0x0BEB, 0x1233, 0x91FB, 0x8823, 0xA24B, 0xBB93, 0xF69B, 0xEF43, 0xC52B, 0xDCF3,
    0xE999, 0xF041, 0xDA29, 0xC3F1, 0x8EF9, 0x9721, 0xBD49, 0xA491, 0x2759, 0x3E81, 0x14E9, 0x0D31, 0x4039, 0x59E1,
    0x7389, 0x6A51, 0x7C08, 0x65D0, 0x4FB8, 0x5660, 0x1B68, 0x02B0, 0x28D8, 0x3100, 0xB2C8, 0xAB10, 0x8178, 0x98A0,
    0xD5A8, 0xCC70, 0xE618, 0xFFC0,
};

uint16_t navkit_crc16(const uint8_t *data, size_t len)
{
    uint32_t crc = 0xFFFFu; /* 16 bits held in 32: no narrowing in the loop */
    const uint8_t *end = data + (len & ~(size_t)1u);
    while (data != end) {
        crc ^= (uint32_t)data[0] | (uint32_t)data[1] << 8;
        crc = (uint32_t)CRC_TABLE2[crc & 0xFFu] ^ CRC_TABLE[crc >> 8];
        data += 2;
    }
    if (len & 1u) {
        crc = (crc >> 8) ^ CRC_TABLE[(crc ^ *data) & 0xFFu];
    }
    return (uint16_t)crc;
}
#endif

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

/* Reject the candidate at buf[0]: count its reason, skip its first `skip` bytes. */
static void parser_reject(navkit_parser_t *p, int reason, uint32_t *counter, uint16_t skip)
{
    (*counter)++;
    p->last_error = reason;
    p->last_error_offset = p->offset;
    p->stats.dropped_bytes += skip;
    parser_drop(p, skip);
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
    } else if (p->have < p->want) {
        return 0; /* a caller feeding a few bytes at a time pays little per call */
    }
    for (;;) {
        uint16_t i = 0, type, words, claimed, n;
        /* Skip to the first possible start word. */
        while (i < p->have && p->buf[i] != start_lo) {
            i++;
        }
        if (i) {
            p->stats.dropped_bytes += i;
            parser_drop(p, i);
        }
        if (p->have < 2u) {
            p->want = (uint16_t)(p->have + 1u); /* the next byte is judged (or dropped) */
            return 0;
        }
        if (p->buf[1] != start_hi) {
            p->stats.dropped_bytes++;
            parser_drop(p, 1u);
            continue;
        }
        if (p->have < 2u * (NAVKIT_LENGTH_WORD + 1u)) {
            p->want = (uint16_t)(2u * (NAVKIT_LENGTH_WORD + 1u));
            return 0;
        }
        type = navkit_frame_type(p->buf);
        words = navkit_frame_words(type, p->dir);
        if (words == 0u) {
            parser_reject(p, NAVKIT_ERR_TYPE, &p->stats.unknown_type, 1u);
            continue;
        }
        claimed = navkit_get_u16(p->buf + 2u * NAVKIT_LENGTH_WORD);
        if (claimed != words) {
            /* contract 5: maybe a whole frame of another spec version */
            if (!navkit_frame_hashed(type, p->dir) || claimed < NAVKIT_HASH_WORD + 3u ||
                claimed > NAVKIT_MAX_FRAME_WORDS) {
                parser_reject(p, NAVKIT_ERR_LENGTH, &p->stats.bad_length, 1u);
                continue;
            }
            n = (uint16_t)(2u * claimed);
            if (p->have < n) {
                p->want = n;
                return 0;
            }
            if (navkit_get_u16(p->buf + n - 2u) != navkit_crc16(p->buf, n - 2u)) {
                parser_reject(p, NAVKIT_ERR_LENGTH, &p->stats.bad_length, 1u);
                continue;
            }
            p->foreign_hash = navkit_get_u32(p->buf + 2u * NAVKIT_HASH_WORD);
            p->foreign_offset = p->offset;
            parser_reject(p, NAVKIT_ERR_SCHEMA, &p->stats.schema_mismatch, n);
            continue;
        }
        n = (uint16_t)(2u * words);
        if (p->have < n) {
            p->want = n;
            return 0;
        }
        if (navkit_get_u16(p->buf + n - 2u) != navkit_crc16(p->buf, n - 2u)) {
            parser_reject(p, NAVKIT_ERR_CRC, &p->stats.bad_crc, 1u);
            continue;
        }
        p->stats.good++;
        p->want = 0u;
        p->consume = n;
        *frame = p->buf;
        *len = n;
        return 1;
    }
}
