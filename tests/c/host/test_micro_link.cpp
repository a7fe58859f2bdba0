// MicroLink's shutdown write (host/src/micro_link.cpp): the stop goes out at once and whole,
// over the serial line and over CAN through an SLCAN adapter. The port is a pty; the
// adapter and the micro behind it are this test: it reads the host's SLCAN lines, plays the
// micro's ISO-TP receiver (protocol/runtime/navkit_isotp.c, the firmware's own) and answers
// its flow controls. Over CAN a command still waiting for its flow control must not hold
// the stop back: it is abandoned, and the micro's receiver restarts on the stop.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <poll.h>
#include <pty.h>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include "navkit/console.hpp"
#include "navkit/micro_link.hpp"
#include "navkit/slcan.hpp"

using namespace navkit;

namespace {

// The pty's adapter side: the host's frames as it wrote them, the micro's receiver.
struct Adapter {
    int master = -1;
    Slcan slcan;                              // the host's lines, read as an adapter reads them
    std::vector<navkit_isotp_frame_t> frames; // every frame the host sent
    navkit_isotp_rx_t rx{};
    std::vector<std::vector<uint8_t>> messages; // messages the micro's receiver completed

    Adapter() { navkit_isotp_rx_init(&rx, NAVKIT_DIR_TO_MICRO); }

    // Reads what the host wrote within wait_ms (ms); each frame through the micro's
    // receiver (the adapter's set-up commands are no frames). answer: its flow controls
    // go back to the host.
    void pump(int wait_ms, bool answer)
    {
        pollfd p{master, POLLIN, 0};
        while (poll(&p, 1, wait_ms) > 0) {
            uint8_t buf[512];
            const ssize_t n = read(master, buf, sizeof buf);
            if (n <= 0) {
                return;
            }
            std::vector<SlcanFrame> got;
            slcan.feed(buf, static_cast<size_t>(n), &got);
            for (const SlcanFrame &sf : got) {
                frame(sf, answer);
            }
            wait_ms = 20; // then only what follows at once
        }
    }

