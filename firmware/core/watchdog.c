/* watchdog: the link-silence watchdog. See watchdog.h. */
#include "watchdog.h"

void watchdog_reset(watchdog_t *w)
{
    w->quiet_us = 0u;
    w->tripped = 0u;
}

void watchdog_feed(watchdog_t *w)
{
    w->quiet_us = 0u;
    w->tripped = 0u;
}
