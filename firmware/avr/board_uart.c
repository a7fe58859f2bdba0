/* board_uart.c: UART0 rings (board_uart.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "board_uart.h"

#if BOARD_UART_RX_SIZE != 256u || BOARD_UART_TX_SIZE != 256u
#error "the rings wrap with 8-bit indices: 256 bytes each"
#endif

static uint8_t uart_rx[BOARD_UART_RX_SIZE];
static uint8_t uart_tx[BOARD_UART_TX_SIZE];
static volatile uint8_t uart_rx_head;  /* written by the RX interrupt */
static volatile uint8_t uart_rx_tail;  /* written by board_uart_read() */
static volatile uint8_t uart_tx_head;  /* written by board_uart_write() */
static volatile uint8_t uart_tx_tail;  /* written by the UDRE interrupt */
static volatile uint16_t uart_rx_lost; /* bytes dropped on a full RX ring */

void board_uart_init(void)
{
    UCSR0B = 0u; /* off while reprogramming */
    UCSR0A = _BV(U2X0);
    UBRR0H = (uint8_t)(BOARD_UART_UBRR >> 8);
    UBRR0L = (uint8_t)BOARD_UART_UBRR;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1, asynchronous */
    uart_rx_head = uart_rx_tail = 0u;
    uart_tx_head = uart_tx_tail = 0u;
    uart_rx_lost = 0u;
    UCSR0B = _BV(RXCIE0) | _BV(RXEN0) | _BV(TXEN0);
}

ISR(USART0_RX_vect)
{
    uint8_t c = UDR0;
    uint8_t next = (uint8_t)(uart_rx_head + 1u);
    if (next == uart_rx_tail) {
        uart_rx_lost++;
        return;
    }
    uart_rx[uart_rx_head] = c;
    uart_rx_head = next;
}

ISR(USART0_UDRE_vect)
{
    uint8_t t = uart_tx_tail;
    if (t == uart_tx_head) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0); /* empty: the next write re-enables */
        return;
    }
    UDR0 = uart_tx[t];
    uart_tx_tail = (uint8_t)(t + 1u);
}

size_t board_uart_read(uint8_t *buf, size_t cap)
{
    size_t n = 0u;
    uint8_t t = uart_rx_tail;
    uint8_t h = uart_rx_head;
    while (n < cap && t != h) {
        buf[n++] = uart_rx[t];
        t = (uint8_t)(t + 1u);
    }
    uart_rx_tail = t;
    return n;
}

uint8_t board_uart_rx_ready(void)
{
    return (uint8_t)(uart_rx_tail != uart_rx_head);
}

size_t board_uart_tx_free(void)
{
    return (size_t)(uint8_t)(uart_tx_tail - uart_tx_head - 1u);
}

void board_uart_write(const uint8_t *buf, size_t len)
{
    size_t room = board_uart_tx_free();
    uint8_t h = uart_tx_head;
    size_t i;
    if (len > room) {
        len = room;
    }
    for (i = 0u; i < len; i++) {
        uart_tx[h] = buf[i];
        h = (uint8_t)(h + 1u);
    }
    uart_tx_head = h;
    if (len > 0u) {
        /* the UDRE interrupt may clear UDRIE0 between this read and write: setting it is
           right either way, bytes are queued */
        UCSR0B |= _BV(UDRIE0);
    }
}

uint16_t board_uart_rx_overflows(void)
{
    uint16_t n;
    uint8_t s = SREG;
    cli();
    n = uart_rx_lost;
    SREG = s;
    return n;
}
