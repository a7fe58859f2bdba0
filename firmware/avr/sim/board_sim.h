/* board_sim.h: the Arduino Mega 2560 of firmware/avr/board.h simulated in simavr, as wires
 * (prefix board_sim_). Library target navkit_board_sim (links libsimavr).
 *
 * One board_sim_t is one board: an ATmega2560 at 16 MHz running a navkit image (the ELF or
 * the Intel HEX of <build>/firmware/avr/), loaded at flash address 0 (no bootloader), plus
 * models of the parts board.h wires to it: two quadrature encoders, the analog inputs, an
 * MPU-6050-class gyro and a CMPS03-class compass on TWI, four SRF04 sonars, the DIO pins,
 * the motor driver's PWM/DIR pins, eight RC servo pins, UART0 and an MCP2515 CAN controller
 * on the SPI with its bus. Instances are independent
 * (no shared state), but one instance must be used from one thread at a time.
 *
 * Time is the AVR's cycle count (16 000 000 cycles per second). Ordering:
 *   - an input set now takes effect from the current cycle (board_sim_cycles()) on; the
 *     image sees it the next time it samples that input (the gyro and compass at the next
 *     TWI read of that part, the ADC at its next conversion of that channel, a sonar at its
 *     next echo, encoder and DIO levels at once on the pins);
 *   - outputs are what the pins show up to the current cycle;
 *   - board_sim_run_until() is the only call that advances time.
 * So a co-simulation step is: set inputs, run_until(end of step), read outputs.
 */
#ifndef NAVKIT_BOARD_SIM_H
#define NAVKIT_BOARD_SIM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define BOARD_SIM_F_CPU_HZ 16000000u /* Hz: the board's clock; cycles per simulated second */

typedef struct board_sim board_sim_t;

/* Cycle counts of the image's own markers (GPIOR0, firmware/avr/board.h: BOARD_PROF_*):
 * fw_tick() and fw_link_poll() each from their first to their last instruction, interrupts
 * taken inside them included. */
typedef struct {
    uint32_t ticks;             /* fw_tick() calls completed */
    uint32_t tick_worst_cycles; /* cycles: the longest fw_tick() */
    uint32_t tick_mean_cycles;  /* cycles: mean fw_tick(), rounded down; 0 if no tick */
    uint32_t polls;             /* fw_link_poll() calls completed */
    uint32_t poll_worst_cycles; /* cycles: the longest fw_link_poll() */
    uint32_t poll_mean_cycles;  /* cycles: mean fw_link_poll(); 0 if no poll */
    uint64_t tick_total_cycles; /* cycles: all fw_tick() together (CPU share = this / cycles) */
    uint64_t poll_total_cycles; /* cycles: all fw_link_poll() together */
    uint32_t resets;            /* resets of the core after the first start (any cause) */
    uint32_t watchdog_resets;   /* of which by the hardware watchdog */
    uint16_t stack_min_sp;      /* the lowest stack pointer seen (a data address; RAMEND = 0x21FF) */
    uint16_t stack_max_bytes;   /* bytes: deepest stack, RAMEND - stack_min_sp */
    /* tick lateness: cycles from the tick timer's interrupt request (Timer3 compare A: the
     * moment a tick falls due) to the start of the fw_tick() that serves it, due ticks
     * served oldest first; what a long fw_link_poll() (or a run of ticks) holds them up */
    uint32_t tick_late_worst_cycles; /* cycles: the latest tick */
    uint64_t tick_late_total_cycles; /* cycles: all ticks' lateness together (mean = this / ticks) */
} board_sim_profile_t;

/* A board running image_path (.elf, or .hex/.ihex: Intel HEX) from reset. On failure
 * returns NULL and writes a one-line reason naming the file into err (err_len bytes,
 * NUL-terminated; err may be NULL). */
board_sim_t *board_sim_new(const char *image_path, char *err, size_t err_len);
/* Free the board (NULL is fine). */
void board_sim_free(board_sim_t *b);
/* Run the core until its cycle count reaches `cycle` (cycles since board_sim_new(); a cycle
 * at or before the current one returns at once). Returns 0, or -1 if the core stopped
 * (crashed, or executed `sleep` with interrupts off); board_sim_error() says why. */
