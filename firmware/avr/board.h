/* board.h: the Arduino Mega 2560 (ATmega2560, 16 MHz) as navkit wires it (prefix BOARD_).
 *
 * One place names every signal's pin, in the style of grbl's cpu_map.h: the Arduino pin
 * number (the silkscreen), the port/bit, and the peripheral that serves it. The board
 * simulator (sim/board_sim.c) wires its part models to the same names, so this header is
 * the contract between the image and the simulated board.
 *
 * Timers:  Timer1 RC servo pulses (CTC, one pulse after the other, 0.5 us counts)
 *          Timer3 control tick (CTC, 0.5 us counts)
 *          Timer4 motor PWM (fast PWM, TOP = ICR4, 20 kHz)
 *          Timer5 free-running 0.5 us clock for sonar echo timing (+ overflow count)
 *          Timer2 the CAN build's MCP2515 INT poll (CTC, BOARD_CAN_POLL_US)
 *          Timer0 unused.
 */
#ifndef NAVKIT_BOARD_H
#define NAVKIT_BOARD_H

#define BOARD_F_CPU_HZ 16000000UL /* Hz: the Mega's crystal */
#define BOARD_MCU_NAME "atmega2560"
#define BOARD_SIGNATURE_0 0x1E /* ATmega2560 device signature bytes */
#define BOARD_SIGNATURE_1 0x98
#define BOARD_SIGNATURE_2 0x01
#define BOARD_RAMEND 0x21FF /* last SRAM data address */

/* ---- UART0: the micro link (the Mega's USB-serial, DTR resets the board) ----
 * pin 0 = PE0 RXD0, pin 1 = PE1 TXD0. 115200 8N1 with U2X: UBRR = 16 gives 117 647 baud,
 * +2.1 % (the same setting avrdude/Arduino use; within the +/-2.5 % an 8N1 link allows at
 * a receiver that samples at the bit centre). Without U2X: UBRR 8 = 111 111 baud, -3.5 %. */
#define BOARD_UART_BAUD 115200UL
#define BOARD_UART_UBRR 16u
#define BOARD_UART_RX_SIZE 256u /* bytes of the RX ring (one slot stays free: 255 usable) */
#define BOARD_UART_TX_SIZE 256u /* bytes of the TX ring (255 usable) */

/* ---- Motors: a dual sign-magnitude H-bridge with one PWM and one DIR input per motor
 * (Cytron MDD10A / Pololu VNH5019 style: PWM = enable, DIR low = forward) ----
 * Left:  PWM pin 6 = PH3 (OC4A), DIR pin 8 = PH5.
 * Right: PWM pin 7 = PH4 (OC4B), DIR pin 9 = PH6.
 * Timer4 fast PWM mode 14, prescaler 1, TOP = ICR4 = 799: 20 kHz (above hearing), 800
 * steps; duty n/800 with OCR = n - 1, and the output disconnected (pin low) at n = 0. */
#define BOARD_MOTOR_PWM_TOP 799u
#define BOARD_MOTOR_PORT PORTH
#define BOARD_MOTOR_PORT_NAME 'H' /* the port's letter (the simulator's pin IRQs) */
#define BOARD_MOTOR_DDR DDRH
#define BOARD_MOTOR_L_PWM_BIT 3 /* PH3 OC4A, pin 6 */
#define BOARD_MOTOR_R_PWM_BIT 4 /* PH4 OC4B, pin 7 */
#define BOARD_MOTOR_L_DIR_BIT 5 /* PH5, pin 8 */
#define BOARD_MOTOR_R_DIR_BIT 6 /* PH6, pin 9 */

/* ---- Encoders: A/B of each wheel on four external interrupts, any edge (x4) ----
 * INT0/INT1 (PD0/PD1) are the TWI pins, so the encoders use INT2-INT5.
 * Left:  A pin 3 = PE5 (INT5), B pin 2 = PE4 (INT4): state = (PINE >> 4) & 3 = A<<1 | B.
 * Right: A pin 18 = PD3 (INT3), B pin 19 = PD2 (INT2): state = (PIND >> 2) & 3.
 * (pins 18/19 are TXD1/RXD1: UART1 stays off.) A leading B counts up.
 * Guaranteed: 50 000 edges/s on each encoder at once (20 us between edges of one encoder;
 * docs/avr.md, Encoders); INT2-INT5 are the highest-priority vectors the board uses. */
