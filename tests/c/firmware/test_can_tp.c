/* ISO-TP (protocol/runtime/navkit_isotp.c) against the golden vectors navkit.can made
 * (tests/vectors/can.txt, see tools/navkit/can_vectors.py): the receiver must complete the
 * same messages, send the same flow controls and count the same, frame by frame; the
 * sender must cut each whole message into the same frames. Then the sender's own rules:
 * flow control wait, overflow, invalid status, timeouts, block size, STmin.
 * Usage: fw_test_can_tp [--list | --case NAME] tests/vectors/can.txt */
#include <stdio.h>
#include <string.h>

#include "navkit/navkit_proto.h"
#include "check.h"

#define LINE_MAX_CHARS 65536
#define CASE_FRAMES 256

typedef struct {
    uint32_t t;  /* ms */
    uint16_t id; /* with NAVKIT_ISOTP_EXT / NAVKIT_ISOTP_RTR */
    uint8_t dlc;
    uint8_t data[8];
} vec_frame_t;

static int hexval(char c)
{
    return (c >= '0' && c <= '9')   ? c - '0'
           : (c >= 'A' && c <= 'F') ? c - 'A' + 10
           : (c >= 'a' && c <= 'f') ? c - 'a' + 10
                                    : -1;
}

/* Hex digits from s (up to a non-hex char) into out; returns the bytes. */
static size_t unhex(const char *s, uint8_t *out, size_t cap)
{
    size_t n = 0u;
    while (hexval(s[0]) >= 0 && hexval(s[1]) >= 0 && n < cap) {
        out[n++] = (uint8_t)(hexval(s[0]) * 16 + hexval(s[1]));
        s += 2;
    }
    return n;
}

/* Field k (0-based) of a `a | b | c` line, trimmed, into out. */
static void field(const char *line, int k, char *out, size_t cap)
{
    const char *s = line;
    const char *e;
    size_t n;
    while (k-- > 0 && s) {
        s = strchr(s, '|');
        s = s ? s + 1 : NULL;
    }
    out[0] = '\0';
    if (!s) {
        return;
    }
    while (*s == ' ') {
        s++;
    }
    e = strchr(s, '|');
    n = e ? (size_t)(e - s) : strlen(s);
    while (n > 0u && (s[n - 1] == ' ' || s[n - 1] == '\n')) {
        n--;
    }
    if (n >= cap) {
        n = cap - 1u;
    }
    memcpy(out, s, n);
    out[n] = '\0';
}

/* `T:ID#DATA ...` into frames; returns how many. */
static int parse_frames(char *s, vec_frame_t *f, int cap)
{
    int n = 0;
    char *tok = strtok(s, " ");
    while (tok && n < cap) {
        char *colon = strchr(tok, ':');
        char *hash = strchr(tok, '#');
        unsigned long id;
        f[n].t = (uint32_t)strtoul(tok, NULL, 10);
        id = strtoul(colon + 1, NULL, 16);
        f[n].id = (uint16_t)(id & NAVKIT_ISOTP_ID_MASK);
        if (hash - colon - 1 == 8) {
            f[n].id |= NAVKIT_ISOTP_EXT;
        }
        if (hash[1] == 'R') {
            f[n].id |= NAVKIT_ISOTP_RTR;
            f[n].dlc = 8u;
            memset(f[n].data, 0, 8u);
        } else {
            f[n].dlc = (uint8_t)unhex(hash + 1, f[n].data, 8u);
        }
        n++;
        tok = strtok(NULL, " ");
    }
    return n;
}

static void hexstr(const uint8_t *b, size_t n, char *out)
{
    size_t i;
    for (i = 0u; i < n; i++) {
        sprintf(out + 2 * i, "%02X", b[i]);
    }
    out[2 * n] = '\0';
}

/* Append `s` to the separator-joined list in out. */
static void join(char *out, const char *sep, const char *s)
{
    if (out[0] != '\0') {
        strcat(out, sep);
    }
    strcat(out, s);
}