int board_sim_run_until(board_sim_t *b, uint64_t cycle);
/* Cycles executed since board_sim_new() (16 MHz). */
uint64_t board_sim_cycles(const board_sim_t *b);
/* Why the core stopped (an empty string while it runs). */
const char *board_sim_error(const board_sim_t *b);

/* ---- inputs, effective from the current cycle ---- */

/* Encoder positions, x4 quadrature counts (the image's raw hal_enc_* sign). The A/B edges
 * from the positions on the pins now to these are spread evenly over (now, by_cycle]; a new
 * call replaces edges not yet made (from wherever the pins are). by_cycle <= now: the edges
 * come BOARD_SIM_ENC_MIN_EDGE_CYCLES apart from now. Edges closer than
 * BOARD_SIM_ENC_MIN_EDGE_CYCLES are spread to that spacing (the board's guaranteed rate,
 * docs/avr.md), so the pins lag the request instead of the board losing counts. */
#define BOARD_SIM_ENC_MIN_EDGE_CYCLES 320u /* cycles: 20 us, 50 000 edges/s per encoder */
void board_sim_set_encoders(board_sim_t *b, int32_t left_counts, int32_t right_counts, uint64_t by_cycle);
/* Voltage at the analog pin of hal channel ch (0..4: IR 0-3, battery after the board's
 * divider), mV (0..5000, the 5.0 V AVcc reference; above is read as 5000). Other ch: ignored. */
void board_sim_set_adc_mv(board_sim_t *b, uint8_t ch, uint16_t mv);
/* The gyro part's yaw-rate register (GYRO_ZOUT, 131 LSB per deg/s, counter-clockwise +),
 * LSB: what hal_gyro_raw() returns once the image has read it. */
void board_sim_set_gyro_raw(board_sim_t *b, int16_t lsb);
/* The compass part's bearing register, deg*10 (0..3599, clockwise from north). */
void board_sim_set_compass(board_sim_t *b, uint16_t deg10);
/* Sonar i (0..3): the echo pulse width, us, the SRF04 gives after the image's next trigger
 * of it; 0 = no echo (the part's 36 ms no-object pulse, which the image reports as 0). */
void board_sim_set_sonar_echo_us(board_sim_t *b, uint8_t i, uint16_t us);
/* on = 0: the TWI part at 7-bit address addr7 (BOARD_GYRO_ADDR, BOARD_COMPASS_ADDR) stops
 * answering (a loose cable: every transfer to it is NACKed); on = 1: it answers again, in
 * the state it had (the gyro stays awake). Default: both answer. */
void board_sim_set_twi_part_present(board_sim_t *b, uint8_t addr7, int on);
/* Levels driven onto the 12 DIO pins from outside, bit n = DIO n (a pin the image drives
 * as an output shows the image's level instead). */
void board_sim_set_dio_in(board_sim_t *b, uint16_t levels);

/* ---- outputs, measured at the pins ---- */

/* Motor drive from the timer's PWM compare registers and the DIR pins, duty*1e4
 * (-10000..10000; + = DIR pin low, the image's hal_motor sign). */
void board_sim_motor_duty(const board_sim_t *b, int16_t *left_e4, int16_t *right_e4);
/* Servo i (0..7): width of the last complete high pulse on its pin, us (rounded to the
 * nearest); 0 = no pulse yet, or none for longer than 100 ms (the image stopped driving it). */
uint16_t board_sim_servo_pulse_us(const board_sim_t *b, uint8_t i);
/* DIO pins: dir bit n = 1 if the image drives DIO n as an output; levels = the pin levels
 * (outputs as driven, inputs as set by board_sim_set_dio_in()). */
void board_sim_dio(const board_sim_t *b, uint16_t *dir, uint16_t *levels);

/* ---- UART0 (the micro link), 8N1 at the baud rate the image programs (115200) ---- */

/* Queue len bytes towards the image's RX pin. They arrive one byte per 10 bit times as the
 * core runs; the queue holds BOARD_SIM_UART_QUEUE bytes, a write beyond that drops the
 * excess (counted in board_sim_uart_dropped()). */
#define BOARD_SIM_UART_QUEUE 65536u /* bytes */
void board_sim_uart_write(board_sim_t *b, const uint8_t *buf, size_t len);
/* Copy up to cap bytes the image has sent (oldest first) into buf; returns how many. The
 * board keeps up to BOARD_SIM_UART_QUEUE unread bytes; older ones are dropped (counted). */
