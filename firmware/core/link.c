/* link: the micro link. See link.h. */
#include "link.h"

#include <stddef.h>

#include "fw.h"

void link_reset(link_t *l)
{
    navkit_parser_init(&l->parser, NAVKIT_DIR_TO_MICRO);
    l->last_tag = 0u;
    l->ack_tag = 0u;
    l->tx_tag = 0u;
    l->schema_mismatch = 0u;
    l->cmd_rejected = 0u;
    l->last_reject = 0u;
    l->mc_datalog = NAVKIT_MC_DATALOG_NONE;
    l->have_tag = 0u;
    l->tag_pending = 0u;
    l->more = 0u;
    l->reply_due = 0u;
#if FW_LINK_CAN
    navkit_isotp_rx_init(&l->can_rx, NAVKIT_DIR_TO_MICRO);
    navkit_isotp_tx_init(&l->can_tx);
#endif
}

static void link_reject(link_t *l, uint16_t code)
{
    l->cmd_rejected++;
    l->last_reject = code;
}

/* An axis command's result: 1 for a start; a modify (code 3) that found nothing to
   modify is refused; one after a stop latch is ignored without counting (the latch shows
   in micro_data.status). */
static uint8_t link_axis_result(link_t *l, motion_result_t r, uint16_t code)
{
    switch (r) {
    case MOTION_STARTED:
        return 1u;
    case MOTION_NOT_STARTED:
        link_reject(l, code);
        break;
    case MOTION_LATCHED: /* ignored: fwd/turn_stop_latched says why */
    case MOTION_OK:
    default:
        break;
    }
    return 0u;
}

static uint8_t link_fwd_code_ok(uint16_t code)
{
    return (uint8_t)(code == NAVKIT_FWD_CMD_NONE || code == NAVKIT_FWD_CMD_START || code == NAVKIT_FWD_CMD_MODIFY ||
                     code == NAVKIT_FWD_CMD_STOP);
}

static uint8_t link_turn_code_ok(uint16_t code)
{
    return (uint8_t)(code == NAVKIT_TURN_CMD_NONE || code == NAVKIT_TURN_CMD_TURN || code == NAVKIT_TURN_CMD_MODIFY ||
                     code == NAVKIT_TURN_CMD_STOP || code == NAVKIT_TURN_CMD_HDG_SEL);
}

/* Reject code for a micro_cmd whose content is refused, or 0 if it may run. */
static uint16_t link_cmd_check(const navkit_micro_cmd_t *c)
{
    if (!link_fwd_code_ok(c->fwd_cmd)) {
        return c->fwd_cmd;
    }
    if (!link_turn_code_ok(c->turn_cmd)) {
        return c->turn_cmd;
    }
    if (c->turn_cmd == NAVKIT_TURN_CMD_HDG_SEL && (c->turn_distance < -3600 || c->turn_distance > 3600)) {
        return c->turn_cmd; /* HdgSel takes a heading of -360..360 deg */
    }
    if (navkit_micro_cmd_check(c, 0) != NAVKIT_OK || excite_refused(c)) {
        return (uint16_t)(NAVKIT_REJECT_RANGE | NAVKIT_MSG_TYPE_MICRO_CMD);
    }
    return 0u;
}

/* Execute a checked micro_cmd on a configured micro: each module takes its part (in this
   order: dg_control's heading and X/Y set before a HdgSel reads the heading); a start of
   either axis or of an experiment ends a watchdog stop. */
