/* board_info: the image-info block in flash (prefix board_info_).
 *
 * 37 bytes, little-endian, so a tool can check a HEX file without the ELF (navkit flash
 * scans the HEX's data for the magic): the agreed layout of the navkit image info.
 * Version 2 appends `link` to version 1's 36 bytes (a version-1 block is a serial image);
 * the fields before it never move, so a reader of version 1 reads them from either. */
#ifndef NAVKIT_BOARD_INFO_H
#define NAVKIT_BOARD_INFO_H

#include <stdint.h>

#define BOARD_INFO_MAGIC "NAVKITIM" /* 8 ASCII bytes, no NUL */
#define BOARD_INFO_VERSION 2u
#define BOARD_INFO_LINK_SERIAL 0u /* the micro link on UART0 (the board's USB-serial port) */
#define BOARD_INFO_LINK_CAN 1u    /* the micro link over CAN (the MCP2515 on the SPI, the spec's [can]) */

typedef struct {
    char magic[8];        /* BOARD_INFO_MAGIC */
    uint8_t info_version; /* BOARD_INFO_VERSION */
    uint8_t signature[3]; /* device signature: 1E 98 01 = ATmega2560 */
    uint32_t spec_hash;   /* NAVKIT_SPEC_HASH the image was built from */
    uint32_t f_cpu_hz;    /* Hz: the clock the image is built for */
    char mcu[16];         /* avr-gcc -mmcu name, NUL-padded */
    uint8_t link;         /* BOARD_INFO_LINK_*: the link the image speaks (version 2) */
} board_info_t;

/* The block itself, kept by the link (-Wl,-u,board_info) although no code reads it. */
extern const board_info_t board_info;

#endif /* NAVKIT_BOARD_INFO_H */
