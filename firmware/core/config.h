/* config: the three config messages, checked and turned into working units (prefix config_).
 *
 * At reset the spec defaults are loaded (so every value is sane) but no config counts
 * as received: the micro stays unconfigured until all three arrive. A message whose
 * spec_hash differs from NAVKIT_SPEC_HASH, or with a field out of range, is refused
 * whole and changes nothing.
 */
#ifndef NAVKIT_CONFIG_H
#define NAVKIT_CONFIG_H

#include <stdint.h>

#include "navkit/navkit_proto.h"
#include "odom.h"
#include "servo.h"
#include "wheel.h"

/* Re-plan window and "done" speed, at the wheel (the turn axis uses the same at the wheel). */
#define CONFIG_TRACK_WINDOW_MM 25.0f    /* mm: how far a reference may lead the wheels */
#define CONFIG_TRACK_VWINDOW_MM_S 50.0f /* mm/s: its speed lead when pulled back */
#define CONFIG_DONE_VTOL_MM_S 10.0f     /* mm/s: "stopped" for done */

/* Highest control_rate (Hz) this build accepts; a micro_cfg_geometry above it is refused
 * (CONFIG_ERR_RANGE) like one outside the spec's 100..2000. A target whose tick cannot
 * keep up sets its own with -DCONFIG_RATE_MAX=...: a 16 MHz AVR re-plans both axes every
 * tick in float at up to 400 Hz (docs/firmware.md, AVR budget). */
#ifndef CONFIG_RATE_MAX
#define CONFIG_RATE_MAX 2000u
#endif
#if CONFIG_RATE_MAX < 100 || CONFIG_RATE_MAX > 2000
#error "CONFIG_RATE_MAX must be within the spec's control_rate range, 100..2000 Hz"
#endif

/* One axis's re-plan window and "done" limits, in the axis's units u (mm or deg):
 * motion_tick() reads them through one pointer. */
typedef struct {
    float window;  /* u: how far the reference may lead the measurement */
    float vwindow; /* u/s: the reference's speed lead when pulled back */
    float tol;     /* u: "done" within this of the target */
    float vtol;    /* u/s: "done" at most this fast */
} config_track_t;
/* Result of config_*(). */
typedef enum {
    CONFIG_OK = 0,       /* applied */
    CONFIG_ERR_HASH = 1, /* spec_hash differs from the firmware's: refused */
    CONFIG_ERR_RANGE = 2 /* a field out of range, a spec constraint broken (a sign of 0, a servo_min above its
                             servo_max) or control_rate above CONFIG_RATE_MAX: refused */
} config_result_t;

typedef struct {
    /* geometry */
    odom_geom_t odom;         /* encoder geometry for odom_count() / odom_xy_step() */
    float mm_per_count;       /* mm per encoder count */
    float wheel_deg_per_mm;   /* deg of turn per mm one wheel runs ahead of the centre */
    float wheel_mm_per_deg;   /* its inverse, mm per deg */
    float turn_rate_per_mm_s; /* deg/s of turn per mm/s of left-minus-right wheel speed: wheel_deg_per_mm / 2 */
    float gyro_dps_per_lsb;   /* deg/s per LSB, gyro_sign folded in (clockwise positive) */
    float compass_gain;       /* 1/s: compass fusion gain, 0 = gyro only */
    float dt;                 /* s: control tick */
    float dt_fold;            /* s: period of the heading fold or compass fusion, odom.xy_ticks * dt (~10 ms) */
    uint32_t tick_us;         /* us: control tick, rounded */
    uint16_t tick_ms;         /* ms: whole milliseconds of tick_us */
    uint16_t tick_us_rem;     /* us: tick_us beyond tick_ms */
    uint16_t still_ticks;     /* ticks of quiet encoders that mean "standing still" (0.25 s) */
    uint16_t control_rate;    /* Hz */
    int8_t motor_left_sign;   /* +1/-1 */
    int8_t motor_right_sign;  /* +1/-1 */
    /* motion */
    float default_accel;      /* mm/s^2 */
    float default_speed;      /* mm/s */
    float default_turn_accel; /* deg/s^2 */
    float default_turn_rate;  /* deg/s */
    float max_speed;          /* mm/s */
    float max_turn_rate;      /* deg/s */
    float heading_kp;         /* (deg/s)/deg */
    float watchdog_decel;     /* mm/s^2 */
    float stop_tolerance;     /* mm */
    wheel_gains_t wheel;      /* wheel-speed loop gains */
    /* each axis's window, tolerance and "stopped" speed: forward (mm, mm/s), from motion;
       turn (deg, deg/s), the same at the wheel, from geometry and motion */
    config_track_t fwd_track;
    config_track_t turn_track;
    uint32_t watchdog_timeout_us; /* us: micro_cfg_motion's watchdog_timeout */
    /* io */
    uint16_t dio_direction;  /* bitmask, 1 = output */
    uint16_t dio_safe_state; /* bitmask */
    uint16_t sensor_enable;  /* NAVKIT_SENSOR_ENABLE_* bits */
    servo_cal_t servo[SERVO_COUNT];
    /* which messages arrived: NAVKIT_MICRO_STATUS_CFG_*_OK bits */
    uint16_t received;
} config_t;

/* Spec defaults (control_rate at most CONFIG_RATE_MAX), nothing received. */
void config_reset(config_t *c);
/* 1 when all three config messages have been applied since reset (inline: the tick asks
 * it every time). */
static inline uint8_t config_complete(const config_t *c)
{
    const uint16_t all = NAVKIT_MICRO_STATUS_CFG_GEOMETRY_OK | NAVKIT_MICRO_STATUS_CFG_MOTION_OK |
                         NAVKIT_MICRO_STATUS_CFG_IO_OK;
    return (uint8_t)((c->received & all) == all);
}
/* Apply micro_cfg_geometry (control_rate at most CONFIG_RATE_MAX). */
config_result_t config_geometry(config_t *c, const navkit_micro_cfg_geometry_t *m);
/* Apply micro_cfg_motion. */
config_result_t config_motion(config_t *c, const navkit_micro_cfg_motion_t *m);
/* Apply micro_cfg_io. */
config_result_t config_io(config_t *c, const navkit_micro_cfg_io_t *m);

#endif /* NAVKIT_CONFIG_H */
