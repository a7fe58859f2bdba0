/* dio: the 12 discrete I/O bits. See dio.h. */
#include "dio.h"

void dio_reset(dio_t *d)
{
    d->dir = 0u;
    d->out = 0u;
    d->safe = 0u;
    d->in = 0u;
}

void dio_configure(dio_t *d, uint16_t dir, uint16_t safe)
{
    d->dir = (uint16_t)(dir & DIO_MASK);
    d->safe = (uint16_t)(safe & DIO_MASK);
    dio_safe(d);
}

void dio_command(dio_t *d, uint16_t cmd)
{
    d->out = (uint16_t)(cmd & d->dir);
}

void dio_safe(dio_t *d)
{
    d->out = (uint16_t)(d->safe & d->dir);
}

uint16_t dio_state(const dio_t *d)
{
    return (uint16_t)(((d->out & d->dir) | (d->in & (uint16_t)~d->dir)) & DIO_MASK);
}

void dio_micro_cmd(dio_t *d, const navkit_micro_cmd_t *c)
{
    dio_command(d, c->dio_command);
}
