/* board_adc: the analog inputs sampled in the background (prefix board_adc_).
 *
 * board_adc_sweep() (from the tick interrupt) starts one conversion of each channel in
 * turn, chained by the ADC interrupt (single conversions: the channel switch of a
 * free-running ADC lands one conversion late). board_adc_get() returns the latest result
 * at once. */
#ifndef NAVKIT_BOARD_ADC_H
#define NAVKIT_BOARD_ADC_H

#include <stdint.h>

/* ADC on: AVcc reference, 125 kHz ADC clock, interrupt on, all results 0. */
void board_adc_init(void);
/* Start a sweep of the BOARD_ADC_CHANNELS channels unless one is running (the tick
 * interrupt calls it; safe with interrupts on). */
void board_adc_sweep(void);
/* Latest result of hal channel ch (0..BOARD_ADC_CHANNELS-1), counts 0..1023; 0 for others. */
uint16_t board_adc_get(uint8_t ch);

#endif /* NAVKIT_BOARD_ADC_H */