static void run_case(const char *line)
{
    static char buf[LINE_MAX_CHARS], got_msgs[LINE_MAX_CHARS], got_fc[LINE_MAX_CHARS], want[LINE_MAX_CHARS];
    static vec_frame_t frames[CASE_FRAMES];
    char name[64], item[600], stats[128];
    navkit_isotp_rx_t rx;
    navkit_isotp_frame_t fc;
    int n, i;
    field(line, 0, name, sizeof name);
    field(line, 1, buf, sizeof buf);
    n = parse_frames(buf, frames, CASE_FRAMES);
    navkit_isotp_rx_init(&rx, NAVKIT_DIR_TO_MICRO);
    got_msgs[0] = got_fc[0] = '\0';
    for (i = 0; i < n; i++) {
        uint8_t fc_out;
        uint16_t len = navkit_isotp_rx_frame(&rx, frames[i].id, frames[i].data, frames[i].dlc, frames[i].t, &fc,
                                             &fc_out);
        if (len) {
            hexstr(rx.buf, len, item);
            join(got_msgs, ",", item);
        }
        if (fc_out) {
            sprintf(item, "%03X#", fc.id);
            hexstr(fc.data, 8u, item + 4);
            join(got_fc, " ", item);
        }
    }
    field(line, 2, want, sizeof want);
    if (strcmp(want, got_msgs[0] ? got_msgs : "-") != 0) {
        fprintf(stderr, "case %s: messages differ\n  want %s\n  got  %s\n", name, want, got_msgs);
        check_failures++;
    }
    field(line, 3, want, sizeof want);
    if (strcmp(want, got_fc[0] ? got_fc : "-") != 0) {
        fprintf(stderr, "case %s: flow controls differ\n  want %s\n  got  %s\n", name, want, got_fc);
        check_failures++;
    }
    field(line, 4, want, sizeof want);
    sprintf(stats, "%u,%u,%u,%u,%u,%u,%u", rx.stats.good, rx.stats.bad_frame, rx.stats.wrong_sn, rx.stats.unexpected,
            rx.stats.restarted, rx.stats.timeout, rx.stats.overflow);
    if (strcmp(want, stats) != 0) {
        fprintf(stderr, "case %s: stats differ: want %s, got %s\n", name, want, stats);
        check_failures++;
    }
    /* a whole message: the sender cuts it into the very frames of the case */
    if (strncmp(name, "whole ", 6) == 0) {
        static navkit_isotp_tx_t tx;
        uint8_t cts[8] = {0x30, 0, 0, 0xCC, 0xCC, 0xCC, 0xCC, 0xCC};
        navkit_isotp_frame_t f;
        int k = 0;
        uint16_t len;
        field(line, 2, want, sizeof want);
        navkit_isotp_tx_init(&tx);
        len = (uint16_t)unhex(want, tx.buf, sizeof tx.buf);
        CHECK(navkit_isotp_tx_start(&tx, len, navkit_get_u16(tx.buf + 4), 0u));
        while (navkit_isotp_tx_next(&tx, 0u, &f)) {
            CHECK(k < n && f.id == frames[k].id && memcmp(f.data, frames[k].data, 8u) == 0);
            k++;
            if (k == 1) {
                CHECK(!navkit_isotp_tx_next(&tx, 0u, &f)); /* nothing before the flow control */
                navkit_isotp_tx_frame(&tx, navkit_can_id(navkit_get_u16(tx.buf + 4), 1), cts, 8u, 0u);
            }
        }
        CHECK(k == n && !navkit_isotp_tx_busy(&tx) && tx.stats.sent == 1u);
    }
}

/* The golden vectors file, the program's last argument (main() keeps it for test_vectors). */
static const char *vectors_path;

static void test_vectors(void)
{
    static char line[LINE_MAX_CHARS];
    const char *path = vectors_path;
    int cases = 0;
    FILE *fp = fopen(path, "r");
    if (!fp) {
        fprintf(stderr, "%s: cannot open\n", path);
        check_failures++;
        return;
    }
    while (fgets(line, sizeof line, fp)) {
        if (line[0] == '#' || line[0] == '\n') {
            if (strncmp(line, "# spec-hash ", 12) == 0 && strtoul(line + 12, NULL, 16) != NAVKIT_SPEC_HASH) {
                fprintf(stderr, "%s: made from another spec (run python -m navkit.can_vectors --write)\n", path);
                check_failures++;
            }
            continue;
        }
        run_case(line);
        cases++;
    }
    fclose(fp);
    CHECK(cases >= 20);
}

