/* fw_avr_fmu_model.h: the contract of the AVR firmware FMU (navkit_firmware_avr) beyond
 * the variables it shares with navkit_firmware (fmu/firmware/fw_fmu_model.h, same names,
 * value references, types and units, so an importer swaps one FMU for the other).
 *
 * FMI 3.0 co-simulation. The flashed AVR image (<build>/firmware/avr/navkit-mega2560.elf,
 * shipped in the FMU as resources/navkit-mega2560.elf) runs in simavr on the simulated
 * Arduino Mega 2560 of firmware/avr/sim/board_sim.h: processor in the loop. Any step size
 * works: a doStep of h s runs the core for exactly h * 16 MHz cycles (counted from the
 * start, so steps never drift). The extra variables: the image to run (a parameter) and
 * what the board simulator measured from the running image (outputs, counts since the last
 * power-on, i.e. instantiation or fmi3Reset).
 *
 * fw_fmu_mdgen (built with FW_FMU_MDGEN_AVR) writes the modelDescription.xml from both
 * tables; tests/test_pil_fmu.py checks it against them.
 */
#ifndef NAVKIT_FW_AVR_FMU_MODEL_H
#define NAVKIT_FW_AVR_FMU_MODEL_H

#if defined(FW_LINK_CAN) && FW_LINK_CAN
/* The CAN build (navkit_firmware_avr_can): the CAN image (navkit-mega2560-can.elf) on the
 * board's simulated MCP2515; its bus frames in can_rx / can_tx (fw_fmu_model.h, the CAN
 * build's records) instead of serial_rx / serial_tx. */
#define FWAVR_MODEL_IDENTIFIER "navkit_firmware_avr_can"
#define FWAVR_MODEL_NAME "navkit firmware on the AVR (CAN link)"
#define FWAVR_INSTANTIATION_TOKEN "{5f0c6a52-7e0b-4c8e-9a4f-6e61766b6143}"
#define FWAVR_DESCRIPTION                                                                                              \
    "navkit reference firmware as the flashed ATmega2560 CAN image, executed cycle by cycle in simavr on a "           \
    "simulated Arduino Mega 2560 with an MCP2515, coupled at its pins and its CAN bus (processor in the loop)"
#define FWAVR_IMAGE_RESOURCE "navkit-mega2560-can.elf" /* in the FMU's resources/ folder */
#else
#define FWAVR_MODEL_IDENTIFIER "navkit_firmware_avr"
#define FWAVR_MODEL_NAME "navkit firmware on the AVR"
#define FWAVR_INSTANTIATION_TOKEN "{5f0c6a52-7e0b-4c8e-9a4f-6e61766b6176}"
#define FWAVR_DESCRIPTION                                                                                              \
    "navkit reference firmware as the flashed ATmega2560 image, executed cycle by cycle in simavr on a "               \
    "simulated Arduino Mega 2560, coupled at its pins (processor in the loop)"
#define FWAVR_IMAGE_RESOURCE "navkit-mega2560.elf" /* in the FMU's resources/ folder */
#endif
#define FWAVR_F_CPU_HZ 16000000.0 /* Hz: cycles per simulated second */
#define FWAVR_BAUD 115200u        /* the image's UART0 rate */

/* String: X(vr, name, causality, description); the start value is "". */
#define FWAVR_STRING_VARS(X)                                                                                           \
    X(60, image, parameter, "AVR image to run (.elf or .hex), an absolute path; empty = the one in the FMU's resources")

/* X(vr, name, causality, variability, unit, start, field, description), as fw_fmu_model.h;
 * every one an output read from the board simulator's profile (board_sim_profile_t). */
#define FWAVR_UINT32_VARS(X)                                                                                           \
    X(62, prof_ticks, output, discrete, "", 0, prof.ticks, "fw_tick() calls completed")                                \
    X(63, prof_tick_worst_cycles, output, discrete, "", 0, prof.tick_worst_cycles,                                     \
      "Cycles of the longest fw_tick() (interrupts taken inside it included)")                                         \
    X(64, prof_tick_mean_cycles, output, discrete, "", 0, prof.tick_mean_cycles,                                       \
      "Mean cycles of fw_tick(), rounded down")                                                                        \
    X(66, prof_polls, output, discrete, "", 0, prof.polls, "fw_link_poll() calls completed")                           \
    X(67, prof_poll_worst_cycles, output, discrete, "", 0, prof.poll_worst_cycles,                                     \
      "Cycles of the longest fw_link_poll()")                                                                          \
    X(68, prof_poll_mean_cycles, output, discrete, "", 0, prof.poll_mean_cycles,                                       \
      "Mean cycles of fw_link_poll(), rounded down")                                                                   \
    X(70, prof_resets, output, discrete, "", 0, prof.resets, "Resets of the core after its first start")               \
    X(71, prof_watchdog_resets, output, discrete, "", 0, prof.watchdog_resets,                                         \
      "Of prof_resets, those by the hardware watchdog")                                                                \
    X(72, prof_stack_max_bytes, output, discrete, "", 0, prof.stack_max_bytes, "Deepest stack seen, bytes below RAMEND")

#define FWAVR_UINT64_VARS(X)                                                                                           \
    X(61, avr_cycles, output, discrete, "", 0, prof.cycles, "Cycles the core has run (16 MHz)")                        \
    X(65, prof_tick_total_cycles, output, discrete, "", 0, prof.tick_total_cycles,                                     \
      "Cycles of all fw_tick() calls together (CPU share = this / avr_cycles)")                                        \
    X(69, prof_poll_total_cycles, output, discrete, "", 0, prof.poll_total_cycles,                                     \
      "Cycles of all fw_link_poll() calls together")

#define FWAVR_NUM_VRS 73u /* one past the highest value reference of both tables */

#endif /* NAVKIT_FW_AVR_FMU_MODEL_H */
