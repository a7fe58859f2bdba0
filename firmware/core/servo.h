/* servo: RC servo GoTo and Scan (prefix servo_).
 *
 * Angles are deg*10, + clockwise (right). GoTo (param2 = 9999) moves to param1 at rate
 * param0; Scan moves back and forth between param1 (right limit) and param2 (left limit)
 * at rate param0, going to param1 first. param0 = 0 means no command. Every angle is
 * clamped to the servo's calibrated travel [min, max]. A servo is not driven (pulse 0)
 * until its first command, and starts from 0 deg.
 *
 * Cost on a small micro: stepping is integer adds (position in deg*10 * 1024); the pulse
 * width (one 32-bit division) is refreshed by servo_update_pulse(), which the firmware
 * calls for one servo per tick in turn (an RC servo only samples it every 20 ms).
 */
#ifndef NAVKIT_SERVO_H
#define NAVKIT_SERVO_H

#include <stdint.h>

#include "navkit/navkit_proto.h"

#define SERVO_COUNT 8u
#define SERVO_GOTO_FLAG NAVKIT_SERVO_GOTO_GOTO_FLAG /* param2 value that selects GoTo (9999) */
#define SERVO_Q 1024L                               /* position units per deg*10 */

typedef enum {
    SERVO_OFF = 0,  /* not driven */
    SERVO_HOLD = 1, /* driven, standing at pos */
    SERVO_GOTO = 2, /* moving to goal, then HOLD */
    SERVO_SCAN = 3  /* moving between left and right */
} servo_mode_t;

typedef struct {
    uint16_t center_us;     /* us: pulse at 0 deg */
    uint16_t us_per_deg_e2; /* 0.01 us/deg: pulse change per deg, + clockwise */
    int16_t min10;          /* deg*10: left travel limit */
    int16_t max10;          /* deg*10: right travel limit */
} servo_cal_t;

typedef struct {
    int32_t pos;    /* deg*10 * SERVO_Q: position */
    int32_t step;   /* deg*10 * SERVO_Q per tick: speed */
    int16_t goal;   /* deg*10: where it is moving now */
    int16_t right;  /* deg*10: scan right limit (param1) */
    int16_t left;   /* deg*10: scan left limit (param2) */
    uint16_t rate;  /* deg*10/s: commanded rate */
    uint16_t pulse; /* us: pulse width as last refreshed, 0 while not driven (mode SERVO_OFF) */
    uint8_t mode;   /* servo_mode_t */
} servo_t;

/* Not driven, at 0 deg. */
void servo_reset(servo_t *s);
/* Apply one command: p0 rate (deg*10/s; 0 or less = no command, nothing changes);
 * p1 (deg*10): the GoTo goal, or the Scan right limit; p2 (deg*10): the Scan left limit,
 * or SERVO_GOTO_FLAG (9999) for GoTo; rate_hz (Hz) is the control tick rate. */
void servo_command(servo_t *s, const servo_cal_t *cal, int16_t p0, int16_t p1, int16_t p2, uint16_t rate_hz);
/* The servos' part of a checked micro_cmd c: servo i (0..SERVO_COUNT-1, s[i] with
 * calibration cal[i]) takes rc<i>_param0..2 as servo_command() does; rate_hz (Hz) is the
 * control tick rate. */
void servo_micro_cmd(servo_t s[SERVO_COUNT], const servo_cal_t cal[SERVO_COUNT], const navkit_micro_cmd_t *c,
                     uint16_t rate_hz);
/* The control tick rate changed to rate_hz (Hz): keep the speed in deg/s. */
void servo_retime(servo_t *s, uint16_t rate_hz);
/* Stop where it is (watchdog); a servo not yet driven stays off. */
void servo_hold(servo_t *s);
/* 1 while the servo moves (GoTo or Scan): only then does servo_step() change it, so the
 * tick asks this first (inline) and steps only moving servos. */
static inline uint8_t servo_moving(const servo_t *s)
{
    return (uint8_t)(s->mode == SERVO_GOTO || s->mode == SERVO_SCAN);
}
/* One tick: move toward the goal (integer only); nothing unless servo_moving(). */
void servo_step(servo_t *s, const servo_cal_t *cal);
/* Recompute the pulse width from the position and calibration; a servo not driven keeps
 * pulse 0. */
void servo_update_pulse(servo_t *s, const servo_cal_t *cal);
/* Position, deg*10 (rounded). */
int16_t servo_pos10(const servo_t *s);
/* Pulse width, us, as last refreshed; 0 when not driven (inline: the tick reads all
 * eight every time). */
static inline uint16_t servo_pulse_us(const servo_t *s)
{
    return s->pulse; /* 0 while mode is SERVO_OFF: servo_reset() and servo_update_pulse() keep it so */
}

#endif /* NAVKIT_SERVO_H */
