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

// Every shared word is read and written with atomic 32-bit accesses (aligned: the
// layout's offsets are multiples of 4); byte order is fixed to little-endian by
// navkit_put_u32/navkit_get_u32 on the local copies.
static uint32_t load32(const uint8_t *base, size_t off, int order)
{
    return __atomic_load_n(reinterpret_cast<const uint32_t *>(base + off), order);
}

static void store32(uint8_t *base, size_t off, uint32_t v, int order)
{
    __atomic_store_n(reinterpret_cast<uint32_t *>(base + off), v, order);
}

static uint32_t le32(uint32_t native)
{
    uint8_t b[4];
    std::memcpy(b, &native, 4);
    return navkit_get_u32(b);
}

static uint32_t native32(uint32_t le)
{
    uint8_t b[4];
    navkit_put_u32(b, le);
    uint32_t v;
    std::memcpy(&v, b, 4);
    return v;
}

bool Comm::seqlock_read(const uint8_t *base, size_t slot_off, uint8_t *out, size_t nbytes)
{
    // Reader: copy between two equal, even reads of seq; bounded retries.
    for (int attempt = 0; attempt < 1000; attempt++) {
        const uint32_t s1 = le32(load32(base, slot_off, __ATOMIC_ACQUIRE));
        if (s1 & 1u) {
            continue;  // a write is in progress
        }
        for (size_t i = 0; i < nbytes; i += 4) {
            navkit_put_u32(out + i, le32(load32(base, slot_off + NAVKIT_RCOMM_SLOT_WORDS_OFFSET + i, __ATOMIC_RELAXED)));
        }
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        const uint32_t s2 = le32(load32(base, slot_off, __ATOMIC_RELAXED));
        if (s1 == s2) {
            return s1 != 0;  // seq 0: never written
        }
    }
    return false;
}

void Comm::seqlock_write(uint8_t *base, size_t slot_off, const uint8_t *in, size_t nbytes)
{
    // Writer: seq odd, words, seq even (+2 per message).
    uint32_t s = le32(load32(base, slot_off, __ATOMIC_RELAXED));
    s += (s & 1u) ? 1u : 0u;  // a writer that died mid-write left it odd
    store32(base, slot_off, native32(s + 1), __ATOMIC_RELAXED);
    __atomic_thread_fence(__ATOMIC_RELEASE);
    for (size_t i = 0; i < nbytes; i += 4) {
        store32(base, slot_off + NAVKIT_RCOMM_SLOT_WORDS_OFFSET + i, native32(navkit_get_u32(in + i)), __ATOMIC_RELAXED);
    }
    store32(base, slot_off, native32(s + 2), __ATOMIC_RELEASE);
}

// The SIGBUS guard of the mapped region: another process of our user may ftruncate() it
// under us, and the next access to a page past its new end faults. An access made
// through Comm::guarded() jumps back to it instead; any other SIGBUS goes to the handler
// that was there before (the executive's, or the default: the process ends).
namespace {
sigjmp_buf *g_guard = nullptr;                   // the running guarded access's return point
const uint8_t *g_guard_lo = nullptr, *g_guard_hi = nullptr;  // the mapping it guards, [lo, hi)
struct sigaction g_prev_bus;                     // SIGBUS's handler before on_bus

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
        signal(sig, SIG_DFL);  // a fault repeats on return and ends the process; a sent one is raised again
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
}  // namespace

template <class F>
bool Comm::guarded(F access) const
{
    if (!base_) {
        return false;
    }
    struct stat st;
    if (fstat(fd_, &st) != 0 || st.st_size < static_cast<off_t>(NAVKIT_RCOMM_SIZE)) {
        lose(fstat(fd_, &st) == 0 ? static_cast<long long>(st.st_size) : -1);
        return false;
    }
    if (between_) {
        between_();
    }
    // the size may still shrink between the check and the access: the guard catches that
    sigjmp_buf back;
    if (sigsetjmp(back, 1) != 0) {  // 1: the signal mask (SIGBUS blocked in the handler) comes back too
        g_guard = nullptr;
        lose(fstat(fd_, &st) == 0 ? static_cast<long long>(st.st_size) : -1);
        return false;
    }
    g_guard_lo = base_;
    g_guard_hi = base_ + NAVKIT_RCOMM_SIZE;
    g_guard = &back;
    access();
    g_guard = nullptr;
    return true;
}

void Comm::lose(long long size) const
{
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
            throw std::runtime_error(what + "exists and belongs to another user (uid " +
                                     std::to_string(st.st_uid) + "): refused");
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            ::close(fd);
            throw std::runtime_error(what + "in use by a running navkit-host (it holds the region's lock): "
                                            "stop that one, or give this one another name with --shm NAME "
                                            "or [executive] shm_name");
        }
        shm_unlink(name_.c_str());  // stale: its host ended without removing it
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
    store32(base_, NAVKIT_RCOMM_VERSION_OFFSET, native32(NAVKIT_RCOMM_VERSION), __ATOMIC_RELAXED);
    store32(base_, NAVKIT_RCOMM_SPEC_HASH_OFFSET, native32(NAVKIT_SPEC_HASH), __ATOMIC_RELAXED);
    store32(base_, NAVKIT_RCOMM_MAGIC_OFFSET, native32(NAVKIT_RCOMM_MAGIC), __ATOMIC_RELEASE);
}

void Comm::shutdown()
{
    if (base_) {
        munmap(base_, NAVKIT_RCOMM_SIZE);
        base_ = nullptr;
    }
    if (created_) {
        shm_unlink(name_.c_str());  // before the lock goes, so no one replaces it meanwhile
        created_ = false;
    }
    if (fd_ >= 0) {
        ::close(fd_);  // drops the lock
        fd_ = -1;
    }
}

bool Comm::read_lisp_cmd(navkit_lisp_cmd_t *out) const
{
    uint8_t b[NAVKIT_LISP_CMD_BYTES];
    bool ok = false;
    if (!guarded([&] { ok = seqlock_read(base_, NAVKIT_RCOMM_LISP_CMD_OFFSET, b, sizeof b); }) || !ok) {
        return false;
    }
    navkit_lisp_cmd_load(b, out);
    return true;
}

bool Comm::read_emotion(navkit_emotion_t *out) const
{
    uint8_t b[NAVKIT_EMOTION_BYTES];
    bool ok = false;
    if (!guarded([&] { ok = seqlock_read(base_, NAVKIT_RCOMM_EMOTION_OFFSET, b, sizeof b); }) || !ok) {
        return false;
    }
    navkit_emotion_load(b, out);
    return true;
}

void Comm::send_lisp_data(const navkit_lisp_data_t &d)
{
    uint8_t b[NAVKIT_LISP_DATA_BYTES];
    navkit_lisp_data_store(&d, b);
    guarded([&] { seqlock_write(base_, NAVKIT_RCOMM_LISP_DATA_OFFSET, b, sizeof b); });
}

uint32_t Comm::planner_heartbeat() const
{
    uint32_t v = 0;
    guarded([&] { v = le32(load32(base_, NAVKIT_RCOMM_PLANNER_HEARTBEAT_OFFSET, __ATOMIC_ACQUIRE)); });
    return v;
}

void Comm::set_host_heartbeat(uint32_t v)
{
    guarded([&] { store32(base_, NAVKIT_RCOMM_HOST_HEARTBEAT_OFFSET, native32(v), __ATOMIC_RELEASE); });
}

}  // namespace navkit
