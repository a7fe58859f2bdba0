// navkit-host: the executive. Loads the config, picks the clock, then runs the seed's
// RobotInit, RobotMain once per frame, and RobotShutdown (host/src/robot.cpp).
#include <cerrno>
#include <cstdio>
#include <fcntl.h>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <unistd.h>

#include "navkit/convert_lisp.hpp"
#include "navkit/ini.hpp"
#include "navkit/options.hpp"
#include "navkit/port_discovery.hpp"
#include "navkit/robot.hpp"

using namespace navkit;

// fds 0-2 that the caller left closed get /dev/null, before anything else opens a file:
// otherwise the next open (the rcomm region, the port, the datalog) would take their
// place, and the console would read keys from it or print into it. False if impossible.
static bool std_fds_open()
{
    for (int fd = 0; fd <= 2; fd++) {
        if (fcntl(fd, F_GETFD) != -1 || errno != EBADF) {
            continue;
        }
        const int n = open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY); // the lowest free fd: this one
        if (n != fd) {
            return false;
        }
    }
    return true;
}

int main(int argc, char **argv)
{
    if (!std_fds_open()) {
        return 1; // no /dev/null: nowhere to say so either
    }
    Options o;
    const std::string err = parse_options(argc, argv, &o);
    if (!err.empty()) {
        std::fprintf(stderr, "navkit-host: %s\n%s", err.c_str(), usage());
        return 2;
    }
    if (o.help) {
        std::fputs(usage(), stdout);
        return 0;
    }
    if (o.convert_lisp) {
        std::string why;
        if (convert_lisp_lines(std::cin, std::cout, &why) != 0) {
            std::fprintf(stderr, "navkit-host: --convert-lisp: %s\n", why.c_str());
            return 1;
        }
        return std::cout.flush() ? 0 : 1;
    }
    if (o.list_ports) {
        DeviceRoots roots;
        if (!o.dev_root.empty()) {
            roots.dev = o.dev_root + "/dev";
            roots.sys = o.dev_root + "/sys";
        }
        std::fputs(ports_json(o.link, roots).c_str(), stdout);
        return std::fflush(stdout) == 0 ? 0 : 1;
    }
    if (o.lockstep && fcntl(o.lockstep_fd, F_GETFD) == -1) { // a usage error, said before any start-up
        std::fprintf(stderr, "navkit-host: --lockstep-fd %d: not an open file descriptor\n%s", o.lockstep_fd, usage());
        return 2;
    }
    Config cfg;
    try {
        cfg = o.print_config ? Ini::load_path(o.config_dir) : Ini::load(o.config_dir);
    } catch (const ConfigError &e) {
        std::fprintf(stderr, "navkit-host: %s\n", e.what());
        return 1;
    }
    // the command line over the INI, each replaced key's origin the option
    if (!o.port.empty()) {
        cfg.micro.port = o.port;
        cfg.origin["micro.port"] = "--port";
    }
    if (!o.link.empty()) {
        cfg.micro.link = o.link;
        cfg.origin["micro.link"] = "--link";
    }
    if (o.rate_hz > 0) {
        cfg.exec.frame_rate_hz = o.rate_hz;
        cfg.origin["executive.frame_rate_hz"] = "--rate";
    } else if (o.frame_ms > 0) {
        cfg.exec.frame_rate_hz = 1000.0 / o.frame_ms;
        cfg.origin["executive.frame_rate_hz"] = "--frame-ms";
    }
    if (!o.lockstep) { // the frame in use against the micro's watchdog
        const unsigned watchdog_ms = cfg.micro.motion.watchdog_timeout;
        const std::string why = o.frame_ms > 0 ? frame_ms_watchdog_error(o.frame_ms, watchdog_ms)
                                               : frame_watchdog_error(cfg.exec.frame_rate_hz, watchdog_ms);
        if (!why.empty()) { // named where the frame came from: the command line (usage) or the INI
            if (o.rate_hz > 0) {
                std::fprintf(stderr, "navkit-host: --rate %g: %s\n", o.rate_hz, why.c_str());
                return 2;
            }
            if (o.frame_ms > 0) { // the text names the frame given
                std::fprintf(stderr, "navkit-host: --frame-ms: %s\n", why.c_str());
                return 2;
            }
            const std::string at = later_key_at(cfg, "executive", "frame_rate_hz", "micro_cfg_motion",
                                                "watchdog_timeout");
            std::fprintf(stderr, "navkit-host: %s: %s\n", at.c_str(), why.c_str());
            return 1;
        }
    }
    if (!o.shm.empty()) {
        cfg.exec.shm_name = o.shm;
        cfg.origin["executive.shm_name"] = "--shm";
    }
    if (!o.log_dir.empty()) {
        cfg.exec.log_dir = o.log_dir; // checked by parse_options
        cfg.origin["executive.log_dir"] = "--log-dir";
    } else if (!o.print_config) { // the folder the datalog would be written to: only for a run
        const std::string why = log_dir_error(cfg.exec.log_dir);
        if (!why.empty()) {
            std::fprintf(stderr, "navkit-host: %s: %s\n", key_at(cfg, "executive", "log_dir").c_str(), why.c_str());
            return 1;
        }
    }
    if (o.record) {
        cfg.exec.record = true;
        cfg.origin["executive.record"] = "--record";
    }
    if (o.print_config) {
        std::fputs(Ini::json(cfg).c_str(), stdout);
        return std::fflush(stdout) == 0 ? 0 : 1;
    }

    install_signal_handlers();
    std::unique_ptr<Clock> clock;
    if (o.lockstep) {
        clock.reset(new LockstepClock(o.lockstep_fd));
    } else {
        clock.reset(new RealClock(cfg.exec.frame_rate_hz, o.timing_log));
    }
    Robot r(cfg);
    r.clock = clock.get();
    try {
        RobotInit(r);
    } catch (const std::runtime_error &e) {
        std::fprintf(stderr, "navkit-host: %s\n", e.what());
        r.console.shutdown();
        return 1;
    }
    for (const std::string &note : cfg.notes) {
        r.console.print("%s", note.c_str());
    }
    FrameTick tick;
    int rc = 0;
    while (clock->wait_frame(&tick)) {
        r.tick = tick;
        RobotMain(r);
        // the planner's region cut short under us: no planner, so the robot stops and the
        // executive ends (RobotShutdown sends the stop) rather than drive on unattended
        const bool lost = !r.comm.lost().empty();
        const uint32_t flags = (r.quit || lost ? 1u : 0u) | (r.micro.port_open() ? 0u : 2u);
        clock->frame_done(r.micro.tx_bytes_frame(), flags);
        if (lost) {
            r.console.print("%s: stopping the robot and shutting down", r.comm.lost().c_str());
            rc = 1;
            break;
        }
        if (r.quit) {
            r.console.print("Q: quitting");
            break;
        }
    }
    if (!clock->error().empty()) {
        r.console.print("%s", clock->error().c_str());
        rc = 1;
    } else if (g_quit_signal) {
        r.console.print("signal %d: shutting down", g_quit_signal);
    }
    RobotShutdown(r);
    return rc;
}
