/* navkit-simboard: an Arduino Mega 2560 simulated in simavr, reachable on a pty.
 *
 *   navkit-simboard --link PATH [--flash FILE] [--bootloader HEX] [--speed X] [--quiet]
 *
 * The ATmega2560 (16 MHz) starts in its boot section (BOOTRST programmed, BOOTSZ 4096
 * words: the Mega's fuses) where the real stk500v2 bootloader is loaded from HEX; UART0
 * is the master side of a pseudo-terminal whose slave is reachable through the symlink
 * PATH. The flash is kept in FILE (256 KiB raw image, 0xFF = erased) across runs: read
 * at start, written whenever the port is closed and at exit.
 *
 * DTR: a pty carries no modem lines, so the board's auto-reset (the Mega resets when a
 * host opens its USB-serial port and DTR falls) is stood in for by the open itself: when
 * the slave side goes from closed to open (the master's hang-up state clears, or inotify
 * saw a close and an open in between two looks) the AVR gets an external reset
 * (MCUSR.EXTRF set, RAM kept) and starts in the bootloader, as on the board.
 *
 * Time: simulated time is paced to the wall clock times --speed (1 = real time, the
 * default, so the bootloader's ~1 s wait and the baud rate are as on the board; 0 = as
 * fast as the host can run). UART0 moves bytes at the baud rate the image programs, in
 * simulated time; bytes from the pty wait while the receiver is disabled.
 *
 * Exit: SIGINT or SIGTERM ends the run: flash written, the PATH symlink removed, status
 * 0. Errors (a missing bootloader, a FILE of the wrong size, PATH taken by a file that
 * is not a symlink) are one line on stderr naming the file, status 1; bad options 2.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_io.h>
#include <sim_irq.h>
#include <sim_regbit.h>

#define SB_MCU "atmega2560"
#define SB_F_CPU 16000000u /* Hz, the Mega's crystal */
#define SB_FLASH_BYTES (256u * 1024u)
#define SB_BOOT_START 0x3E000u /* bytes: BOOTSZ=00, 4096 words at the top */
#define SB_FUSE_LOW 0xFFu      /* the Arduino Mega 2560's fuses */
#define SB_FUSE_HIGH 0xD8u     /* BOOTRST programmed, BOOTSZ=00 */
#define SB_FUSE_EXT 0xFDu
#define SB_LOCKBITS 0xCFu
#define SB_UCSR0B 0xC1u /* data address of UCSR0B (RXEN0 is bit 4) */
#define SB_RXEN0 4
#define SB_SLICE_CYCLES 16000u /* cycles between two services of the pty: 1 ms */
#define SB_QUEUE 8192u         /* bytes held each way (pty -> UART, UART -> pty) */
#define SB_DEFAULT_BOOTLOADER "/usr/share/arduino/hardware/arduino/avr/bootloaders/stk500v2/stk500boot_v2_mega2560.hex"

/* A byte queue (ring) of SB_QUEUE bytes. */
typedef struct {
    uint8_t buf[SB_QUEUE];
    size_t head;   /* index of the oldest byte */
    size_t len;    /* bytes held */
    uint64_t lost; /* bytes dropped because the queue was full */
} sb_queue_t;

typedef struct {
    avr_t *avr;
    const char *link;       /* the symlink path */
    const char *flash_path; /* NULL: no persistence */
    uint8_t *saved;         /* flash as last written to flash_path */
    int master;             /* pty master fd */
    int watch;              /* inotify fd watching the slave's opens/closes, -1 = none */
    char slave[128];        /* pty slave device name */
    int open;               /* 1 while a client has the slave open */
    int xoff;               /* 1 while the UART's input FIFO is full */
    avr_irq_t *uart_in;     /* UART0 input IRQ */
    sb_queue_t rx;          /* pty -> UART0 */
    sb_queue_t tx;          /* UART0 -> pty */
    uint64_t cycle_base;    /* cycles run before the last reset of avr->cycle */
    avr_cycle_count_t last_cycle;
    double speed; /* simulated seconds per wall second, 0 = unpaced */
    int quiet;
    unsigned resets; /* resets by port open */
} sb_t;

