// SerialPort on a pseudo-terminal: raw non-blocking I/O, and a vanished other end seen
// as "gone" (the unplug path), never as an endless stream of empty reads.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <fcntl.h>
#include <pty.h>
#include <unistd.h>

#include "navkit/console.hpp"
#include "navkit/micro_usb.hpp"

using namespace navkit;

TEST(SerialPort, ReadsWritesAndSeesTheOtherEndVanish)
{
    int master = -1, slave = -1;
    ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    MicroCfg cfg;
    cfg.port = ttyname(slave);
    SerialPort p;
    ASSERT_EQ(p.open(cfg), "");
    close(slave);  // the port keeps its own descriptor
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

// A fake /dev and /sys in a temporary folder: an FTDI adapter whose by-id link points at
// a pty (so it really opens), a non-FTDI one before it, and the FTDI's latency_timer.
class FakeDevices : public ::testing::Test {
protected:
    void SetUp() override
    {
        char tmpl[] = "/tmp/navkit-devXXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        root_ = tmpl;
        ASSERT_EQ(openpty(&master_, &slave_, nullptr, nullptr, nullptr), 0);
        pts_ = ttyname(slave_);
        tty_ = pts_.substr(pts_.rfind('/') + 1);  // the pty's number: its "tty name" in the fake sysfs
        roots_.dev = root_ + "/dev";
        roots_.sys = root_ + "/sys";
        sh("mkdir -p " + roots_.dev + "/serial/by-id " + roots_.sys + "/class/tty " + roots_.sys +
           "/devices/usb1/1-1/1-1:1.0/ttyUSB0 " + roots_.sys + "/devices/usb1/1-2/1-2:1.0/ttyUSB1 " + roots_.sys +
           "/bus/usb-serial/devices/" + tty_);
        sh("echo 0403 > " + roots_.sys + "/devices/usb1/1-1/idVendor");
        sh("echo 1a86 > " + roots_.sys + "/devices/usb1/1-2/idVendor");
        // the pty is the FTDI's tty; ttyOTHER is a CH340 (VID 1a86), listed first by name
        sh("mkdir " + roots_.sys + "/class/tty/" + tty_ + " && ln -s ../../../devices/usb1/1-1/1-1:1.0 " +
           roots_.sys + "/class/tty/" + tty_ + "/device");
        sh("mkdir " + roots_.sys + "/class/tty/ttyOTHER && ln -s ../../../devices/usb1/1-2/1-2:1.0 " + roots_.sys +
           "/class/tty/ttyOTHER/device");
        sh("touch " + roots_.dev + "/ttyOTHER && ln -s ../../ttyOTHER " + roots_.dev +
           "/serial/by-id/usb-1a86_USB_Serial-if00-port0");
        sh("ln -s " + pts_ + " " + roots_.dev + "/serial/by-id/usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0");
        sh("echo 16 > " + roots_.sys + "/bus/usb-serial/devices/" + tty_ + "/latency_timer");
    }
    void TearDown() override
    {
        close(master_);
        close(slave_);
        sh("rm -rf " + root_);
    }
    static void sh(const std::string &cmd) { ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd; }
    static std::string slurp(const std::string &p)
    {
        std::string s;
        if (FILE *f = std::fopen(p.c_str(), "r")) {
            char b[64];
            s.assign(b, std::fread(b, 1, sizeof b, f));
            std::fclose(f);
        }
        return s;
    }
    std::string root_, pts_, tty_;
    DeviceRoots roots_;
    int master_ = -1, slave_ = -1;
};

TEST_F(FakeDevices, FindsTheFtdiByIdAndSetsItsLatencyTimer)
{
    EXPECT_EQ(find_ftdi(roots_), roots_.dev + "/serial/by-id/usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0")
        << "VID 0403 through the tty's sysfs parent; the VID 1a86 adapter is passed over";
    EXPECT_EQ(latency_timer_path(pts_, roots_),
              roots_.sys + "/bus/usb-serial/devices/" + tty_ + "/latency_timer");
    EXPECT_EQ(find_ftdi(DeviceRoots{root_ + "/none", root_ + "/none"}), "") << "nothing there";

    std::FILE *out = std::tmpfile();
    Console con(out, -1, 1.0);
    MicroCfg cfg;  // port = auto, latency_timer_ms = 1
    MicroUsb micro(cfg, con, roots_);
    micro.init();
    EXPECT_TRUE(micro.port_open());
    EXPECT_EQ(slurp(roots_.sys + "/bus/usb-serial/devices/" + tty_ + "/latency_timer"), "1\n")
        << "the FTDI latency timer is set to 1 ms at open";
    micro.shutdown();
    std::fclose(out);
}

TEST_F(FakeDevices, FallsBackToSysClassTtyWithoutById)
{
    sh("rm -r " + roots_.dev + "/serial");
    sh("mkdir " + roots_.sys + "/class/tty/ttyUSB7 && ln -s ../../../devices/usb1/1-1/1-1:1.0 " + roots_.sys +
       "/class/tty/ttyUSB7/device");
    EXPECT_EQ(find_ftdi(roots_), roots_.dev + "/ttyUSB7");
}
