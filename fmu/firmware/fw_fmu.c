/* fw_fmu.c: the firmware core as an FMI 3.0 co-simulation FMU (navkit_firmware), the
 * model code behind the FMI layer (fmu/fmi/fmil.h; state and variables: fmil_model.h,
 * fw_fmu_model.h).
 *
 * One instance = one micro: the fw_t state, the simulated board behind hal.h and the UART
 * model, all in the instance (no statics with state), so instances are independent.
 *
 * The board (the FMU's side of hal.h):
 *   - inputs are whatever the importer set before the doStep; ADC: 10 bit, 5.0 V
 *     reference, battery through a divide-by-3;
 *   - UART at `baud`, 10 bits per byte: serial_rx bytes queue in an RX FIFO and reach the
 *     core at that rate, tick by tick; bytes the core writes queue in a TX FIFO and leave
 *     at that rate into serial_tx (the bytes of this doStep).
 * Per control tick: UART RX delivery, fw_link_poll(), fw_tick(), UART TX drain.
 * doStep(h) runs the ticks due in [t, t + h): the first at the start time, each next one
 * a tick period (as configured when it is scheduled) after the one before, on a
 * microsecond clock, so any step size works and a tick period that does not divide the
 * step (400 Hz under 1 ms steps) keeps its rate exactly.
 */
#include <math.h>
#include <string.h>

#include "fmil.h"

#define FW_FMU_BITS_PER_BYTE 10u
#define FW_FMU_ADC_REF_V 5.0
#define FW_FMU_BATTERY_DIVIDER 3.0

const fmil_var_t fmil_model_vars[FMIL_NUM_VRS] = {FW_FMU_FMIL_ROWS};

/* ---------------------------------------------------------------- the board (hal.h) */

static uint16_t fw_fmu_adc_counts(double volts)
{
    double c = floor(volts / FW_FMU_ADC_REF_V * 1024.0);
    if (!(c > 0.0)) {
        return 0u;
    }
    return (c > 1023.0) ? 1023u : (uint16_t)c;
}

int32_t hal_enc_left(hal_t *h)
{
    return h->io->enc_left;
}
int32_t hal_enc_right(hal_t *h)
{
    return h->io->enc_right;
}
int16_t hal_gyro_raw(hal_t *h)
{
    int32_t g = h->io->gyro_raw;
    return (int16_t)((g > 32767) ? 32767 : (g < -32768) ? -32768 : g);
}
uint16_t hal_compass(hal_t *h)
{
    int32_t c = h->io->compass_raw % 3600;
    return (uint16_t)((c < 0) ? c + 3600 : c);
}
uint16_t hal_adc(hal_t *h, uint8_t ch)
{
    /* the firmware reads ch0..FW_ADC_CHANNELS-1 only: ch0-3 IR, ch4 the battery divider */
    unsigned k = (ch < 4u) ? ch : 4u;
    double v = (k < 4u) ? h->io->ir_voltage[k] : h->io->battery_voltage;
    if (!(v == h->adc_v[k])) {
        h->adc_v[k] = v;
        h->adc_counts[k] = fw_fmu_adc_counts((k < 4u) ? v : v / FW_FMU_BATTERY_DIVIDER);
    }
    return h->adc_counts[k];
}
uint16_t hal_sonar_echo(hal_t *h, uint8_t i)
{
    double v = h->io->sonar_echo[i];
    if (!(v == h->sonar_v[i])) {
        double us = floor(v + 0.5);
        h->sonar_v[i] = v;
        h->sonar_us[i] = (!(us > 0.0)) ? 0u : (us > 65535.0) ? 65535u : (uint16_t)us;
    }
    return h->sonar_us[i];
}
uint16_t hal_dio_in(hal_t *h)
{
    return (uint16_t)(h->io->dio_in & 0x0FFF);
}
uint8_t hal_reset_cause(hal_t *h)
{
    (void)h;
    return NAVKIT_RESET_CAUSE_POWER_ON;
} /* no reset pin, watchdog or supply */
void hal_motor(hal_t *h, int16_t l, int16_t r)
{
    h->io->motor_left_duty = (double)l / 10000.0;
    h->io->motor_right_duty = (double)r / 10000.0;
}
void hal_servo_pulse(hal_t *h, uint8_t i, uint16_t us)
{
    h->io->servo_pulse[i] = (double)us;
}
void hal_dio_write(hal_t *h, uint16_t dir, uint16_t out)
{
    h->io->dio_dir = dir;
    h->io->dio_out = out;
}
size_t hal_uart_read(hal_t *h, uint8_t *buf, size_t cap)
{
    size_t n = 0;
    while (n < cap && h->rx_ready > 0u) {
        buf[n++] = h->rx[h->rx_head];
        h->rx_head = (h->rx_head + 1u) % FW_FMU_RX_CAP;
        h->rx_len--;
        h->rx_ready--;
    }
    return n;
}
size_t hal_uart_tx_free(hal_t *h)
{
    return FW_FMU_TX_CAP - h->tx_len;
}
void hal_uart_write(hal_t *h, const uint8_t *buf, size_t len)
{
    size_t i;
    for (i = 0; i < len && h->tx_len < FW_FMU_TX_CAP; i++) {
        h->tx[(h->tx_head + h->tx_len) % FW_FMU_TX_CAP] = buf[i];
        h->tx_len++;
    }
}