static volatile sig_atomic_t sb_stop = 0;

/* Signal handler: ask the main loop to finish (it writes the flash and removes the link). */
static void sb_on_signal(int sig)
{
    (void)sig;
    sb_stop = 1;
}

/* One line on stdout (unless --quiet), flushed at once (a reader sees each event). */
static void sb_say(const sb_t *sb, const char *fmt, ...)
{
    va_list ap;
    if (sb->quiet) {
        return;
    }
    va_start(ap, fmt);
    fputs("simboard: ", stdout);
    vfprintf(stdout, fmt, ap);
    fputc('\n', stdout);
    va_end(ap);
    fflush(stdout);
}

/* One error line on stderr. */
static void sb_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("navkit-simboard: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

/* Append one byte; a full queue drops it and counts it in q->lost. */
static void sb_queue_put(sb_queue_t *q, uint8_t b)
{
    if (q->len == SB_QUEUE) {
        q->lost++;
        return;
    }
    q->buf[(q->head + q->len) % SB_QUEUE] = b;
    q->len++;
}

/* Remove and return the oldest byte; the queue must not be empty. */
static uint8_t sb_queue_get(sb_queue_t *q)
{
    uint8_t b = q->buf[q->head];
    q->head = (q->head + 1u) % SB_QUEUE;
    q->len--;
    return b;
}

/* Monotonic wall clock, seconds. */
static double sb_wall(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* Cycles run since start, also across a reset should simavr restart avr->cycle at 0. */
static uint64_t sb_cycles(sb_t *sb)
{
    if (sb->avr->cycle < sb->last_cycle) {
        sb->cycle_base += sb->last_cycle;
    }
    sb->last_cycle = sb->avr->cycle;
    return sb->cycle_base + sb->avr->cycle;
}

/* UART0 output IRQ: a byte the image sent; held for the pty while a client listens. */
static void sb_on_uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    sb_t *sb = param;
    (void)irq;
    if (sb->open) {
        sb_queue_put(&sb->tx, (uint8_t)value);
    }
}

/* Feed held pty bytes to UART0 while its FIFO takes them and its receiver is enabled. */
static void sb_feed_uart(sb_t *sb)
{
    while (sb->rx.len > 0u && !sb->xoff && (sb->avr->data[SB_UCSR0B] & (1u << SB_RXEN0))) {
        avr_raise_irq(sb->uart_in, sb_queue_get(&sb->rx));
    }
}

/* UART0 XON IRQ: its input FIFO has room again. */
static void sb_on_xon(struct avr_irq_t *irq, uint32_t value, void *param)
{
    sb_t *sb = param;
    (void)irq;
    (void)value;
    sb->xoff = 0;
    sb_feed_uart(sb);
}

/* UART0 XOFF IRQ: its input FIFO is full; hold bytes until XON. */
static void sb_on_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
    sb_t *sb = param;
    (void)irq;
    (void)value;
    sb->xoff = 1;
}

/* The CPU's sleep callback: simulated time advances, the pacing below owns the wall clock. */
static void sb_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
    (void)avr;
    (void)how_long;
}

/* Write the flash to flash_path (a temporary file renamed over it) if it changed since
 * the last write. Returns 0, or -1 after printing the error. */
static int sb_save_flash(sb_t *sb)
{
    char tmp[4096];
    FILE *f;
    if (!sb->flash_path || memcmp(sb->saved, sb->avr->flash, SB_FLASH_BYTES) == 0) {
        return 0;
    }
    snprintf(tmp, sizeof tmp, "%s.tmp", sb->flash_path);
    f = fopen(tmp, "wb");
    if (!f || fwrite(sb->avr->flash, 1, SB_FLASH_BYTES, f) != SB_FLASH_BYTES || fflush(f) != 0 ||
        fsync(fileno(f)) != 0) {
        sb_error("%s: cannot write the flash: %s", tmp, strerror(errno));
        if (f) {
            fclose(f);
        }
        return -1;
    }
    fclose(f);
    if (rename(tmp, sb->flash_path) != 0) {
        sb_error("%s: cannot replace it: %s", sb->flash_path, strerror(errno));
        return -1;
    }
    memcpy(sb->saved, sb->avr->flash, SB_FLASH_BYTES);
    sb_say(sb, "flash saved to %s", sb->flash_path);
    return 0;
}

