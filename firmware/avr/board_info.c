/* board_info.c: the image-info block (board_info.h), in flash (.progmem). */
#include "board.h"
#include "board_info.h"
#include "link.h"
#include "navkit/navkit_proto.h"

typedef char board_info_size_check[(sizeof(board_info_t) == 37u) ? 1 : -1];

#if FW_LINK_CAN
#define BOARD_INFO_LINK BOARD_INFO_LINK_CAN
#else
#define BOARD_INFO_LINK BOARD_INFO_LINK_SERIAL
#endif

const board_info_t board_info __attribute__((used, section(".progmem.navkit_info"))) = {
    {'N', 'A', 'V', 'K', 'I', 'T', 'I', 'M'},
    BOARD_INFO_VERSION,
    {BOARD_SIGNATURE_0, BOARD_SIGNATURE_1, BOARD_SIGNATURE_2},
    (uint32_t)NAVKIT_SPEC_HASH,
    (uint32_t)BOARD_F_CPU_HZ,
    BOARD_MCU_NAME,
    BOARD_INFO_LINK,
};