static void link_cmd_run(fw_t *fw, const navkit_micro_cmd_t *c)
{
    link_t *l = &fw->link;
    uint8_t started;
    l->ack_tag = c->time_tag;
    heading_micro_cmd(&fw->hdg, c);
    odom_micro_cmd(&fw->odom, c);
    started = link_axis_result(l, motion_micro_cmd(&fw->fwd, c, &fw->odom, &fw->cfg), c->fwd_cmd);
    started |= link_axis_result(l, turn_micro_cmd(&fw->turn, c, &fw->odom, &fw->hdg, &fw->cfg), c->turn_cmd);
    started |= excite_micro_cmd(&fw->excite, c, fw->cfg.control_rate);
    if (started) {
        fw->wd_stop = 0u;
    }
    dio_micro_cmd(&fw->dio, c);
    servo_micro_cmd(fw->servo, fw->cfg.servo, c, fw->cfg.control_rate);
    l->mc_datalog = c->mc_datalog_cmd;
}

/* Reject code of a checked micro_cmd refused because the micro is unconfigured: its
   fwd_cmd, else its turn_cmd, else reject.unconfigured | msg_type (spec flags reject). */
static uint16_t link_unconfigured_code(const navkit_micro_cmd_t *c)
{
    if (c->fwd_cmd != NAVKIT_FWD_CMD_NONE) {
        return c->fwd_cmd;
    }
    if (c->turn_cmd != NAVKIT_TURN_CMD_NONE) {
        return c->turn_cmd;
    }
    return (uint16_t)(NAVKIT_REJECT_UNCONFIGURED | NAVKIT_MSG_TYPE_MICRO_CMD);
}

/* One decoded micro_cmd: the time-tag rules (docs/firmware.md "Time tags"), then run,
   refuse, or keep pending. Only a command refused for want of the configs is ever
   pending, so a command that ran never runs again on a repeated tag. */
static void link_cmd(fw_t *fw, const navkit_micro_cmd_t *c)
{
    link_t *l = &fw->link;
    uint16_t code;
    uint8_t first = (uint8_t)!l->have_tag;
    if (!first && c->time_tag == l->last_tag) {
        /* a repeat: handled already, unless it waited only for the configs; then it is
           handled once, as it comes now (the same tag may carry changed content): checked
           like a new command and refused if that fails, else run unless a watchdog stop
           since the configs drops it (a repeat never resumes motion) */
        if (l->tag_pending && config_complete(&fw->cfg)) {
            l->tag_pending = 0u;
            code = link_cmd_check(c);
            if (code != 0u) {
                link_reject(l, code);
            } else if (!fw->wd_stop) {
                link_cmd_run(fw, c);
            }
        }
        return;
    }
    l->have_tag = 1u;
    l->last_tag = c->time_tag;
    l->tag_pending = 0u;
    code = link_cmd_check(c);
    if (code == 0u && !config_complete(&fw->cfg)) {
        /* every micro_cmd is refused whole while unconfigured (servos, DIO, dg_control
           and the datalog selection too); its repeat runs once the configs are in, except
           the first command after a reset, which may be the host repeating what the micro
           ran before it reset (a stale command must never run again) */
        code = link_unconfigured_code(c);
        l->tag_pending = (uint8_t)!first;
    }
    if (code != 0u) {
        link_reject(l, code);
        return;
    }
    link_cmd_run(fw, c);
}

/* A config's result r: applied (the modules take what changed: fw_config_applied()), or
   refused and counted. */
static void link_cfg(fw_t *fw, config_result_t r, uint16_t msg_type)
{
    if (r == CONFIG_OK) {
        fw_config_applied(fw, msg_type);
    } else if (r == CONFIG_ERR_HASH) {
        fw->link.schema_mismatch++;
    } else if (r == CONFIG_ERR_RANGE) {
        link_reject(&fw->link, (uint16_t)(NAVKIT_REJECT_RANGE | msg_type));
    }
}