/* Load flash_path into the AVR's flash (absent: all erased). Returns 0 or -1 (printed). */
static int sb_load_flash(sb_t *sb)
{
    struct stat st;
    FILE *f;
    memset(sb->avr->flash, 0xFF, SB_FLASH_BYTES);
    if (sb->flash_path && stat(sb->flash_path, &st) == 0) {
        if (!S_ISREG(st.st_mode) || (size_t)st.st_size != SB_FLASH_BYTES) {
            sb_error("%s: not a flash image of the ATmega2560 (%lld bytes, needs %u): remove it "
                     "or give another --flash FILE",
                     sb->flash_path, (long long)st.st_size, SB_FLASH_BYTES);
            return -1;
        }
        f = fopen(sb->flash_path, "rb");
        if (!f || fread(sb->avr->flash, 1, SB_FLASH_BYTES, f) != SB_FLASH_BYTES) {
            sb_error("%s: cannot read it: %s", sb->flash_path, strerror(errno));
            if (f) {
                fclose(f);
            }
            return -1;
        }
        fclose(f);
    }
    return 0;
}

/* The value of n hex digits at s, or -1 if one is not a hex digit. */
static long sb_hex(const char *s, int n)
{
    long v = 0;
    for (int i = 0; i < n; i++) {
        int c = s[i], d;
        if (c >= '0' && c <= '9') {
            d = c - '0';
        } else if (c >= 'A' && c <= 'F') {
            d = c - 'A' + 10;
        } else if (c >= 'a' && c <= 'f') {
            d = c - 'a' + 10;
        } else {
            return -1;
        }
        v = v * 16 + d;
    }
    return v;
}

/* Load the bootloader (Intel HEX: data, end, extended segment/linear address and start
 * address records) into the boot section. Returns 0 or -1 (printed as file:line). */
static int sb_load_bootloader(sb_t *sb, const char *path)
{
    char line[600];
    uint32_t base = 0u;
    unsigned lineno = 0u, loaded = 0u;
    int done = 0;
    FILE *f = fopen(path, "r");
    if (!f) {
        sb_error("bootloader %s: %s: install arduino-core-avr (scripts/setup.sh) or give "
                 "--bootloader HEX",
                 path, strerror(errno));
        return -1;
    }
    while (!done && fgets(line, sizeof line, f)) {
        long count, addr, type, sum = 0;
        size_t len = strcspn(line, "\r\n");
        lineno++;
        line[len] = '\0';
        if (len == 0u) {
            continue;
        }
        count = len >= 11u && line[0] == ':' ? sb_hex(line + 1, 2) : -1;
        if (count < 0 || len != 11u + 2u * (size_t)count) {
            sb_error("bootloader %s:%u: not an Intel HEX record", path, lineno);
            fclose(f);
            return -1;
        }
        for (size_t i = 1u; i < len; i += 2u) {
            long b = sb_hex(line + i, 2);
            if (b < 0) {
                sb_error("bootloader %s:%u: not a hex digit in the record", path, lineno);
                fclose(f);
                return -1;
            }
            sum += b;
        }
        if ((sum & 0xFF) != 0) {
            sb_error("bootloader %s:%u: bad record checksum", path, lineno);
            fclose(f);
            return -1;
        }
        addr = sb_hex(line + 3, 4);
        type = sb_hex(line + 7, 2);
        if (type == 0) {
            uint32_t at = base + (uint32_t)addr;
            if (at < SB_BOOT_START || at + (uint32_t)count > SB_FLASH_BYTES) {
                sb_error("bootloader %s:%u: data at 0x%05x is outside the boot section "
                         "0x%05x..0x%05x",
                         path, lineno, at, SB_BOOT_START, SB_FLASH_BYTES - 1u);
                fclose(f);
                return -1;
            }
            for (long i = 0; i < count; i++) {
                sb->avr->flash[at + (uint32_t)i] = (uint8_t)sb_hex(line + 9 + 2 * i, 2);
            }
            loaded += (unsigned)count;
        } else if (type == 1) {
            done = 1;
        } else if (type == 2 && count == 2) {
            base = (uint32_t)sb_hex(line + 9, 4) << 4;
        } else if (type == 4 && count == 2) {
            base = (uint32_t)sb_hex(line + 9, 4) << 16;
        } else if (type != 3 && type != 5) {
            sb_error("bootloader %s:%u: record type %ld is not Intel HEX", path, lineno, type);
            fclose(f);
            return -1;
        }
    }
    fclose(f);
    if (loaded == 0u) {
        sb_error("bootloader %s: no data records", path);
        return -1;
    }
    return 0;
}

