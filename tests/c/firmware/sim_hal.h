/* sim_hal: a test implementation of hal.h with a simple differential-drive plant.
 * The plant: each wheel's speed follows duty * top_speed with a first-order lag, capped
 * at speed_cap (to model a robot that cannot reach the commanded speed); encoders
 * integrate the wheel travel; the gyro reads the yaw rate (CCW positive) plus a bias. */
#ifndef NAVKIT_SIM_HAL_H
#define NAVKIT_SIM_HAL_H

#include <stddef.h>
#include <stdint.h>

#include "fw.h"

#define SIM_UART_CAP 4096u
#define SIM_RAD_TO_DEG 57.29577951308232 /* deg per rad */

struct hal {
    /* inputs the firmware reads */
    double enc_l, enc_r; /* counts (continuous; read as whole counts) */
    int16_t gyro_bias;   /* LSB */
    uint16_t compass;    /* deg*10 */
    uint16_t adc[8];
    uint16_t sonar[4];
    uint16_t dio_in;
    /* outputs the firmware wrote */
    int16_t duty_l, duty_r; /* e4 */
    uint16_t servo_us[8];
    uint16_t dio_dir, dio_out;
    long servo_writes, dio_writes; /* hal_servo_pulse() and hal_dio_write() calls */
    /* UART: rx from the test to the firmware, tx from the firmware */
    uint8_t rx[SIM_UART_CAP];
    size_t rx_len, rx_pos;
    uint8_t tx[SIM_UART_CAP];
    size_t tx_len;
    /* plant */
    double v_l, v_r;     /* mm/s */
    double top_speed;    /* mm/s at duty 1 */
    double speed_cap;    /* mm/s: the plant's hard limit */
    double tau;          /* s: wheel lag */
    double mm_per_count; /* must match the config sent */
    double track_mm;
    double yaw_deg; /* ground-truth heading, clockwise */
    double dist_mm; /* ground-truth path length (signed) */
    double lsb_per_dps;
};

/* Plant at rest with the spec's default geometry. */
void sim_init(struct hal *h);
/* Queue bytes for the firmware's UART. */
void sim_send(struct hal *h, const uint8_t *data, size_t len);
/* The three config messages with the spec's defaults. */
void sim_cfg_defaults(navkit_micro_cfg_geometry_t *g, navkit_micro_cfg_motion_t *m, navkit_micro_cfg_io_t *io);
/* Send the three given config messages (their time tags set to 1..3). */
void sim_configure_with(fw_t *fw, struct hal *h, navkit_micro_cfg_geometry_t *g, navkit_micro_cfg_motion_t *m,
                        navkit_micro_cfg_io_t *io);
/* Send the three default config messages (time tags 1..3). */
void sim_configure(fw_t *fw, struct hal *h);
/* Send a micro_cmd and run the link once. */
void sim_cmd(fw_t *fw, struct hal *h, const navkit_micro_cmd_t *c);
/* Run n control ticks (link poll + tick + plant step). */
void sim_run(fw_t *fw, struct hal *h, long n);
/* A zeroed micro_cmd with the given time tag. */
void sim_cmd_init(navkit_micro_cmd_t *c, uint16_t tag);
/* Decode the last micro_data the firmware sent; returns 1 if there was one. */
int sim_last_data(struct hal *h, navkit_micro_data_t *d);

#endif