/* Handle one valid frame; returns 1 if it decoded (and deserves a reply). */
static uint8_t link_frame(fw_t *fw, const uint8_t *frame, size_t len)
{
    uint16_t type = navkit_frame_type(frame);
    union {
        navkit_micro_cmd_t cmd;
        navkit_micro_cfg_geometry_t geo;
        navkit_micro_cfg_motion_t mot;
        navkit_micro_cfg_io_t io;
    } m;
    switch (type) {
    case NAVKIT_MSG_TYPE_MICRO_CMD:
        if (navkit_micro_cmd_decode(frame, len, &m.cmd) != NAVKIT_OK) {
            return 0u;
        }
        link_cmd(fw, &m.cmd);
        break;
    case NAVKIT_MSG_TYPE_MICRO_CFG_GEOMETRY:
        if (navkit_micro_cfg_geometry_decode(frame, len, &m.geo) != NAVKIT_OK) {
            return 0u;
        }
        link_cfg(fw, config_geometry(&fw->cfg, &m.geo), type);
        break;
    case NAVKIT_MSG_TYPE_MICRO_CFG_MOTION:
        if (navkit_micro_cfg_motion_decode(frame, len, &m.mot) != NAVKIT_OK) {
            return 0u;
        }
        link_cfg(fw, config_motion(&fw->cfg, &m.mot), type);
        break;
    case NAVKIT_MSG_TYPE_MICRO_CFG_IO:
        if (navkit_micro_cfg_io_decode(frame, len, &m.io) != NAVKIT_OK) {
            return 0u;
        }
        link_cfg(fw, config_io(&fw->cfg, &m.io), type);
        break;
    default:
        return 0u;
    }
    watchdog_feed(&fw->wd);
    return 1u;
}

static int16_t link_clamp16(float v)
{
    if (v > 32767.0f) {
        return 32767;
    }
    if (v < -32768.0f) {
        return -32768;
    }
    return (int16_t)((v >= 0.0f) ? v + 0.5f : v - 0.5f);
}

static int32_t link_round32(float v)
{
    return (int32_t)((v >= 0.0f) ? v + 0.5f : v - 0.5f);
}

/* mc_datalog words for the selection. */
static void link_datalog(const fw_t *fw, int16_t w[4])
{
    const motion_t *ax = &fw->turn.ax;
    uint8_t i;
    for (i = 0u; i < 4u; i++) {
        w[i] = 0;
    }
    switch (fw->link.mc_datalog) {
    case NAVKIT_MC_DATALOG_WHEEL_LEFT: /* setpoint mm/s, speed mm/s, duty e4, integral e4 */
        w[0] = link_clamp16(fw->speed_setpoint_l);
        w[1] = link_clamp16(fw->odom.v_l);
        w[2] = link_clamp16(fw->wheel_l.duty * 10000.0f);
        w[3] = link_clamp16(fw->wheel_l.integ * 10000.0f);
        break;
    case NAVKIT_MC_DATALOG_WHEEL_RIGHT:
        w[0] = link_clamp16(fw->speed_setpoint_r);
        w[1] = link_clamp16(fw->odom.v_r);
        w[2] = link_clamp16(fw->wheel_r.duty * 10000.0f);
        w[3] = link_clamp16(fw->wheel_r.integ * 10000.0f);
        break;
    case NAVKIT_MC_DATALOG_FWD_PROFILE: /* ref mm/s, ref to-go mm, measured to-go mm, flags */
        w[0] = link_clamp16(fw->fwd.prof.vel);
        w[1] = link_clamp16(fw->fwd.prof.togo);
        w[2] = link_clamp16(fw->fwd.target - fw_fwd_distance(fw));
        w[3] = (int16_t)(fw->fwd.prof.moving | (fw->fwd.done << 1) | (fw->fwd.latched << 2) | (fw->fwd.limited << 3));
        break;
    case NAVKIT_MC_DATALOG_TURN_PROFILE: /* ref deg*10/s, ref to-go deg*10, measured to-go deg*10, flags */
        w[0] = link_clamp16(ax->prof.vel * 10.0f);
        w[1] = link_clamp16(ax->prof.togo * 10.0f);
        w[2] = link_clamp16((ax->target - fw_turn_angle(fw)) * 10.0f);
        w[3] = (int16_t)(ax->prof.moving | (ax->done << 1) | (ax->latched << 2) | (ax->limited << 3) |
                         (fw->turn.hdg << 4));
        break;
    case NAVKIT_MC_DATALOG_HEADING: /* heading deg*10, rate deg*10/s, bias LSB*10, compass error deg*10 */
        w[0] = (int16_t)heading_deg10(&fw->hdg);
        w[1] = link_clamp16(fw->hdg.rate * 10.0f);
        w[2] = link_clamp16(fw->hdg.bias * 10.0f);
        w[3] = link_clamp16(heading_wrap180(0.1f * (float)fw->compass - heading_deg(&fw->hdg)) * 10.0f);
        break;
    case NAVKIT_MC_DATALOG_WHEELS: /* duty e4 and speed mm/s of the left, then the right wheel */
        w[0] = link_clamp16(fw->wheel_l.duty * 10000.0f);
        w[1] = link_clamp16(fw->odom.v_l);
        w[2] = link_clamp16(fw->wheel_r.duty * 10000.0f);
        w[3] = link_clamp16(fw->odom.v_r);
        break;
    default: /* NAVKIT_MC_DATALOG_NONE */
        break;
    }
}

