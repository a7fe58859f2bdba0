/* fw_fmu.c: the firmware core as an FMI 3.0 co-simulation FMU (navkit_firmware).
 *
 * One instance = one micro: the fw_t state, the simulated board behind hal.h, the UART
 * model and the FMI state machine, all in the instance struct (no statics with state),
 * so instances are independent. The variables come from fw_fmu_model.h.
 *
 * The board (the FMU's side of hal.h):
 *   - inputs are whatever the importer set before the doStep; ADC: 10 bit, 5.0 V
 *     reference, battery through a divide-by-3;
 *   - UART at `baud`, 10 bits per byte: serial_rx bytes queue in an RX FIFO and reach the
 *     core at that rate, tick by tick; bytes the core writes queue in a TX FIFO and leave
 *     at that rate into serial_tx (the bytes of this doStep).
 * Per control tick: UART RX delivery, fw_link_poll(), fw_tick(), UART TX drain.
 * doStep(h) runs h / tick ticks; h must be a whole number of ticks.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h" /* exports the fmi3* API (the rest is hidden) */
#include "fw.h"
#include "fw_fmu_model.h"

#define FWFMU_RX_CAP 8192u    /* bytes: RX FIFO (host -> micro, not yet delivered) */
#define FWFMU_TX_CAP 512u     /* bytes: the micro's TX FIFO */
#define FWFMU_WIRE_CAP 16384u /* bytes: serial_tx of one doStep */
#define FWFMU_BITS_PER_BYTE 10u
#define FWFMU_ADC_REF_V 5.0
#define FWFMU_BATTERY_DIVIDER 3.0

struct hal {
    /* inputs (set by the importer) */
    int32_t enc_left, enc_right, gyro_raw, compass_raw, dio_in;
    double ir_voltage[4], battery_voltage, sonar_echo[4];
    /* outputs (written by the core at the end of each tick) */
    double motor_left_duty, motor_right_duty, servo_pulse[8];
    int32_t dio_out, dio_dir;
    /* UART */
    uint8_t rx[FWFMU_RX_CAP];   /* ring: bytes from the host */
    uint32_t rx_head, rx_len;   /* ring start and fill */
    uint32_t rx_ready;          /* of rx_len, bytes that have arrived at the micro */
    uint64_t rx_credit;         /* bit-us: line time not yet used for a byte */
    uint32_t rx_dropped;        /* bytes lost to a full RX FIFO */
    uint8_t tx[FWFMU_TX_CAP];   /* ring: bytes the core queued */
    uint32_t tx_head, tx_len;
    uint64_t tx_credit;
    uint8_t wire[FWFMU_WIRE_CAP]; /* serial_tx */
    uint32_t wire_len;
    uint32_t baud;
    /* conversions of the last input value seen (the core reads every channel every tick;
     * inputs change far less often): a value that compares equal converts to the same
     * counts (the only unequal bits that compare equal, +0 and -0, both give 0); NaN at
     * power-on, so the first read converts */
    double adc_v[5], sonar_v[4];       /* ADC: IR 0-3, battery */
    uint16_t adc_counts[5], sonar_us[4];
};

typedef enum {
    ST_INSTANTIATED = 1u << 0,
    ST_INIT = 1u << 1,
    ST_STEP = 1u << 2,
    ST_TERMINATED = 1u << 3
} fwfmu_state_t;

#define ST_ANY (ST_INSTANTIATED | ST_INIT | ST_STEP | ST_TERMINATED)

