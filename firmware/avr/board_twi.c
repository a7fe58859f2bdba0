/* board_twi.c: the TWI master, a table-driven interrupt (board_twi.h).
 *
 * A round is a fixed script of bus steps (twi_script). Each TWI interrupt checks that the
 * last step was acknowledged (a NACK, lost arbitration or bus error counts an error and
 * ends that part's transfer: STOP, then the next part's transfer or the round's end),
 * keeps the byte just received if the step was a read, and starts the next step. Short
 * and the same for every step: the encoder interrupts, which must not wait long, come
 * right behind it. The gyro's wake-up writes lead the script and are skipped once
 * acknowledged. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/twi.h>

#include "board.h"
#include "board_twi.h"

/* Script steps: what to do when the previous step is done. */
enum {
    TWI_OP_START, /* (repeated) START */
    TWI_OP_SEND,  /* send the byte `arg` (an SLA+R/W or a register/value) */
    TWI_OP_READ,  /* receive a byte into twi_raw[arg], acknowledge it (more follow) */
    TWI_OP_LAST,  /* receive the last byte into twi_raw[arg], no acknowledge */
    TWI_OP_AWAKE, /* the gyro's writes went through: STOP, START, and skip them from now */
    TWI_OP_NEXT,  /* STOP, then START the next part's transfer */
    TWI_OP_END    /* STOP: the round is over */
};

typedef struct {
    uint8_t op;   /* TWI_OP_* */
    uint8_t arg;  /* byte to send, or twi_raw index */
    uint8_t fail; /* after an error here: the step whose START goes next (TWI_FAIL_END: none) */
} twi_step_t;

#define TWI_SLA_W(a) ((uint8_t)(((a) << 1) | TW_WRITE))
#define TWI_SLA_R(a) ((uint8_t)(((a) << 1) | TW_READ))
#define TWI_READS 4u     /* gyro ZOUT H/L, compass bearing H/L */
#define TWI_READ_FROM 9u /* index of the reads' START (after the wake-up writes) */
#define TWI_COMPASS 16u  /* index of the compass transfer's START (a TWI_OP_NEXT) */
#define TWI_FAIL_END 0xFFu

/* Each entry is the step the bus does next; the interrupt that follows finishes it. */
static const twi_step_t twi_script[] = {
    /* wake the gyro (PWR_MGMT_1 = 0), then its range (GYRO_CONFIG = 0: 131 LSB per deg/s) */
    {TWI_OP_START, 0u, TWI_COMPASS},
    {TWI_OP_SEND, TWI_SLA_W(BOARD_GYRO_ADDR), TWI_COMPASS},
    {TWI_OP_SEND, BOARD_GYRO_REG_PWR_MGMT_1, TWI_COMPASS},
    {TWI_OP_SEND, 0x00u, TWI_COMPASS},
    {TWI_OP_NEXT, 0u, TWI_COMPASS},
    {TWI_OP_SEND, TWI_SLA_W(BOARD_GYRO_ADDR), TWI_COMPASS},
    {TWI_OP_SEND, BOARD_GYRO_REG_GYRO_CONFIG, TWI_COMPASS},
    {TWI_OP_SEND, 0x00u, TWI_COMPASS},
    {TWI_OP_AWAKE, 0u, TWI_COMPASS}, /* its START counts as the reads' first step */
    /* TWI_READ_FROM: the gyro's GYRO_ZOUT_H/L */
    {TWI_OP_START, 0u, TWI_COMPASS},
    {TWI_OP_SEND, TWI_SLA_W(BOARD_GYRO_ADDR), TWI_COMPASS},
    {TWI_OP_SEND, BOARD_GYRO_REG_ZOUT_H, TWI_COMPASS},
    {TWI_OP_START, 0u, TWI_COMPASS},
    {TWI_OP_SEND, TWI_SLA_R(BOARD_GYRO_ADDR), TWI_COMPASS},
    {TWI_OP_READ, 0u, TWI_COMPASS},
    {TWI_OP_LAST, 1u, TWI_COMPASS},
    /* TWI_COMPASS: the compass's bearing word */
    {TWI_OP_NEXT, 0u, TWI_FAIL_END},
    {TWI_OP_SEND, TWI_SLA_W(BOARD_COMPASS_ADDR), TWI_FAIL_END},
    {TWI_OP_SEND, BOARD_COMPASS_REG_BEARING, TWI_FAIL_END},
    {TWI_OP_START, 0u, TWI_FAIL_END},
    {TWI_OP_SEND, TWI_SLA_R(BOARD_COMPASS_ADDR), TWI_FAIL_END},
    {TWI_OP_READ, 2u, TWI_FAIL_END},
    {TWI_OP_LAST, 3u, TWI_FAIL_END},
    {TWI_OP_END, 0u, TWI_FAIL_END},
};

