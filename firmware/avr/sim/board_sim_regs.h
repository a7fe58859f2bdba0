/* board_sim_regs.h: avr-libc's ATmega2560 register map (<avr/iom2560.h>) as plain
 * data-space addresses, the way simavr's cores include it, so the simulated board reads the
 * image's registers by the names board.h uses (PINB, TIMSK3, ...). Include after the
 * system and simavr headers (the build puts avr-libc's folder last: -idirafter). */
#ifndef NAVKIT_BOARD_SIM_REGS_H
#define NAVKIT_BOARD_SIM_REGS_H

#define _AVR_IO_H_
#define _SFR_IO8(a) ((a) + 0x20)
#define _SFR_IO16(a) ((a) + 0x20)
#define _SFR_MEM8(a) (a)
#define _SFR_MEM16(a) (a)
#define _SFR_MEM32(a) (a)
#include <avr/iom2560.h>

#endif /* NAVKIT_BOARD_SIM_REGS_H */
