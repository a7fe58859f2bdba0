#include "navkit/port_discovery.hpp"

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <dirent.h>
#include <fstream>
#include <unistd.h>
#include <vector>

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

// USB vendor of a tty (ttyUSB0): the interface's parent device holds idVendor.
static bool is_ftdi(const std::string &tty, const DeviceRoots &roots)
{
    for (const char *rel : {"/device/../idVendor", "/device/../../idVendor"}) {
        if (read_line(roots.sys + "/class/tty/" + tty + rel).rfind("0403", 0) == 0) {
            return true;
        }
    }
    return false;
}

std::string find_ftdi(const DeviceRoots &roots)
{
    const std::string by_id = roots.dev + "/serial/by-id";
    for (const std::string &e : list_dir(by_id)) {
        const std::string p = by_id + "/" + e;
        if (is_ftdi(base_name(real_path(p)), roots)) {
            return p;
        }
    }
    for (const std::string &e : list_dir(roots.sys + "/class/tty")) {
        if (e.rfind("ttyUSB", 0) == 0 && is_ftdi(e, roots)) {
            return roots.dev + "/" + e;
        }
    }
    return "";
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

}  // namespace navkit