void link_telemetry(const fw_t *fw, navkit_micro_data_t *d)
{
    const link_t *l = &fw->link;
    const navkit_link_stats_t *st = &l->parser.stats;
    uint8_t i;
    navkit_micro_data_defaults(d);
    d->time_tag = l->tx_tag;
    d->ack_time_tag = l->ack_tag;
    d->status = fw_status(fw);
    d->fw_version = FW_VERSION;
    d->spec_hash = NAVKIT_SPEC_HASH;
    d->micro_time = fw->ms;
    d->enc_left = fw->odom.enc_l;
    d->enc_right = fw->odom.enc_r;
    d->distance = link_round32(fw_fwd_distance(fw));
    d->fwd_speed = link_clamp16(0.5f * (fw->odom.v_l + fw->odom.v_r));
    d->turn_progress = link_round32(fw_turn_angle(fw) * 10.0f);
    d->heading = heading_deg10(&fw->hdg);
    d->yaw_rate = link_clamp16(fw->hdg.rate * 10.0f);
    d->x = fw->odom.x;
    d->y = fw->odom.y;
    for (i = 0u; i < FW_ADC_CHANNELS; i++) {
        d->adc[i] = fw->adc[i]; /* the spare ch5-7 stay 0 (defaults) */
    }
    for (i = 0u; i < SERVO_COUNT; i++) {
        d->servo_pos[i] = servo_pos10(&fw->servo[i]);
    }
    d->gyro_raw = fw->gyro_raw;
    d->compass = fw->compass;
    for (i = 0u; i < 4u; i++) {
        d->sonar_echo[i] = fw->sonar[i];
    }
    d->dio_state = dio_state(&fw->dio);
    link_datalog(fw, d->mc_datalog);
    d->mc_datalog_sel = l->mc_datalog;
    d->rx_good = (uint16_t)st->good;
    d->rx_bad_crc = (uint16_t)st->bad_crc;
    d->rx_unknown_type = (uint16_t)st->unknown_type;
    d->rx_bad_length = (uint16_t)st->bad_length;
    d->rx_schema_mismatch = (uint16_t)(l->schema_mismatch + st->schema_mismatch);
    d->rx_dropped_bytes = (uint16_t)st->dropped_bytes;
    d->cmd_rejected = l->cmd_rejected;
    d->last_reject = l->last_reject;
    d->watchdog_stops = fw->watchdog_stops;
    d->reset_cause = fw->reset_cause;
#if FW_LINK_CAN
    /* the CAN transport's counters, one field each (the serial build leaves them 0) */
    d->can_rx_bad_frame = l->can_rx.stats.bad_frame;
    d->can_rx_wrong_sn = l->can_rx.stats.wrong_sn;
    d->can_rx_unexpected = l->can_rx.stats.unexpected;
    d->can_rx_restarted = l->can_rx.stats.restarted;
    d->can_rx_timeout = l->can_rx.stats.timeout;
    d->can_rx_overflow = l->can_rx.stats.overflow;
    d->can_tx_timeout = l->can_tx.stats.timeout;
    d->can_tx_overflow = l->can_tx.stats.overflow;
    d->can_tx_bad_fc = l->can_tx.stats.bad_fc;
    d->can_tx_wait = l->can_tx.stats.wait;
    d->can_rx_lost = hal_can_rx_lost(fw->hal);
#endif
}