/* Which FMI call is legal in which state. */
enum {
    F_SET_DEBUG_LOGGING, F_ENTER_INIT, F_EXIT_INIT, F_TERMINATE, F_RESET, F_GET, F_SET_INPUT, F_SET_PARAMETER,
    F_DO_STEP, F_COUNT
};
static const struct {
    const char *name;
    unsigned states;
} fwfmu_legal[F_COUNT] = {
    [F_SET_DEBUG_LOGGING] = {"fmi3SetDebugLogging", ST_ANY},
    [F_ENTER_INIT] = {"fmi3EnterInitializationMode", ST_INSTANTIATED},
    [F_EXIT_INIT] = {"fmi3ExitInitializationMode", ST_INIT},
    [F_TERMINATE] = {"fmi3Terminate", ST_STEP},
    [F_RESET] = {"fmi3Reset", ST_ANY},
    [F_GET] = {"fmi3Get*", ST_INIT | ST_STEP | ST_TERMINATED},
    [F_SET_INPUT] = {"fmi3Set* (input)", ST_INSTANTIATED | ST_INIT | ST_STEP},
    [F_SET_PARAMETER] = {"fmi3Set* (fixed parameter)", ST_INSTANTIATED | ST_INIT},
    [F_DO_STEP] = {"fmi3DoStep", ST_STEP},
};

typedef struct {
    struct hal hal;
    fw_t fw;
    uint32_t baud;             /* the parameter (copied into hal at init exit) */
    fwfmu_state_t state;
    double time;               /* s: time of the next doStep */
    double start_time;         /* s */
    uint64_t elapsed_us;       /* us: communication steps since the start, summed */
    /* the last step size that passed the checks (NaN: none yet), the tick period it was
     * checked with, and what follows from the two: ticks and us per step */
    double step_h;             /* s */
    uint32_t step_period_us;
    uint64_t step_ticks, step_us;
    uint8_t rx_stage[FWFMU_RX_CAP]; /* serial_rx as set, consumed by the next doStep */
    size_t rx_stage_len;
    char *name;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    unsigned log_events;       /* 1: report logEvents messages (fmi3SetDebugLogging) */
} fwfmu_t;

/* Report a message: logStatusError always, logEvents only when debug logging enabled it. */
static void fwfmu_log(const fwfmu_t *m, fmi3Status st, const char *cat, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    if (!m || !m->log || (strcmp(cat, "logEvents") == 0 && !m->log_events)) {
        return;
    }
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    m->log(m->env, st, cat, msg);
}

static int fwfmu_allowed(fwfmu_t *m, int f)
{
    if (!m) {
        return 0;
    }
    if (!(fwfmu_legal[f].states & (unsigned)m->state)) {
        fwfmu_log(m, fmi3Error, "logStatusError", "%s is not allowed in state %u", fwfmu_legal[f].name,
                  (unsigned)m->state);
        return 0;
    }
    return 1;
}

/* ---------------------------------------------------------------- the board (hal.h) */

static uint16_t fwfmu_adc_counts(double volts)
{
    double c = floor(volts / FWFMU_ADC_REF_V * 1024.0);
    if (!(c > 0.0)) {
        return 0u;
    }
    return (c > 1023.0) ? 1023u : (uint16_t)c;
}

