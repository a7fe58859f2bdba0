/* board_twi.c: the TWI master state machine (board_twi.h). */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/twi.h>

#include "board.h"
#include "board_twi.h"

/* One register transfer: write `value` to `reg` (nread 0), or read nread bytes from reg on. */
typedef struct {
    uint8_t addr;  /* 7-bit part address */
    uint8_t reg;   /* first register */
    uint8_t value; /* byte to write (nread 0) */
    uint8_t nread; /* bytes to read, 0 = a write */
} twi_xfer_t;

#define TWI_X_WAKE 0u    /* gyro PWR_MGMT_1 = 0 */
#define TWI_X_RANGE 1u   /* gyro GYRO_CONFIG = 0 */
#define TWI_X_GYRO 2u    /* read GYRO_ZOUT_H/L */
#define TWI_X_COMPASS 3u /* read the bearing word */
#define TWI_X_COUNT 4u

static const twi_xfer_t twi_xfers[TWI_X_COUNT] = {
    { BOARD_GYRO_ADDR, BOARD_GYRO_REG_PWR_MGMT_1, 0x00u, 0u },
    { BOARD_GYRO_ADDR, BOARD_GYRO_REG_GYRO_CONFIG, 0x00u, 0u },
    { BOARD_GYRO_ADDR, BOARD_GYRO_REG_ZOUT_H, 0u, 2u },
    { BOARD_COMPASS_ADDR, BOARD_COMPASS_REG_BEARING, 0u, 2u },
};

#define TWI_GO (_BV(TWINT) | _BV(TWEN) | _BV(TWIE))

static volatile uint8_t twi_busy;     /* 1 while a round runs */
static uint8_t twi_gyro_awake;        /* 1 once the wake and range writes were acknowledged */
static uint8_t twi_x;                 /* transfer in progress */
static uint8_t twi_reading;           /* 1 after the repeated START of a read */
static uint8_t twi_sent;              /* master-transmitter bytes of this transfer sent and
                                         acknowledged: 1 SLA+W, 2 + register, 3 + value */
static uint8_t twi_n;                 /* bytes read so far */
static uint8_t twi_buf[2];
static volatile int16_t twi_gyro;     /* LSB */
static volatile uint16_t twi_compass; /* deg*10 */
static volatile uint16_t twi_err;

void board_twi_init(void)
{
    twi_busy = 0u;
    twi_gyro_awake = 0u;
    twi_gyro = 0;
    twi_compass = 0u;
    twi_err = 0u;
    TWSR = 0u; /* prescaler 1 */
    TWBR = BOARD_TWI_TWBR;
    TWCR = _BV(TWEN);
}

/* Begin transfer x with a START (a STOP first if `stop`), or end the round. */
static void twi_begin(uint8_t x, uint8_t stop)
{
    uint8_t cr = stop ? (uint8_t)(_BV(TWINT) | _BV(TWSTO) | _BV(TWEN)) : (uint8_t)_BV(TWEN);
    if (x >= TWI_X_COUNT) {
        TWCR = cr;
        twi_busy = 0u;
        return;
    }
    twi_x = x;
    twi_reading = 0u;
    twi_sent = 0u;
    twi_n = 0u;
    TWCR = (uint8_t)(cr | _BV(TWSTA) | _BV(TWIE));
}

void board_twi_round(void)
{
    uint8_t sreg = SREG;
    cli(); /* twi_busy is cleared by the TWI interrupt */
    if (!twi_busy) {
        twi_busy = 1u;
        twi_begin(twi_gyro_awake ? TWI_X_GYRO : TWI_X_WAKE, 0u);
    }
    SREG = sreg;
}

/* Transfer twi_x is complete (ok 1) or failed (ok 0): keep its result, go on. */
static void twi_done(uint8_t ok)
{
    uint8_t x = twi_x;
    if (!ok) {
        twi_err++;
        if (x <= TWI_X_RANGE) {
            twi_gyro_awake = 0u;
            x = TWI_X_RANGE; /* skip to the gyro read (it will fail too: retry next round) */
        }
    } else if (x == TWI_X_RANGE) {
        twi_gyro_awake = 1u;
    } else if (x == TWI_X_GYRO) {
        twi_gyro = (int16_t)(((uint16_t)twi_buf[0] << 8) | twi_buf[1]);
    } else if (x == TWI_X_COMPASS) {
        twi_compass = (uint16_t)(((uint16_t)twi_buf[0] << 8) | twi_buf[1]);
    }
    twi_begin((uint8_t)(x + 1u), 1u);
}

ISR(TWI_vect)
{
    const twi_xfer_t *x = &twi_xfers[twi_x];
    switch (TW_STATUS) {
    case TW_START:
    case TW_REP_START:
        TWDR = (uint8_t)((x->addr << 1) | (twi_reading ? TW_READ : TW_WRITE));
        TWCR = TWI_GO;
        break;
    case TW_MT_SLA_ACK:
    case TW_MT_DATA_ACK:
        /* which byte was acknowledged comes from our own count, not from telling these two
           codes apart (simavr 1.6 reports DATA_ACK for SLA+W too) */
        twi_sent++;
        if (twi_sent == 1u) {
            TWDR = x->reg;
            TWCR = TWI_GO;
        } else if (x->nread != 0u) {
            twi_reading = 1u;
            TWCR = (uint8_t)(TWI_GO | _BV(TWSTA));
        } else if (twi_sent == 2u) {
            TWDR = x->value;
            TWCR = TWI_GO;
        } else {
            twi_done(1u);
        }
        break;
    case TW_MR_SLA_ACK:
        TWCR = (uint8_t)(TWI_GO | ((x->nread > 1u) ? _BV(TWEA) : 0u));
        break;
    case TW_MR_DATA_ACK:
        twi_buf[twi_n++] = TWDR;
        TWCR = (uint8_t)(TWI_GO | (((uint8_t)(twi_n + 1u) < x->nread) ? _BV(TWEA) : 0u));
        break;
    case TW_MR_DATA_NACK:
        twi_buf[twi_n++] = TWDR;
        twi_done(1u);
        break;
    default: /* NACK, arbitration lost, bus error */
        twi_done(0u);
        break;
    }
}

int16_t board_twi_gyro(void)
{
    int16_t v;
    uint8_t s = SREG;
    cli();
    v = twi_gyro;
    SREG = s;
    return v;
}

uint16_t board_twi_compass(void)
{
    uint16_t v;
    uint8_t s = SREG;
    cli();
    v = twi_compass;
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