/* Reset the AVR as the DTR pulse does: external reset, start in the bootloader. */
static void sb_reset(sb_t *sb)
{
    avr_reset(sb->avr);
    sb_cycles(sb);
    sb->avr->pc = sb->avr->reset_pc;
    avr_regbit_set(sb->avr, sb->avr->reset_flags.extrf);
    sb->rx.len = 0u;
    sb->tx.len = 0u;
    sb->xoff = 0;
    sb->resets++;
}

/* Open the pty, make it raw, point the symlink at its slave. Returns 0 or -1 (printed). */
static int sb_open_pty(sb_t *sb)
{
    struct termios tio;
    struct stat st;
    int s;
    sb->master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (sb->master < 0 || grantpt(sb->master) != 0 || unlockpt(sb->master) != 0 ||
        ptsname_r(sb->master, sb->slave, sizeof sb->slave) != 0) {
        sb_error("cannot create a pseudo-terminal: %s", strerror(errno));
        return -1;
    }
    if (tcgetattr(sb->master, &tio) == 0) {
        cfmakeraw(&tio);
        cfsetispeed(&tio, B115200);
        cfsetospeed(&tio, B115200);
        tcsetattr(sb->master, TCSANOW, &tio);
    }
    /* Open and close the slave once: the master then reports a hang-up until a client
     * opens it, which is how a client's open (the DTR stand-in) is seen. */
    s = open(sb->slave, O_RDWR | O_NOCTTY);
    if (s >= 0) {
        close(s);
    }
    /* The hang-up state shows whether a client has the port open when we look (every
     * SB_SLICE_CYCLES); inotify shows a close and re-open quicker than that. */
    sb->watch = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (sb->watch >= 0 && inotify_add_watch(sb->watch, sb->slave, IN_OPEN | IN_CLOSE) < 0) {
        close(sb->watch);
        sb->watch = -1;
    }
    if (lstat(sb->link, &st) == 0) {
        if (!S_ISLNK(st.st_mode)) {
            sb_error("--link %s: exists and is not a symlink (remove it or choose another path)", sb->link);
            return -1;
        }
        unlink(sb->link);
    }
    if (symlink(sb->slave, sb->link) != 0) {
        sb_error("--link %s: cannot create the symlink: %s", sb->link, strerror(errno));
        return -1;
    }
    return 0;
}

/* 1 if inotify saw the slave closed and then opened again since the last call (the
 * queue merges repeated identical events, so the order is what counts). */
