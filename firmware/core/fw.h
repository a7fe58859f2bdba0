/* fw: the firmware as one state struct (prefix fw_).
 *
 * Everything the firmware remembers is in fw_t: no file-level mutable state, so several
 * instances can live in one process (the FMU does exactly that). A target:
 *   fw_init(&fw, &hal);                       power-on / reset
 *   every fw_tick_period_us(&fw):  fw_link_poll(&fw); fw_tick(&fw);
 * (or, where a poll may take longer than a tick: the timer counts due ticks, the main loop
 * runs fw_tick() for each and fw_link_poll() when none is due; hal.h, ordering contract).
 * The tick rate comes from micro_cfg_geometry.control_rate (1 kHz by default, at most the
 * target's CONFIG_RATE_MAX, config.h: a 16 MHz AVR builds with 400 Hz) and may change when
 * that config arrives, so read fw_tick_period_us() before every tick.
 */
#ifndef NAVKIT_FW_H
#define NAVKIT_FW_H

#include <stdint.h>

#include "config.h"
#include "dio.h"
#include "excite.h"
#include "hal.h"
#include "heading.h"
#include "link.h"
#include "motion.h"
#include "odom.h"
#include "servo.h"
#include "turn.h"
#include "watchdog.h"
#include "wheel.h"

#define FW_VERSION 0x0100u /* major*256 + minor, reported in micro_data.fw_version */
/* ADC channels the board has: ch0-3 IR rangers, ch4 battery. micro_data.adc[5..7] (spare
   in the spec) report 0. */
#define FW_ADC_CHANNELS 5u

typedef struct fw {
    hal_t *hal;      /* the target's wires */
    config_t cfg;    /* working configuration */
    link_t link;     /* micro link */
    odom_t odom;     /* encoders and X/Y */
    heading_t hdg;   /* gyro heading */
    motion_t fwd;    /* forward axis, mm */
    turn_t turn;     /* turn axis, deg */
    wheel_t wheel_l; /* left wheel-speed loop */
    wheel_t wheel_r; /* right wheel-speed loop */
    servo_t servo[SERVO_COUNT];
    dio_t dio;
    watchdog_t wd;
    excite_t excite;               /* open-loop wheel excitation experiment (bypasses the wheel loops while active) */
    float speed_setpoint_l;        /* mm/s: left wheel speed setpoint of the last tick */
    float speed_setpoint_r;        /* mm/s: right wheel speed setpoint */
    int16_t duty_l;                /* duty*1e4, motor sign applied: left output of the last tick */
    int16_t duty_r;                /* duty*1e4, motor sign applied: right output */
    uint16_t adc[FW_ADC_CHANNELS]; /* counts: ADC sample of the last tick (0 if disabled) */
    uint16_t sonar[4];             /* us: sonar echoes of the last tick (0 if disabled) */
    uint16_t compass;              /* deg*10: compass of the last tick (0 if disabled) */
    int16_t gyro_raw;              /* LSB: gyro of the last tick */
    uint16_t watchdog_stops;       /* watchdog stops since reset */
    uint32_t ms;                   /* ms: uptime */
    uint16_t us_frac;              /* us: uptime below one ms */
    uint8_t wd_stop;               /* 1 from a watchdog stop until a new fwd/turn start */
    uint8_t reset_cause;           /* NAVKIT_RESET_CAUSE_*: why the board last started (hal_reset_cause()) */
    uint8_t limited;               /* 1 if the plant lagged or the output saturated on the last tick */
    uint8_t servo_next;            /* servo whose pulse width is refreshed next */
    uint16_t servo_held[SERVO_COUNT]; /* us: the pulse width each servo output holds (its last hal_servo_pulse()) */
    uint16_t dio_dir_held;            /* the DIO directions and levels the outputs hold (last hal_dio_write()) */
    uint16_t dio_out_held;
    uint8_t held;      /* 1 once a tick has written every output: then only changes are written */
    uint8_t slow_tick; /* tick within the slow period, 0..odom.xy_ticks-1: the heading fold runs on tick 0,
                            the X/Y step on another (fw.c) */
} fw_t;

/* Power-on reset: unconfigured, spec defaults loaded, all outputs off/safe. */
void fw_init(fw_t *fw, hal_t *hal);
/* Control tick period, us (from the configured control rate). */
uint32_t fw_tick_period_us(const fw_t *fw);
/* One control tick: inputs, estimation, motion, wheel loops, servos, outputs. */
void fw_tick(fw_t *fw);
/* Handle the link: call between ticks. */
void fw_link_poll(fw_t *fw);
/* 1 if fw_link_poll() should run again although the UART may be empty: the last poll
 * stopped at its frame bound (FW_LINK_FRAMES_PER_POLL, link.h) with bytes read but not yet
 * handled; always 0 without a bound. */
uint8_t fw_link_pending(const fw_t *fw);
/* A config of msg_type (NAVKIT_MSG_TYPE_MICRO_CFG_*) was just applied to fw->cfg; the
 * state built on it follows: micro_cfg_geometry (control_rate and odom.xy_ticks may have
 * changed): every servo keeps its speed in deg/s at the new rate, the slow period starts
 * again at its first tick; micro_cfg_io: the DIO takes its directions and safe levels, the
 * outputs go safe; micro_cfg_motion: nothing (the tick reads fw->cfg). */
void fw_config_applied(fw_t *fw, uint16_t msg_type);
/* micro_data.status bits (NAVKIT_MICRO_STATUS_*). */
uint16_t fw_status(const fw_t *fw);
/* Watchdog stop now: decelerate to rest, servos hold, DIO outputs safe, latch. */
void fw_watchdog_stop(fw_t *fw);
/* Measured distance (mm) from the forward reference (inline: the tick measures the axis
 * with it). */
static inline float fw_fwd_distance(const fw_t *fw)
{
    return motion_distance(&fw->fwd, &fw->odom, fw->cfg.mm_per_count);
}
/* Measured turn angle (deg, clockwise) from the turn reference (inline: the tick measures
 * the axis with it). */
static inline float fw_turn_angle(const fw_t *fw)
{
    return turn_angle(&fw->turn, &fw->odom, fw->cfg.odom.turn_deg_per_count);
}

#endif /* NAVKIT_FW_H */
