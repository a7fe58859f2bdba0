/* fw_avr_fmu.c: the AVR firmware FMU (navkit_firmware_avr), the model code behind the FMI
 * layer (fmu/fmi/fmil.h; state: fmil_model.h; variables: fw_fmu_model.h and
 * fw_avr_fmu_model.h).
 *
 * One instance = one simulated Arduino Mega 2560 (firmware/avr/sim/board_sim.h) running
 * the image from power-on; it is made when the model starts (ExitInitializationMode) and
 * made again after fmi3Reset (a power cycle). A doStep from t by h:
 *   1. serial_rx goes to UART0's RX pin (paced at the line rate by the board); in the CAN
 *      build (navkit_firmware_avr_can) can_rx's frames go onto the board's CAN bus;
 *   2. the plant's values reach the pins: ADC voltages (battery through the board's
 *      divide-by-3), gyro and compass registers, sonar echo widths, DIO input levels, and
 *      the encoder positions, whose quadrature edges are spread evenly over the step;
 *   3. the core runs to cycle round((t + h - start) * 16 MHz);
 *   4. motor duty and servo pulse widths measured at the pins, the DIO pins, the bytes
 *      UART0 sent (serial_tx; the CAN build: the frames its MCP2515 sent, can_tx) and the
 *      profile come back as outputs.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmil.h"

#define FWAVR_BATTERY_DIVIDER 3.0 /* the board's battery divider (firmware/avr/board.h) */
#define FWAVR_ADC_MAX_MV 5000.0   /* mV: the ADC reference; above reads as full scale */

#define FWAVR_ROW_STR(vr, name, caus, desc) FW_FMU_ROW(vr, name, caus, FMIL_STR, name)
#define FWAVR_ROW_U64(vr, name, caus, var, unit, start, field, desc) FW_FMU_ROW(vr, name, caus, FMIL_U64, field)
const fmil_var_t fmil_model_vars[FMIL_NUM_VRS] = {FW_FMU_FMIL_ROWS FWAVR_STRING_VARS(FWAVR_ROW_STR) FWAVR_UINT32_VARS(
    FW_FMU_ROW_U32) FWAVR_UINT64_VARS(FWAVR_ROW_U64)};

#if defined(FW_LINK_CAN) && FW_LINK_CAN
/* The CAN build: the link's Binary variables are the bus's frames, FW_FMU_CAN_RECORD_BYTES
   each (fw_fmu_model.h), onto and off the board's simulated MCP2515 bus (board_sim.h, CAN). */
#define FWAVR_LINK_RX can_rx
#define FWAVR_LINK_TX can_tx
#else
#define FWAVR_LINK_RX serial_rx
#define FWAVR_LINK_TX serial_tx
#endif

fmil_status_t fmil_model_instantiate(fmil_instance_t *c)
{
    fmil_model_t *m = &c->model;
    m->FWAVR_LINK_RX.data = m->rx;
    m->FWAVR_LINK_RX.cap = FWAVR_RX_CAP;
    m->FWAVR_LINK_TX.data = m->wire;
    m->FWAVR_LINK_TX.cap = 0u; /* an output */
    return FMIL_OK;
}

/* Frees the board, if there is one. */
static void fwavr_power_off(fmil_model_t *m)
{
    board_sim_free(m->board);
    m->board = NULL;
}

void fmil_model_start_values(fmil_instance_t *c)
{
    fmil_model_t *m = &c->model;
    fwavr_power_off(m);
    FW_FMU_START_VALUES(m)
    m->image[0] = '\0';
    m->FWAVR_LINK_RX.len = m->FWAVR_LINK_TX.len = 0u;
    memset(&m->prof, 0, sizeof m->prof);
    m->enc_set[0] = m->enc_set[1] = 0;
    m->dio_in_set = 0;
    /* outputs before the first step: a board in reset drives nothing */
    memset(m->io.servo_pulse, 0, sizeof m->io.servo_pulse);
}