#if FW_LINK_CAN
/* The CAN controller (the CAN build, navkit_firmware_can): the frames of can_rx join an RX
 * queue at the start of the doStep and the core reads them at its next link poll; the
 * core's frames take one of FW_FMU_CAN_TXQ TX buffers and go on the bus at the end of the
 * tick (into can_tx), so at most FW_FMU_CAN_TXQ frames leave per tick (the bus itself, at
 * 500 kbit/s ~4.5 frames a ms, is never the limit at 1 kHz). Records: fw_fmu_model.h. */
uint8_t hal_can_read(hal_t *h, uint16_t *id, uint8_t data[8], uint8_t *dlc)
{
    if (h->canq_len == 0u) {
        return 0u;
    }
    *dlc = fw_fmu_can_record_get(&h->canq[h->canq_head * FW_FMU_CAN_RECORD_BYTES], id, data);
    h->canq_head = (h->canq_head + 1u) % FW_FMU_CAN_RXQ;
    h->canq_len--;
    return 1u;
}
uint8_t hal_can_tx_free(hal_t *h)
{
    return (uint8_t)(FW_FMU_CAN_TXQ - h->can_txb_len);
}
void hal_can_write(hal_t *h, uint16_t id, const uint8_t data[8])
{
    if (h->can_txb_len >= FW_FMU_CAN_TXQ) {
        return; /* the core never writes more than hal_can_tx_free() */
    }
    fw_fmu_can_record_put(&h->can_txb[h->can_txb_len++ * FW_FMU_CAN_RECORD_BYTES], id, 8u, data);
}
/* can_rx records dropped for a full RX queue (fmil_model_step), frames */
uint16_t hal_can_rx_lost(hal_t *h)
{
    return (uint16_t)h->can_rx_dropped;
}
#else
/* Bytes the line carries in tick_us at the baud rate, from the credit (bit-us). */
static uint32_t fw_fmu_line_bytes(uint64_t *credit, uint32_t baud, uint32_t tick_us, uint32_t waiting)
{
    const uint64_t per_byte = (uint64_t)FW_FMU_BITS_PER_BYTE * 1000000u;
    uint64_t n;
    *credit += (uint64_t)baud * tick_us;
    if (waiting == 0u) {
        /* idle (most ticks): what the general case below gives, without the division */
        if (*credit >= per_byte) {
            *credit = 0u;
        }
        return 0u;
    }
    n = *credit / per_byte;
    if (n >= waiting) {
        /* an idle line saves no credit beyond the current byte time */
        *credit = (n > waiting) ? 0u : *credit - n * per_byte;
        return waiting;
    }
    *credit -= n * per_byte;
    return (uint32_t)n;
}

