// Command line of navkit-host (overrides the INI files).
#pragma once

#include <string>

namespace navkit {

// Frame rates --rate and [executive] frame_rate_hz take, Hz.
constexpr double kMinRateHz = 0.1;
constexpr double kMaxRateHz = 1000.0;

struct Options {
    std::string config_dir = "config";
    std::string port;    // "" = INI
    std::string link;    // "" = INI ([micro] link: serial or slcan)
    double rate_hz = 0;  // 0 = INI
    double frame_ms = 0; // ms, the frame as a period (instead of --rate); 0 = INI
    bool lockstep = false;
    int lockstep_fd = -1;
    std::string shm; // "" = INI
    bool record = false;
    std::string log_dir;    // "" = INI
    std::string timing_log; // "" = none
    bool help = false;
    bool print_config = false; // print the effective configuration as JSON and exit (Ini::json)
    bool convert_lisp = false; // planner commands (stdin) -> micro commands (stdout), then exit (convert_lisp.hpp)
    bool list_ports = false;   // print the USB ttys port discovery finds as JSON and exit (port_discovery.hpp)
    std::string dev_root;      // "" = /; else the folder holding the dev/ and sys/ --list-ports reads (tests)
};

// "" on success, else the error (unknown or repeated option, missing or bad value).
std::string parse_options(int argc, char **argv, Options *o);
const char *usage();

} // namespace navkit
