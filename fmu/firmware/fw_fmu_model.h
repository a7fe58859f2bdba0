/* fw_fmu_model.h: the whole contract of the firmware FMU in one header.
 *
 * modelIdentifier navkit_firmware, FMI 3.0 co-simulation. The variable table below is
 * the single source of truth: the FMI layer's table (fmu/fmi/fmil.h) is built from it
 * (FW_FMU_FMIL_ROWS), and fw_fmu_mdgen.c writes modelDescription.xml from it at build time,
 * so the two cannot drift apart (tests/test_firmware_fmu.py checks the packaged result
 * with fmpy). The AVR firmware FMU (fmu/firmware_avr, navkit_firmware_avr) has the same
 * variables from the same table, and profiling outputs of its own.
 *
 * Names and units follow docs/internals.md ("Firmware FMU <-> plant FMU").
 */
#ifndef NAVKIT_FW_FMU_MODEL_H
#define NAVKIT_FW_FMU_MODEL_H

#include <stdint.h>
#include <string.h>

#if defined(FW_LINK_CAN) && FW_LINK_CAN
/* The CAN build (navkit_firmware_can): the core's CAN link (ISO-TP, firmware/core/link.c)
 * instead of the UART; CAN frames in can_rx / can_tx instead of serial_rx / serial_tx. */
#define FW_FMU_MODEL_IDENTIFIER "navkit_firmware_can"
#define FW_FMU_MODEL_NAME "navkit firmware (CAN link)"
#define FW_FMU_INSTANTIATION_TOKEN "{5f0c6a52-7e0b-4c8e-9a4f-6e61766b6943}"
#define FW_FMU_DESCRIPTION                                                                                             \
    "navkit reference firmware (firmware/core) on a simulated micro: control ticks at the configured rate, the micro link over CAN (ISO-TP) in can_rx and can_tx"
#else
#define FW_FMU_MODEL_IDENTIFIER "navkit_firmware"
#define FW_FMU_MODEL_NAME "navkit firmware"
#define FW_FMU_INSTANTIATION_TOKEN "{5f0c6a52-7e0b-4c8e-9a4f-6e61766b6974}"
#define FW_FMU_DESCRIPTION                                                                                             \
    "navkit reference firmware (firmware/core) on a simulated micro: control ticks at the configured rate, UART at the baud parameter"
#endif
#define FW_FMU_DEFAULT_BAUD 115200u

/* X(vr, name, causality, variability, unit, start, field, description)
 *   causality: independent | input | output | parameter;
 *   variability: continuous | discrete | fixed
 *   start: the start value of inputs and parameters (ignored for outputs)
 *   field: the instance member holding the value */
#define FW_FMU_FLOAT64_VARS(X)                                                                                         \
    X(0, time, independent, continuous, "s", 0.0, time, "Simulation time")                                             \
    X(1, motor_left_duty, output, discrete, "1", 0.0, io.motor_left_duty,                                              \
      "Left motor PWM duty -1..1, + drives the wheel forward (motor_left_sign applied)")                               \
    X(2, motor_right_duty, output, discrete, "1", 0.0, io.motor_right_duty, "Right motor PWM duty -1..1")              \
    X(3, servo_pulse_0, output, discrete, "us", 0.0, io.servo_pulse[0], "RC servo 0 pulse width, 0 = not driven")      \
    X(4, servo_pulse_1, output, discrete, "us", 0.0, io.servo_pulse[1], "RC servo 1 pulse width, 0 = not driven")      \
    X(5, servo_pulse_2, output, discrete, "us", 0.0, io.servo_pulse[2], "RC servo 2 pulse width, 0 = not driven")      \
    X(6, servo_pulse_3, output, discrete, "us", 0.0, io.servo_pulse[3], "RC servo 3 pulse width, 0 = not driven")      \
    X(7, servo_pulse_4, output, discrete, "us", 0.0, io.servo_pulse[4], "RC servo 4 pulse width, 0 = not driven")      \
    X(8, servo_pulse_5, output, discrete, "us", 0.0, io.servo_pulse[5], "RC servo 5 pulse width, 0 = not driven")      \
    X(9, servo_pulse_6, output, discrete, "us", 0.0, io.servo_pulse[6], "RC servo 6 pulse width, 0 = not driven")      \
    X(10, servo_pulse_7, output, discrete, "us", 0.0, io.servo_pulse[7], "RC servo 7 pulse width, 0 = not driven")     \
    X(24, ir_voltage_0, input, continuous, "V", 0.0, io.ir_voltage[0], "Sharp GP2D12 0 output (ADC ch0)")              \
    X(25, ir_voltage_1, input, continuous, "V", 0.0, io.ir_voltage[1], "Sharp GP2D12 1 output (ADC ch1)")              \
    X(26, ir_voltage_2, input, continuous, "V", 0.0, io.ir_voltage[2], "Sharp GP2D12 2 output (ADC ch2)")              \
    X(27, ir_voltage_3, input, continuous, "V", 0.0, io.ir_voltage[3], "Sharp GP2D12 3 output (ADC ch3)")              \
    X(28, battery_voltage, input, continuous, "V", 12.0, io.battery_voltage,                                           \
      "Battery pack; the board divides it by 3 into ADC ch4 (10 bit, 5.0 V reference)")                                \
    X(29, sonar_echo_0, input, discrete, "us", 0.0, io.sonar_echo[0], "SRF04 0 echo pulse width, 0 = no echo")         \
    X(30, sonar_echo_1, input, discrete, "us", 0.0, io.sonar_echo[1], "SRF04 1 echo pulse width, 0 = no echo")         \
    X(31, sonar_echo_2, input, discrete, "us", 0.0, io.sonar_echo[2], "SRF04 2 echo pulse width, 0 = no echo")         \
    X(32, sonar_echo_3, input, discrete, "us", 0.0, io.sonar_echo[3], "SRF04 3 echo pulse width, 0 = no echo")