size_t board_sim_uart_read(board_sim_t *b, uint8_t *buf, size_t cap);
/* Bytes dropped by either queue of this side (the image's own ring buffers are its affair). */
uint32_t board_sim_uart_dropped(const board_sim_t *b);

/* ---- CAN: an MCP2515 module on the SPI (board.h, CAN; board_sim_can.h has the model)
 * and the bus between it and the host's end (a USB-CAN adapter). Only the image built with
 * the CAN link (navkit-mega2560-can) drives the part; the serial image leaves it in reset.
 * Ordering: frames written go on the bus in the order written, one at a time at the spec's
 * bit rate (NAVKIT_CAN_BITRATE; 47 + 8 x DLC bits a frame, no stuff bits), each once the part acknowledges it
 * (normal mode, bit timing at the bus rate: until then they wait, as an adapter repeats an
 * unacknowledged frame); between a host frame and the part's, the lower identifier goes
 * first. The part's frames come out in the order they left it. ---- */

/* One classic data frame: 11-bit identifier, dlc data bytes (data past dlc: 0). */
typedef struct {
    uint16_t id;
    uint8_t dlc;
    uint8_t data[8];
    uint64_t cycle; /* cycles: when its last bit went (frames read back; ignored on write) */
} board_sim_can_frame_t;

/* Counts of the part and the bus since board_sim_new(). */
typedef struct {
    uint32_t part_bps;     /* bit/s the part's CNF1-3 give at its crystal (BOARD_CAN_OSC_HZ); 0 none valid */
    uint8_t normal_mode;   /* 1 while the part is in normal mode */
    uint32_t to_part;      /* host frames the part acknowledged (received whole) */
    uint32_t accepted;     /* of those, frames its masks and filters took into a receive buffer */
    uint32_t filtered;     /* of those, frames its filters refused */
    uint32_t overflowed;   /* of those, frames that found their buffers full (lost: EFLG RXnOVR) */
    uint32_t from_part;    /* frames the part sent */
    uint32_t host_waiting; /* host frames written, not yet acknowledged */
    uint32_t dropped;      /* frames lost to a full queue of this side (BOARD_SIM_CAN_QUEUE each way) */
} board_sim_can_stats_t;

#define BOARD_SIM_CAN_QUEUE 4096u /* frames each way */
/* Queue a frame from the host's end (id: 11 bits; dlc 0..8 bytes of data). */
void board_sim_can_write(board_sim_t *b, uint16_t id, const uint8_t *data, uint8_t dlc);
/* The oldest frame the part has sent: 1 and *out, or 0 if none. */
int board_sim_can_read(board_sim_t *b, board_sim_can_frame_t *out);
/* The part's and the bus's counts so far into *out. */
void board_sim_can_stats(const board_sim_t *b, board_sim_can_stats_t *out);
/* held 1: the part's INT pin reads high at the AVR whatever the part asks, as for a driver
 * whose poll is held off (interrupts off too long): its receive buffers fill, then
 * overflow; 0: INT shows the part's state again. A fault for tests. */
void board_sim_can_hold_int(board_sim_t *b, int held);

/* ---- resets ---- */

#define BOARD_SIM_RESET_EXTERNAL 0  /* the reset pin (the USB-serial's DTR): SRAM kept, MCUSR EXTRF */
#define BOARD_SIM_RESET_POWER_ON 1  /* power cycle: SRAM arbitrary, MCUSR PORF */
#define BOARD_SIM_RESET_BROWN_OUT 2 /* supply dip: SRAM kept, MCUSR BORF */
/* Reset the core now with one of BOARD_SIM_RESET_*: the image starts again from address 0
 * (the parts keep their inputs and state; a power-on also restarts the gyro asleep). */
void board_sim_reset(board_sim_t *b, int cause);
/* on = 1: after every reset, MCUSR reads 0 when the image starts, as the stk500v2
 * bootloader leaves it (it reads and clears the flags before jumping to the image); the
 * image must then tell the cause from its RAM markers. Default 0 (no bootloader). */
void board_sim_set_bootloader_clears_mcusr(board_sim_t *b, int on);

/* ---- profiling from the running image ---- */

/* Counts since board_sim_new(), across resets. */
void board_sim_profile(const board_sim_t *b, board_sim_profile_t *out);

#ifdef __cplusplus
}
#endif

#endif /* NAVKIT_BOARD_SIM_H */
