// Ini: the seed's INI class. Reads config/NavAndControl.ini and config/sensors.ini with
// ini_read (ini_file.hpp, inih) into one Config. Every key has a default (the value
// shipped in the INI files); an unknown section or key, a malformed or out-of-range
// value, a duplicate key or section or a missing file throws ConfigError with the text
// "file:line: key: reason".
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

class ConfigError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct ExecutiveCfg {
    double frame_rate_hz = 10.0;    // Hz, frame k starts at t0 + k / frame_rate_hz
    double planner_timeout_s = 1.0; // s without a planner heartbeat -> stop; 0 = never
    double console_idle_s = 2.0;    // s after the last planner command before console teleop is obeyed
    std::string shm_name = "/navkit";
    std::string shm_group; // empty: mode 0600; a group name: 0660 and that group
    std::string log_dir = ".";
    bool record = false; // start the datalog at start-up
    int dio_default = 0; // levels of the DIO bits no planner owns (12 bits)
    int mc_datalog = 0;  // micro datalog selection (spec enum mc_datalog) at start-up
};

// Numbers of the INI files and the command line. Integers are decimal: [+-]digits (a
// leading zero is not octal: 0400 is 400); with hex_ok (the bit-mask keys) also 0x and
// hex digits. Reals are decimal, [+-]digits[.digits][e[+-]digits], finite: no hex, inf
// or nan. "" with *out set, else why v is refused ("'v' is ...").
std::string ini_parse_int(const std::string &v, bool hex_ok, long *out);
std::string ini_parse_real(const std::string &v, double *out);

// The frame rate against the micro's watchdog: the watchdog must outlast two frames, so
// that one lost or corrupted frame does not stop the robot. "" if it does, else why not
// (naming the frame and the rate). The one check of this rule: main checks the frame in
// use (--rate, --frame-ms or the INI's) with the real-time clock and with --print-config
// (which the co-simulation asks about its lockstep frame), not under --clock lockstep.
std::string frame_watchdog_error(double frame_rate_hz, unsigned watchdog_timeout_ms);
// The same rule for a frame given as a period of frame_ms (ms; --frame-ms): the text names
// the frame only.
std::string frame_ms_watchdog_error(double frame_ms, unsigned watchdog_timeout_ms);

// [micro] link (and --link): serial or slcan; "" if v is one, else why not.
std::string micro_link_error(const std::string &v);

// Checks of [executive] values (and of --shm, --log-dir): "" if v is fine, else why not.
// A POSIX shared-memory name: '/' then 1..NAME_MAX characters, no other '/'.
std::string shm_name_error(const std::string &v);
// Empty (owner only), or a group getgrnam() knows.
std::string shm_group_error(const std::string &v);
// An existing directory this process can create files in (the datalog's).
std::string log_dir_error(const std::string &v);

// A micro datalog selection (micro_cmd.mc_datalog_cmd, spec enum mc_datalog): "" if v is
// one the spec's range check of micro_cmd accepts, else why not.
std::string mc_datalog_error(long v);

// The serial rates [micro] baud may take (each has a termios speed constant; SerialPort
// maps them), in bit/s.
const std::vector<int> &supported_bauds();

struct MicroCfg {
    MicroCfg()
    {
        navkit_micro_cfg_geometry_defaults(&geometry);
        navkit_micro_cfg_motion_defaults(&motion);
        navkit_micro_cfg_io_defaults(&io);
    }
    std::string port = "auto"; // "auto" = the one USB tty of link's kind (port_discovery.hpp)
    int baud = 115200;
    int data_bits = 8;
    char parity = 'N'; // N, E or O
    int stop_bits = 1;
    int latency_timer_ms = 1;                               // FTDI latency timer, where sysfs lets us set it; 0 = leave
    std::string link = "serial";                            // serial: frames on the line; slcan: CAN frames through an
                                                            // SLCAN USB-CAN adapter on the port (docs/can.md)
    int can_bitrate = static_cast<int>(NAVKIT_CAN_BITRATE); // bit/s of the CAN bus (slcan)
    navkit_micro_cfg_geometry_t geometry{};
    navkit_micro_cfg_motion_t motion{};
    navkit_micro_cfg_io_t io{};
};