/* The micro sends micro_data: first frame, then nothing until the flow control. */
static void start_data(navkit_isotp_tx_t *tx, uint32_t now)
{
    navkit_isotp_frame_t f;
    memset(tx->buf, 0x5A, sizeof tx->buf);
    CHECK(navkit_isotp_tx_start(tx, NAVKIT_MICRO_DATA_BYTES, NAVKIT_MSG_TYPE_MICRO_DATA, now));
    CHECK(navkit_isotp_tx_next(tx, now, &f) && f.id == NAVKIT_CAN_ID_MICRO_DATA && f.data[0] == 0x10u &&
          f.data[1] == NAVKIT_MICRO_DATA_BYTES);
    CHECK(!navkit_isotp_tx_next(tx, now, &f));
}

static void test_sender_rules(void)
{
    static navkit_isotp_tx_t tx;
    navkit_isotp_frame_t f;
    uint8_t fc[8] = {0x30, 4, 2, 0xCC, 0xCC, 0xCC, 0xCC, 0xCC}; /* 4 frames a block, 2 ms apart */
    uint32_t t;
    int sent = 0, fcs = 1;
    navkit_isotp_tx_init(&tx);
    start_data(&tx, 0u);
    CHECK(!navkit_isotp_tx_start(&tx, 10u, NAVKIT_MSG_TYPE_MICRO_DATA, 0u) && tx.stats.busy == 1u);
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_CMD, fc, 8u, 1u); /* another message's flow control: ignored */
    CHECK(!navkit_isotp_tx_next(&tx, 1u, &f));
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, fc, 8u, 1u);
    for (t = 1u; t < 400u && navkit_isotp_tx_busy(&tx); t++) {
        while (navkit_isotp_tx_next(&tx, t, &f)) {
            CHECK((f.data[0] & 0x0Fu) == (uint8_t)((sent + 1) & 0x0F));
            sent++;
            if (sent % 4 == 0 && navkit_isotp_tx_busy(&tx)) {
                CHECK(!navkit_isotp_tx_next(&tx, t + 50u, &f)); /* a block ends: wait for the next flow control */
                navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, fc, 8u, t);
                fcs++;
            }
        }
    }
    CHECK(sent == (NAVKIT_MICRO_DATA_BYTES - 6 + 6) / 7 && tx.stats.sent == 1u && fcs == (sent + 3) / 4);
    /* STmin 2 ms: one consecutive frame every 2 ms, so about 2 ms a frame */
    CHECK(t >= 2u * (uint32_t)sent - 2u);
    /* no flow control: abandoned after N_Bs; a wait restarts that */
    start_data(&tx, 1000u);
    fc[0] = 0x31u;
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, fc, 8u, 1000u + NAVKIT_CAN_N_BS_MS - 1u);
    CHECK(!navkit_isotp_tx_next(&tx, 1000u + NAVKIT_CAN_N_BS_MS + 1u, &f) && navkit_isotp_tx_busy(&tx) &&
          tx.stats.wait == 1u);
    CHECK(!navkit_isotp_tx_next(&tx, 1000u + 2u * NAVKIT_CAN_N_BS_MS, &f) && !navkit_isotp_tx_busy(&tx) &&
          tx.stats.timeout == 1u);
    /* an overflow abandons the message; so does an invalid status; a short frame is no flow control */
    start_data(&tx, 2000u);
    fc[0] = 0x32u;
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, fc, 8u, 2001u);
    CHECK(!navkit_isotp_tx_busy(&tx) && tx.stats.overflow == 1u);
    start_data(&tx, 3000u);
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, fc, 3u, 3001u);
    CHECK(navkit_isotp_tx_busy(&tx) && tx.stats.bad_fc == 1u);
    fc[0] = 0x37u;
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, fc, 8u, 3001u);
    CHECK(!navkit_isotp_tx_busy(&tx) && tx.stats.bad_fc == 2u);
    /* a short message goes as one single frame, padded */
    tx.buf[0] = 1u;
    tx.buf[1] = 2u;
    CHECK(navkit_isotp_tx_start(&tx, 2u, NAVKIT_MSG_TYPE_MICRO_DATA, 4000u));
    CHECK(navkit_isotp_tx_next(&tx, 4000u, &f) && f.data[0] == 2u && f.data[1] == 1u && f.data[2] == 2u &&
          f.data[3] == NAVKIT_CAN_PADDING && f.data[7] == NAVKIT_CAN_PADDING && !navkit_isotp_tx_busy(&tx));
    CHECK(!navkit_isotp_tx_start(&tx, 2u, 99u, 4000u)); /* no identifier for an unknown msg_type */
}