int32_t hal_enc_left(hal_t *h) { return h->enc_left; }
int32_t hal_enc_right(hal_t *h) { return h->enc_right; }
int16_t hal_gyro_raw(hal_t *h)
{
    return (int16_t)((h->gyro_raw > 32767) ? 32767 : (h->gyro_raw < -32768) ? -32768 : h->gyro_raw);
}
uint16_t hal_compass(hal_t *h)
{
    int32_t c = h->compass_raw % 3600;
    return (uint16_t)((c < 0) ? c + 3600 : c);
}
uint16_t hal_adc(hal_t *h, uint8_t ch)
{
    /* the firmware reads ch0..FW_ADC_CHANNELS-1 only: ch0-3 IR, ch4 the battery divider */
    unsigned k = (ch < 4u) ? ch : 4u;
    double v = (k < 4u) ? h->ir_voltage[k] : h->battery_voltage;
    if (!(v == h->adc_v[k])) {
        h->adc_v[k] = v;
        h->adc_counts[k] = fwfmu_adc_counts((k < 4u) ? v : v / FWFMU_BATTERY_DIVIDER);
    }
    return h->adc_counts[k];
}
uint16_t hal_sonar_echo(hal_t *h, uint8_t i)
{
    double v = h->sonar_echo[i];
    if (!(v == h->sonar_v[i])) {
        double us = floor(v + 0.5);
        h->sonar_v[i] = v;
        h->sonar_us[i] = (!(us > 0.0)) ? 0u : (us > 65535.0) ? 65535u : (uint16_t)us;
    }
    return h->sonar_us[i];
}
uint16_t hal_dio_in(hal_t *h) { return (uint16_t)(h->dio_in & 0x0FFF); }
uint8_t hal_reset_cause(hal_t *h) { (void)h; return NAVKIT_RESET_CAUSE_POWER_ON; } /* no reset pin, watchdog or supply */
void hal_motor(hal_t *h, int16_t l, int16_t r)
{
    h->motor_left_duty = (double)l / 10000.0;
    h->motor_right_duty = (double)r / 10000.0;
}
void hal_servo_pulse(hal_t *h, uint8_t i, uint16_t us) { h->servo_pulse[i] = (double)us; }
void hal_dio_write(hal_t *h, uint16_t dir, uint16_t out)
{
    h->dio_dir = dir;
    h->dio_out = out;
}
size_t hal_uart_read(hal_t *h, uint8_t *buf, size_t cap)
{
    size_t n = 0;
    while (n < cap && h->rx_ready > 0u) {
        buf[n++] = h->rx[h->rx_head];
        h->rx_head = (h->rx_head + 1u) % FWFMU_RX_CAP;
        h->rx_len--;
        h->rx_ready--;
    }
    return n;
}
size_t hal_uart_tx_free(hal_t *h) { return FWFMU_TX_CAP - h->tx_len; }
void hal_uart_write(hal_t *h, const uint8_t *buf, size_t len)
{
    size_t i;
    for (i = 0; i < len && h->tx_len < FWFMU_TX_CAP; i++) {
        h->tx[(h->tx_head + h->tx_len) % FWFMU_TX_CAP] = buf[i];
        h->tx_len++;
    }
}

