/* board_enc.c: x4 quadrature decoding in the pin interrupts (board_enc.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_enc.h"

/* Count step for (last state << 2 | new state), state = A << 1 | B; 0 for no change and
 * for the four transitions that change both pins (an edge was missed: not counted).
 * Forward (A leads B): 0 2 3 1 0. */
static const int8_t enc_step[16] = {0, -1, 1, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 1, -1, 0};

/* The interrupts only add to 16-bit accumulators (short interrupts: the other encoder's
 * edges must not wait); board_enc_left/right fold them into the 32-bit counts. At 50 000
 * edges/s an accumulator holds 0.65 s of counts; the core reads every tick (<= 10 ms). */
static volatile int16_t enc_l_acc, enc_r_acc;
static uint8_t enc_l_last, enc_r_last; /* state << 2 at the last interrupt */
static int32_t enc_l, enc_r;           /* counts up to the last fold (main loop only) */

void board_enc_init(void)
{
    DDRE &= (uint8_t) ~(3u << BOARD_ENC_L_SHIFT);
    DDRD &= (uint8_t) ~(3u << BOARD_ENC_R_SHIFT);
    enc_l = 0;
    enc_r = 0;
    enc_l_acc = 0;
    enc_r_acc = 0;
    enc_l_last = (uint8_t)(((BOARD_ENC_L_PIN >> BOARD_ENC_L_SHIFT) & 3u) << 2);
    enc_r_last = (uint8_t)(((BOARD_ENC_R_PIN >> BOARD_ENC_R_SHIFT) & 3u) << 2);
    /* any logical change: ISCn1:0 = 01 */
    EICRA = (uint8_t)((EICRA & 0x0Fu) | _BV(ISC20) | _BV(ISC30));
    EICRB = (uint8_t)((EICRB & 0xF0u) | _BV(ISC40) | _BV(ISC50));
    EIFR = _BV(INTF2) | _BV(INTF3) | _BV(INTF4) | _BV(INTF5);
    EIMSK |= _BV(INT2) | _BV(INT3) | _BV(INT4) | _BV(INT5);
}

ISR(INT4_vect)
{
    uint8_t s = (uint8_t)((BOARD_ENC_L_PIN >> BOARD_ENC_L_SHIFT) & 3u);
    uint8_t i = (uint8_t)(enc_l_last | s);
    enc_l_last = (uint8_t)(s << 2);
    enc_l_acc += enc_step[i];
}
ISR(INT5_vect, ISR_ALIASOF(INT4_vect));

ISR(INT2_vect)
{
    uint8_t s = (uint8_t)((BOARD_ENC_R_PIN >> BOARD_ENC_R_SHIFT) & 3u);
    uint8_t i = (uint8_t)(enc_r_last | s);
    enc_r_last = (uint8_t)(s << 2);
    enc_r_acc += enc_step[i];
}
ISR(INT3_vect, ISR_ALIASOF(INT2_vect));

/* Fold one encoder's interrupt accumulator *acc into its 32-bit count *count (counts),
 * taking and clearing *acc with interrupts held off; returns the new count. */
static int32_t enc_fold(volatile int16_t *acc, int32_t *count)
{
    int16_t a;
    uint8_t s = SREG;
    cli();
    a = *acc;
    *acc = 0;
    SREG = s;
    *count += a;
    return *count;
}

int32_t board_enc_left(void)
{
    return enc_fold(&enc_l_acc, &enc_l);
}

int32_t board_enc_right(void)
{
    return enc_fold(&enc_r_acc, &enc_r);
}
