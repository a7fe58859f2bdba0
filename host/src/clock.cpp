#include "navkit/clock.hpp"

#include <cerrno>
#include <csignal>
#include <cstring>
#include <ctime>
#include <sys/prctl.h>
#include <unistd.h>

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

volatile int g_quit_signal = 0;

// A signal sent to the process (kill, raise: si_code <= 0) asks it to end; a fault the
// kernel raised (SIGSEGV on a bad address, ...) cannot be carried on from: the default
// action runs as the faulting instruction repeats (a core, as without this handler).
static void on_signal(int sig, siginfo_t *si, void *)
{
    if (si && si->si_code > 0 &&
        (sig == SIGSEGV || sig == SIGBUS || sig == SIGILL || sig == SIGFPE || sig == SIGTRAP || sig == SIGSYS)) {
        signal(sig, SIG_DFL);
        return;
    }
    g_quit_signal = sig;
}

void install_signal_handlers()
{
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_sigaction = on_signal; // no SA_RESTART: blocking waits return EINTR
    sa.sa_flags = SA_SIGINFO;
    sigemptyset(&sa.sa_mask);
    // every signal whose default action ends the process takes the path of SIGTERM
    // (stop sent last, datalog closed, region removed); SIGKILL cannot be caught
    static const int ending[] = {SIGHUP,  SIGINT,    SIGQUIT, SIGILL,  SIGTRAP, SIGABRT, SIGBUS,
                                 SIGFPE,  SIGUSR1,   SIGSEGV, SIGUSR2, SIGALRM, SIGTERM, SIGSTKFLT,
                                 SIGXCPU, SIGVTALRM, SIGPROF, SIGIO,   SIGPWR,  SIGSYS};
    for (int sig : ending) {
        sigaction(sig, &sa, nullptr);
    }
    for (int sig = SIGRTMIN; sig <= SIGRTMAX; sig++) {
        sigaction(sig, &sa, nullptr);
    }
    signal(SIGPIPE, SIG_IGN); // a closed reader: write() returns EPIPE instead
    signal(SIGXFSZ, SIG_IGN); // a file over RLIMIT_FSIZE: write() returns EFBIG (the datalog stops)
}

static int64_t mono_ns()
{
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

RealClock::RealClock(double rate_hz, const std::string &timing_log)
{
    sched_.period_ns = period_ns_of(rate_hz);
    prctl(PR_SET_TIMERSLACK, 1000UL); // wake within ~1 us of the deadline, not the 50 us default
    if (!timing_log.empty()) {
        timing_ = std::fopen(timing_log.c_str(), "w");
        if (!timing_) {
            error_ = timing_log + ": " + std::strerror(errno);
        } else {
            std::fprintf(timing_, "# frame scheduled_ns start_ns end_ns (since t0), period_ns %lld\n",
                         static_cast<long long>(sched_.period_ns));
        }
    }
}

RealClock::~RealClock()
{
    if (timing_) {
        std::fclose(timing_);
    }
}

bool RealClock::wait_frame(FrameTick *tick)
{
    if (!error_.empty()) {
        return false;
    }
    if (!started_) {
        started_ = true;
        sched_.t0_ns = mono_ns();
        frame_ = 0;
    } else {
        const NextFrame n = next_frame(sched_, frame_, mono_ns());
        overruns_ += n.overrun ? 1 : 0;
        skipped_ += n.skipped;
        frame_ = n.frame;
        const int64_t at = frame_start(sched_, frame_);
        timespec ts;
        ts.tv_sec = static_cast<time_t>(at / 1000000000LL);
        ts.tv_nsec = static_cast<long>(at % 1000000000LL);
        while (!g_quit_signal) {
            const int rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
            if (rc != EINTR) {
                break;
            }
        }
    }
    if (g_quit_signal) {
        return false;
    }
    start_ns_ = mono_ns();
    tick->frame = frame_;
    tick->time_us = (frame_start(sched_, frame_) - sched_.t0_ns) / 1000;
    tick->rx_bytes = -1;
    return true;
}

void RealClock::frame_done(uint32_t, uint32_t)
{
    if (timing_) {
        const int64_t end = mono_ns();
        std::fprintf(timing_, "%llu %lld %lld %lld\n", static_cast<unsigned long long>(frame_),
                     static_cast<long long>(frame_start(sched_, frame_) - sched_.t0_ns),
                     static_cast<long long>(start_ns_ - sched_.t0_ns), static_cast<long long>(end - sched_.t0_ns));
    }
}

static const uint32_t kTickMagic = 0x4B544B4Eu; // 'NKTK'
static const uint32_t kDoneMagic = 0x4E444B4Eu; // 'NKDN'

LockstepClock::LockstepClock(int fd) : fd_(fd) {}

LockstepClock::~LockstepClock()
{
    if (fd_ >= 0) {
        ::close(fd_);
    }
}

bool LockstepClock::wait_frame(FrameTick *tick)
{
    uint8_t b[24];
    size_t have = 0;
    if (g_quit_signal) {
        return false; // a signal that came during the last frame
    }
    while (have < sizeof b) {
        const ssize_t n = ::read(fd_, b + have, sizeof b - have);
        if (n > 0) {
            have += static_cast<size_t>(n);
        } else if (n == 0 || errno == ECONNRESET) {
            // EOF: the driver is done, shut down cleanly (a reset: it closed its end with
            // our last done unread, as a driver stopped between frames does)
            if (have) {
                error_ = "lockstep: EOF in the middle of a tick";
            }
            return false;
        } else if (errno != EINTR) {
            error_ = std::string("lockstep: ") + std::strerror(errno);
            return false;
        }
        if (g_quit_signal) {
            return false;
        }
    }
    const uint32_t magic = navkit_get_u32(b);
    if (magic != kTickMagic) {
        char msg[96];
        std::snprintf(msg, sizeof msg, "lockstep: bad tick magic 0x%08X", magic);
        error_ = msg;
        return false;
    }
    frame_ = navkit_get_u32(b + 4);
    const uint64_t t_us = static_cast<uint64_t>(navkit_get_u32(b + 8)) |
                          (static_cast<uint64_t>(navkit_get_u32(b + 12)) << 32);
    tick->frame = frame_;
    tick->time_us = static_cast<int64_t>(t_us);
    tick->rx_bytes = static_cast<long>(navkit_get_u32(b + 16));
    return true;
}

void LockstepClock::frame_done(uint32_t tx_bytes, uint32_t flags)
{
    uint8_t b[16];
    navkit_put_u32(b, kDoneMagic);
    navkit_put_u32(b + 4, frame_);
    navkit_put_u32(b + 8, tx_bytes);
    navkit_put_u32(b + 12, flags);
    size_t done = 0;
    while (done < sizeof b) {
        const ssize_t n = ::write(fd_, b + done, sizeof b - done);
        if (n > 0) {
            done += static_cast<size_t>(n);
        } else if (n < 0 && errno == EINTR) {
            continue;
        } else {
            return; // the driver went away: the next wait_frame sees EOF
        }
    }
}

} // namespace navkit