#define BOARD_ENC_L_PIN PINE
#define BOARD_ENC_L_PORT_NAME 'E'
#define BOARD_ENC_L_SHIFT 4
#define BOARD_ENC_R_PIN PIND
#define BOARD_ENC_R_PORT_NAME 'D'
#define BOARD_ENC_R_SHIFT 2
#define BOARD_ENC_MIN_EDGE_US 20u /* us: closest edges of one encoder the board guarantees */

/* ---- Analog inputs: ADC with AVcc (5.0 V) reference, 10 bit, 125 kHz ADC clock ----
 * hal channel 0-3: Sharp IR rangers on A0-A3 (PF0-PF3 = ADC0-3);
 * hal channel 4: battery through a divide-by-3 on A4 (PF4 = ADC4).
 * One sweep of the five channels (5 x 104 us) starts at every control tick. */
#define BOARD_ADC_CHANNELS 5u
#define BOARD_ADC_REF_MV 5000u /* mV: AVcc */

/* ---- TWI (I2C) at 100 kHz: pin 20 = PD1 SDA, pin 21 = PD0 SCL ----
 * Gyro: an MPU-6050-class part at 0x68 (FS_SEL 0: 131 LSB per deg/s, Z up: counter-
 * clockwise +), GYRO_ZOUT big-endian at registers 0x47/0x48, woken by PWR_MGMT_1 = 0.
 * Compass: a CMPS03-class part at 0x60, bearing 0..3599 (deg*10) big-endian at 2/3.
 * One read of each starts at every control tick (both take ~1.3 ms of bus time). */
#define BOARD_TWI_TWBR 72u /* 16 MHz / (16 + 2*72) = 100 kHz */
#define BOARD_GYRO_ADDR 0x68u
#define BOARD_GYRO_REG_PWR_MGMT_1 0x6Bu
#define BOARD_GYRO_REG_GYRO_CONFIG 0x1Bu
#define BOARD_GYRO_REG_ZOUT_H 0x47u
#define BOARD_COMPASS_ADDR 0x60u
#define BOARD_COMPASS_REG_BEARING 0x02u

/* ---- Sonars: four SRF04 (trigger in, echo out), one pinged at a time ----
 * Trigger 0-3: pins A12-A15 = PK4-PK7 (outputs).
 * Echo 0-3:    pins 10, 11, 12, 13 = PB4-PB7 (PCINT4-7; PB0-PB3 are the SPI pins, which
 *              the CAN build's MCP2515 uses; pin 13's LED buffer loads the line negligibly).
 * The trigger is held high for one control tick (>= 10 us: the part fires on its falling
 * edge); the echo width is timed with Timer5 (0.5 us) at its pin-change edges. An echo of
 * 30 ms or more is the part's no-object pulse (~36 ms) and reads 0, as does no echo within
 * 5 ms of the trigger. 10 ms pass between the end of one echo and the next trigger. */
#define BOARD_SONAR_TRIG_PORT PORTK
#define BOARD_SONAR_TRIG_PORT_NAME 'K'
#define BOARD_SONAR_TRIG_DDR DDRK
#define BOARD_SONAR_TRIG_SHIFT 4 /* PK4..PK7 */
#define BOARD_SONAR_ECHO_PIN PINB
#define BOARD_SONAR_ECHO_PORT_NAME 'B'
#define BOARD_SONAR_ECHO_SHIFT 4      /* echo i is PB(4+i) */
#define BOARD_SONAR_ECHO_MASK 0xF0u   /* PB4..PB7 */
#define BOARD_SONAR_NOECHO_US 30000u  /* us: an echo this long or longer reads 0 */
#define BOARD_SONAR_RISE_US 5000u     /* us: no echo edge this long after the trigger reads 0 */
#define BOARD_SONAR_HOLDOFF_US 10000u /* us: quiet time before the next trigger */

/* ---- RC servos: eight pulses on pins 22-29 = PA0-PA7, one after the other ----
 * Timer1 CTC at 0.5 us: each servo has a 2500 us slot (pulse, then low), 8 slots = 20 ms
 * frame (50 Hz). A pulse is clamped to BOARD_SERVO_MIN_US..BOARD_SERVO_MAX_US; 0 = none. */
#define BOARD_SERVO_PORT PORTA
#define BOARD_SERVO_PORT_NAME 'A'
#define BOARD_SERVO_DDR DDRA
#define BOARD_SERVO_SLOT_US 2500u
#define BOARD_SERVO_MIN_US 400u
#define BOARD_SERVO_MAX_US 2450u

/* ---- DIO: 12 pins ----
 * DIO 0-7:  pins 37, 36, 35, 34, 33, 32, 31, 30 = PC0-PC7.
 * DIO 8-11: pins 49, 48, 47, 46 = PL0-PL3.
 * Inputs have no pull-up (the robot's wiring drives them); every pin is an input from
 * reset until the core writes a direction. */