#define TWI_GO (_BV(TWINT) | _BV(TWEN) | _BV(TWIE))

static volatile uint8_t twi_busy;           /* 1 while a round runs */
static volatile uint8_t twi_gyro_awake;     /* 1 once the wake-up writes were acknowledged */
static uint8_t twi_step;                    /* index of the step in progress */
static volatile uint8_t twi_raw[TWI_READS]; /* bytes read, big-endian pairs */
static volatile uint16_t twi_err;

void board_twi_init(void)
{
    uint8_t i;
    twi_busy = 0u;
    twi_gyro_awake = 0u;
    twi_err = 0u;
    for (i = 0u; i < TWI_READS; i++) {
        twi_raw[i] = 0u;
    }
    TWSR = 0u; /* prescaler 1 */
    TWBR = BOARD_TWI_TWBR;
    TWCR = _BV(TWEN);
}

void board_twi_round(void)
{
    uint8_t sreg = SREG;
    cli(); /* twi_busy is cleared by the TWI interrupt */
    if (!twi_busy) {
        twi_busy = 1u;
        twi_step = twi_gyro_awake ? TWI_READ_FROM : 0u;
        TWCR = (uint8_t)(TWI_GO | _BV(TWSTA));
    }
    SREG = sreg;
}

ISR(TWI_vect)
{
    uint8_t st = TW_STATUS;
    const twi_step_t *s = &twi_script[twi_step];
    /* the step in progress went through? (START, acknowledged SLA/data, a received byte) */
    if (!(st == TW_START || st == TW_REP_START || st == TW_MT_SLA_ACK || st == TW_MT_DATA_ACK || st == TW_MR_SLA_ACK ||
          st == TW_MR_DATA_ACK || st == TW_MR_DATA_NACK)) {
        twi_err++;
        if (twi_step < TWI_READ_FROM) {
            twi_gyro_awake = 0u; /* its wake-up writes again next round */
        }
        twi_step = s->fail;
        if (twi_step == TWI_FAIL_END) {
            TWCR = (uint8_t)(_BV(TWINT) | _BV(TWSTO) | _BV(TWEN));
            twi_busy = 0u;
        } else {
            TWCR = (uint8_t)(TWI_GO | _BV(TWSTO) | _BV(TWSTA));
        }
        return;
    }
    if (s->op == TWI_OP_READ || s->op == TWI_OP_LAST) {
        twi_raw[s->arg] = TWDR;
    }
    twi_step++;
    s++;
    switch (s->op) {
    case TWI_OP_START:
        TWCR = (uint8_t)(TWI_GO | _BV(TWSTA));
        break;
    case TWI_OP_SEND:
        TWDR = s->arg;
        TWCR = TWI_GO;
        break;
    case TWI_OP_READ:
        TWCR = (uint8_t)(TWI_GO | _BV(TWEA));
        break;
    case TWI_OP_LAST:
        TWCR = TWI_GO;
        break;
    case TWI_OP_AWAKE:
        twi_gyro_awake = 1u;
        twi_step = TWI_READ_FROM;
        TWCR = (uint8_t)(TWI_GO | _BV(TWSTO) | _BV(TWSTA));
        break;
    case TWI_OP_NEXT:
        TWCR = (uint8_t)(TWI_GO | _BV(TWSTO) | _BV(TWSTA));
        break;
    default: /* TWI_OP_END */
        TWCR = (uint8_t)(_BV(TWINT) | _BV(TWSTO) | _BV(TWEN));
        twi_busy = 0u;
        break;
    }
}

int16_t board_twi_gyro(void)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = (uint16_t)(((uint16_t)twi_raw[0] << 8) | twi_raw[1]);
    SREG = s;
    return (int16_t)v;
}

uint16_t board_twi_compass(void)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = (uint16_t)(((uint16_t)twi_raw[2] << 8) | twi_raw[3]);
    SREG = s;
    return v;
}

uint16_t board_twi_errors(void)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = twi_err;
    SREG = s;
    return v;
}
