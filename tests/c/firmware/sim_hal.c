/* sim_hal: see sim_hal.h. */
#include "sim_hal.h"

#include <math.h>
#include <string.h>

void sim_init(struct hal *h)
{
    memset(h, 0, sizeof *h);
    h->top_speed = 1.0 / 0.0018; /* matches the default feed-forward */
    h->speed_cap = 1e9;
    h->tau = 0.03;
    h->mm_per_count = 3.14159265358979 * 100.0 / 2000.0;
    h->track_mm = 300.0;
    h->lsb_per_dps = 131.0;
}

int32_t hal_enc_left(hal_t *h)
{
    return (int32_t)floor(h->enc_l);
}
int32_t hal_enc_right(hal_t *h)
{
    return (int32_t)floor(h->enc_r);
}
int16_t hal_gyro_raw(hal_t *h)
{
    /* the plant's yaw rate (clockwise) as a CCW-positive reading */
    double w_cw = (h->v_l - h->v_r) / h->track_mm * SIM_RAD_TO_DEG;
    return (int16_t)lround(-w_cw * h->lsb_per_dps) + h->gyro_bias;
}
uint16_t hal_compass(hal_t *h)
{
    return h->compass;
}
uint16_t hal_adc(hal_t *h, uint8_t ch)
{
    return h->adc[ch];
}
uint16_t hal_sonar_echo(hal_t *h, uint8_t i)
{
    return h->sonar[i];
}
uint16_t hal_dio_in(hal_t *h)
{
    return h->dio_in;
}
uint8_t hal_reset_cause(hal_t *h)
{
    (void)h;
    return NAVKIT_RESET_CAUSE_POWER_ON;
}
void hal_motor(hal_t *h, int16_t l, int16_t r)
{
    h->duty_l = l;
    h->duty_r = r;
}
void hal_servo_pulse(hal_t *h, uint8_t i, uint16_t us)
{
    h->servo_us[i] = us;
    h->servo_writes++;
}
void hal_dio_write(hal_t *h, uint16_t dir, uint16_t out)
{
    h->dio_dir = dir;
    h->dio_out = out;
    h->dio_writes++;
}
size_t hal_uart_read(hal_t *h, uint8_t *buf, size_t cap)
{
    size_t n = h->rx_len - h->rx_pos;
    if (n > cap) {
        n = cap;
    }
    memcpy(buf, h->rx + h->rx_pos, n);
    h->rx_pos += n;
    if (h->rx_pos == h->rx_len) {
        h->rx_pos = h->rx_len = 0;
    }
    return n;
}
size_t hal_uart_tx_free(hal_t *h)
{
    return SIM_UART_CAP - h->tx_len;
}
void hal_uart_write(hal_t *h, const uint8_t *buf, size_t len)
{
    memcpy(h->tx + h->tx_len, buf, len);
    h->tx_len += len;
}

void sim_send(struct hal *h, const uint8_t *data, size_t len)
{
    memcpy(h->rx + h->rx_len, data, len);
    h->rx_len += len;
}

void sim_configure_with(fw_t *fw, struct hal *h, navkit_micro_cfg_geometry_t *g, navkit_micro_cfg_motion_t *m,
                        navkit_micro_cfg_io_t *io)
{
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    h->tx_len = 0;
    g->time_tag = 1;
    m->time_tag = 2;
    io->time_tag = 3;
    sim_send(h, buf, navkit_micro_cfg_geometry_encode(g, buf, sizeof buf));
    sim_send(h, buf, navkit_micro_cfg_motion_encode(m, buf, sizeof buf));
    sim_send(h, buf, navkit_micro_cfg_io_encode(io, buf, sizeof buf));
    fw_link_poll(fw);
}

void sim_cfg_defaults(navkit_micro_cfg_geometry_t *g, navkit_micro_cfg_motion_t *m, navkit_micro_cfg_io_t *io)
{
    navkit_micro_cfg_geometry_defaults(g);
    navkit_micro_cfg_motion_defaults(m);
    navkit_micro_cfg_io_defaults(io);
}

void sim_configure(fw_t *fw, struct hal *h)
{
    navkit_micro_cfg_geometry_t g;
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_io_t io;
    sim_cfg_defaults(&g, &m, &io);
    sim_configure_with(fw, h, &g, &m, &io);
}

void sim_cmd_init(navkit_micro_cmd_t *c, uint16_t tag)
{
    memset(c, 0, sizeof *c);
    c->msg_type = NAVKIT_MSG_TYPE_MICRO_CMD;
    c->time_tag = tag;
}

void sim_cmd(fw_t *fw, struct hal *h, const navkit_micro_cmd_t *c)
{
    uint8_t buf[NAVKIT_MAX_FRAME_BYTES];
    h->tx_len = 0;
    sim_send(h, buf, navkit_micro_cmd_encode(c, buf, sizeof buf));
    fw_link_poll(fw);
}

static void sim_wheel(double *v, int16_t duty_e4, const struct hal *h, double dt)
{
    double goal = (double)duty_e4 / 10000.0 * h->top_speed;
    if (goal > h->speed_cap) {
        goal = h->speed_cap;
    } else if (goal < -h->speed_cap) {
        goal = -h->speed_cap;
    }
    *v += (goal - *v) * dt / (h->tau + dt);
}

void sim_run(fw_t *fw, struct hal *h, long n)
{
    long i;
    for (i = 0; i < n; i++) {
        double dt = (double)fw_tick_period_us(fw) * 1e-6;
        fw_link_poll(fw);
        fw_tick(fw);
        sim_wheel(&h->v_l, h->duty_l, h, dt);
        sim_wheel(&h->v_r, h->duty_r, h, dt);
        h->enc_l += h->v_l * dt / h->mm_per_count;
        h->enc_r += h->v_r * dt / h->mm_per_count;
        h->yaw_deg += (h->v_l - h->v_r) / h->track_mm * SIM_RAD_TO_DEG * dt;
        h->dist_mm += 0.5 * (h->v_l + h->v_r) * dt;
    }
}

int sim_last_data(struct hal *h, navkit_micro_data_t *d)
{
    size_t n = NAVKIT_MICRO_DATA_BYTES;
    if (h->tx_len < n) {
        return 0;
    }
    return navkit_micro_data_decode(h->tx + h->tx_len - n, n, d) == NAVKIT_OK;
}
