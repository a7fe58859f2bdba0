// Port discovery on a fake /dev and /sys (the kernel's layout in a temporary folder): the
// port of each link kind by its USB ids, none or several found said with what was seen,
// the --list-ports JSON and its options, and MicroUsb opening the one it finds.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>
#include <fcntl.h>
#include <pty.h>
#include <unistd.h>

#include "navkit/console.hpp"
#include "navkit/micro_usb.hpp"
#include "navkit/options.hpp"
#include "navkit/port_discovery.hpp"

using namespace navkit;

// A fake /dev and /sys in a temporary folder: an FTDI adapter whose by-id link points at
// a pty (so it really opens), a CANable (an SLCAN adapter) listed before it, and the
// FTDI's latency_timer. add_usb() adds more devices.
class FakeDevices : public ::testing::Test {
protected:
    void SetUp() override
    {
        char tmpl[] = "/tmp/navkit-devXXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        root_ = tmpl;
        ASSERT_EQ(openpty(&master_, &slave_, nullptr, nullptr, nullptr), 0);
        pts_ = ttyname(slave_);
        tty_ = pts_.substr(pts_.rfind('/') + 1); // the pty's number: its "tty name" in the fake sysfs
        roots_.dev = root_ + "/dev";
        roots_.sys = root_ + "/sys";
        sh("mkdir -p " + roots_.dev + "/serial/by-id " + roots_.sys + "/class/tty " + roots_.sys +
           "/devices/usb1/1-1/1-1:1.0/ttyUSB0 " + roots_.sys + "/devices/usb1/1-2/1-2:1.0/ttyUSB1 " + roots_.sys +
           "/bus/usb-serial/devices/" + tty_);
        sh("echo 0403 > " + roots_.sys + "/devices/usb1/1-1/idVendor && echo 6001 > " + roots_.sys +
           "/devices/usb1/1-1/idProduct");
        sh("echo 16d0 > " + roots_.sys + "/devices/usb1/1-2/idVendor");
        sh("echo 117e > " + roots_.sys + "/devices/usb1/1-2/idProduct");
        // the pty is the FTDI's (0403:6001) tty; ttyOTHER is a CANable (16d0:117e), listed first by name
        sh("mkdir " + roots_.sys + "/class/tty/" + tty_ + " && ln -s ../../../devices/usb1/1-1/1-1:1.0 " + roots_.sys +
           "/class/tty/" + tty_ + "/device");
        sh("mkdir " + roots_.sys + "/class/tty/ttyOTHER && ln -s ../../../devices/usb1/1-2/1-2:1.0 " + roots_.sys +
           "/class/tty/ttyOTHER/device");
        sh("touch " + roots_.dev + "/ttyOTHER && ln -s ../../ttyOTHER " + roots_.dev +
           "/serial/by-id/usb-Protofusion_Labs_CANable-if00");
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
    // A USB CDC ACM device (its tty's sysfs device is the USB interface, the ids one folder
    // up) on bus port n: <sys>/class/tty/<tty>, <dev>/<tty>, and a by-id link if by_id.
    void add_acm(int n, const std::string &tty, const std::string &vid, const std::string &pid,
                 const std::string &by_id = "")
    {
        const std::string usb = roots_.sys + "/devices/usb2/2-" + std::to_string(n);
        sh("mkdir -p " + usb + "/2-" + std::to_string(n) + ":1.0/tty/" + tty + " " + roots_.sys + "/class/tty/" + tty);
        sh("echo " + vid + " > " + usb + "/idVendor && echo " + pid + " > " + usb + "/idProduct && echo 85735 > " +
           usb + "/serial");
        sh("ln -s ../../../devices/usb2/2-" + std::to_string(n) + "/2-" + std::to_string(n) + ":1.0 " + roots_.sys +
           "/class/tty/" + tty + "/device && touch " + roots_.dev + "/" + tty);
        if (!by_id.empty()) {
            sh("ln -s ../../" + tty + " " + roots_.dev + "/serial/by-id/" + by_id);
        }
    }
    std::string root_, pts_, tty_;
    DeviceRoots roots_;
    int master_ = -1, slave_ = -1;
};

TEST_F(FakeDevices, FindsTheFtdiByIdAndSetsItsLatencyTimer)
{
    std::string path;
    EXPECT_EQ(find_port("serial", roots_, &path), "");
    EXPECT_EQ(path, roots_.dev + "/serial/by-id/usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0")
        << "VID 0403 through the tty's sysfs parent; the CANable (an slcan adapter) is passed over";
    EXPECT_EQ(latency_timer_path(pts_, roots_), roots_.sys + "/bus/usb-serial/devices/" + tty_ + "/latency_timer");
    EXPECT_EQ(find_port("serial", DeviceRoots{root_ + "/none", root_ + "/none"}, &path),
              "no serial-link port found (no USB tty at all; the USB ids of each link are listed by "
              "navkit-host --list-ports)")
        << "nothing there";

    std::FILE *out = std::tmpfile();
    Console con(out, -1, 1.0);
    MicroCfg cfg; // port = auto, link = serial, latency_timer_ms = 1
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
    std::string path;
    EXPECT_EQ(find_port("serial", roots_, &path), "");
    EXPECT_EQ(path, roots_.dev + "/ttyUSB7");
}

TEST_F(FakeDevices, AMegaOnTtyAcmIsASerialPortByEitherVendor)
{
    sh("rm " + roots_.dev + "/serial/by-id/usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0 && rm -r " + roots_.sys +
       "/class/tty/" + tty_);
    add_acm(1, "ttyACM0", "2341", "0042", "usb-Arduino__www.arduino.cc__0042_85735-if00");
    std::string path;
    EXPECT_EQ(find_port("serial", roots_, &path), "");
    EXPECT_EQ(path, roots_.dev + "/serial/by-id/usb-Arduino__www.arduino.cc__0042_85735-if00");
    const std::vector<UsbPort> ports = list_usb_ports(roots_);
    ASSERT_EQ(ports.size(), 2u) << "the Mega and the CANable, each once (by-id and sysfs name one tty)";
    EXPECT_EQ(ports[0].tty, "ttyACM0");
    EXPECT_EQ(ports[0].dev, roots_.dev + "/ttyACM0");
    EXPECT_EQ(ports[0].name, "Arduino Mega 2560 R3");
    EXPECT_EQ(ports[0].serial, "85735");

    sh("rm " + roots_.dev + "/serial/by-id/usb-Arduino__www.arduino.cc__0042_85735-if00");
    sh("echo 2a03 > " + roots_.sys + "/devices/usb2/2-1/idVendor");
    EXPECT_EQ(find_port("serial", roots_, &path), "");
    EXPECT_EQ(path, roots_.dev + "/ttyACM0") << "the arduino.org Mega (2a03) through /sys/class/tty";
}

TEST_F(FakeDevices, SlcanAdaptersAreFoundByTheirIdsAndCanusbIsNoSerialPort)
{
    std::string path;
    EXPECT_EQ(find_port("slcan", roots_, &path), "");
    EXPECT_EQ(path, roots_.dev + "/serial/by-id/usb-Protofusion_Labs_CANable-if00") << "CANable 16d0:117e";

    sh("rm " + roots_.dev + "/serial/by-id/usb-Protofusion_Labs_CANable-if00");
    sh("echo 04d8 > " + roots_.sys + "/devices/usb1/1-2/idVendor && echo 000a > " + roots_.sys +
       "/devices/usb1/1-2/idProduct");
    sh("mv " + roots_.sys + "/class/tty/ttyOTHER " + roots_.sys + "/class/tty/ttyACM3");
    EXPECT_EQ(find_port("slcan", roots_, &path), "");
    EXPECT_EQ(path, roots_.dev + "/ttyACM3") << "USBtin 04d8:000a";

    // a Lawicel CANUSB is an FTDI chip with its own product id: slcan, not serial
    sh("echo ffa8 > " + roots_.sys + "/devices/usb1/1-1/idProduct");
    const std::string none = find_port("serial", roots_, &path);
    EXPECT_EQ(none.find("no serial-link port found (USB ttys: "), 0u) << none;
    EXPECT_NE(none.find("[0403:ffa8]"), std::string::npos) << none;
    EXPECT_EQ(find_port("slcan", roots_, &path).find("several slcan-link ports found: "), 0u);
}

TEST_F(FakeDevices, MicroUsbWithLinkSlcanOpensTheOneCanAdapter)
{
    // the pty becomes a Lawicel CANUSB (FTDI 0403:ffa8); the CANable is unplugged
    sh("echo ffa8 > " + roots_.sys + "/devices/usb1/1-1/idProduct");
    sh("rm " + roots_.dev + "/serial/by-id/usb-Protofusion_Labs_CANable-if00 && rm -r " + roots_.sys +
       "/class/tty/ttyOTHER");
    std::FILE *out = std::tmpfile();
    Console con(out, -1, 1.0);
    MicroCfg cfg;
    cfg.link = "slcan";
    MicroUsb micro(cfg, con, roots_);
    micro.init();
    EXPECT_TRUE(micro.port_open()) << "port = auto, link = slcan: the CANUSB";
    EXPECT_EQ(slurp(roots_.sys + "/bus/usb-serial/devices/" + tty_ + "/latency_timer"), "1\n")
        << "an FTDI-based adapter's latency timer is set too";
    micro.shutdown();
    MicroCfg serial;
    MicroUsb none(serial, con, roots_);
    none.init();
    EXPECT_FALSE(none.port_open()) << "link = serial: no port of that kind";
    std::fclose(out);
}

TEST_F(FakeDevices, SeveralFoundAreListedAndNoneFoundSaysWhatWasSeen)
{
    add_acm(1, "ttyACM0", "2341", "0042");
    std::string path = "unchanged";
    const std::string several = find_port("serial", roots_, &path);
    EXPECT_EQ(
        several,
        "several serial-link ports found: " + roots_.dev +
            "/serial/by-id/usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0 (FTDI USB-serial [0403:6001], link serial), " +
            roots_.dev +
            "/ttyACM0 (Arduino Mega 2560 R3 [2341:0042] serial 85735, link serial): " + "give [micro] port or --port");
    EXPECT_EQ(path, "unchanged");

    std::FILE *out = std::tmpfile();
    Console con(out, -1, 1.0);
    MicroCfg cfg;
    MicroUsb micro(cfg, con, roots_);
    micro.init();
    EXPECT_FALSE(micro.port_open()) << "several: none is taken";
    micro.shutdown();
    std::fclose(out);

    sh("rm -r " + roots_.sys + "/class/tty/ttyACM0 " + roots_.dev + "/serial/by-id/usb-FTDI*");
    EXPECT_EQ(find_port("serial", roots_, &path),
              "no serial-link port found (USB ttys: " + roots_.dev +
                  "/serial/by-id/usb-Protofusion_Labs_CANable-if00 (CANable (slcan firmware) [16d0:117e], link slcan); "
                  "the USB ids of each link are listed by navkit-host --list-ports)");
}

TEST_F(FakeDevices, PortsJsonListsTheLinksPortsThenTheOthers)
{
    add_acm(1, "ttyACM0", "2341", "0010");
    const std::string j = ports_json("slcan", roots_);
    const size_t ports = j.find("\"ports\": ["), others = j.find("\"others\": [");
    ASSERT_NE(ports, std::string::npos) << j;
    ASSERT_NE(others, std::string::npos) << j;
    EXPECT_EQ(j.find("\"link\": \"slcan\""), 4u) << j;
    const size_t canable = j.find("\"name\": \"CANable (slcan firmware)\""),
                 mega = j.find("\"name\": \"Arduino Mega 2560\"");
    EXPECT_TRUE(ports < canable && canable < others) << j;
    EXPECT_GT(mega, others) << j;
    EXPECT_NE(j.find("\"dev\": \"" + roots_.dev + "/ttyACM0\""), std::string::npos) << j;
    EXPECT_NE(ports_json("", roots_).find("\"link\": null"), std::string::npos);
    EXPECT_NE(ports_json("", roots_).find("\"others\": []"), std::string::npos) << "no link: every port in ports";
}

TEST(ListPorts, TakesOnlyLinkAndDevRoot)
{
    auto parse = [](std::vector<const char *> args, Options *o) {
        args.insert(args.begin(), "navkit-host");
        return parse_options(static_cast<int>(args.size()), const_cast<char **>(args.data()), o);
    };
    Options o;
    EXPECT_EQ(parse({"--list-ports", "--link", "slcan", "--dev-root", "/tmp/x"}, &o), "");
    EXPECT_TRUE(o.list_ports);
    EXPECT_EQ(o.link, "slcan");
    EXPECT_EQ(o.dev_root, "/tmp/x");
    Options p;
    EXPECT_EQ(parse({"--list-ports", "--port", "auto"}, &p),
              "--port has no effect with --list-ports (it only lists the USB ttys)");
    Options q;
    EXPECT_EQ(parse({"--dev-root", "/tmp/x"}, &q), "--dev-root needs --list-ports");
    Options r;
    EXPECT_EQ(parse({"--list-ports", "--link", "can"}, &r).find("--link: "), 0u) << "the link's own rule";
}
