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

uint8_t watchdog_tick(watchdog_t *w, uint32_t tick_us, uint16_t timeout_ms)
{
    if (w->tripped) {
        return 0u;
    }
    w->quiet_us += tick_us;
    if (w->quiet_us >= (uint32_t)timeout_ms * 1000ul) {
        w->tripped = 1u;
        return 1u;
    }
    return 0u;
}