#endif

#if FW_LINK_CAN
/* One control tick of the CAN build: link poll (the RX queue), control, then the TX
 * buffers onto the bus (can_tx; a full can_tx of this doStep keeps them for the next tick). */
static void fw_fmu_tick(fmil_model_t *m)
{
    struct hal *h = &m->hal;
    size_t at;
    fw_link_poll(&m->fw);
    fw_tick(&m->fw);
    at = m->can_tx.len / FW_FMU_CAN_RECORD_BYTES;
    if (h->can_txb_len > 0u && at + h->can_txb_len <= FW_FMU_CAN_WIRE) {
        memcpy(&h->can_wire[at * FW_FMU_CAN_RECORD_BYTES], h->can_txb, h->can_txb_len * FW_FMU_CAN_RECORD_BYTES);
        m->can_tx.len += h->can_txb_len * FW_FMU_CAN_RECORD_BYTES;
        h->can_txb_len = 0u;
    }
}
#else
static void fw_fmu_tick(fmil_model_t *m)
{
    struct hal *h = &m->hal;
    uint32_t tick_us = fw_tick_period_us(&m->fw);
    uint32_t n;
    /* RX: bytes that reached the micro during this tick */
    h->rx_ready += fw_fmu_line_bytes(&h->rx_credit, h->baud, tick_us, h->rx_len - h->rx_ready);
    fw_link_poll(&m->fw);
    fw_tick(&m->fw);
    /* TX: bytes that left the micro during this tick */
    n = fw_fmu_line_bytes(&h->tx_credit, h->baud, tick_us, h->tx_len);
    if (n > FW_FMU_WIRE_CAP - m->serial_tx.len) {
        n = (uint32_t)(FW_FMU_WIRE_CAP - m->serial_tx.len); /* the rest waits in the TX FIFO */
    }
    while (n-- > 0u) {
        h->wire[m->serial_tx.len++] = h->tx[h->tx_head];
        h->tx_head = (h->tx_head + 1u) % FW_FMU_TX_CAP;
        h->tx_len--;
    }
}
#endif

/* ---------------------------------------------------------------- the model's hooks */

fmil_status_t fmil_model_instantiate(fmil_instance_t *c)
{
    fmil_model_t *m = &c->model;
    m->hal.io = &m->io;
    m->serial_rx.data = m->rx_stage;
    m->serial_rx.cap = FW_FMU_RX_CAP;
    m->serial_tx.data = m->hal.wire;
    m->serial_tx.cap = 0u; /* an output */
#if FW_LINK_CAN
    m->can_rx.data = m->can_stage;
    m->can_rx.cap = sizeof m->can_stage;
    m->can_tx.data = m->hal.can_wire;
    m->can_tx.cap = 0u; /* an output */
#endif
    return FMIL_OK;
}

/* Start values of every variable, a powered-up micro (unconfigured), empty UART. */
void fmil_model_start_values(fmil_instance_t *c)
{
    fmil_model_t *m = &c->model;
    struct hal *h = &m->hal;
    unsigned i;
    FW_FMU_START_VALUES(m)
    h->rx_head = h->rx_len = h->rx_ready = 0u;
    h->rx_credit = h->tx_credit = 0u;
    h->rx_dropped = 0u;
    h->tx_head = h->tx_len = 0u;
    h->baud = m->baud;
    for (i = 0; i < 5u; i++) {
        h->adc_v[i] = NAN;
    }
    for (i = 0; i < 4u; i++) {
        h->sonar_v[i] = NAN;
    }
    m->serial_rx.len = m->serial_tx.len = 0u;
#if FW_LINK_CAN
    h->canq_head = h->canq_len = h->can_rx_dropped = h->can_txb_len = 0u;
    m->can_rx.len = m->can_tx.len = 0u;
#endif
    m->t_start = 0.0;
    m->next_tick_us = 0u;
    fw_init(&m->fw, h);
    /* outputs as the micro holds them before its first tick: everything off */
    m->io.motor_left_duty = m->io.motor_right_duty = 0.0;
    memset(m->io.servo_pulse, 0, sizeof m->io.servo_pulse);
    m->io.dio_out = m->io.dio_dir = 0;
}