#define BOARD_DIO_LO_PORT PORTC
#define BOARD_DIO_LO_PORT_NAME 'C'
#define BOARD_DIO_LO_DDR DDRC
#define BOARD_DIO_LO_PIN PINC
#define BOARD_DIO_HI_PORT PORTL
#define BOARD_DIO_HI_PORT_NAME 'L'
#define BOARD_DIO_HI_DDR DDRL
#define BOARD_DIO_HI_PIN PINL
#define BOARD_DIO_HI_MASK 0x0Fu /* PL0..PL3 */

/* ---- CAN (the image built with the CAN link, navkit-mega2560-can): an MCP2515 module
 * (MCP2515 + TJA1050 transceiver) on the hardware SPI, master at F_CPU/2 = 8 MHz (the part
 * takes up to 10 MHz), mode 0,0. Pins: SCK 52 = PB1, MOSI 51 = PB2, MISO 50 = PB3,
 * CS 53 = PB0 (SS: an output anyway in master mode, so it serves as the chip select), the
 * part's INT (active low) on A8 = PK0, a plain input.
 * INT0-INT5 are taken (TWI, encoders) and simavr 1.6 models no pin-change interrupt on port
 * K (and drops a pin change that arrives while its interrupt is masked), so the INT line is
 * polled: Timer2 (CTC) interrupts every BOARD_CAN_POLL_US, shorter than one frame on the
 * bus, and only when INT is low does it read the part (with interrupts on: the encoders
 * never wait for SPI). Two receive buffers then always suffice: a frame waits at most one
 * poll period plus the read, less than the next two frames take. The crystal of the module
 * is BOARD_CAN_OSC_HZ (CMake option NAVKIT_AVR_MCP2515_OSC_HZ: the common blue module has
 * 8 MHz, some 16 MHz); docs/avr.md, CAN. ---- */
#ifndef BOARD_CAN_OSC_HZ
#define BOARD_CAN_OSC_HZ 8000000UL /* Hz: the MCP2515 module's crystal */
#endif
#define BOARD_CAN_SPI_PORT PORTB
#define BOARD_CAN_SPI_DDR DDRB
#define BOARD_CAN_CS_BIT 0   /* PB0, pin 53 */
#define BOARD_CAN_SCK_BIT 1  /* PB1, pin 52 */
#define BOARD_CAN_MOSI_BIT 2 /* PB2, pin 51 */
#define BOARD_CAN_MISO_BIT 3 /* PB3, pin 50 */
#define BOARD_CAN_SPI_PORT_NAME 'B'
#define BOARD_CAN_INT_PIN PINK
#define BOARD_CAN_INT_DDR DDRK
#define BOARD_CAN_INT_BIT 0 /* PK0, pin A8 */
#define BOARD_CAN_INT_PORT_NAME 'K'
#define BOARD_CAN_POLL_US 200u  /* us: INT poll period (Timer2); one 8-byte frame at 500 kbit/s: 222 us */
#define BOARD_CAN_RX_FRAMES 32u /* frames: the RX ring the poll fills (a power of two): ~7 ms of a full bus */
/* frames: the TX queue behind the part's TXB0 (a power of two): a whole micro_data and a
 * flow control fit (board_can.c checks) */
#define BOARD_CAN_TX_FRAMES 32u

/* ---- Control tick: Timer3 CTC, 0.5 us counts; the period is fw_tick_period_us() ---- */
#define BOARD_TICK_COUNTS_PER_US 2u

/* ---- Profiling marks in GPIOR0 (read by the board simulator): the value written at the
 * start of fw_tick() / fw_link_poll(), and 0 at their end. ---- */
#define BOARD_PROF_IDLE 0u
#define BOARD_PROF_TICK 1u
#define BOARD_PROF_POLL 2u

/* ---- Watchdog: interrupt + reset mode, 60 ms (64 ms nominal). A main loop stuck for
 * one period runs the watchdog interrupt (motors off, watchdog marker), the next period
 * resets the board. ---- */

/* ---- Reset-cause markers: 8 bytes at a fixed SRAM address that neither this image's
 * static data (below it; checked by the footprint test) nor any stack (above it) nor the
 * stk500v2 bootloader's own data (low) and stack (high) reach, so they survive every
 * reset that keeps SRAM powered. docs/avr.md, Reset cause. ---- */
#define BOARD_MARK_ADDR 0x1000u
#define BOARD_MARK_BYTES 8u

#endif /* NAVKIT_BOARD_H */