#define FW_FMU_INT32_VARS(X)                                                                                           \
    X(11, dio_out, output, discrete, "", 0, io.dio_out,                                                                \
      "Levels the micro drives on its 12 DIO pins (output pins only), bitmask")                                        \
    X(12, dio_dir, output, discrete, "", 0, io.dio_dir, "DIO directions, bitmask, 1 = output")                         \
    X(20, enc_left, input, discrete, "", 0, io.enc_left, "Left encoder, quadrature-decoded counts (x4), + forward")    \
    X(21, enc_right, input, discrete, "", 0, io.enc_right, "Right encoder, counts (x4), + forward")                    \
    X(22, gyro_raw, input, discrete, "", 0, io.gyro_raw,                                                               \
      "Yaw-rate gyro, LSB, counter-clockwise positive (z up), 16-bit range")                                           \
    X(23, compass_raw, input, discrete, "", 0, io.compass_raw,                                                         \
      "Compass bearing, deg*10, 0..3599, clockwise from north")                                                        \
    X(33, dio_in, input, discrete, "", 0, io.dio_in, "Levels external circuits drive on input pins, bitmask")

#define FW_FMU_UINT32_VARS(X)                                                                                          \
    X(50, baud, parameter, fixed, "", FW_FMU_DEFAULT_BAUD, baud, "UART baud rate (10 bits per byte on the wire)")

/* A CAN frame in can_rx / can_tx (the CAN build): FW_FMU_CAN_RECORD_BYTES bytes, frames back
 * to back: bytes 0-1 the identifier, little-endian (11 bits, ORed with NAVKIT_ISOTP_EXT
 * 0x8000 for an extended frame, NAVKIT_ISOTP_RTR 0x4000 for a remote one: such frames
 * reach the core, which refuses them), byte 2 the DLC (data bytes, 0..8), byte 3 zero,
 * bytes 4-11 the data (bytes past the DLC zero, ignored). */
#define FW_FMU_CAN_RECORD_BYTES 12u

/* Writes the record of a frame at `r` (FW_FMU_CAN_RECORD_BYTES bytes): identifier `id` with
 * its flags, `dlc` data bytes (0..8), the 8 bytes of `data`. */
static inline void fw_fmu_can_record_put(uint8_t *r, uint16_t id, uint8_t dlc, const uint8_t data[8])
{
    r[0] = (uint8_t)(id & 0xFFu);
    r[1] = (uint8_t)(id >> 8);
    r[2] = dlc;
    r[3] = 0u;
    memcpy(&r[4], data, 8u);
}

/* Reads the record at `r`: its identifier with its flags into *id, its 8 data bytes into
 * `data`; returns its DLC (a record's DLC above 8 reads as 8). */
static inline uint8_t fw_fmu_can_record_get(const uint8_t *r, uint16_t *id, uint8_t data[8])
{
    *id = (uint16_t)(r[0] | (r[1] << 8));
    memcpy(data, &r[4], 8u);
    return (r[2] > 8u) ? 8u : r[2];
}

