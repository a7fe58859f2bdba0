/* board_info: the image-info block in flash (prefix board_info_).
 *
 * 36 bytes, little-endian, so a tool can check a HEX file without the ELF (navkit flash
 * scans the HEX's data for the magic): the agreed layout of the navkit image info. */
#ifndef NAVKIT_BOARD_INFO_H
#define NAVKIT_BOARD_INFO_H

#include <stdint.h>

#define BOARD_INFO_MAGIC "NAVKITIM" /* 8 ASCII bytes, no NUL */
#define BOARD_INFO_VERSION 1u

typedef struct {
    char magic[8];        /* BOARD_INFO_MAGIC */
    uint8_t info_version; /* BOARD_INFO_VERSION */
    uint8_t signature[3]; /* device signature: 1E 98 01 = ATmega2560 */
    uint32_t spec_hash;   /* NAVKIT_SPEC_HASH the image was built from */
    uint32_t f_cpu_hz;    /* Hz: the clock the image is built for */
    char mcu[16];         /* avr-gcc -mmcu name, NUL-padded */
} board_info_t;

/* The block itself, kept by the link (-Wl,-u,board_info) although no code reads it. */
extern const board_info_t board_info;

#endif /* NAVKIT_BOARD_INFO_H */
