// Comm: the seed's Comm class plus its RComm.dll, as POSIX shared memory laid out per
// docs/internals.md: header words, then the lisp_cmd, lisp_data and emotion slots, each
// behind a seqlock (planner/include/navkit_rcomm_slot.h, the planner library's own code).
// The host creates the region (mode 0600, or 0660 with a group) and holds an flock() on
// it while it runs; it refuses a region owned by another user or locked by a running
// host, replaces a stale one of its user, and unlinks it at shutdown.
// A region another process cut short (ftruncate) is let go, never a SIGBUS. The order:
// begin_frame() checks the region's size once at the start of each frame, before the
// frame's accesses; each access then runs under a SIGBUS guard (comm.cpp), so a cut that
// takes an accessed page away lets the region go at that access. A cut after the frame's
// check that leaves the accessed page in the file (the region fits in one page: a cut to
// 1 byte or more) reads zeros past the new end, and writes there are lost, until the next
// frame's check lets the region go.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

extern "C" {
#include "navkit/navkit_proto.h"
}
#include "navkit_rcomm_slot.h"

namespace navkit {

class Comm {
public:
    Comm(std::string name, std::string group);
    ~Comm();
    // Create the region (and take its lock); throws std::runtime_error saying why not.
    void init();
    void shutdown();
    // The size check of a frame, before its accesses: false (and the region let go, lost()
    // says why) if another process cut it shorter than the layout; false when already lost.
    bool begin_frame();

    // ReadLispCmds: the planner's current lisp_cmd; false if none written yet or torn
    // (the seqlock kept changing for the whole bounded retry).
    bool read_lisp_cmd(navkit_lisp_cmd_t *out) const;
    bool read_emotion(navkit_emotion_t *out) const;
    // SendLispData: publish this frame's lisp_data.
    void send_lisp_data(const navkit_lisp_data_t &d);
    uint32_t planner_heartbeat() const;
    void set_host_heartbeat(uint32_t v);
    // "" while the region is usable; else why it was let go (cut short by another
    // process): every access since reads nothing and writes nothing.
    const std::string &lost() const { return lost_; }
    // Called before each access, after the frame's size check (tests: another process
    // cutting the region in that moment); empty by default.
    void set_between_check_and_access(std::function<void()> f) { between_ = std::move(f); }

private:
    // Runs access() on the mapping and returns true; false (and the region let go, lost()
    // says why) if the access faults on a page the region no longer has, or it was let go.
    template <class F> bool guarded(F access) const;
    // Reads the n words of the seqlocked slot at byte offset `slot` into w; false if the
    // region is lost or no consistent copy came within the slot's retries.
    bool read_slot(size_t slot, int32_t *w, size_t n) const;
    // Lets the region go; lost() names the size (bytes) it has now.
    void lose() const;

    std::string name_, group_;
    mutable uint8_t *base_ = nullptr; // nullptr: not mapped (before init, after shutdown or lose)
    mutable std::string lost_;
    std::function<void()> between_;
    int fd_ = -1; // the region, kept open for its lock
    bool created_ = false;
};

} // namespace navkit
