/* board_sonar.c: the SRF04 ping sequence (board_sonar.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_sonar.h"

#define SONAR_COUNTS_PER_US 2u /* Timer5 at 16 MHz / 8 */

enum { SONAR_IDLE, SONAR_TRIG, SONAR_WAIT_RISE, SONAR_ECHO, SONAR_WAIT_LOW };

static volatile uint16_t sonar_us[4]; /* us: results */
static volatile uint16_t sonar_t5_high; /* Timer5 overflows */
static uint8_t sonar_state;
static uint8_t sonar_cur;      /* sonar being pinged */
static uint8_t sonar_pins;     /* echo pin levels at the last pin change */
static uint32_t sonar_t_state; /* 0.5 us: when the state began (rise time in SONAR_ECHO) */

/* The 32-bit Timer5 clock, 0.5 us. Interrupts off. */
static uint32_t sonar_now(void)
{
    uint16_t lo = TCNT5;
    uint16_t hi = sonar_t5_high;
    if ((TIFR5 & _BV(TOV5)) && (lo < 0x8000u)) {
        hi++; /* overflowed before lo was read, its interrupt still pending */
    }
    return ((uint32_t)hi << 16) | lo;
}

void board_sonar_init(void)
{
    uint8_t i;
    for (i = 0u; i < 4u; i++) {
        sonar_us[i] = 0u;
    }
    BOARD_SONAR_TRIG_PORT &= (uint8_t)~(0x0Fu << BOARD_SONAR_TRIG_SHIFT);
    BOARD_SONAR_TRIG_DDR |= (uint8_t)(0x0Fu << BOARD_SONAR_TRIG_SHIFT);
    DDRB &= (uint8_t)~BOARD_SONAR_ECHO_MASK;
    sonar_t5_high = 0u;
    TCCR5A = 0u;
    TCCR5B = _BV(CS51); /* normal mode, 16 MHz / 8 */
    TIFR5 = _BV(TOV5);
    TIMSK5 = _BV(TOIE5);
    sonar_cur = 0u;
    sonar_state = SONAR_IDLE;
    sonar_t_state = 0u;
    sonar_pins = (uint8_t)(BOARD_SONAR_ECHO_PIN & BOARD_SONAR_ECHO_MASK);
    PCMSK0 = BOARD_SONAR_ECHO_MASK;
    PCIFR = _BV(PCIF0);
    PCICR |= _BV(PCIE0);
}

ISR(TIMER5_OVF_vect)
{
    sonar_t5_high++;
}

static void board_sonar_step(void);

/* Result r (us) for the current sonar, then the quiet time before the next. */
static void sonar_finish(uint16_t r, uint32_t now)
{
    sonar_us[sonar_cur] = r;
    sonar_cur = (uint8_t)((sonar_cur + 1u) & 3u);
    sonar_state = SONAR_IDLE;
    sonar_t_state = now;
}

void board_sonar_tick(void)
{
    uint8_t sreg = SREG;
    cli(); /* the pin-change interrupt shares the state (and Timer5's TEMP byte) */
    board_sonar_step();
    SREG = sreg;
}

static void board_sonar_step(void)
{
    uint32_t now = sonar_now();
    uint32_t dt = now - sonar_t_state;
    uint8_t trig = (uint8_t)(1u << (BOARD_SONAR_TRIG_SHIFT + sonar_cur));
    switch (sonar_state) {
    case SONAR_IDLE:
        if (dt >= (uint32_t)BOARD_SONAR_HOLDOFF_US * SONAR_COUNTS_PER_US) {
            BOARD_SONAR_TRIG_PORT |= trig;
            sonar_state = SONAR_TRIG;
            sonar_t_state = now;
        }
        break;
    case SONAR_TRIG:
        BOARD_SONAR_TRIG_PORT &= (uint8_t)~trig;
        sonar_state = SONAR_WAIT_RISE;
        sonar_t_state = now;
        break;
    case SONAR_WAIT_RISE:
        if (dt >= (uint32_t)BOARD_SONAR_RISE_US * SONAR_COUNTS_PER_US) {
            sonar_finish(0u, now); /* no part, or it never answered */
        }
        break;
    case SONAR_ECHO:
        if (dt >= (uint32_t)BOARD_SONAR_NOECHO_US * SONAR_COUNTS_PER_US) {
            sonar_us[sonar_cur] = 0u;
            sonar_state = SONAR_WAIT_LOW; /* the no-object pulse: wait for its end */
        }
        break;
    default: /* SONAR_WAIT_LOW */
        if (!(BOARD_SONAR_ECHO_PIN & (1u << sonar_cur))) {
            sonar_finish(0u, now);
        }
        break;
    }
}

ISR(PCINT0_vect)
{
    uint32_t now = sonar_now();
    uint8_t pins = (uint8_t)(BOARD_SONAR_ECHO_PIN & BOARD_SONAR_ECHO_MASK);
    uint8_t rose = (uint8_t)(pins & ~sonar_pins);
    uint8_t fell = (uint8_t)(~pins & sonar_pins);
    uint8_t bit = (uint8_t)(1u << sonar_cur);
    sonar_pins = pins;
    if ((sonar_state == SONAR_WAIT_RISE) && (rose & bit)) {
        sonar_state = SONAR_ECHO;
        sonar_t_state = now;
    } else if ((sonar_state == SONAR_ECHO) && (fell & bit)) {
        uint32_t w = (now - sonar_t_state + SONAR_COUNTS_PER_US / 2u) / SONAR_COUNTS_PER_US;
        sonar_finish((w >= BOARD_SONAR_NOECHO_US) ? 0u : (uint16_t)w, now);
    } else if ((sonar_state == SONAR_WAIT_LOW) && (fell & bit)) {
        sonar_finish(0u, now);
    }
}

uint16_t board_sonar_get(uint8_t i)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = sonar_us[i & 3u];
    SREG = s;
    return v;
}