struct ConsoleCfg {
    int teleop_speed = 200;       // mm/s of the forward/reverse keys
    int teleop_accel = 300;       // mm/s^2
    int teleop_turn_rate = 300;   // deg/s x 10 of the left/right keys
    double status_period_s = 1.0; // s between status lines when stdout is not a terminal
};

struct SafetyCfg {
    double battery_min_v = 0.0; // V; below it (micro online) the robot stops; 0 = off
    int ir_stop_mm = 0;         // mm; an IR range below it stops the robot; 0 = off
};

struct BatteryCal {
    int channel = 4;       // ADC channel
    double vref = 5.0;     // V: ADC reference (counts = V * 1024 / vref)
    double divider = 3.0;  // board divider ratio
    double offset_v = 0.0; // V added after scaling
};

struct Gp2d12Cal {
    int channel = 0;       // ADC channel
    double vref = 5.0;     // V at ADC full scale
    double a_v_mm = 331.4; // curve V = a / (d + b) + c, d in mm
    double b_mm = 40.0;
    double c_v = 0.015;
    int min_mm = 100; // valid range; outside it the value is 0
    int max_mm = 800;
};

struct Srf04Cal {
    double mm_per_us = 0.1715; // half the speed of sound
    double offset_mm = 0.0;
    int max_mm = 3000; // farther = 0 (no echo)
};

struct ServoCal {
    double gain = 1.0; // position = gain * reported + offset
    double offset_deg = 0.0;
};

struct SensorsCfg {
    SensorsCfg()
    {
        for (int i = 0; i < 4; i++) {
            ir[i].channel = i; // GP2D12 rangers on ADC ch0-3
        }
    }
    BatteryCal battery;
    Gp2d12Cal ir[4];
    Srf04Cal sonar[4];
    ServoCal servo[8];
};

// [animation]: the seed's face (Animation.cpp), drawn above the console's status line.
struct AnimationCfg {
    bool on = false;                            // the seed's [Animation] On
    std::string file_setting = "Animation.ini"; // [animation] file as written (relative: to the config dir)
    std::string file = "Animation.ini";         // the face's path Animation::start opens (Ini::load: file_setting
                                                // made relative to the config dir)
    bool log = false;                           // stdout not a terminal: a "face:" line when the face changes
};

struct Config {
    ExecutiveCfg exec;
    MicroCfg micro;
    ConsoleCfg console;
    SafetyCfg safety;
    SensorsCfg sensors;
    AnimationCfg animation;
    // What start-up says once about the files read (a file without any key: every value
    // its default), in file order; main prints them.
    std::vector<std::string> notes;
    // The files read, in order (Ini::json shows their sections).
    std::vector<std::string> files;
    // Where each key's value came from: "section.key" (lower-case) -> "file:line" of the
    // key, or the command-line option that replaced it ("--rate"); a key not here has its
    // default. "section" -> "file:line" of its [header], for the sections in the files.
    std::map<std::string, std::string> origin;
};

// "file:line: key" where [sec] key was written in c's files, from c.origin: the key's
// line, else its section header's, else line 0 of the first file read (the default). The
// place an error about a key's value is named at.
std::string key_at(const Config &c, const std::string &sec, const std::string &key);
// key_at of the later written of [sec_a] key_a and [sec_b] key_b (key_b on a tie): where a
// pair of values that do not fit together is named (the frame rate and the watchdog).
std::string later_key_at(const Config &c, const std::string &sec_a, const std::string &key_a, const std::string &sec_b,
                         const std::string &key_b);

class Ini {
public:
    // Defaults, then dir/NavAndControl.ini and dir/sensors.ini over them.
    static Config load(const std::string &dir);
    // One file into cfg (the file's name decides which sections it may hold).
    static void load_file(const std::string &path, Config &cfg);
    // load(path) for a folder; for a file (--print-config --config FILE) only that file over
    // the defaults (its [animation] file beside it, as load does).
    static Config load_path(const std::string &path);
    // JSON of the effective configuration: {"files": [path, ...], "sections": {section:
    // {key: {"value": v, "from": "file:line" | option | "default"}}}, "headers": {section:
    // "file:line"}} for every key of the files read (values typed: numbers, strings,
    // true/false, the servo arrays as lists); headers: the sections the files hold.
    static std::string json(const Config &c);
};

} // namespace navkit