/* A message pre-empted by the sender (a stop that must not wait behind an unfinished
 * command, host/src/micro_link.cpp): abort makes the sender idle at once; the receiver,
 * holding the first frame of the abandoned message, drops it when the next one's first
 * frame comes (restarted) and completes the new message. */
static void test_sender_abort(void)
{
    static navkit_isotp_tx_t tx;
    static navkit_isotp_rx_t rx;
    navkit_isotp_frame_t f, fc;
    uint8_t fc_out = 0u;
    uint16_t got = 0u, i;
    const uint8_t cts[8] = {0x30, 0, 0, 0xCC, 0xCC, 0xCC, 0xCC, 0xCC}; /* continue, all the rest, no gap */
    navkit_isotp_tx_init(&tx);
    navkit_isotp_rx_init(&rx, NAVKIT_DIR_TO_HOST);
    CHECK(!navkit_isotp_tx_abort(&tx) && tx.stats.aborted == 0u); /* idle: nothing to abandon */
    memset(tx.buf, 0x5A, sizeof tx.buf);
    CHECK(navkit_isotp_tx_start(&tx, NAVKIT_MICRO_DATA_BYTES, NAVKIT_MSG_TYPE_MICRO_DATA, 0u));
    CHECK(navkit_isotp_tx_next(&tx, 0u, &f) && f.data[0] == 0x10u); /* its first frame; no flow control yet */
    CHECK(navkit_isotp_rx_frame(&rx, f.id, f.data, 8u, 0u, &fc, &fc_out) == 0u && fc_out && rx.active);
    CHECK(!navkit_isotp_tx_start(&tx, NAVKIT_MICRO_DATA_BYTES, NAVKIT_MSG_TYPE_MICRO_DATA, 5u)); /* still busy */
    CHECK(navkit_isotp_tx_abort(&tx) && !navkit_isotp_tx_busy(&tx) && tx.stats.aborted == 1u);
    CHECK(!navkit_isotp_tx_next(&tx, 5u, &f)); /* nothing more of the abandoned message */
    for (i = 0u; i < NAVKIT_MICRO_DATA_BYTES; i++) {
        tx.buf[i] = (uint8_t)(i * 7u);
    }
    CHECK(navkit_isotp_tx_start(&tx, NAVKIT_MICRO_DATA_BYTES, NAVKIT_MSG_TYPE_MICRO_DATA, 5u));
    CHECK(navkit_isotp_tx_next(&tx, 5u, &f) && f.data[0] == 0x10u); /* the new message's first frame, at once */
    CHECK(navkit_isotp_rx_frame(&rx, f.id, f.data, 8u, 5u, &fc, &fc_out) == 0u && fc_out && rx.stats.restarted == 1u);
    navkit_isotp_tx_frame(&tx, NAVKIT_CAN_FC_ID_MICRO_DATA, cts, 8u, 6u);
    while (navkit_isotp_tx_next(&tx, 6u, &f)) {
        got = navkit_isotp_rx_frame(&rx, f.id, f.data, 8u, 6u, &fc, &fc_out);
    }
    CHECK(got == NAVKIT_MICRO_DATA_BYTES && tx.stats.sent == 1u && rx.stats.good == 1u);
    for (i = 0u; i < NAVKIT_MICRO_DATA_BYTES; i++) {
        CHECK(rx.buf[i] == (uint8_t)(i * 7u));
    }
}

static const check_case_t cases[] = {
    CHECK_CASE(vectors),
    CHECK_CASE(sender_rules),
    CHECK_CASE(sender_abort),
};

int main(int argc, char **argv)
{
    vectors_path = argv[argc - 1];
    return check_main(argc, argv, cases, sizeof cases / sizeof cases[0], "tests/vectors/can.txt");
}