/* Bytes the line carries in tick_us at the baud rate, from the credit (bit-us). */
static uint32_t fwfmu_line_bytes(uint64_t *credit, uint32_t baud, uint32_t tick_us, uint32_t waiting)
{
    const uint64_t per_byte = (uint64_t)FWFMU_BITS_PER_BYTE * 1000000u;
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

static void fwfmu_tick(fwfmu_t *m)
{
    struct hal *h = &m->hal;
    uint32_t tick_us = fw_tick_period_us(&m->fw);
    uint32_t n;
    /* RX: bytes that reached the micro during this tick */
    h->rx_ready += fwfmu_line_bytes(&h->rx_credit, h->baud, tick_us, h->rx_len - h->rx_ready);
    fw_link_poll(&m->fw);
    fw_tick(&m->fw);
    /* TX: bytes that left the micro during this tick */
    n = fwfmu_line_bytes(&h->tx_credit, h->baud, tick_us, h->tx_len);
    if (n > FWFMU_WIRE_CAP - h->wire_len) {
        n = FWFMU_WIRE_CAP - h->wire_len; /* the rest waits in the TX FIFO */
    }
    while (n-- > 0u) {
        h->wire[h->wire_len++] = h->tx[h->tx_head];
        h->tx_head = (h->tx_head + 1u) % FWFMU_TX_CAP;
        h->tx_len--;
    }
}

/* ---------------------------------------------------------------- instance life */

/* Start values of every variable, a powered-up micro, empty UART. */
static void fwfmu_power_on(fwfmu_t *m)
{
    unsigned i;
#define FWFMU_START(vr, name, caus, var, unit, start, field, desc) m->field = start;
    FWFMU_FLOAT64_VARS(FWFMU_START)
    FWFMU_INT32_VARS(FWFMU_START)
    FWFMU_UINT32_VARS(FWFMU_START)
#undef FWFMU_START
    m->hal.rx_head = m->hal.rx_len = m->hal.rx_ready = 0u;
    m->hal.rx_credit = m->hal.tx_credit = 0u;
    m->hal.rx_dropped = 0u;
    m->hal.tx_head = m->hal.tx_len = 0u;
    m->hal.wire_len = 0u;
    m->hal.baud = m->baud;
    for (i = 0; i < 5u; i++) {
        m->hal.adc_v[i] = NAN;
    }
    for (i = 0; i < 4u; i++) {
        m->hal.sonar_v[i] = NAN;
    }
    m->rx_stage_len = 0u;
    m->time = 0.0;
    m->start_time = 0.0;
    m->elapsed_us = 0u;
    m->step_h = NAN;
    fw_init(&m->fw, &m->hal);
    /* outputs as the micro holds them before its first tick: everything off */
    m->hal.motor_left_duty = m->hal.motor_right_duty = 0.0;
    memset(m->hal.servo_pulse, 0, sizeof m->hal.servo_pulse);
    m->hal.dio_out = m->hal.dio_dir = 0;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    fwfmu_t *m;
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    if (!instanceName || !instantiationToken || strcmp(instantiationToken, FWFMU_INSTANTIATION_TOKEN) != 0 ||
        eventModeUsed || earlyReturnAllowed || nRequiredIntermediateVariables != 0u) {
        if (logMessage) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "navkit_firmware: wrong instantiation token, or an unsupported option (event mode, early "
                       "return, intermediate variables)");
        }
        return NULL;
    }
    m = (fwfmu_t *)calloc(1, sizeof *m);
    if (!m) {
        return NULL;
    }
    m->name = (char *)malloc(strlen(instanceName) + 1u);
    if (!m->name) {
        free(m);
        return NULL;
    }
    strcpy(m->name, instanceName);
    m->env = instanceEnvironment;
    m->log = logMessage;
    m->log_events = loggingOn ? 1u : 0u;
    fwfmu_power_on(m);
    m->state = ST_INSTANTIATED;
    return m;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    if (logMessage) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError", "navkit_firmware is co-simulation only");
    }
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    if (logMessage) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError", "navkit_firmware is co-simulation only");
    }
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    if (m) {
        free(m->name);
        free(m);
    }
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    fwfmu_t *m = (fwfmu_t *)instance;
    size_t i;
    unsigned events = 0u;
    if (!fwfmu_allowed(m, F_SET_DEBUG_LOGGING)) {
        return fmi3Error;
    }
    if (nCategories == 0u) {
        events = 1u; /* all categories */
    }
    for (i = 0; i < nCategories; i++) {
        if (strcmp(categories[i], "logEvents") == 0) {
            events = 1u;
        } else if (strcmp(categories[i], "logStatusError") != 0) {
            fwfmu_log(m, fmi3Error, "logStatusError", "unknown log category \"%s\"", categories[i]);
            return fmi3Error;
        }
    }
    /* logStatusError is always reported; loggingOn switches logEvents when it is listed */
    if (events) {
        m->log_events = loggingOn ? 1u : 0u;
    }
    return fmi3OK;
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    if (!fwfmu_allowed(m, F_ENTER_INIT)) {
        return fmi3Error;
    }
    m->time = startTime;
    m->start_time = startTime;
    m->state = ST_INIT;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    if (!fwfmu_allowed(m, F_EXIT_INIT)) {
        return fmi3Error;
    }
    if (m->baud < 300u || m->baud > 4000000u) {
        fwfmu_log(m, fmi3Error, "logStatusError", "baud %u outside 300..4000000", (unsigned)m->baud);
        return fmi3Error;
    }
    m->hal.baud = m->baud;
    m->state = ST_STEP;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    fwfmu_log((fwfmu_t *)instance, fmi3Error, "logStatusError", "event mode is not supported");
    return fmi3Error;
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    if (!fwfmu_allowed(m, F_TERMINATE)) {
        return fmi3Error;
    }
    m->state = ST_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    if (!fwfmu_allowed(m, F_RESET)) {
        return fmi3Error;
    }
    fwfmu_power_on(m); /* a micro reset: unconfigured again */
    m->state = ST_INSTANTIATED;
    return fmi3OK;
}

