// Port discovery: the tty of the micro link when [micro] port = auto, found from the USB
// ids the kernel lists under /sys, and an FTDI adapter's latency timer file. Reads (and for
// the latency timer writes) only files under DeviceRoots; opens no tty.
#pragma once

#include <string>

namespace navkit {

// Where discovery looks for devices: the roots of /dev and /sys (a test points them at a
// fake tree in a temporary folder).
struct DeviceRoots {
    std::string dev = "/dev";
    std::string sys = "/sys";
};

// First FTDI (USB VID 0403) tty: <dev>/serial/by-id, then <sys>/class/tty; "" if none.
std::string find_ftdi(const DeviceRoots &roots);

// <sys>/bus/usb-serial/devices/<tty>/latency_timer of tty path `dev`; "" if the device has
// none (not FTDI).
std::string latency_timer_path(const std::string &dev, const DeviceRoots &roots);

// Sets the latency timer (ms) of tty path `dev`, if it has one: "" when done or when the
// device has none, else what went wrong ("FTDI latency timer is 16 ms, could not set 1 ms
// (path)").
std::string set_latency_timer(const std::string &dev, const DeviceRoots &roots, int ms);

}  // namespace navkit
