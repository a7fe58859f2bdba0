// Frame scheduling arithmetic of the real-time clock (pure functions, unit-tested).
//
// Frame k starts at t0 + k * period: deadlines are absolute, so errors never accumulate.
// When frame k ends after the start of frame k+1 it is an overrun; the next frame run is
// the latest one whose start has passed (it starts at once, late), and every frame
// between is skipped, so late frames are never run back to back to catch up.
#pragma once

#include <cstdint>

namespace navkit {

struct Schedule {
    int64_t t0_ns = 0;
    int64_t period_ns = 100000000;
};

struct NextFrame {
    uint64_t frame = 0;   // the frame to run next
    uint64_t skipped = 0; // frames between the last and the next that are not run
    bool overrun = false; // the last frame ended after the next one should have started
};

// Start of frame k (ns on the same clock as t0_ns).
int64_t frame_start(const Schedule &s, uint64_t k);

// Frame k ended at now_ns: which frame runs next.
NextFrame next_frame(const Schedule &s, uint64_t k, int64_t now_ns);

// Period (ns) of a rate in Hz, rounded to the nearest ns.
int64_t period_ns_of(double hz);

} // namespace navkit