/* ---------------------------------------------------------------- variables */

#define FWFMU_CAUS_input F_SET_INPUT
#define FWFMU_CAUS_parameter F_SET_PARAMETER
#define FWFMU_CAUS_output F_COUNT
#define FWFMU_CAUS_independent F_COUNT

/* Check nValues == nValueReferences (scalars only). */
static int fwfmu_counts_ok(fwfmu_t *m, size_t nvr, size_t nv)
{
    if (nvr != nv) {
        fwfmu_log(m, fmi3Error, "logStatusError", "nValues %u != nValueReferences %u (all variables are scalars)",
                  (unsigned)nv, (unsigned)nvr);
        return 0;
    }
    return 1;
}

static fmi3Status fwfmu_bad_vr(fwfmu_t *m, fmi3ValueReference vr, const char *type)
{
    fwfmu_log(m, fmi3Error, "logStatusError", "no %s variable with value reference %u", type, (unsigned)vr);
    return fmi3Error;
}

static fmi3Status fwfmu_set_check(fwfmu_t *m, int legal, const char *name)
{
    if (legal == F_COUNT) {
        fwfmu_log(m, fmi3Error, "logStatusError", "%s is not an input or parameter and cannot be set", name);
        return fmi3Error;
    }
    return fwfmu_allowed(m, legal) ? fmi3OK : fmi3Error;
}

#define FWFMU_GET_CASE(vr, name, caus, var, unit, start, field, desc) \
    case vr:                                                          \
        values[i] = m->field;                                         \
        break;
