// Port discovery: the tty of the micro link when [micro] port = auto, found by the USB
// ids the kernel lists under /sys, per link kind ([micro] link: serial, a USB-serial
// bridge to the micro's UART; slcan, a USB-CAN adapter speaking SLCAN). The one table of
// which USB ids mean what (usb_kinds()): `navkit-host --list-ports` prints what it finds
// as JSON, and `navkit flash` asks it. Also an FTDI adapter's latency timer file. Reads
// (and for the latency timer writes) only files under DeviceRoots; opens no tty.
#pragma once

#include <string>
#include <vector>

namespace navkit {

// Where discovery looks for devices: the roots of /dev and /sys (a test points them at a
// fake tree in a temporary folder).
struct DeviceRoots {
    std::string dev = "/dev";
    std::string sys = "/sys";
};

// A kind of USB device the micro link knows: USB vendor and product id (product -1: any
// product of the vendor not listed before it), its link kind and what it is.
struct UsbKind {
    unsigned vid;
    int pid;
    const char *link; // "serial" or "slcan"
    const char *name;
};

// The known kinds, specific products before a vendor's "any product" entry.
const std::vector<UsbKind> &usb_kinds();

// A tty on USB, as discovery saw it.
struct UsbPort {
    std::string path;    // what port = auto opens: the /dev/serial/by-id link if any, else <dev>/<tty>
    std::string dev;     // <dev>/<tty>
    std::string tty;     // kernel name (ttyACM0)
    std::string by_id;   // name of its /dev/serial/by-id link, "" if none
    std::string vid;     // USB vendor id, 4 hex digits as sysfs has them ("" if unknown)
    std::string pid;     // USB product id, likewise
    std::string product; // the device's USB product string ("" if none)
    std::string serial;  // the device's USB serial number ("" if none)
    std::string link;    // link kind of its ids (usb_kinds()): "serial", "slcan", "" none known
    std::string name;    // what its ids are (usb_kinds()), "" if none known
};

// Every USB tty: the <dev>/serial/by-id links (sorted by name), then the <sys>/class/tty
// entries named ttyUSB* or ttyACM* that no by-id link points at (sorted). A tty whose
// USB ids cannot be read is listed with empty ids (kind none).
std::vector<UsbPort> list_usb_ports(const DeviceRoots &roots);

// The USB ttys of link kind `link` ("serial" or "slcan").
std::vector<UsbPort> ports_of_link(const std::vector<UsbPort> &ports, const std::string &link);

// "/dev/ttyACM0 (Arduino Mega 2560 R3 [2341:0042] serial 85735)": a port for a message.
std::string port_text(const UsbPort &p);

// The one port of link kind `link` into *path: "" when exactly one is found, else why not,
// listing what was found ("no slcan-link port found (USB ttys: ...)", "several serial-link
// ports found: ...: give [micro] port or --port").
std::string find_port(const std::string &link, const DeviceRoots &roots, std::string *path);

// `navkit-host --list-ports`: JSON {"link": link or null, "ports": [...], "others": [...]}:
// the USB ttys of link kind `link` and the other USB ttys (with link "": every one in
// "ports"), each with the fields of UsbPort.
std::string ports_json(const std::string &link, const DeviceRoots &roots);

// <sys>/bus/usb-serial/devices/<tty>/latency_timer of tty path `dev`; "" if the device has
// none (not FTDI).
std::string latency_timer_path(const std::string &dev, const DeviceRoots &roots);

// Sets the latency timer (ms) of tty path `dev`, if it has one: "" when done or when the
// device has none, else what went wrong ("FTDI latency timer is 16 ms, could not set 1 ms
// (path)").
std::string set_latency_timer(const std::string &dev, const DeviceRoots &roots, int ms);

} // namespace navkit