    void frame(const SlcanFrame &sf, bool answer)
    {
        navkit_isotp_frame_t f;
        f.id = static_cast<uint16_t>(sf.id);
        std::copy(sf.data, sf.data + 8, f.data);
        frames.push_back(f);
        navkit_isotp_frame_t fc;
        uint8_t fc_out = 0;
        const uint16_t n = navkit_isotp_rx_frame(&rx, f.id, f.data, sf.dlc, 0, &fc, &fc_out);
        if (n) {
            messages.emplace_back(rx.buf, rx.buf + n);
        }
        if (fc_out && answer) {
            const std::string back = Slcan::frame_command(fc.id, fc.data);
            ASSERT_EQ(write(master, back.data(), back.size()), static_cast<ssize_t>(back.size()));
        }
    }
};

// A micro_cmd frame: fwd_cmd / turn_cmd and time tag as given, the rest the spec's defaults.
std::vector<uint8_t> command(uint16_t fwd, uint16_t turn, uint16_t tag)
{
    navkit_micro_cmd_t m;
    navkit_micro_cmd_defaults(&m);
    m.fwd_cmd = fwd;
    m.turn_cmd = turn;
    m.time_tag = tag;
    std::vector<uint8_t> buf(NAVKIT_MAX_FRAME_BYTES);
    buf.resize(navkit_micro_cmd_encode(&m, buf.data(), buf.size()));
    return buf;
}

class MicroLinkStop : public ::testing::Test {
protected:
    void SetUp() override
    {
        int slave = -1;
        ASSERT_EQ(openpty(&ad_.master, &slave, nullptr, nullptr, nullptr), 0);
        cfg_.port = ttyname(slave);
        cfg_.latency_timer_ms = 0;
        close(slave);
        out_ = std::tmpfile();
        con_ = new Console(out_, -1, 1.0);
    }
    void TearDown() override
    {
        delete con_;
        std::fclose(out_);
        close(ad_.master);
    }
    MicroCfg cfg_;
    Adapter ad_;
    std::FILE *out_ = nullptr;
    Console *con_ = nullptr;
};

// ms of the monotonic clock since t0
double ms_since(std::chrono::steady_clock::time_point t0)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

TEST_F(MicroLinkStop, OverCanTheStopPreEmptsACommandWaitingForItsFlowControl)
{
    cfg_.link = "slcan";
    MicroLink link(cfg_, *con_);
    ASSERT_TRUE(link.open(true));
    link.begin_frame(100000); // the adapter's set-up
    const std::vector<uint8_t> drive = command(NAVKIT_FWD_CMD_START, 0, 7);
    ASSERT_TRUE(link.write_frame(drive.data(), drive.size()));
    ad_.pump(200, false); // its first frame; the micro answers nothing yet
    ASSERT_EQ(ad_.frames.size(), 1u);
    EXPECT_EQ(ad_.frames[0].data[0] >> 4, 1) << "a first frame: micro_cmd needs a flow control";
    EXPECT_TRUE(ad_.rx.active) << "the micro is receiving the command";

    const std::vector<uint8_t> stop = command(NAVKIT_FWD_CMD_STOP, NAVKIT_TURN_CMD_STOP, 8);
    std::thread micro([this] { ad_.pump(3000, true); }); // from now on it answers
    const auto t0 = std::chrono::steady_clock::now();
    const bool sent = link.write_frame_now(stop.data(), stop.size());
    const double took = ms_since(t0);
    micro.join();
    EXPECT_TRUE(sent) << link.unsent_reason();
    EXPECT_EQ(link.unsent_reason(), "");
    EXPECT_LT(took, NAVKIT_CAN_N_BS_MS / 2.0) << "the stop did not wait N_Bs behind the command";
    EXPECT_EQ(link.tx_aborted(), 1u) << "the command was abandoned, and counted";
    EXPECT_EQ(ad_.rx.stats.restarted, 1u) << "the micro dropped the command's part on the stop's first frame";
    ASSERT_EQ(ad_.messages.size(), 1u) << "the stop, and nothing of the command, arrived whole";
    EXPECT_EQ(ad_.messages[0], stop);
    navkit_micro_cmd_t m;
    ASSERT_EQ(navkit_micro_cmd_decode(ad_.messages[0].data(), ad_.messages[0].size(), &m), NAVKIT_OK);
    EXPECT_EQ(m.fwd_cmd, NAVKIT_FWD_CMD_STOP);
    EXPECT_EQ(m.turn_cmd, NAVKIT_TURN_CMD_STOP);
    // the last frame on the wire is the stop's last consecutive frame
    EXPECT_EQ(ad_.frames.back().id, NAVKIT_CAN_ID_MICRO_CMD);
    EXPECT_EQ(ad_.frames.back().data[0] >> 4, 2);
}

TEST_F(MicroLinkStop, OverCanACommandWhoseFlowControlCameEndsBeforeTheStop)
{
    cfg_.link = "slcan";
    MicroLink link(cfg_, *con_);
    ASSERT_TRUE(link.open(true));
    link.begin_frame(100000);
    const std::vector<uint8_t> drive = command(NAVKIT_FWD_CMD_START, 0, 7);
    ASSERT_TRUE(link.write_frame(drive.data(), drive.size()));
    ad_.pump(200, true); // its first frame, answered: the flow control waits in the port
    const std::vector<uint8_t> stop = command(NAVKIT_FWD_CMD_STOP, NAVKIT_TURN_CMD_STOP, 8);
    std::thread micro([this] { ad_.pump(3000, true); });
    const bool sent = link.write_frame_now(stop.data(), stop.size());
    micro.join();
    EXPECT_TRUE(sent) << link.unsent_reason();
    EXPECT_EQ(link.tx_aborted(), 0u) << "nothing abandoned: the command had what it needed";
    EXPECT_EQ(ad_.rx.stats.restarted, 0u);
    ASSERT_EQ(ad_.messages.size(), 2u);
    EXPECT_EQ(ad_.messages[0], drive);
    EXPECT_EQ(ad_.messages[1], stop) << "the stop last";
}

TEST_F(MicroLinkStop, OverCanANeverAnsweredStopIsSaidUnsentAfterNBs)
{
    cfg_.link = "slcan";
    MicroLink link(cfg_, *con_);
    ASSERT_TRUE(link.open(true));
    link.begin_frame(0);
    const std::vector<uint8_t> stop = command(NAVKIT_FWD_CMD_STOP, NAVKIT_TURN_CMD_STOP, 2);
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_FALSE(link.write_frame_now(stop.data(), stop.size()));
    const double took = ms_since(t0);
    EXPECT_GE(took, NAVKIT_CAN_N_BS_MS - 20.0);
    EXPECT_LT(took, 2.0 * NAVKIT_CAN_N_BS_MS);
    EXPECT_EQ(link.unsent_reason(),
              "no flow control from the micro within N_Bs (" + std::to_string(NAVKIT_CAN_N_BS_MS) + " ms)");
    EXPECT_EQ(link.tx_aborted(), 0u) << "nothing was going out";
}

TEST_F(MicroLinkStop, OverSerialTheStopGoesOutWhole)
{
    MicroLink link(cfg_, *con_);
    ASSERT_TRUE(link.open(true));
    link.begin_frame(0);
    const std::vector<uint8_t> stop = command(NAVKIT_FWD_CMD_STOP, NAVKIT_TURN_CMD_STOP, 3);
    EXPECT_TRUE(link.write_frame_now(stop.data(), stop.size()));
    EXPECT_TRUE(link.finish_now()) << "nothing is left going out on a serial line";
    std::vector<uint8_t> got(stop.size() + 16);
    pollfd p{ad_.master, POLLIN, 0};
    ASSERT_GT(poll(&p, 1, 1000), 0);
    EXPECT_EQ(read(ad_.master, got.data(), got.size()), static_cast<ssize_t>(stop.size()));
    got.resize(stop.size());
    EXPECT_EQ(got, stop);
    link.close();
    EXPECT_FALSE(link.write_frame_now(stop.data(), stop.size()));
    EXPECT_EQ(link.unsent_reason(), "the port is closed");
}
