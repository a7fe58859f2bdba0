/* fmil_model.h: the firmware FMU's config header for the FMI layer (fmu/fmi/fmil.h):
 * its token and variables from fw_fmu_model.h, and its whole state: the core's fw_t, the
 * simulated board behind hal.h (struct hal, fw_fmu.c) and the UART model. */
#ifndef FW_FMU_FMIL_MODEL_H
#define FW_FMU_FMIL_MODEL_H

#include "fmil_types.h"
#include "fw.h"
#include "fw_fmu_model.h"

#define FMIL_INSTANTIATION_TOKEN FW_FMU_INSTANTIATION_TOKEN
#define FMIL_NUM_VRS FW_FMU_NUM_VRS

#define FW_FMU_RX_CAP 8192u    /* bytes: RX FIFO (host -> micro, not yet delivered), and serial_rx */
#define FW_FMU_TX_CAP 512u     /* bytes: the micro's TX FIFO */
#define FW_FMU_WIRE_CAP 16384u /* bytes: serial_tx of one doStep */
#if FW_LINK_CAN
#define FW_FMU_CAN_RXQ 256u   /* frames: RX queue (the bus -> the core, not yet read), and can_rx */
#define FW_FMU_CAN_TXQ 3u     /* frames: TX buffers (an MCP2515 has 3); they go on the bus each tick */
#define FW_FMU_CAN_WIRE 1024u /* frames: can_tx of one doStep */
#endif

/* The board the core runs on (its side of hal.h). */
struct hal {
    fw_fmu_io_t *io;           /* the FMU's variables: inputs read, outputs written */
    uint8_t rx[FW_FMU_RX_CAP]; /* ring: bytes from the host */
    uint32_t rx_head, rx_len;  /* ring start and fill */
    uint32_t rx_ready;         /* of rx_len, bytes that have arrived at the micro */
    uint64_t rx_credit;        /* bit-us: line time not yet used for a byte */
    uint32_t rx_dropped;       /* bytes lost to a full RX FIFO */
    uint8_t tx[FW_FMU_TX_CAP]; /* ring: bytes the core queued */
    uint32_t tx_head, tx_len;
    uint64_t tx_credit;
    uint8_t wire[FW_FMU_WIRE_CAP]; /* serial_tx's bytes */
    uint32_t baud;
    /* conversions of the last input value seen (the core reads every channel every tick;
     * inputs change far less often): a value that compares equal converts to the same
     * counts (the only unequal bits that compare equal, +0 and -0, both give 0); NaN at
     * power-on, so the first read converts */
    double adc_v[5], sonar_v[4]; /* ADC: IR 0-3, battery */
    uint16_t adc_counts[5], sonar_us[4];
#if FW_LINK_CAN
    uint8_t canq[FW_FMU_CAN_RXQ * FW_FMU_CAN_RECORD_BYTES]; /* ring of records (fw_fmu_model.h) */
    uint32_t canq_head, canq_len;                           /* frames */
    uint32_t can_rx_dropped;                                /* frames lost to a full RX queue */
    uint8_t can_txb[FW_FMU_CAN_TXQ * FW_FMU_CAN_RECORD_BYTES];
    uint32_t can_txb_len;                                        /* frames in the TX buffers */
    uint8_t can_wire[FW_FMU_CAN_WIRE * FW_FMU_CAN_RECORD_BYTES]; /* can_tx's records */
#endif
};

typedef struct {
    fw_fmu_io_t io;
    struct hal hal;
    fw_t fw;
    double time;             /* s: the `time` variable */
    uint32_t baud;           /* the parameter (copied into hal when the model starts) */
    fmil_binary_t serial_rx; /* -> rx_stage: bytes for the next doStep */
    fmil_binary_t serial_tx; /* -> hal.wire: bytes of the last doStep */
    uint8_t rx_stage[FW_FMU_RX_CAP];
#if FW_LINK_CAN
    fmil_binary_t can_rx; /* -> can_stage: frames for the next doStep */
    fmil_binary_t can_tx; /* -> hal.can_wire: frames of the last doStep */
    uint8_t can_stage[FW_FMU_CAN_RXQ * FW_FMU_CAN_RECORD_BYTES];
#endif
    /* the control ticks' schedule on the simulated clock, us since t_start: tick k runs at
     * the previous tick's time plus the tick period in force after it (a config may change
     * the period), in the doStep whose interval [t, t + h) holds that time */
    double t_start;        /* s: the time the model started at */
    uint64_t next_tick_us; /* us since t_start */
} fmil_model_t;

#endif /* FW_FMU_FMIL_MODEL_H */
