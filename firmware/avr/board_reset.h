/* board_reset: why the board started, and the hardware watchdog (prefix board_reset_).
 *
 * The reset flags (MCUSR) are saved and cleared, and the watchdog stopped, in .init3,
 * before the C runtime. The stock Mega stk500v2 bootloader clears MCUSR itself before it
 * starts this image, so the image also keeps two markers in SRAM at BOARD_MARK_ADDR that
 * survive a reset while powered: "running" (set at every start) and "watchdog" (set by
 * the watchdog interrupt just before the watchdog resets the board). The cause:
 *   MCUSR PORF -> power_on; BORF -> brown_out; WDRF -> watchdog; EXTRF -> external;
 *   MCUSR 0 (a bootloader cleared it): watchdog marker -> watchdog; else running marker
 *   -> external (RAM kept: the reset pin, DTR); else power_on (RAM lost);
 *   any other flag alone (JTRF) -> unknown.
 * docs/avr.md, Reset cause, says what a bootloader hides (a brown-out that kept RAM reads
 * external). */
#ifndef NAVKIT_BOARD_RESET_H
#define NAVKIT_BOARD_RESET_H

#include <stdint.h>

/* Work out the cause from the saved flags and the markers, then set the markers for this
 * run. Call once, early in main(). */
void board_reset_init(void);
/* Why the board started, a NAVKIT_RESET_CAUSE_* code. */
uint8_t board_reset_cause(void);
/* The MCUSR value the image started with (0 after the stk500v2 bootloader). */
uint8_t board_reset_mcusr(void);
/* Start the watchdog: interrupt then reset mode, ~64 ms each. */
void board_reset_watchdog_start(void);
/* Feed the watchdog (the main loop, once per pass). */
void board_reset_watchdog_feed(void);

#endif /* NAVKIT_BOARD_RESET_H */