fmil_status_t fmil_model_start(fmil_instance_t *c)
{
    fmil_model_t *m = &c->model;
    char path[FMIL_STR_MAX + sizeof FWAVR_IMAGE_RESOURCE + 2];
    char err[512] = "";
    size_t n;
    if (m->baud != FWAVR_BAUD) {
        fmil_log(c, FMIL_ERROR, "baud %u: the AVR image's UART0 runs at %u baud", (unsigned)m->baud,
                 (unsigned)FWAVR_BAUD);
        return FMIL_ERROR;
    }
    if (m->image[0] != '\0') {
        snprintf(path, sizeof path, "%s", m->image);
    } else if (c->resources[0] != '\0') {
        n = strlen(c->resources);
        snprintf(path, sizeof path, "%s%s%s", c->resources, c->resources[n - 1] == '/' ? "" : "/",
                 FWAVR_IMAGE_RESOURCE);
    } else {
        fmil_log(c, FMIL_ERROR, "no image: the importer gave no resources folder and the parameter image is empty");
        return FMIL_ERROR;
    }
    fwavr_power_off(m);
    m->board = board_sim_new(path, err, sizeof err);
    if (!m->board) {
        fmil_log(c, FMIL_ERROR, "%s", err[0] ? err : path);
        return FMIL_ERROR;
    }
    m->start_time = c->time;
    m->time = c->time;
    m->enc_set[0] = m->enc_set[1] = 0;
    m->dio_in_set = 0; /* the board powers on with no DIO input driven high */
    return FMIL_OK;
}

void fmil_model_inputs_changed(fmil_instance_t *c)
{
    (void)c; /* the pins take the inputs at the next step */
}

/* mV for a voltage (V), clamped to the ADC's range, rounded to the nearest. */
static uint16_t fwavr_mv(double volts)
{
    double mv = floor(volts * 1000.0 + 0.5);
    return (!(mv > 0.0)) ? 0u : (mv > FWAVR_ADC_MAX_MV) ? (uint16_t)FWAVR_ADC_MAX_MV : (uint16_t)mv;
}

/* The importer's values onto the board's pins, for a step ending at cycle `end`. */
static void fwavr_inputs(fmil_model_t *m, uint64_t end)
{
    const fw_fmu_io_t *io = &m->io;
    board_sim_t *b = m->board;
    int32_t g = io->gyro_raw, cmp = io->compass_raw % 3600;
    unsigned i;
    if (io->enc_left != m->enc_set[0] || io->enc_right != m->enc_set[1]) {
        board_sim_set_encoders(b, io->enc_left, io->enc_right, end);
        m->enc_set[0] = io->enc_left;
        m->enc_set[1] = io->enc_right;
    }
    for (i = 0; i < 4u; i++) {
        double us = floor(io->sonar_echo[i] + 0.5);
        board_sim_set_adc_mv(b, (uint8_t)i, fwavr_mv(io->ir_voltage[i]));
        board_sim_set_sonar_echo_us(b, (uint8_t)i, (!(us > 0.0)) ? 0u : (us > 65535.0) ? 65535u : (uint16_t)us);
    }
    board_sim_set_adc_mv(b, 4u, fwavr_mv(io->battery_voltage / FWAVR_BATTERY_DIVIDER));
    board_sim_set_gyro_raw(b, (int16_t)((g > 32767) ? 32767 : (g < -32768) ? -32768 : g));
    board_sim_set_compass(b, (uint16_t)((cmp < 0) ? cmp + 3600 : cmp));
    if ((io->dio_in & 0x0FFF) != m->dio_in_set) { /* pin changes only: the pins' edges are events */
        m->dio_in_set = io->dio_in & 0x0FFF;
        board_sim_set_dio_in(b, (uint16_t)m->dio_in_set);
    }
}

