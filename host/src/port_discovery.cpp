#include "navkit/port_discovery.hpp"

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <dirent.h>
#include <fstream>
#include <unistd.h>
#include <utility>
#include <vector>

#include "navkit/json.hpp"

namespace navkit {

static std::string read_line(const std::string &path)
{
    std::ifstream f(path);
    std::string s;
    std::getline(f, s);
    return s;
}

static std::string real_path(const std::string &p)
{
    char buf[PATH_MAX];
    return realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

static std::string base_name(const std::string &p)
{
    const size_t s = p.rfind('/');
    return s == std::string::npos ? p : p.substr(s + 1);
}

static std::vector<std::string> list_dir(const std::string &dir)
{
    std::vector<std::string> out;
    DIR *d = opendir(dir.c_str());
    if (!d) {
        return out;
    }
    while (dirent *e = readdir(d)) {
        if (e->d_name[0] != '.') {
            out.push_back(e->d_name);
        }
    }
    closedir(d);
    std::sort(out.begin(), out.end());
    return out;
}

// clang-format off
static const std::vector<UsbKind> kKinds = {
    {0x2341, 0x0010, "serial", "Arduino Mega 2560"},
    {0x2341, 0x0042, "serial", "Arduino Mega 2560 R3"},
    {0x2a03, 0x0010, "serial", "Arduino Mega 2560 (arduino.org)"},
    {0x2a03, 0x0042, "serial", "Arduino Mega 2560 R3 (arduino.org)"},
    {0x1a86, 0x7523, "serial", "CH340 USB-serial (Mega clones)"},
    {0x10c4, 0xea60, "serial", "CP210x USB-serial"},
    {0x16d0, 0x117e, "slcan",  "CANable (slcan firmware)"},
    {0x04d8, 0x000a, "slcan",  "USBtin"},
    {0x0403, 0xffa8, "slcan",  "Lawicel CANUSB"},
    {0x0403, -1,     "serial", "FTDI USB-serial"},
};
// clang-format on

const std::vector<UsbKind> &usb_kinds()
{
    return kKinds;
}

// Hex id of sysfs (4 digits), -1 if `s` is none.
static long hex_id(const std::string &s)
{
    char *end = nullptr;
    const long v = std::strtol(s.c_str(), &end, 16);
    return s.empty() || *end ? -1 : v;
}

// The USB ids, product and serial of tty `p.tty`: the first of the sysfs device's folder
// and its parents (a ttyACM's device is the USB interface, a ttyUSB's the usb-serial port
// below it) that holds idVendor; then its kind from kKinds.
static void read_usb_ids(const DeviceRoots &roots, UsbPort *p)
{
    std::string d = real_path(roots.sys + "/class/tty/" + p->tty + "/device");
    for (int up = 0; up < 3 && !d.empty(); up++) {
        const std::string vid = read_line(d + "/idVendor");
        if (!vid.empty()) {
            p->vid = vid;
            p->pid = read_line(d + "/idProduct");
            p->product = read_line(d + "/product");
            p->serial = read_line(d + "/serial");
            break;
        }
        d = d.substr(0, d.rfind('/'));
    }
    const long vid = hex_id(p->vid), pid = hex_id(p->pid);
    for (const UsbKind &k : kKinds) {
        if (vid >= 0 && static_cast<unsigned long>(vid) == k.vid && (k.pid < 0 || k.pid == pid)) {
            p->link = k.link;
            p->name = k.name;
            return;
        }
    }
}

std::vector<UsbPort> list_usb_ports(const DeviceRoots &roots)
{
    std::vector<UsbPort> out;
    const std::string by_id = roots.dev + "/serial/by-id";
    for (const std::string &e : list_dir(by_id)) {
        UsbPort p;
        p.path = by_id + "/" + e;
        p.by_id = e;
        p.tty = base_name(real_path(p.path));
        if (p.tty.empty()) {
            continue; // a link to a device that is gone
        }
        p.dev = roots.dev + "/" + p.tty;
        read_usb_ids(roots, &p);
        out.push_back(p);
    }
    const size_t linked = out.size();
    for (const std::string &e : list_dir(roots.sys + "/class/tty")) {
        if (e.rfind("ttyUSB", 0) != 0 && e.rfind("ttyACM", 0) != 0) {
            continue;
        }
        bool seen = false;
        for (size_t i = 0; i < linked; i++) {
            seen = seen || out[i].tty == e;
        }
        if (seen) {
            continue;
        }
        UsbPort p;
        p.tty = e;
        p.dev = roots.dev + "/" + e;
        p.path = p.dev;
        read_usb_ids(roots, &p);
        out.push_back(p);
    }
    return out;
}

std::vector<UsbPort> ports_of_link(const std::vector<UsbPort> &ports, const std::string &link)
{
    std::vector<UsbPort> out;
    for (const UsbPort &p : ports) {
        if (p.link == link) {
            out.push_back(p);
        }
    }
    return out;
}

std::string port_text(const UsbPort &p)
{
    std::string what = !p.product.empty() ? p.product : !p.name.empty() ? p.name : "USB tty";
    if (!p.vid.empty()) {
        what += " [" + p.vid + (p.pid.empty() ? "" : ":" + p.pid) + "]";
    }
    if (!p.serial.empty()) {
        what += " serial " + p.serial;
    }
    return p.path + " (" + what + (p.link.empty() ? "" : ", link " + p.link) + ")";
}

// The ports as "a, b, c" (port_text).
static std::string ports_text(const std::vector<UsbPort> &ports)
{
    std::string s;
    for (const UsbPort &p : ports) {
        s += (s.empty() ? "" : ", ") + port_text(p);
    }
    return s;
}

std::string find_port(const std::string &link, const DeviceRoots &roots, std::string *path)
{
    const std::vector<UsbPort> all = list_usb_ports(roots);
    const std::vector<UsbPort> mine = ports_of_link(all, link);
    if (mine.size() == 1) {
        *path = mine[0].path;
        return "";
    }
    if (mine.empty()) {
        return "no " + link + "-link port found (" +
               (all.empty() ? std::string("no USB tty at all") : "USB ttys: " + ports_text(all)) +
               "; the USB ids of each link are listed by navkit-host --list-ports)";
    }
    return "several " + link + "-link ports found: " + ports_text(mine) + ": give [micro] port or --port";
}

// A port as a JSON object of UsbPort's fields.
static std::string port_json(const UsbPort &p)
{
    const std::pair<const char *, const std::string *> fields[] = {
        {"path", &p.path}, {"dev", &p.dev},         {"tty", &p.tty},       {"by_id", &p.by_id}, {"vid", &p.vid},
        {"pid", &p.pid},   {"product", &p.product}, {"serial", &p.serial}, {"link", &p.link},   {"name", &p.name},
    };
    std::string s = "{";
    for (const auto &f : fields) {
        s += std::string(s.size() > 1 ? ", " : "") + json_string(f.first) + ": " + json_string(*f.second);
    }
    return s + "}";
}

// A JSON array of ports, one a line.
static std::string ports_array(const std::vector<UsbPort> &ports)
{
    std::string s = "[";
    for (size_t i = 0; i < ports.size(); i++) {
        s += std::string(i ? "," : "") + "\n    " + port_json(ports[i]);
    }
    return s + (ports.empty() ? "]" : "\n  ]");
}

std::string ports_json(const std::string &link, const DeviceRoots &roots)
{
    const std::vector<UsbPort> all = list_usb_ports(roots);
    std::vector<UsbPort> mine = all, others;
    if (!link.empty()) {
        mine = ports_of_link(all, link);
        for (const UsbPort &p : all) {
            if (p.link != link) {
                others.push_back(p);
            }
        }
    }
    return "{\n  \"link\": " + (link.empty() ? std::string("null") : json_string(link)) +
           ",\n  \"ports\": " + ports_array(mine) + ",\n  \"others\": " + ports_array(others) + "\n}\n";
}

std::string latency_timer_path(const std::string &dev, const DeviceRoots &roots)
{
    const std::string p = roots.sys + "/bus/usb-serial/devices/" + base_name(real_path(dev)) + "/latency_timer";
    return access(p.c_str(), F_OK) == 0 ? p : std::string();
}

std::string set_latency_timer(const std::string &dev, const DeviceRoots &roots, int ms)
{
    const std::string lt = latency_timer_path(dev, roots);
    if (lt.empty()) {
        return "";
    }
    std::ofstream f(lt);
    f << ms << "\n";
    f.close();
    const std::string now = read_line(lt);
    if (now == std::to_string(ms)) {
        return "";
    }
    return "FTDI latency timer is " + now + " ms, could not set " + std::to_string(ms) + " ms (" + lt + ")";
}

} // namespace navkit