static int sb_reopened(const sb_t *sb)
{
    char buf[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
    int closed = 0, reopened = 0;
    ssize_t n;
    if (sb->watch < 0) {
        return 0;
    }
    while ((n = read(sb->watch, buf, sizeof buf)) > 0) {
        for (char *p = buf; p < buf + n;) {
            const struct inotify_event *e = (const struct inotify_event *)p;
            if (e->mask & IN_CLOSE) {
                closed = 1;
            } else if ((e->mask & IN_OPEN) && closed) {
                reopened = 1;
            }
            p += sizeof *e + e->len;
        }
    }
    return reopened;
}

/* The port was closed: drop what nobody will read, keep the flash. */
static void sb_port_closed(sb_t *sb)
{
    sb->open = 0;
    sb->tx.len = 0u;
    sb_say(sb, "port closed");
    sb_save_flash(sb);
}

/* Move bytes between the pty and the queues; see a client's open and close. */
static void sb_service_pty(sb_t *sb)
{
    struct pollfd p = {sb->master, POLLIN, 0};
    uint8_t buf[512];
    ssize_t n;
    int reopened = sb_reopened(sb);
    if (poll(&p, 1, 0) < 0) {
        return;
    }
    if (p.revents & POLLHUP) {
        if (sb->open) {
            sb_port_closed(sb);
        }
        return;
    }
    if (sb->open && reopened) {
        sb_port_closed(sb);
    }
    if (!sb->open) {
        sb->open = 1;
        sb_reset(sb);
        sb_say(sb, "port opened: reset into the bootloader");
    }
    while ((n = read(sb->master, buf, sizeof buf)) > 0) {
        for (ssize_t i = 0; i < n; i++) {
            sb_queue_put(&sb->rx, buf[i]);
        }
    }
    while (sb->tx.len > 0u) {
        size_t run = sb->tx.len;
        if (sb->tx.head + run > SB_QUEUE) {
            run = SB_QUEUE - sb->tx.head;
        }
        n = write(sb->master, sb->tx.buf + sb->tx.head, run);
        if (n <= 0) {
            break; /* the client is not reading: keep the bytes (bounded) */
        }
        sb->tx.head = (sb->tx.head + (size_t)n) % SB_QUEUE;
        sb->tx.len -= (size_t)n;
    }
}

/* Wait up to `seconds`, returning early when a client sends bytes. */
static void sb_wait(const sb_t *sb, double seconds)
{
    struct pollfd p = {sb->master, POLLIN, 0};
    if (sb->open) {
        poll(&p, 1, (int)(seconds * 1000.0 + 0.5)); /* a closed slave reports POLLHUP at once */
    } else {
        struct timespec ts;
        ts.tv_sec = (time_t)seconds;
        ts.tv_nsec = (long)((seconds - (double)ts.tv_sec) * 1e9);
        nanosleep(&ts, NULL);
    }
}

/* Run until a signal: one slice of simulated time, then the pty, then pacing. */
static int sb_run(sb_t *sb)
{
    double t0 = sb_wall();
    uint64_t c0 = sb_cycles(sb);
    while (!sb_stop) {
        uint64_t end = sb_cycles(sb) + SB_SLICE_CYCLES;
        int state = cpu_Running;
        while (sb_cycles(sb) < end) {
            state = avr_run(sb->avr);
            if (state == cpu_Done || state == cpu_Crashed) {
                break;
            }
        }
        if (state == cpu_Done || state == cpu_Crashed) {
            /* as a board whose program ran away: nothing happens until the next reset */
            sb_say(sb, "the AVR stopped (%s) at pc 0x%05x; waiting for a reset (open the port)",
                   state == cpu_Done ? "done" : "crashed", sb->avr->pc);
            unsigned resets = sb->resets;
            while (!sb_stop && sb->resets == resets) {
                sb_wait(sb, 0.005);
                sb_service_pty(sb); /* resets the AVR when a client opens the port */
            }
            t0 = sb_wall();
            c0 = sb_cycles(sb);
            continue;
        }
        sb_service_pty(sb);
        sb_feed_uart(sb);
        if (sb->speed > 0.0) {
            double ahead = (double)(sb_cycles(sb) - c0) / (SB_F_CPU * sb->speed) - (sb_wall() - t0);
            if (ahead > 0.0005) {
                sb_wait(sb, ahead);
            } else if (ahead < -0.25) {
                t0 = sb_wall(); /* the host fell behind: do not race to catch up */
                c0 = sb_cycles(sb);
            }
        }
    }
    return 0;
}

static void sb_usage(FILE *to)
{
    fprintf(to,
            "usage: navkit-simboard --link PATH [--flash FILE] [--bootloader HEX] [--speed X] [--quiet]\n"
            "  --link PATH        symlink to the pty of UART0 (the board's USB-serial port)\n"
            "  --flash FILE       keep the 256 KiB flash in FILE across runs (default: erased each run)\n"
            "  --bootloader HEX   stk500v2 bootloader (default %s)\n"
            "  --speed X          simulated seconds per wall second (default 1; 0 = unpaced)\n"
            "  --quiet            no progress lines on stdout\n",
            SB_DEFAULT_BOOTLOADER);
}

int main(int argc, char **argv)
{
    static sb_t sb;
    const char *bootloader = SB_DEFAULT_BOOTLOADER;
    struct sigaction sa;
    int i, status;
    uint32_t flags = 0;

    sb.speed = 1.0;
    sb.master = -1;
    sb.watch = -1;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            sb_usage(stdout);
            return 0;
        }
        if (strcmp(a, "--quiet") == 0) {
            sb.quiet = 1;
            continue;
        }
        if (strcmp(a, "--link") != 0 && strcmp(a, "--flash") != 0 && strcmp(a, "--bootloader") != 0 &&
            strcmp(a, "--speed") != 0) {
            sb_error("unknown option %s (--help)", a);
            return 2;
        }
        if (i + 1 >= argc) {
            sb_error("%s: needs a value (--help)", a);
            return 2;
        }
        if (strcmp(a, "--link") == 0) {
            sb.link = argv[++i];
        } else if (strcmp(a, "--flash") == 0) {
            sb.flash_path = argv[++i];
        } else if (strcmp(a, "--bootloader") == 0) {
            bootloader = argv[++i];
        } else {
            char *end;
            sb.speed = strtod(argv[++i], &end);
            if (*end != '\0' || end == argv[i] || !(sb.speed >= 0.0)) {
                sb_error("--speed %s: not a number of at least 0", argv[i]);
                return 2;
            }
        }
    }
    if (!sb.link) {
        sb_error("--link PATH is required (--help)");
        return 2;
    }

    sb.avr = avr_make_mcu_by_name(SB_MCU);
    if (!sb.avr) {
        sb_error("this simavr has no %s core: install Debian's libsimavr (scripts/setup.sh)", SB_MCU);
        return 1;
    }
    avr_init(sb.avr);
    sb.avr->frequency = SB_F_CPU;
    sb.avr->fuse[0] = SB_FUSE_LOW;
    sb.avr->fuse[1] = SB_FUSE_HIGH;
    sb.avr->fuse[2] = SB_FUSE_EXT;
    sb.avr->lockbits = SB_LOCKBITS;
    sb.avr->reset_pc = SB_BOOT_START;
    sb.avr->pc = SB_BOOT_START;
    sb.avr->codeend = SB_FLASH_BYTES - 1u;
    sb.avr->sleep = sb_sleep;
    sb.avr->log = LOG_ERROR;
    sb.saved = malloc(SB_FLASH_BYTES);
    if (!sb.saved || sb_load_flash(&sb) != 0 || sb_load_bootloader(&sb, bootloader) != 0) {
        return 1;
    }
    memcpy(sb.saved, sb.avr->flash, SB_FLASH_BYTES);

    /* UART0: no console echo, no real-time sleeps when the image polls it */
    avr_ioctl(sb.avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    sb.uart_in = avr_io_getirq(sb.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(sb.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), sb_on_uart_out, &sb);
    avr_irq_register_notify(avr_io_getirq(sb.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), sb_on_xon, &sb);
    avr_irq_register_notify(avr_io_getirq(sb.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), sb_on_xoff, &sb);

    if (sb_open_pty(&sb) != 0) {
        return 1;
    }
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = sb_on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    sb_say(&sb, "ATmega2560 at %u Hz, bootloader %s, flash %s, link %s -> %s", SB_F_CPU, bootloader,
           sb.flash_path ? sb.flash_path : "(not kept)", sb.link, sb.slave);
    status = sb_run(&sb);
    if (sb_save_flash(&sb) != 0) {
        status = 1;
    }
    unlink(sb.link);
    close(sb.master);
    if (sb.watch >= 0) {
        close(sb.watch);
    }
    sb_say(&sb,
           "stopped after %.3f s of simulated time (%u resets by port open; bytes dropped "
           "by full queues: %llu to the image, %llu from it)",
           (double)sb_cycles(&sb) / SB_F_CPU, sb.resets, (unsigned long long)sb.rx.lost,
           (unsigned long long)sb.tx.lost);
    avr_terminate(sb.avr);
    free(sb.saved);
    return status;
}