/* The pins and the profile into the output variables. */
static void fwavr_outputs(fmil_model_t *m)
{
    fw_fmu_io_t *io = &m->io;
    board_sim_t *b = m->board;
    board_sim_profile_t p;
    int16_t l, r;
    uint16_t dir, levels;
    unsigned i;
    board_sim_motor_duty(b, &l, &r);
    io->motor_left_duty = (double)l / 10000.0;
    io->motor_right_duty = (double)r / 10000.0;
    for (i = 0; i < 8u; i++) {
        io->servo_pulse[i] = (double)board_sim_servo_pulse_us(b, (uint8_t)i);
    }
    board_sim_dio(b, &dir, &levels);
    io->dio_dir = dir;
    io->dio_out = levels & dir;
    board_sim_profile(b, &p);
    m->prof.cycles = board_sim_cycles(b);
    m->prof.ticks = p.ticks;
    m->prof.tick_worst_cycles = p.tick_worst_cycles;
    m->prof.tick_mean_cycles = p.tick_mean_cycles;
    m->prof.tick_total_cycles = p.tick_total_cycles;
    m->prof.polls = p.polls;
    m->prof.poll_worst_cycles = p.poll_worst_cycles;
    m->prof.poll_mean_cycles = p.poll_mean_cycles;
    m->prof.poll_total_cycles = p.poll_total_cycles;
    m->prof.resets = p.resets;
    m->prof.watchdog_resets = p.watchdog_resets;
    m->prof.stack_max_bytes = p.stack_max_bytes;
}

#if defined(FW_LINK_CAN) && FW_LINK_CAN
/* can_rx's whole records onto the bus (a partial record is ignored); the bus carries data
   frames with 11-bit identifiers, so an extended or remote record goes on as its 11 bits. */
static void fwavr_link_in(fmil_model_t *m)
{
    uint32_t i;
    uint16_t id;
    uint8_t data[8];
    uint8_t dlc;
    for (i = 0u; i + FW_FMU_CAN_RECORD_BYTES <= m->can_rx.len; i += FW_FMU_CAN_RECORD_BYTES) {
        dlc = fw_fmu_can_record_get(&m->rx[i], &id, data);
        board_sim_can_write(m->board, (uint16_t)(id & 0x7FFu), data, dlc);
    }
    m->can_rx.len = 0u;
}

/* The frames the part sent during the step, into can_tx's records. */
static void fwavr_link_out(fmil_model_t *m)
{
    board_sim_can_frame_t f;
    uint32_t n = 0u;
    while (n + FW_FMU_CAN_RECORD_BYTES <= FWAVR_WIRE_CAP && board_sim_can_read(m->board, &f)) {
        fw_fmu_can_record_put(&m->wire[n], f.id, f.dlc, f.data);
        n += FW_FMU_CAN_RECORD_BYTES;
    }
    m->can_tx.len = n;
}
#else
static void fwavr_link_in(fmil_model_t *m)
{
    if (m->serial_rx.len > 0u) {
        board_sim_uart_write(m->board, m->rx, m->serial_rx.len);
        m->serial_rx.len = 0u;
    }
}

static void fwavr_link_out(fmil_model_t *m)
{
    m->serial_tx.len = board_sim_uart_read(m->board, m->wire, FWAVR_WIRE_CAP);
}
#endif

fmil_status_t fmil_model_step(fmil_instance_t *c, double t, double h)
{
    fmil_model_t *m = &c->model;
    double end_s = (t + h - m->start_time) * FWAVR_F_CPU_HZ;
    uint64_t end = (uint64_t)floor(end_s + 0.5);
    fwavr_link_in(m);
    fwavr_inputs(m, end);
    if (board_sim_run_until(m->board, end) != 0) {
        fmil_log(c, FMIL_ERROR, "%sDoStep: the AVR core stopped at %.6f s: %s", c->api,
                 m->start_time + (double)board_sim_cycles(m->board) / FWAVR_F_CPU_HZ, board_sim_error(m->board));
        return FMIL_ERROR;
    }
    fwavr_link_out(m);
    fwavr_outputs(m);
    m->time = t + h;
    return FMIL_OK;
}

void fmil_model_free(fmil_instance_t *c)
{
    fwavr_power_off(&c->model);
}
