/* watchdog: the link-silence watchdog (prefix watchdog_). */
#ifndef NAVKIT_WATCHDOG_H
#define NAVKIT_WATCHDOG_H

#include <stdint.h>

typedef struct {
    uint32_t quiet_us; /* us since the last valid message */
    uint8_t tripped;   /* 1 after a trip, until the next valid message */
} watchdog_t;

/* Quiet time zero, not tripped. */
void watchdog_reset(watchdog_t *w);
/* A valid message arrived: quiet time zero, re-armed. */
void watchdog_feed(watchdog_t *w);
/* One tick of tick_us (us) with timeout_us (us); returns 1 on the tick it trips (once per
 * silence), else 0. Inline: the tick's one call. */
static inline uint8_t watchdog_tick(watchdog_t *w, uint32_t tick_us, uint32_t timeout_us)
{
    if (w->tripped) {
        return 0u;
    }
    w->quiet_us += tick_us;
    if (w->quiet_us >= timeout_us) {
        w->tripped = 1u;
        return 1u;
    }
    return 0u;
}

#endif /* NAVKIT_WATCHDOG_H */
