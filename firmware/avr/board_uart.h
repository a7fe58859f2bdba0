/* board_uart: UART0 (the micro link) with interrupt-driven RX and TX rings (prefix board_uart_).
 *
 * RX: the receive interrupt puts each byte into a 255-byte ring; when the ring is full the
 * new byte is dropped and counted (board_uart_rx_overflows()), the bytes already in it are
 * kept in order. TX: board_uart_write() queues into a 255-byte ring that the data-register-
 * empty interrupt drains at the line rate. Each ring has one writer and one reader, with
 * 8-bit indices, so neither side needs to disable interrupts. */
#ifndef NAVKIT_BOARD_UART_H
#define NAVKIT_BOARD_UART_H

#include <stddef.h>
#include <stdint.h>

/* Set UART0 to 115200 8N1 (U2X, UBRR BOARD_UART_UBRR), rings empty, RX interrupt on.
 * Writes every UART0 register (a bootloader may have left them set). */
void board_uart_init(void);
/* Copy up to cap received bytes (oldest first) into buf; returns how many (0 = none). */
size_t board_uart_read(uint8_t *buf, size_t cap);
/* 1 if a received byte waits in the RX ring. */
uint8_t board_uart_rx_ready(void);
/* Bytes the TX ring can take now, 0..255. */
size_t board_uart_tx_free(void);
/* Queue len bytes to send; bytes beyond board_uart_tx_free() are dropped. */
void board_uart_write(const uint8_t *buf, size_t len);
/* Bytes dropped because the RX ring was full, since reset (wraps). */
uint16_t board_uart_rx_overflows(void);

#endif /* NAVKIT_BOARD_UART_H */