#define FWFMU_SET_CASE(vr, name, caus, var, unit, start, field, desc)             \
    case vr:                                                                      \
        if (fwfmu_set_check(m, FWFMU_CAUS_##caus, #name) != fmi3OK) {              \
            return fmi3Error;                                                     \
        }                                                                         \
        m->field = values[i];                                                     \
        break;

#define FWFMU_ACCESSORS(Type, ctype, LIST)                                                                      \
    fmi3Status fmi3Get##Type(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, ctype values[], \
                             size_t nv)                                                                        \
    {                                                                                                          \
        fwfmu_t *m = (fwfmu_t *)instance;                                                                      \
        size_t i;                                                                                              \
        if (!fwfmu_allowed(m, F_GET) || !fwfmu_counts_ok(m, nvr, nv)) {                                        \
            return fmi3Error;                                                                                  \
        }                                                                                                      \
        for (i = 0; i < nvr; i++) {                                                                            \
            switch (vrs[i]) {                                                                                  \
                LIST(FWFMU_GET_CASE)                                                                           \
            default:                                                                                           \
                return fwfmu_bad_vr(m, vrs[i], #Type);                                                         \
            }                                                                                                  \
        }                                                                                                      \
        return fmi3OK;                                                                                         \
    }                                                                                                          \
    fmi3Status fmi3Set##Type(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,               \
                             const ctype values[], size_t nv)                                                  \
    {                                                                                                          \
        fwfmu_t *m = (fwfmu_t *)instance;                                                                      \
        size_t i;                                                                                              \
        if (!m || !fwfmu_counts_ok(m, nvr, nv)) {                                                              \
            return fmi3Error;                                                                                  \
        }                                                                                                      \
        for (i = 0; i < nvr; i++) {                                                                            \
            switch (vrs[i]) {                                                                                  \
                LIST(FWFMU_SET_CASE)                                                                           \
            default:                                                                                           \
                return fwfmu_bad_vr(m, vrs[i], #Type);                                                         \
            }                                                                                                  \
        }                                                                                                      \
        return fmi3OK;                                                                                         \
    }

FWFMU_ACCESSORS(Float64, fmi3Float64, FWFMU_FLOAT64_VARS)
FWFMU_ACCESSORS(Int32, fmi3Int32, FWFMU_INT32_VARS)
FWFMU_ACCESSORS(UInt32, fmi3UInt32, FWFMU_UINT32_VARS)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nv)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    size_t i;
    if (!fwfmu_allowed(m, F_GET) || !fwfmu_counts_ok(m, nvr, nv)) {
        return fmi3Error;
    }
    for (i = 0; i < nvr; i++) {
        if (vrs[i] == FWFMU_VR_SERIAL_TX) {
            values[i] = m->hal.wire;
            valueSizes[i] = m->hal.wire_len;
        } else if (vrs[i] == FWFMU_VR_SERIAL_RX) {
            values[i] = m->rx_stage;
            valueSizes[i] = m->rx_stage_len;
        } else {
            return fwfmu_bad_vr(m, vrs[i], "Binary");
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nv)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    size_t i;
    if (!m || !fwfmu_counts_ok(m, nvr, nv)) {
        return fmi3Error;
    }
    for (i = 0; i < nvr; i++) {
        if (vrs[i] == FWFMU_VR_SERIAL_TX) {
            return fwfmu_set_check(m, F_COUNT, "serial_tx");
        }
        if (vrs[i] != FWFMU_VR_SERIAL_RX) {
            return fwfmu_bad_vr(m, vrs[i], "Binary");
        }
        if (!fwfmu_allowed(m, F_SET_INPUT)) {
            return fmi3Error;
        }
        if (valueSizes[i] > FWFMU_RX_CAP) {
            fwfmu_log(m, fmi3Error, "logStatusError", "serial_rx of %u bytes exceeds %u", (unsigned)valueSizes[i],
                      (unsigned)FWFMU_RX_CAP);
            return fmi3Error;
        }
        if (valueSizes[i] > 0u) {
            memcpy(m->rx_stage, values[i], valueSizes[i]);
        }
        m->rx_stage_len = valueSizes[i];
    }
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    fwfmu_t *m = (fwfmu_t *)instance;
    struct hal *h;
    double ticks_f, h_s = communicationStepSize;
    uint32_t period_us;
    uint64_t n, k;
    size_t i;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!fwfmu_allowed(m, F_DO_STEP)) {
        return fmi3Error;
    }
    h = &m->hal;
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = m->time;
    if (fabs(currentCommunicationPoint - m->time) > 1e-6) {
        fwfmu_log(m, fmi3Error, "logStatusError", "currentCommunicationPoint %.9f s, expected %.9f s",
                  currentCommunicationPoint, m->time);
        return fmi3Error;
    }
    period_us = fw_tick_period_us(&m->fw);
    if (!(h_s == m->step_h && period_us == m->step_period_us)) {
        /* a new step size or tick period (else the last one's checked results hold) */
        ticks_f = h_s * 1e6 / (double)period_us;
        n = (uint64_t)floor(ticks_f + 0.5);
        if (!(h_s > 0.0) || n < 1u || fabs(ticks_f - (double)n) > 1e-6 * (double)n) {
            fwfmu_log(m, fmi3Error, "logStatusError",
                      "communicationStepSize %.9f s is not a whole number of control ticks of %u us", h_s,
                      (unsigned)period_us);
            return fmi3Error;
        }
        m->step_h = h_s;
        m->step_period_us = period_us;
        m->step_ticks = n;
        m->step_us = (uint64_t)floor(h_s * 1e6 + 0.5);
    }
    n = m->step_ticks;
    /* serial_rx joins the RX FIFO; a full FIFO drops the excess (like a real UART) */
    for (i = 0; i < m->rx_stage_len; i++) {
        if (h->rx_len < FWFMU_RX_CAP) {
            h->rx[(h->rx_head + h->rx_len) % FWFMU_RX_CAP] = m->rx_stage[i];
            h->rx_len++;
        } else {
            h->rx_dropped++;
        }
    }
    if (m->rx_stage_len > 0u && h->rx_dropped > 0u) {
        fwfmu_log(m, fmi3Warning, "logEvents", "RX FIFO full: %u bytes dropped so far", (unsigned)h->rx_dropped);
    }
    m->rx_stage_len = 0u;
    h->wire_len = 0u;
    for (k = 0; k < n; k++) {
        fwfmu_tick(m); /* a config may change the tick period: the step still ends at t + h */
    }
    m->elapsed_us += m->step_us;
    m->time = m->start_time + (double)m->elapsed_us * 1e-6;
    *lastSuccessfulTime = m->time;
    return fmi3OK;
}