fmil_status_t fmil_model_start(fmil_instance_t *c)
{
    fmil_model_t *m = &c->model;
    if (m->baud < 300u || m->baud > 4000000u) {
        fmil_log(c, FMIL_ERROR, "baud %u outside 300..4000000", (unsigned)m->baud);
        return FMIL_ERROR;
    }
    m->hal.baud = m->baud;
    m->time = c->time;
    m->t_start = c->time;
    return FMIL_OK;
}

void fmil_model_inputs_changed(fmil_instance_t *c)
{
    (void)c; /* the core reads its inputs each tick */
}

fmil_status_t fmil_model_step(fmil_instance_t *c, double t, double h_s)
{
    fmil_model_t *m = &c->model;
    struct hal *h = &m->hal;
    /* the step's end on the microsecond clock of the tick schedule, us, rounded half away
       from zero as llround does but without its libm call every step (x - trunc(x) is
       exact; a step ending before the start time would be an importer error: 0) */
    double end_x = (t + h_s - m->t_start) * 1e6;
    uint64_t end_us = (end_x > 0.0) ? (uint64_t)end_x : 0u;
    size_t i;
    if (end_x - (double)end_us >= 0.5) {
        end_us++;
    }
    /* serial_rx joins the RX FIFO; a full FIFO drops the excess (like a real UART) */
    for (i = 0; i < m->serial_rx.len; i++) {
        if (h->rx_len < FW_FMU_RX_CAP) {
            h->rx[(h->rx_head + h->rx_len) % FW_FMU_RX_CAP] = m->rx_stage[i];
            h->rx_len++;
        } else {
            h->rx_dropped++;
        }
    }
    if (m->serial_rx.len > 0u && h->rx_dropped > 0u) {
        fmil_log(c, FMIL_WARNING, "RX FIFO full: %u bytes dropped so far", (unsigned)h->rx_dropped);
    }
    m->serial_rx.len = 0u;
    m->serial_tx.len = 0u;
#if FW_LINK_CAN
    /* can_rx's whole records join the RX queue; a full queue drops the excess (as a
       controller without a free RX buffer does) */
    for (i = 0; i + FW_FMU_CAN_RECORD_BYTES <= m->can_rx.len; i += FW_FMU_CAN_RECORD_BYTES) {
        if (h->canq_len < FW_FMU_CAN_RXQ) {
            memcpy(&h->canq[((h->canq_head + h->canq_len) % FW_FMU_CAN_RXQ) * FW_FMU_CAN_RECORD_BYTES],
                   &m->can_stage[i], FW_FMU_CAN_RECORD_BYTES);
            h->canq_len++;
        } else {
            h->can_rx_dropped++;
        }
    }
    if (m->can_rx.len % FW_FMU_CAN_RECORD_BYTES != 0u) {
        fmil_log(c, FMIL_WARNING, "can_rx: %u bytes are no whole %u-byte frame record, ignored",
                 (unsigned)(m->can_rx.len % FW_FMU_CAN_RECORD_BYTES), FW_FMU_CAN_RECORD_BYTES);
    }
    if (m->can_rx.len > 0u && h->can_rx_dropped > 0u) {
        fmil_log(c, FMIL_WARNING, "CAN RX queue full: %u frames dropped so far", (unsigned)h->can_rx_dropped);
    }
    m->can_rx.len = 0u;
    m->can_tx.len = 0u;
#endif
    while (m->next_tick_us < end_us) {
        fw_fmu_tick(m); /* a config may change the tick period: the next tick takes the new one */
        m->next_tick_us += fw_tick_period_us(&m->fw);
    }
    m->time = t + h_s;
    return FMIL_OK;
}

void fmil_model_free(fmil_instance_t *c)
{
    (void)c; /* everything is in the instance */
}
