#include "navkit/comm.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <grp.h>
#include <csetjmp>
#include <csignal>
#include <stdexcept>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

namespace navkit {

// Every shared word goes through navkit_rcomm_slot.h (aligned 32-bit atomics, the
// region's little-endian byte order, the seqlock): the planner library runs the same code.

// The SIGBUS guard of the mapped region: another process of our user may ftruncate() it
// under us, and the next access to a page past its new end faults. An access made
// through Comm::guarded() jumps back to it instead; any other SIGBUS goes to the handler
// that was there before (the executive's, or the default: the process ends).
namespace {
sigjmp_buf *g_guard = nullptr;                              // the running guarded access's return point
const uint8_t *g_guard_lo = nullptr, *g_guard_hi = nullptr; // the mapping it guards, [lo, hi)
struct sigaction g_prev_bus;                                // SIGBUS's handler before on_bus

void on_bus(int sig, siginfo_t *si, void *ctx)
{
    const uint8_t *a = static_cast<const uint8_t *>(si->si_addr);
    if (g_guard && si->si_code > 0 && a >= g_guard_lo && a < g_guard_hi) {
        siglongjmp(*g_guard, 1);
    }
    if (g_prev_bus.sa_flags & SA_SIGINFO) {
        g_prev_bus.sa_sigaction(sig, si, ctx);
    } else if (g_prev_bus.sa_handler != SIG_DFL && g_prev_bus.sa_handler != SIG_IGN) {
        g_prev_bus.sa_handler(sig);
    } else {
        signal(sig, SIG_DFL); // a fault repeats on return and ends the process; a sent one is raised again
        if (si->si_code <= 0) {
            raise(sig);
        }
    }
}

// Puts on_bus in front of SIGBUS's handler of now (once: a second init finds it there).
void install_bus_guard()
{
    struct sigaction now;
    if (sigaction(SIGBUS, nullptr, &now) != 0 || ((now.sa_flags & SA_SIGINFO) && now.sa_sigaction == on_bus)) {
        return;
    }
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_sigaction = on_bus;
    sa.sa_flags = SA_SIGINFO;
    sigemptyset(&sa.sa_mask);
    g_prev_bus = now;
    sigaction(SIGBUS, &sa, nullptr);
}
} // namespace

bool Comm::begin_frame()
{
    if (!base_) {
        return false;
    }
    struct stat st;
    if (fstat(fd_, &st) != 0 || st.st_size < static_cast<off_t>(NAVKIT_RCOMM_SIZE)) {
        lose();
        return false;
    }
    return true;
}

template <class F> bool Comm::guarded(F access) const
{
    if (!base_) {
        return false;
    }
    if (between_) {
        between_();
    }
    // the size may shrink after begin_frame()'s check: the guard catches an access to a
    // page past the new end
    sigjmp_buf back;
    // 0: no signal mask saved (a sigprocmask call per access, several a frame); the jump
    // comes from on_bus with SIGBUS blocked, which was unblocked here (a blocked SIGBUS
    // fault ends the process without a handler), so unblocking it restores the mask
    if (sigsetjmp(back, 0) != 0) {
        g_guard = nullptr;
        sigset_t bus;
        sigemptyset(&bus);
        sigaddset(&bus, SIGBUS);
        sigprocmask(SIG_UNBLOCK, &bus, nullptr);
        lose();
        return false;
    }
    g_guard_lo = base_;
    g_guard_hi = base_ + NAVKIT_RCOMM_SIZE;
    g_guard = &back;
    access();
    g_guard = nullptr;
    return true;
}

void Comm::lose() const
{
    struct stat st;
    const long long size = fstat(fd_, &st) == 0 ? static_cast<long long>(st.st_size) : -1; // -1: unknown
    munmap(base_, NAVKIT_RCOMM_SIZE);
    base_ = nullptr;
    lost_ = "rcomm " + name_ + ": the region was cut to " +
            (size < 0 ? std::string("an unknown size") : std::to_string(size) + " bytes") + " by another process (" +
            std::to_string(NAVKIT_RCOMM_SIZE) + " needed): refused, the planner is gone";
}

Comm::Comm(std::string name, std::string group) : name_(std::move(name)), group_(std::move(group)) {}

Comm::~Comm()
{
    shutdown();
}

void Comm::init()
{
    const std::string what = "rcomm " + name_ + ": ";
    // A region of this name already there: another user's is refused; one whose host
    // still runs (it holds the region's lock) is refused; one whose host died is stale
    // and replaced.
    int fd = shm_open(name_.c_str(), O_RDWR, 0);
    if (fd >= 0) {
        struct stat st;
        if (fstat(fd, &st) != 0 || st.st_uid != geteuid()) {
            ::close(fd);
            throw std::runtime_error(what + "exists and belongs to another user (uid " + std::to_string(st.st_uid) +
                                     "): refused");
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            ::close(fd);
            throw std::runtime_error(what + "in use by a running navkit-host (it holds the region's lock): "
                                            "stop that one, or give this one another name with --shm NAME "
                                            "or [executive] shm_name");
        }
        shm_unlink(name_.c_str()); // stale: its host ended without removing it
        ::close(fd);
    } else if (errno != ENOENT) {
        // there, but not ours to open (EACCES: another user's mode 0600 region)
        const int e = errno;
        struct stat st;
        if (stat(("/dev/shm" + name_).c_str(), &st) == 0 && st.st_uid != geteuid()) {
            throw std::runtime_error(what + "exists and belongs to another user (uid " + std::to_string(st.st_uid) +
                                     "): refused");
        }
        throw std::runtime_error(what + std::strerror(e));
    }
    fd = shm_open(name_.c_str(), O_RDWR | O_CREAT | O_EXCL, 0600);
    if (fd < 0) {
        throw std::runtime_error(what + std::strerror(errno));
    }
    created_ = true;
    // The lock marks the region live for as long as this host runs (the kernel drops it
    // when the process ends, however it ends). A second host that opens the region in
    // the microseconds between O_EXCL and this call could take it for stale: accepted.
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        const int e = errno;
        ::close(fd);
        throw std::runtime_error(what + "lock: " + std::strerror(e));
    }
    fd_ = fd;
    mode_t mode = 0600;
    if (!group_.empty()) {
        const group *g = getgrnam(group_.c_str());
        if (!g || fchown(fd, static_cast<uid_t>(-1), g->gr_gid) != 0) {
            throw std::runtime_error(what + "group " + group_ + ": " + (g ? std::strerror(errno) : "unknown"));
        }
        mode = 0660;
    }
    if (fchmod(fd, mode) != 0 || ftruncate(fd, NAVKIT_RCOMM_SIZE) != 0) {
        throw std::runtime_error(what + std::strerror(errno));
    }
    void *p = mmap(nullptr, NAVKIT_RCOMM_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
        throw std::runtime_error(what + "mmap: " + std::strerror(errno));
    }
    base_ = static_cast<uint8_t *>(p);
    install_bus_guard();
    // header last-but-magic-last: a client that sees the magic sees the rest
    navkit_rcomm_store(base_, NAVKIT_RCOMM_VERSION_OFFSET, NAVKIT_RCOMM_VERSION, __ATOMIC_RELAXED);
    navkit_rcomm_store(base_, NAVKIT_RCOMM_SPEC_HASH_OFFSET, NAVKIT_SPEC_HASH, __ATOMIC_RELAXED);
    navkit_rcomm_store(base_, NAVKIT_RCOMM_MAGIC_OFFSET, NAVKIT_RCOMM_MAGIC, __ATOMIC_RELEASE);
}

