/* board_reset.c: reset cause and watchdog (board_reset.h). */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>

#include "board.h"
#include "board_motor.h"
#include "board_reset.h"
#include "navkit/navkit_proto.h"

/* The markers at BOARD_MARK_ADDR: the linker places `board_mark` there (--defsym, see
 * CMakeLists.txt), outside every section, so neither the C runtime nor the loader touch it. */
typedef struct {
    uint32_t running;  /* RESET_MARK_RUNNING while the image runs */
    uint32_t watchdog; /* RESET_MARK_WATCHDOG from the watchdog interrupt to the next start */
} reset_mark_t;
extern volatile reset_mark_t board_mark;
typedef char reset_mark_size_check[(sizeof(reset_mark_t) == BOARD_MARK_BYTES) ? 1 : -1];

#define RESET_MARK_RUNNING 0x4E4B5255UL  /* "URKN" */
#define RESET_MARK_WATCHDOG 0x4E4B5744UL /* "DWKN" */

/* MCUSR as the image found it; .noinit: the C runtime's .bss clearing runs after .init3. */
static uint8_t reset_flags __attribute__((section(".noinit")));
static uint8_t reset_cause_code;

/* Runs from .init3, before .data/.bss are set up: save and clear the reset flags and stop
 * the watchdog (after a watchdog reset it stays on at its shortest period). */
void board_reset_early(void) __attribute__((naked, used, section(".init3")));
void board_reset_early(void)
{
    reset_flags = MCUSR;
    MCUSR = 0u;
    wdt_disable();
}

void board_reset_init(void)
{
    uint8_t f = reset_flags;
    uint8_t c;
    if (f & _BV(PORF)) {
        c = NAVKIT_RESET_CAUSE_POWER_ON;
    } else if (f & _BV(BORF)) {
        c = NAVKIT_RESET_CAUSE_BROWN_OUT;
    } else if (f & _BV(WDRF)) {
        c = NAVKIT_RESET_CAUSE_WATCHDOG;
    } else if (f & _BV(EXTRF)) {
        c = NAVKIT_RESET_CAUSE_EXTERNAL;
    } else if (f != 0u) {
        c = NAVKIT_RESET_CAUSE_UNKNOWN; /* JTRF alone */
    } else if (board_mark.watchdog == RESET_MARK_WATCHDOG) {
        c = NAVKIT_RESET_CAUSE_WATCHDOG;
    } else if (board_mark.running == RESET_MARK_RUNNING) {
        c = NAVKIT_RESET_CAUSE_EXTERNAL;
    } else {
        c = NAVKIT_RESET_CAUSE_POWER_ON;
    }
    reset_cause_code = c;
    board_mark.watchdog = 0u;
    board_mark.running = RESET_MARK_RUNNING;
}

uint8_t board_reset_cause(void)
{
    return reset_cause_code;
}

uint8_t board_reset_mcusr(void)
{
    return reset_flags;
}

void board_reset_watchdog_start(void)
{
    /* the timed sequence: WDCE|WDE, then the mode within 4 cycles, interrupts off */
    __asm__ __volatile__("in __tmp_reg__, __SREG__\n\t"
                         "cli\n\t"
                         "wdr\n\t"
                         "sts %0, %1\n\t"
                         "sts %0, %2\n\t"
                         "out __SREG__, __tmp_reg__\n\t"
                         :
                         : "n"(_SFR_MEM_ADDR(WDTCSR)), "r"((uint8_t)(_BV(WDCE) | _BV(WDE))),
                           "r"((uint8_t)(_BV(WDIE) | _BV(WDE) | _BV(WDP1))) /* 64 ms */
                         : "r0");
}

void board_reset_watchdog_feed(void)
{
    wdt_reset();
}

/* The main loop missed one watchdog period: motors off at once, leave the marker, and
 * wait (interrupts off) for the reset the next period brings. */
ISR(WDT_vect)
{
    board_motor_off();
    board_mark.watchdog = RESET_MARK_WATCHDOG;
    for (;;) {
    }
}