#if FW_LINK_CAN
/* One micro_data back, whole: while the last one is still going out it is left due
   (reply_due) and starts, with the telemetry of then, once the sender is free (link_poll). */
static void link_reply(fw_t *fw)
{
    navkit_micro_data_t d;
    navkit_isotp_tx_t *tx = &fw->link.can_tx;
    if (navkit_isotp_tx_busy(tx)) {
        fw->link.reply_due = 1u;
        return;
    }
    fw->link.reply_due = 0u;
    fw->link.tx_tag++;
    link_telemetry(fw, &d);
    (void)navkit_isotp_tx_start(tx, (uint16_t)navkit_micro_data_encode(&d, tx->buf, sizeof tx->buf),
                                NAVKIT_MSG_TYPE_MICRO_DATA, fw->ms);
}

/* CAN: every frame read goes to ISO-TP; a flow control it asks for goes out at once (if the
   TX queue is full it is lost, and the host's sender times out); a reassembled message goes
   through the frame parser as the UART's bytes do; then the micro_data frames ISO-TP lets go.
   With FW_LINK_FRAMES_PER_POLL (any N > 0: one ISO-TP message is one frame) a poll applies
   one reassembled message at most and stops reading there (the frames after it wait in the
   CAN RX), leaving its reply due; a poll that can start a due reply does that and reads
   nothing. So a due tick waits for one message's handling or one reply's build at most. */
void link_poll(fw_t *fw)
{
    link_t *l = &fw->link;
    navkit_isotp_frame_t f;
    uint16_t id;
    uint8_t data[8];
    uint8_t dlc;
    uint8_t fc_out;
    if (FW_LINK_FRAMES_PER_POLL != 0u) {
        l->more = 0u;
        if (l->reply_due && !navkit_isotp_tx_busy(&l->can_tx)) {
            link_reply(fw);
            l->more = 1u; /* frames may wait in the CAN RX */
        }
    }
    while (!l->more && hal_can_read(fw->hal, &id, data, &dlc)) {
        uint16_t n;
        if (dlc > 8u) {
            dlc = 8u;
        }
        navkit_isotp_tx_frame(&l->can_tx, id, data, dlc, fw->ms);
        n = navkit_isotp_rx_frame(&l->can_rx, id, data, dlc, fw->ms, &f, &fc_out);
        if (fc_out && hal_can_tx_free(fw->hal) > 0u) {
            hal_can_write(fw->hal, f.id, f.data);
        }
        if (n > 0u) {
            const uint8_t *frame;
            size_t flen;
            (void)navkit_parser_feed(&l->parser, l->can_rx.buf, n); /* n <= the parser's buffer */
            while (navkit_parser_next(&l->parser, &frame, &flen)) {
                if (link_frame(fw, frame, flen)) {
                    if (FW_LINK_FRAMES_PER_POLL != 0u) {
                        l->reply_due = 1u;
                    } else {
                        link_reply(fw);
                    }
                }
            }
            navkit_parser_discard(&l->parser); /* a message that was no whole frame */
            if (FW_LINK_FRAMES_PER_POLL != 0u) {
                l->more = 1u; /* one message a poll */
            }
        }
    }
    navkit_isotp_rx_poll(&l->can_rx, fw->ms);
    if (FW_LINK_FRAMES_PER_POLL == 0u && l->reply_due && !navkit_isotp_tx_busy(&l->can_tx)) {
        link_reply(fw); /* the reply left due starts once the last one has gone out */
    }
    while (hal_can_tx_free(fw->hal) > 0u && navkit_isotp_tx_next(&l->can_tx, fw->ms, &f)) {
        hal_can_write(fw->hal, f.id, f.data);
    }
}
#else
/* One micro_data back, whole or not at all. */
static void link_reply(fw_t *fw)
{
    navkit_micro_data_t d;
    uint8_t buf[NAVKIT_MICRO_DATA_BYTES];
    size_t n;
    if (hal_uart_tx_free(fw->hal) < NAVKIT_MICRO_DATA_BYTES) {
        return;
    }
    fw->link.tx_tag++;
    link_telemetry(fw, &d);
    n = navkit_micro_data_encode(&d, buf, sizeof buf);
    hal_uart_write(fw->hal, buf, n);
}

