// Comm: the seed's Comm class plus its RComm.dll, as POSIX shared memory laid out per
// docs/internals.md: header words, then the lisp_cmd, lisp_data and emotion slots, each
// behind a seqlock. The host creates the region (mode 0600, or 0660 with a group) and
// holds an flock() on it while it runs; it refuses a region owned by another user or
// locked by a running host, replaces a stale one of its user, and unlinks it at shutdown.
#pragma once

#include <cstdint>
#include <string>

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

class Comm {
public:
    Comm(std::string name, std::string group);
    ~Comm();
    // Create the region (and take its lock); throws std::runtime_error saying why not.
    void init();
    void shutdown();

    // ReadLispCmds: the planner's current lisp_cmd; false if none written yet or torn
    // (the seqlock kept changing for the whole bounded retry).
    bool read_lisp_cmd(navkit_lisp_cmd_t *out) const;
    bool read_emotion(navkit_emotion_t *out) const;
    // SendLispData: publish this frame's lisp_data.
    void send_lisp_data(const navkit_lisp_data_t &d);
    uint32_t planner_heartbeat() const;
    void set_host_heartbeat(uint32_t v);

    // Seqlock on a mapped slot (seq word at slot_off, then nbytes): exposed for tests.
    static bool seqlock_read(const uint8_t *base, size_t slot_off, uint8_t *out, size_t nbytes);
    static void seqlock_write(uint8_t *base, size_t slot_off, const uint8_t *in, size_t nbytes);

private:
    std::string name_, group_;
    uint8_t *base_ = nullptr;
    int fd_ = -1;            // the region, kept open for its lock
    bool created_ = false;
};

}  // namespace navkit
