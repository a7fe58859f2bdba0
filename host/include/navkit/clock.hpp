// The executive's clocks: real time (absolute deadlines, schedule.hpp) and lockstep
// (docs/internals.md "Lockstep channel": one frame per tick of an external driver).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "navkit/schedule.hpp"

namespace navkit {

struct FrameTick {
    uint64_t frame = 0;
    int64_t time_us = 0; // the frame's time: scheduled start since t0, or sim_time_us
    long rx_bytes = -1;  // lockstep: serial bytes the driver wrote since the last tick; -1: real time
};

class Clock {
public:
    virtual ~Clock() = default;
    // Blocks until the next frame may start; false = shut down (signal, EOF, error).
    virtual bool wait_frame(FrameTick *tick) = 0;
    // The frame has ended: tx_bytes written to the port in it; flags bit 0 quitting, bit 1 port closed.
    virtual void frame_done(uint32_t tx_bytes, uint32_t flags) = 0;
    virtual uint64_t overruns() const = 0;
    virtual uint64_t skipped() const = 0;
    // Why wait_frame() returned false, "" for a signal or EOF.
    virtual std::string error() const = 0;
};

// The number of a signal that asks the process to end (every one whose default action
// ends it: SIGHUP, SIGINT, SIGQUIT, SIGTERM, SIGUSR1, ...; not a kernel fault); every
// blocking wait returns when it is set.
extern volatile int g_quit_signal;
void install_signal_handlers();

class RealClock : public Clock {
public:
    // timing_log: "" or a file getting one line per frame: frame, scheduled, start and end (ns since t0).
    RealClock(double rate_hz, const std::string &timing_log);
    ~RealClock() override;
    bool wait_frame(FrameTick *tick) override;
    void frame_done(uint32_t tx_bytes, uint32_t flags) override;
    uint64_t overruns() const override { return overruns_; }
    uint64_t skipped() const override { return skipped_; }
    std::string error() const override { return error_; }

private:
    Schedule sched_;
    bool started_ = false;
    uint64_t frame_ = 0;
    int64_t start_ns_ = 0;
    uint64_t overruns_ = 0, skipped_ = 0;
    std::FILE *timing_ = nullptr;
    std::string error_;
};

class LockstepClock : public Clock {
public:
    explicit LockstepClock(int fd);
    ~LockstepClock() override;
    bool wait_frame(FrameTick *tick) override;
    void frame_done(uint32_t tx_bytes, uint32_t flags) override;
    uint64_t overruns() const override { return 0; }
    uint64_t skipped() const override { return 0; }
    std::string error() const override { return error_; }

private:
    int fd_;
    uint32_t frame_ = 0;
    std::string error_;
};

} // namespace navkit
