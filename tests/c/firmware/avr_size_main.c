/* A minimal AVR program around the firmware core, only to measure its footprint:
 * every hal_* wire is a stub touching a volatile, the fw_t instance is static (as the
 * real AVR target will have it). Built with the link of FW_LINK_CAN (link.h): the UART
 * wires, or with FW_LINK_CAN = 1 the CAN wires in their place (an MCP2515 driver behind
 * them is the board's part). Built and sized by avr_size.cmake (ctest firmware_avr_build,
 * firmware_avr_build_can). */
#include "fw.h"

struct hal {
    volatile int32_t enc;
    volatile uint16_t word;
#if FW_LINK_CAN
    volatile uint8_t byte;
#endif
};

static struct hal board;
static fw_t fw;

int32_t hal_enc_left(hal_t *hal)
{
    return hal->enc;
}
int32_t hal_enc_right(hal_t *hal)
{
    return hal->enc;
}
int16_t hal_gyro_raw(hal_t *hal)
{
    return (int16_t)hal->word;
}
uint16_t hal_compass(hal_t *hal)
{
    return hal->word;
}
uint16_t hal_adc(hal_t *hal, uint8_t ch)
{
    return (uint16_t)(hal->word + ch);
}
uint16_t hal_sonar_echo(hal_t *hal, uint8_t i)
{
    return (uint16_t)(hal->word + i);
}
uint16_t hal_dio_in(hal_t *hal)
{
    return hal->word;
}
uint8_t hal_reset_cause(hal_t *hal)
{
    return (uint8_t)hal->word;
}
void hal_motor(hal_t *hal, int16_t l, int16_t r)
{
    hal->word = (uint16_t)(l + r);
}
void hal_servo_pulse(hal_t *hal, uint8_t i, uint16_t us)
{
    hal->word = (uint16_t)(us + i);
}
void hal_dio_write(hal_t *hal, uint16_t dir, uint16_t out)
{
    hal->word = (uint16_t)(dir ^ out);
}
#if FW_LINK_CAN
uint8_t hal_can_read(hal_t *hal, uint16_t *id, uint8_t data[8], uint8_t *dlc)
{
    uint8_t i;
    if (hal->byte == 0u) {
        return 0u;
    }
    *id = hal->word;
    *dlc = hal->byte;
    for (i = 0u; i < 8u; i++) {
        data[i] = hal->byte;
    }
    return 1u;
}
uint8_t hal_can_tx_free(hal_t *hal)
{
    return hal->byte;
}
void hal_can_write(hal_t *hal, uint16_t id, const uint8_t data[8])
{
    hal->word = (uint16_t)(id + data[0] + data[7]);
}
uint16_t hal_can_rx_lost(hal_t *hal)
{
    return hal->word;
}
#else
size_t hal_uart_read(hal_t *hal, uint8_t *buf, size_t cap)
{
    if (cap == 0u || hal->word == 0u) {
        return 0u;
    }
    buf[0] = (uint8_t)hal->word;
    return 1u;
}
size_t hal_uart_tx_free(hal_t *hal)
{
    return hal->word;
}
void hal_uart_write(hal_t *hal, const uint8_t *buf, size_t len)
{
    hal->word = (uint16_t)(buf[0] + len);
}
#endif

int main(void)
{
    fw_init(&fw, &board);
    for (;;) {
        fw_link_poll(&fw);
        fw_tick(&fw);
    }
}