/* Binary: X(vr, name, causality, description); the serial build's first, then the CAN
 * build's (tests/test_firmware_fmu.py reads the first block, test_firmware_fmu_can.py the
 * second) */
#if !(defined(FW_LINK_CAN) && FW_LINK_CAN)
#define FW_FMU_BINARY_VARS(X)                                                                                          \
    X(40, serial_rx, input, "Bytes arriving from the host during the next doStep (consumed by it)")                    \
    X(41, serial_tx, output, "Bytes the micro sent during the last doStep")

#else
#define FW_FMU_BINARY_VARS(X)                                                                                                     \
    X(42, can_rx, input,                                                                                                          \
      "CAN frames from the bus for the next doStep (consumed by it), 12 bytes each: id (2, little-endian), DLC, 0, 8 data bytes") \
    X(43, can_tx, output, "CAN frames the micro sent during the last doStep, 12 bytes each as can_rx")

#endif

#define FW_FMU_VR_SERIAL_RX 40u
#define FW_FMU_VR_SERIAL_TX 41u
#define FW_FMU_NUM_VRS 51u /* one past the highest value reference of the table */

/* Units used by the table (for <UnitDefinitions>). */
#define FW_FMU_UNITS(X) X("1") X("s") X("us") X("V")

/* The board's signals as the variables above see them, one struct for both firmware FMUs
 * (navkit_firmware: the core's hal.h reads and writes it; navkit_firmware_avr: the pins of
 * the simulated board). Units as in the table. */
typedef struct {
    /* inputs (set by the importer) */
    int32_t enc_left, enc_right, gyro_raw, compass_raw, dio_in;
    double ir_voltage[4], battery_voltage, sonar_echo[4];
    /* outputs */
    double motor_left_duty, motor_right_duty, servo_pulse[8];
    int32_t dio_out, dio_dir;
} fw_fmu_io_t;

/* The rows of the FMI layer's table (fmu/fmi/fmil.h) for the variables above, in a model
 * whose fmil_model_t has the members io (fw_fmu_io_t), time (double, s), baud (uint32_t)
 * and serial_rx, serial_tx (fmil_binary_t). */
#define FW_FMU_CAUS_independent FMIL_INDEPENDENT
#define FW_FMU_CAUS_input FMIL_INPUT
#define FW_FMU_CAUS_output FMIL_OUTPUT
#define FW_FMU_CAUS_parameter FMIL_PARAMETER
#define FW_FMU_ROW(vr, name, caus, type, field) [vr] = {#name, type, FW_FMU_CAUS_##caus, offsetof(fmil_model_t, field)},
#define FW_FMU_ROW_F64(vr, name, caus, var, unit, start, field, desc) FW_FMU_ROW(vr, name, caus, FMIL_F64, field)
#define FW_FMU_ROW_I32(vr, name, caus, var, unit, start, field, desc) FW_FMU_ROW(vr, name, caus, FMIL_I32, field)
#define FW_FMU_ROW_U32(vr, name, caus, var, unit, start, field, desc) FW_FMU_ROW(vr, name, caus, FMIL_U32, field)
#define FW_FMU_ROW_BIN(vr, name, caus, desc) FW_FMU_ROW(vr, name, caus, FMIL_BIN, name)
#define FW_FMU_FMIL_ROWS                                                                                               \
    FW_FMU_FLOAT64_VARS(FW_FMU_ROW_F64)                                                                                \
    FW_FMU_INT32_VARS(FW_FMU_ROW_I32)                                                                                  \
    FW_FMU_UINT32_VARS(FW_FMU_ROW_U32)                                                                                 \
    FW_FMU_BINARY_VARS(FW_FMU_ROW_BIN)

/* Every numeric variable of the table to its start value, in a model state pointed to by m. */
#define FW_FMU_START_ONE(vr, name, caus, var, unit, start, field, desc) (m)->field = start;
#define FW_FMU_START_VALUES(m)                                                                                         \
    FW_FMU_FLOAT64_VARS(FW_FMU_START_ONE)                                                                              \
    FW_FMU_INT32_VARS(FW_FMU_START_ONE)                                                                                \
    FW_FMU_UINT32_VARS(FW_FMU_START_ONE)

#endif /* NAVKIT_FW_FMU_MODEL_H */
