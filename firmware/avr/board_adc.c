/* board_adc.c: background ADC sweeps (board_adc.h). Channel ch is ADCch (A0-A4). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_adc.h"

static volatile uint16_t adc_val[BOARD_ADC_CHANNELS]; /* counts */
static volatile uint8_t adc_ch;                       /* channel being converted */
static volatile uint8_t adc_busy;                     /* 1 while a sweep runs */

void board_adc_init(void)
{
    uint8_t i;
    for (i = 0u; i < BOARD_ADC_CHANNELS; i++) {
        adc_val[i] = 0u;
    }
    adc_busy = 0u;
    DIDR0 = (uint8_t)((1u << BOARD_ADC_CHANNELS) - 1u); /* digital inputs off on A0-A4 */
    ADCSRB = 0u;                                        /* MUX5 = 0: ADC0-7 */
    ADMUX = _BV(REFS0);
    ADCSRA = _BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0); /* 16 MHz / 128 */
}

void board_adc_sweep(void)
{
    uint8_t sreg = SREG;
    cli(); /* adc_busy is cleared by the ADC interrupt */
    if (!adc_busy) {
        adc_busy = 1u;
        adc_ch = 0u;
        ADMUX = _BV(REFS0);
        ADCSRA |= _BV(ADSC);
    }
    SREG = sreg;
}

ISR(ADC_vect)
{
    uint8_t ch = adc_ch;
    adc_val[ch] = ADC;
    ch++;
    if (ch < BOARD_ADC_CHANNELS) {
        adc_ch = ch;
        ADMUX = (uint8_t)(_BV(REFS0) | ch);
        ADCSRA |= _BV(ADSC);
    } else {
        adc_busy = 0u;
    }
}

uint16_t board_adc_get(uint8_t ch)
{
    uint16_t v;
    uint8_t s;
    if (ch >= BOARD_ADC_CHANNELS) {
        return 0u;
    }
    s = SREG;
    cli();
    v = adc_val[ch];
    SREG = s;
    return v;
}