/* Handle the complete frames the parser holds, up to the poll's bound; returns 1 when the
   bound is reached (*frames counts this poll's frames). Without a bound each frame's
   micro_data goes out at once; with one it is left due (reply_due) and goes out before
   the next frame is handled, by the next poll at the latest. */
static uint8_t link_frames(fw_t *fw, uint8_t *frames)
{
    const uint8_t *frame;
    size_t flen;
    while (navkit_parser_next(&fw->link.parser, &frame, &flen)) {
        if (FW_LINK_FRAMES_PER_POLL != 0u && fw->link.reply_due) {
            fw->link.reply_due = 0u;
            link_reply(fw);
        }
        if (link_frame(fw, frame, flen)) {
            if (FW_LINK_FRAMES_PER_POLL != 0u) {
                fw->link.reply_due = 1u;
            } else {
                link_reply(fw);
            }
        }
        if (FW_LINK_FRAMES_PER_POLL != 0u) {
            ++*frames;
            if (*frames == FW_LINK_FRAMES_PER_POLL) {
                return 1u;
            }
        }
    }
    return 0u;
}

/* With a bound, a poll that finds a reply due sends it and ends there (the reply is one
   piece of work, the frame before it the other: a due tick waits for one of them at most);
   otherwise it first takes the frames its parser kept (it stopped at the bound last time), then
   reads the UART chunk by chunk. At the bound it still feeds the rest of the chunk in
   hand: the frame just handled leaves its room in the parser, at least the smallest frame
   (36 bytes) >= LINK_RX_CHUNK, so no byte read is lost. */
void link_poll(fw_t *fw)
{
    uint8_t chunk[LINK_RX_CHUNK];
    size_t got;
    uint8_t frames = 0u;
    if (FW_LINK_FRAMES_PER_POLL != 0u) {
        fw->link.more = 0u; /* set only with a bound */
    }
    if (FW_LINK_FRAMES_PER_POLL != 0u && fw->link.reply_due) {
        fw->link.reply_due = 0u;
        link_reply(fw);
        fw->link.more = 1u; /* the parser may hold the next frame */
        return;
    }
    if (FW_LINK_FRAMES_PER_POLL != 0u && link_frames(fw, &frames)) {
        fw->link.more = 1u;
        return;
    }
    while ((got = hal_uart_read(fw->hal, chunk, sizeof chunk)) > 0u) {
        const uint8_t *p = chunk;
        while (got > 0u) {
            size_t took = navkit_parser_feed(&fw->link.parser, p, got);
            p += took;
            got -= took;
            if (link_frames(fw, &frames)) {
                fw->link.more = 1u;
                while (got > 0u && (took = navkit_parser_feed(&fw->link.parser, p, got)) > 0u) {
                    p += took;
                    got -= took;
                }
                if (got == 0u) {
                    return;
                }
                frames = 0u; /* cannot happen (see above): rather exceed the bound than lose bytes */
            }
        }
    }
}
#endif

uint8_t link_pending(const fw_t *fw)
{
    return (uint8_t)(fw->link.more | fw->link.reply_due);
}