void Comm::shutdown()
{
    if (base_) {
        munmap(base_, NAVKIT_RCOMM_SIZE);
        base_ = nullptr;
    }
    if (created_) {
        shm_unlink(name_.c_str()); // before the lock goes, so no one replaces it meanwhile
        created_ = false;
    }
    if (fd_ >= 0) {
        ::close(fd_); // drops the lock
        fd_ = -1;
    }
}

bool Comm::read_slot(size_t slot, int32_t *w, size_t n) const
{
    bool ok = false;
    return guarded([&] { ok = navkit_rcomm_slot_read(base_, slot, NAVKIT_RCOMM_SLOT_WORDS_OFFSET, w, n); }) && ok;
}

bool Comm::read_lisp_cmd(navkit_lisp_cmd_t *out) const
{
    int32_t w[NAVKIT_LISP_CMD_WORDS];
    if (!read_slot(NAVKIT_RCOMM_LISP_CMD_OFFSET, w, NAVKIT_LISP_CMD_WORDS)) {
        return false;
    }
    navkit_lisp_cmd_unpack(w, out);
    return true;
}

bool Comm::read_emotion(navkit_emotion_t *out) const
{
    int32_t w[NAVKIT_EMOTION_WORDS];
    if (!read_slot(NAVKIT_RCOMM_EMOTION_OFFSET, w, NAVKIT_EMOTION_WORDS)) {
        return false;
    }
    navkit_emotion_unpack(w, out);
    return true;
}

void Comm::send_lisp_data(const navkit_lisp_data_t &d)
{
    int32_t w[NAVKIT_LISP_DATA_WORDS];
    navkit_lisp_data_pack(&d, w);
    guarded([&] {
        navkit_rcomm_slot_write(base_, NAVKIT_RCOMM_LISP_DATA_OFFSET, NAVKIT_RCOMM_SLOT_WORDS_OFFSET, w,
                                NAVKIT_LISP_DATA_WORDS);
    });
}

uint32_t Comm::planner_heartbeat() const
{
    uint32_t v = 0;
    guarded([&] { v = navkit_rcomm_load(base_, NAVKIT_RCOMM_PLANNER_HEARTBEAT_OFFSET, __ATOMIC_ACQUIRE); });
    return v;
}

void Comm::set_host_heartbeat(uint32_t v)
{
    guarded([&] { navkit_rcomm_store(base_, NAVKIT_RCOMM_HOST_HEARTBEAT_OFFSET, v, __ATOMIC_RELEASE); });
}

} // namespace navkit
