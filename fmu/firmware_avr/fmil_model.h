/* fmil_model.h: the AVR firmware FMU's config header for the FMI layer (fmu/fmi/fmil.h):
 * its token and variables (fw_fmu_model.h, shared with navkit_firmware, plus
 * fw_avr_fmu_model.h) and its whole state: one simulated board running the image. */
#ifndef FWAVR_FMIL_MODEL_H
#define FWAVR_FMIL_MODEL_H

#include "board_sim.h"
#include "fmil_types.h"
#include "fw_avr_fmu_model.h"
#include "fw_fmu_model.h"

#define FMIL_INSTANTIATION_TOKEN FWAVR_INSTANTIATION_TOKEN
#define FMIL_NUM_VRS FWAVR_NUM_VRS

#if defined(FW_LINK_CAN) && FW_LINK_CAN
/* bytes: can_rx and can_tx of one doStep, whole frame records (the board's queues' size) */
#define FWAVR_RX_CAP (BOARD_SIM_CAN_QUEUE * FW_FMU_CAN_RECORD_BYTES)
#define FWAVR_WIRE_CAP (BOARD_SIM_CAN_QUEUE * FW_FMU_CAN_RECORD_BYTES)
#else
#define FWAVR_RX_CAP BOARD_SIM_UART_QUEUE   /* bytes: serial_rx of one doStep */
#define FWAVR_WIRE_CAP BOARD_SIM_UART_QUEUE /* bytes: serial_tx of one doStep */
#endif

/* The profile as the output variables hold it (board_sim_profile_t widened to their types). */
typedef struct {
    uint64_t cycles, tick_total_cycles, poll_total_cycles;
    uint32_t ticks, tick_worst_cycles, tick_mean_cycles, polls, poll_worst_cycles, poll_mean_cycles;
    uint32_t resets, watchdog_resets, stack_max_bytes;
} fwavr_prof_t;

typedef struct {
    fw_fmu_io_t io;
    double time;              /* s: the `time` variable */
    uint32_t baud;            /* the parameter: must be the image's FWAVR_BAUD */
    char image[FMIL_STR_MAX]; /* the parameter: path of the image, "" = the resource */
#if defined(FW_LINK_CAN) && FW_LINK_CAN
    fmil_binary_t can_rx; /* -> rx: frame records for the next doStep */
    fmil_binary_t can_tx; /* -> wire: frame records of the last doStep */
#else
    fmil_binary_t serial_rx; /* -> rx: bytes for the next doStep */
    fmil_binary_t serial_tx; /* -> wire: bytes of the last doStep */
#endif
    fwavr_prof_t prof;
    board_sim_t *board; /* NULL until the model starts */
    double start_time;  /* s: when the board powered on (cycle 0) */
    int32_t enc_set[2]; /* encoder counts last handed to the board (left, right) */
    int32_t dio_in_set; /* DIO input levels last handed to the board */
    uint8_t rx[FWAVR_RX_CAP];
    uint8_t wire[FWAVR_WIRE_CAP];
} fmil_model_t;

#endif /* FWAVR_FMIL_MODEL_H */
