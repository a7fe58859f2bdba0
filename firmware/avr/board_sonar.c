/* board_sonar.c: the SRF04 ping sequence (board_sonar.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_sonar.h"

#define SONAR_COUNTS_PER_US 2u /* Timer5 at 16 MHz / 8 */

enum { SONAR_IDLE, SONAR_TRIG, SONAR_WAIT_RISE, SONAR_ECHO, SONAR_WAIT_LOW };

static volatile uint16_t sonar_us[4];   /* us: results */
static volatile uint16_t sonar_t5_high; /* Timer5 overflows */
static uint8_t sonar_state;
static uint8_t sonar_cur;               /* sonar being pinged */
static uint8_t sonar_pins;              /* echo pin levels at the last pin change */
static uint32_t sonar_t_state;          /* 0.5 us: when the state began (rise time in SONAR_ECHO) */
static volatile uint8_t sonar_in_pcint; /* 1 while the pin-change interrupt runs with interrupts on */

/* The sequence's state is shared by the pin-change interrupt and the tick's step; neither
 * keeps interrupts off for long (the encoder interrupts must not wait). The pin-change
 * interrupt takes the edge's time and levels with interrupts off, then lets the encoders
 * in; the step decides on a copy of the state and applies its decision, interrupts off,
 * only if the state is unchanged and the pin-change interrupt is not half-way. (Masking
 * PCIE0 would be simpler, but simavr 1.6 drops a pin change that arrives while its
 * interrupt is masked.) */

/* Each sonar's trigger bit in BOARD_SONAR_TRIG_PORT: a table, since 1 << n by a variable n
 * is a loop on the AVR, too long for the step's critical section (the encoders wait). */
static const uint8_t sonar_trig_bit[4] = {1u << BOARD_SONAR_TRIG_SHIFT, 1u << (BOARD_SONAR_TRIG_SHIFT + 1),
                                          1u << (BOARD_SONAR_TRIG_SHIFT + 2), 1u << (BOARD_SONAR_TRIG_SHIFT + 3)};

/* The 32-bit Timer5 clock, 0.5 us. */
static uint32_t sonar_now(void)
{
    uint8_t sreg = SREG;
    uint16_t lo, hi;
    cli(); /* TCNT5's two bytes go through the TEMP byte the other 16-bit timers' users share */
    lo = TCNT5;
    hi = sonar_t5_high;
    if ((TIFR5 & _BV(TOV5)) && (lo < 0x8000u)) {
        hi++; /* overflowed before lo was read, its interrupt still pending */
    }
    SREG = sreg;
    return ((uint32_t)hi << 16) | lo;
}

void board_sonar_init(void)
{
    uint8_t i;
    for (i = 0u; i < 4u; i++) {
        sonar_us[i] = 0u;
    }
    BOARD_SONAR_TRIG_PORT &= (uint8_t) ~(0x0Fu << BOARD_SONAR_TRIG_SHIFT);
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
    sonar_pins = (uint8_t)((BOARD_SONAR_ECHO_PIN & BOARD_SONAR_ECHO_MASK) >> BOARD_SONAR_ECHO_SHIFT);
    PCMSK0 = BOARD_SONAR_ECHO_MASK;
    PCIFR = _BV(PCIF0);
    PCICR |= _BV(PCIE0);
}

ISR(TIMER5_OVF_vect)
{
    sonar_t5_high++;
}

/* Result r (us) for the current sonar, then the quiet time before the next. Interrupts off. */
static void sonar_finish(uint16_t r, uint32_t now)
{
    sonar_us[sonar_cur] = r;
    sonar_cur = (uint8_t)((sonar_cur + 1u) & 3u);
    sonar_state = SONAR_IDLE;
    sonar_t_state = now;
}

void board_sonar_tick(void)
{
    uint32_t now = sonar_now();
    uint8_t sreg = SREG;
    uint8_t st, cur, next, trig, trig_on = 0u, trig_off = 0u, done = 0u;
    uint32_t dt;
    /* decide on a copy with interrupts on; apply only if the state is still that copy */
    cli();
    st = sonar_state;
    cur = sonar_cur;
    dt = now - sonar_t_state;
    SREG = sreg;
    next = st;
    switch (st) {
    case SONAR_IDLE:
        if (dt >= (uint32_t)BOARD_SONAR_HOLDOFF_US * SONAR_COUNTS_PER_US) {
            trig_on = 1u;
            next = SONAR_TRIG;
        }
        break;
    case SONAR_TRIG:
        trig_off = 1u;
        next = SONAR_WAIT_RISE;
        break;
    case SONAR_WAIT_RISE:
        if (dt >= (uint32_t)BOARD_SONAR_RISE_US * SONAR_COUNTS_PER_US) {
            done = 1u; /* no part, or it never answered */
        }
        break;
    case SONAR_ECHO:
        if (dt >= (uint32_t)BOARD_SONAR_NOECHO_US * SONAR_COUNTS_PER_US) {
            next = SONAR_WAIT_LOW; /* the no-object pulse: wait for its end */
        }
        break;
    default: /* SONAR_WAIT_LOW */
        if (!(BOARD_SONAR_ECHO_PIN & (1u << (BOARD_SONAR_ECHO_SHIFT + cur)))) {
            done = 1u;
        }
        break;
    }
    if (next == st && !done) {
        return;
    }
    trig = sonar_trig_bit[cur];
    cli();
    if (!sonar_in_pcint && sonar_state == st && sonar_cur == cur) {
        if (trig_on) {
            BOARD_SONAR_TRIG_PORT |= trig;
        } else if (trig_off) {
            BOARD_SONAR_TRIG_PORT &= (uint8_t)~trig;
        }
        if (done) {
            sonar_finish(0u, now);
        } else {
            if (next == SONAR_WAIT_LOW) {
                sonar_us[cur] = 0u;
            }
            sonar_state = next;
            sonar_t_state = now;
        }
    } /* else the pin-change interrupt moved it meanwhile: decide again next tick */
    SREG = sreg;
}

ISR(PCINT0_vect)
{
    uint32_t now = sonar_now(); /* edge time and levels first, interrupts still off */
    uint8_t pins = (uint8_t)((BOARD_SONAR_ECHO_PIN & BOARD_SONAR_ECHO_MASK) >> BOARD_SONAR_ECHO_SHIFT);
    uint8_t rose, fell, bit;
    if (sonar_in_pcint) {
        return; /* nested in itself (edges < 20 us apart on one echo line): not a sonar echo */
    }
    sonar_in_pcint = 1u;
    sei(); /* the rest may wait for the encoders */
    rose = (uint8_t)(pins & ~sonar_pins);
    fell = (uint8_t)(~pins & sonar_pins);
    bit = (uint8_t)(1u << sonar_cur);
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
    cli();
    sonar_in_pcint = 0u;
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
