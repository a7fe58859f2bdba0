// SerialPort on a pseudo-terminal: raw non-blocking I/O, and a vanished other end seen
// as "gone" (the unplug path), never as an endless stream of empty reads.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <fcntl.h>
#include <pty.h>
#include <unistd.h>

#include "navkit/serial_port.hpp"

using namespace navkit;

// Opens p on a fresh pty's slave end (default MicroCfg) and closes the slave, so the
// port holds the only descriptor of it; *master: the other end.
static void open_on_pty(SerialPort &p, int *master)
{
    int slave = -1;
    ASSERT_EQ(openpty(master, &slave, nullptr, nullptr, nullptr), 0);
    MicroCfg cfg;
    cfg.port = ttyname(slave);
    ASSERT_EQ(p.open(cfg), "");
    close(slave);
}

TEST(SerialPort, ReadsWritesAndSeesTheOtherEndVanish)
{
    int master = -1;
    SerialPort p;
    ASSERT_NO_FATAL_FAILURE(open_on_pty(p, &master));
    uint8_t buf[16];
    EXPECT_EQ(p.read_some(buf, sizeof buf), 0) << "nothing waiting: no wait, no error";
    ASSERT_EQ(write(master, "\xa5\xff\x01", 3), 3);
    EXPECT_EQ(p.read_some(buf, sizeof buf), 3);
    EXPECT_EQ(buf[0], 0xa5) << "raw: bytes pass untouched";
    const uint8_t out[4] = {1, 2, 3, 4};
    EXPECT_EQ(p.write_all(out, 4), 4);
    uint8_t got[4];
    EXPECT_EQ(read(master, got, 4), 4);
    close(master);
    EXPECT_EQ(p.read_some(buf, sizeof buf), -1) << "hang-up: the port is gone";
    EXPECT_FALSE(p.is_open());
}

TEST(SerialPort, AnExpectedReadGivesTheSameResults)
{
    // expect = true (lockstep: bytes on their way) reads before it polls: nothing waiting,
    // bytes, and a vanished other end come out as without it
    int master = -1;
    SerialPort p;
    ASSERT_NO_FATAL_FAILURE(open_on_pty(p, &master));
    uint8_t buf[16];
    EXPECT_EQ(p.read_some(buf, sizeof buf, true), 0) << "nothing waiting: no wait, no error";
    ASSERT_EQ(write(master, "\x01\x02", 2), 2);
    EXPECT_EQ(p.read_some(buf, sizeof buf, true), 2);
    EXPECT_EQ(buf[1], 0x02);
    close(master);
    EXPECT_EQ(p.read_some(buf, sizeof buf, true), -1) << "hang-up: the port is gone";
    EXPECT_FALSE(p.is_open());
}

TEST(SerialPort, MissingPathAndNotATty)
{
    MicroCfg cfg;
    cfg.port = "/nonexistent/ttyUSB9";
    SerialPort p;
    EXPECT_EQ(p.open(cfg), "/nonexistent/ttyUSB9: No such file or directory");
    cfg.port = "/dev/null";
    EXPECT_NE(p.open(cfg).find("not a serial port"), std::string::npos);
    cfg.port = "/dev/null";
    cfg.baud = 12345;
    EXPECT_EQ(p.open(cfg), "baud 12345 is not supported");
    EXPECT_EQ(latency_timer_path("/dev/null", DeviceRoots()), "") << "not an FTDI device";
}

TEST(SerialPort, EverySupportedBaudOpensAndLineSettingsAreSaid)
{
    int master = -1, slave = -1;
    ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    MicroCfg cfg;
    cfg.port = ttyname(slave);
    for (int b : supported_bauds()) {
        cfg.baud = b;
        SerialPort p;
        EXPECT_EQ(p.open(cfg), "") << b << " baud is in the INI's list, so SerialPort must map it";
    }
    cfg.baud = 57600;
    cfg.data_bits = 7;
    cfg.parity = 'E';
    cfg.stop_bits = 2;
    EXPECT_EQ(SerialPort::line_settings(cfg), "57600 baud 7E2");
    close(master);
    close(slave);
}