/* ---------------------------------------------------------------- not supported */

#define FWFMU_UNSUPPORTED(call)                                                                      \
    do {                                                                                             \
        fwfmu_log((fwfmu_t *)instance, fmi3Error, "logStatusError", "%s is not supported", call);    \
        return fmi3Error;                                                                            \
    } while (0)

#define FWFMU_NO_ACCESSOR(Type, ctype)                                                                          \
    fmi3Status fmi3Get##Type(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, ctype values[], \
                             size_t nv)                                                                        \
    {                                                                                                          \
        (void)vrs, (void)nvr, (void)values, (void)nv;                                                          \
        FWFMU_UNSUPPORTED("fmi3Get" #Type " (no variables of this type)");                                     \
    }                                                                                                          \
    fmi3Status fmi3Set##Type(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,               \
                             const ctype values[], size_t nv)                                                  \
    {                                                                                                          \
        (void)vrs, (void)nvr, (void)values, (void)nv;                                                          \
        FWFMU_UNSUPPORTED("fmi3Set" #Type " (no variables of this type)");                                     \
    }

FWFMU_NO_ACCESSOR(Float32, fmi3Float32)
FWFMU_NO_ACCESSOR(Int8, fmi3Int8)
FWFMU_NO_ACCESSOR(UInt8, fmi3UInt8)
FWFMU_NO_ACCESSOR(Int16, fmi3Int16)
FWFMU_NO_ACCESSOR(UInt16, fmi3UInt16)
FWFMU_NO_ACCESSOR(Int64, fmi3Int64)
FWFMU_NO_ACCESSOR(UInt64, fmi3UInt64)
FWFMU_NO_ACCESSOR(Boolean, fmi3Boolean)

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, fmi3String values[],
                         size_t nv)
{
    (void)vrs, (void)nvr, (void)values, (void)nv;
    FWFMU_UNSUPPORTED("fmi3GetString (no variables of this type)");
}
fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                         const fmi3String values[], size_t nv)
{
    (void)vrs, (void)nvr, (void)values, (void)nv;
    FWFMU_UNSUPPORTED("fmi3SetString (no variables of this type)");
}
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, fmi3Clock values[])
{
    (void)vrs, (void)nvr, (void)values;
    FWFMU_UNSUPPORTED("fmi3GetClock");
}
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, const fmi3Clock values[])
{
    (void)vrs, (void)nvr, (void)values;
    FWFMU_UNSUPPORTED("fmi3SetClock");
}
fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference vr, size_t *n)
{
    (void)vr, (void)n;
    FWFMU_UNSUPPORTED("fmi3GetNumberOfVariableDependencies");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    FWFMU_UNSUPPORTED("fmi3GetVariableDependencies");
}
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *s)
{
    (void)s;
    FWFMU_UNSUPPORTED("fmi3GetFMUState");
}
fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState s)
{
    (void)s;
    FWFMU_UNSUPPORTED("fmi3SetFMUState");
}
fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *s)
{
    (void)s;
    FWFMU_UNSUPPORTED("fmi3FreeFMUState");
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState s, size_t *size)
{
    (void)s, (void)size;
    FWFMU_UNSUPPORTED("fmi3SerializedFMUStateSize");
}
fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState s, fmi3Byte bytes[], size_t size)
{
    (void)s, (void)bytes, (void)size;
    FWFMU_UNSUPPORTED("fmi3SerializeFMUState");
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size, fmi3FMUState *s)
{
    (void)s, (void)bytes, (void)size;
    FWFMU_UNSUPPORTED("fmi3DeserializeFMUState");
}
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    FWFMU_UNSUPPORTED("fmi3GetDirectionalDerivative");
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    FWFMU_UNSUPPORTED("fmi3GetAdjointDerivative");
}
fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) { FWFMU_UNSUPPORTED("fmi3EnterConfigurationMode"); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) { FWFMU_UNSUPPORTED("fmi3ExitConfigurationMode"); }
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)vrs, (void)nvr, (void)intervals, (void)qualifiers;
    FWFMU_UNSUPPORTED("fmi3GetIntervalDecimal");
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                   fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions, (void)qualifiers;
    FWFMU_UNSUPPORTED("fmi3GetIntervalFraction");
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                               fmi3Float64 shifts[])
{
    (void)vrs, (void)nvr, (void)shifts;
    FWFMU_UNSUPPORTED("fmi3GetShiftDecimal");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions;
    FWFMU_UNSUPPORTED("fmi3GetShiftFraction");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    (void)vrs, (void)nvr, (void)intervals;
    FWFMU_UNSUPPORTED("fmi3SetIntervalDecimal");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions;
    FWFMU_UNSUPPORTED("fmi3SetIntervalFraction");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                               const fmi3Float64 shifts[])
{
    (void)vrs, (void)nvr, (void)shifts;
    FWFMU_UNSUPPORTED("fmi3SetShiftDecimal");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions;
    FWFMU_UNSUPPORTED("fmi3SetShiftFraction");
}
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { FWFMU_UNSUPPORTED("fmi3EvaluateDiscreteStates"); }
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    (void)discreteStatesNeedUpdate, (void)terminateSimulation, (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged, (void)nextEventTimeDefined, (void)nextEventTime;
    FWFMU_UNSUPPORTED("fmi3UpdateDiscreteStates");
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) { FWFMU_UNSUPPORTED("fmi3EnterContinuousTimeMode"); }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    FWFMU_UNSUPPORTED("fmi3CompletedIntegratorStep");
}
fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    FWFMU_UNSUPPORTED("fmi3SetTime");
}
fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t nx)
{
    (void)x, (void)nx;
    FWFMU_UNSUPPORTED("fmi3SetContinuousStates");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nx)
{
    (void)derivatives, (void)nx;
    FWFMU_UNSUPPORTED("fmi3GetContinuousStateDerivatives");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t ni)
{
    (void)eventIndicators, (void)ni;
    FWFMU_UNSUPPORTED("fmi3GetEventIndicators");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t nx)
{
    (void)x, (void)nx;
    FWFMU_UNSUPPORTED("fmi3GetContinuousStates");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nx)
{
    (void)nominals, (void)nx;
    FWFMU_UNSUPPORTED("fmi3GetNominalsOfContinuousStates");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *n)
{
    (void)n;
    FWFMU_UNSUPPORTED("fmi3GetNumberOfEventIndicators");
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *n)
{
    (void)n;
    FWFMU_UNSUPPORTED("fmi3GetNumberOfContinuousStates");
}
fmi3Status fmi3EnterStepMode(fmi3Instance instance) { FWFMU_UNSUPPORTED("fmi3EnterStepMode (no event mode)"); }
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nv)
{
    (void)vrs, (void)nvr, (void)orders, (void)values, (void)nv;
    FWFMU_UNSUPPORTED("fmi3GetOutputDerivatives");
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference, (void)activationTime;
    FWFMU_UNSUPPORTED("fmi3ActivateModelPartition");
}
