#include "navkit/schedule.hpp"

#include <cmath>

namespace navkit {

int64_t frame_start(const Schedule &s, uint64_t k)
{
    return s.t0_ns + static_cast<int64_t>(k) * s.period_ns;
}

NextFrame next_frame(const Schedule &s, uint64_t k, int64_t now_ns)
{
    NextFrame n;
    n.frame = k + 1;
    if (now_ns <= frame_start(s, k + 1)) {
        return n; // on time: sleep until frame k+1
    }
    n.overrun = true;
    // the latest frame whose start has passed runs now; the ones before it are skipped
    const uint64_t latest = static_cast<uint64_t>((now_ns - s.t0_ns) / s.period_ns);
    n.frame = latest;
    n.skipped = latest - (k + 1);
    return n;
}

int64_t period_ns_of(double hz)
{
    return static_cast<int64_t>(std::llround(1e9 / hz));
}

} // namespace navkit
