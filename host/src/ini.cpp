#include "navkit/ini.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include <ini.h>

#include "navkit/options.hpp"

namespace navkit {
namespace {

// A key's parser: "" on success, else the reason the value is refused.
using Setter = std::function<std::string(const std::string &)>;
using Section = std::map<std::string, Setter>;
using Table = std::map<std::string, Section>;

bool parse_long(const std::string &v, long *out)
{
    if (v.empty()) {
        return false;
    }
    char *end = nullptr;
    errno = 0;
    const long x = std::strtol(v.c_str(), &end, 0);
    if (errno || *end) {
        return false;
    }
    *out = x;
    return true;
}

template <class T>
Setter int_key(T *p, long lo = std::numeric_limits<T>::min(), long hi = std::numeric_limits<T>::max())
{
    return [p, lo, hi](const std::string &v) -> std::string {
        long x;
        if (!parse_long(v, &x)) {
            return "'" + v + "' is not an integer";
        }
        if (x < lo || x > hi) {
            return std::to_string(x) + " is outside " + std::to_string(lo) + ".." + std::to_string(hi);
        }
        *p = static_cast<T>(x);
        return "";
    };
}

Setter dbl_key(double *p, double lo, double hi)
{
    return [p, lo, hi](const std::string &v) -> std::string {
        char *end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end || !std::isfinite(x)) {
            return "'" + v + "' is not a number";
        }
        if (x < lo || x > hi) {
            std::ostringstream s;
            s << x << " is outside " << lo << ".." << hi;
            return s.str();
        }
        *p = x;
        return "";
    };
}

Setter bool_key(bool *p)
{
    return [p](const std::string &v) -> std::string {
        if (v != "0" && v != "1") {
            return "'" + v + "' is not 0 or 1";
        }
        *p = v == "1";
        return "";
    };
}

Setter str_key(std::string *p, bool allow_empty)
{
    return [p, allow_empty](const std::string &v) -> std::string {
        if (v.empty() && !allow_empty) {
            return "needs a value";
        }
        *p = v;
        return "";
    };
}

// One value for all eight elements, or eight comma-separated values.
template <class T>
Setter array_key(T (*arr)[8])
{
    return [arr](const std::string &v) -> std::string {
        std::vector<std::string> parts;
        std::stringstream ss(v);
        std::string item;
        while (std::getline(ss, item, ',')) {
            const size_t a = item.find_first_not_of(" \t"), b = item.find_last_not_of(" \t");
            parts.push_back(a == std::string::npos ? "" : item.substr(a, b - a + 1));
        }
        if (parts.size() != 1 && parts.size() != 8) {
            return "needs 1 or 8 comma-separated values, got " + std::to_string(parts.size());
        }
        T tmp[8];
        for (size_t i = 0; i < 8; i++) {
            const std::string &s = parts[parts.size() == 1 ? 0 : i];
            long x;
            if (!parse_long(s, &x)) {
                return "'" + s + "' is not an integer";
            }
            if (x < std::numeric_limits<T>::min() || x > std::numeric_limits<T>::max()) {
                return std::to_string(x) + " does not fit the field";
            }
            tmp[i] = static_cast<T>(x);
        }
        std::memcpy(*arr, tmp, sizeof tmp);
        return "";
    };
}

Table nav_table(Config &c)
{
    Table t;
    ExecutiveCfg &e = c.exec;
    t["executive"] = {
        {"frame_rate_hz", dbl_key(&e.frame_rate_hz, kMinRateHz, kMaxRateHz)},
        {"planner_timeout", dbl_key(&e.planner_timeout_s, 0, 3600)},
        {"console_idle", dbl_key(&e.console_idle_s, 0, 3600)},
        {"shm_name", str_key(&e.shm_name, false)},
        {"shm_group", str_key(&e.shm_group, true)},
        {"log_dir", str_key(&e.log_dir, false)},
        {"record", bool_key(&e.record)},
        {"dio_default", int_key(&e.dio_default, 0, 4095)},
    };
    MicroCfg &m = c.micro;
    t["micro"] = {
        {"port", str_key(&m.port, false)},
        {"baud", [&m](const std::string &v) -> std::string {
             long x;
             if (!parse_long(v, &x)) {
                 return "'" + v + "' is not an integer";
             }
             for (int b : supported_bauds()) {
                 if (x == b) {
                     m.baud = b;
                     return "";
                 }
             }
             std::string list;
             for (int b : supported_bauds()) {
                 list += (list.empty() ? "" : ", ") + std::to_string(b);
             }
             return std::to_string(x) + " is not a supported rate (" + list + ")";
         }},
        {"data_bits", int_key(&m.data_bits, 5, 8)},
        {"parity", [&m](const std::string &v) -> std::string {
             if (v != "N" && v != "E" && v != "O") {
                 return "'" + v + "' is not N, E or O";
             }
             m.parity = v[0];
             return "";
         }},
        {"stop_bits", int_key(&m.stop_bits, 1, 2)},
        {"latency_timer_ms", int_key(&m.latency_timer_ms, 0, 255)},
    };
    navkit_micro_cfg_geometry_t &g = m.geometry;
    t["micro_cfg_geometry"] = {
        {"wheel_diameter", int_key(&g.wheel_diameter)}, {"counts_per_rev", int_key(&g.counts_per_rev)},
        {"track_width", int_key(&g.track_width)},       {"enc_left_sign", int_key(&g.enc_left_sign)},
        {"enc_right_sign", int_key(&g.enc_right_sign)}, {"motor_left_sign", int_key(&g.motor_left_sign)},
        {"motor_right_sign", int_key(&g.motor_right_sign)},
        {"gyro_lsb_per_dps", int_key(&g.gyro_lsb_per_dps)}, {"gyro_sign", int_key(&g.gyro_sign)},
        {"compass_weight", int_key(&g.compass_weight)}, {"control_rate", int_key(&g.control_rate)},
    };
    navkit_micro_cfg_motion_t &mo = m.motion;
    t["micro_cfg_motion"] = {
        {"default_accel", int_key(&mo.default_accel)}, {"default_speed", int_key(&mo.default_speed)},
        {"default_turn_accel", int_key(&mo.default_turn_accel)},
        {"default_turn_rate", int_key(&mo.default_turn_rate)}, {"max_speed", int_key(&mo.max_speed)},
        {"max_turn_rate", int_key(&mo.max_turn_rate)}, {"wheel_kff", int_key(&mo.wheel_kff)},
        {"wheel_kp", int_key(&mo.wheel_kp)}, {"wheel_ki", int_key(&mo.wheel_ki)},
        {"wheel_kd", int_key(&mo.wheel_kd)}, {"wheel_i_limit", int_key(&mo.wheel_i_limit)},
        {"pwm_limit", int_key(&mo.pwm_limit)}, {"heading_kp", int_key(&mo.heading_kp)},
        {"watchdog_timeout", int_key(&mo.watchdog_timeout)}, {"watchdog_decel", int_key(&mo.watchdog_decel)},
        {"stop_tolerance", int_key(&mo.stop_tolerance)},
    };
    navkit_micro_cfg_io_t &io = m.io;
    t["micro_cfg_io"] = {
        {"dio_direction", int_key(&io.dio_direction)}, {"dio_safe_state", int_key(&io.dio_safe_state)},
        {"sensor_enable", int_key(&io.sensor_enable)}, {"servo_center", array_key(&io.servo_center)},
        {"servo_us_per_deg", array_key(&io.servo_us_per_deg)}, {"servo_min", array_key(&io.servo_min)},
        {"servo_max", array_key(&io.servo_max)},
    };
    ConsoleCfg &co = c.console;
    t["console"] = {
        {"teleop_speed", int_key(&co.teleop_speed, 1, 3000)},
        {"teleop_accel", int_key(&co.teleop_accel, 0, 5000)},
        {"teleop_turn_rate", int_key(&co.teleop_turn_rate, 1, 20000)},
        {"status_period", dbl_key(&co.status_period_s, 0.1, 3600)},
    };
    SafetyCfg &sa = c.safety;
    t["safety"] = {
        {"battery_min_v", dbl_key(&sa.battery_min_v, 0, 100)},
        {"ir_stop_mm", int_key(&sa.ir_stop_mm, 0, 800)},
    };
    AnimationCfg &an = c.animation;
    t["animation"] = {
        {"on", bool_key(&an.on)},
        {"file", str_key(&an.file, false)},
        {"log", bool_key(&an.log)},
    };
    return t;
}

Table sensors_table(Config &c)
{
    Table t;
    SensorsCfg &s = c.sensors;
    t["battery"] = {
        {"channel", int_key(&s.battery.channel, 0, 7)},
        {"vref", dbl_key(&s.battery.vref, 0.1, 10)},
        {"divider", dbl_key(&s.battery.divider, 0.1, 100)},
        {"offset_v", dbl_key(&s.battery.offset_v, -10, 10)},
    };
    for (int i = 0; i < 4; i++) {
        Gp2d12Cal &g = s.ir[i];
        t["ir" + std::to_string(i)] = {
            {"channel", int_key(&g.channel, 0, 7)},      {"vref", dbl_key(&g.vref, 0.1, 10)},
            {"a_v_mm", dbl_key(&g.a_v_mm, 1, 100000)},    {"b_mm", dbl_key(&g.b_mm, -1000, 1000)},
            {"c_v", dbl_key(&g.c_v, -5, 5)},              {"min_mm", int_key(&g.min_mm, 0, 10000)},
            {"max_mm", int_key(&g.max_mm, 0, 10000)},
        };
        Srf04Cal &so = s.sonar[i];
        t["sonar" + std::to_string(i)] = {
            {"mm_per_us", dbl_key(&so.mm_per_us, 0.01, 1)},
            {"offset_mm", dbl_key(&so.offset_mm, -1000, 1000)},
            {"max_mm", int_key(&so.max_mm, 1, 100000)},
        };
    }
    for (int i = 0; i < 8; i++) {
        ServoCal &v = s.servo[i];
        t["servo" + std::to_string(i)] = {
            {"gain", dbl_key(&v.gain, -10, 10)},
            {"offset_deg", dbl_key(&v.offset_deg, -360, 360)},
        };
    }
    return t;
}

std::string lower(std::string s)
{
    for (char &ch : s) {
        ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    }
    return s;
}

// The first refusal of a file: inih goes on after a handler error and returns the
// line of the first bad line, so the handler keeps only the first one it meets (with
// the line it came from, counted by read_line below).
struct ParseState {
    Table *table;
    std::FILE *f;
    int line = 0;          // lines read so far (inih calls the reader once per line)
    int error_line = 0;    // line of `error`, 0 = none yet
    std::string error;     // "key: reason" of the first refused line
    std::set<std::string> seen;
};

void refuse(ParseState *st, const std::string &why)
{
    if (st->error_line == 0) {
        st->error_line = st->line;
        st->error = why;
    }
}

// inih's reader: one whole line per call, counted; a line longer than inih's buffer is
// refused here (inih would cut it and parse the pieces).
char *read_line(char *str, int num, void *stream)
{
    ParseState *st = static_cast<ParseState *>(stream);
    std::string line;
    int ch;
    while ((ch = std::fgetc(st->f)) != EOF) {
        line.push_back(static_cast<char>(ch));
        if (ch == '\n') {
            break;
        }
    }
    if (line.empty()) {
        return nullptr;
    }
    st->line++;
    if (line.size() > static_cast<size_t>(num) - 1) {
        refuse(st, "line: longer than " + std::to_string(num - 2) + " characters");
        line = "\n";  // parsed as an empty line
    }
    std::memcpy(str, line.c_str(), line.size() + 1);
    return str;
}

int handler(void *user, const char *section, const char *name, const char *value)
{
    ParseState *st = static_cast<ParseState *>(user);
    const std::string sec = lower(section), key = lower(name);
    auto s = st->table->find(sec);
    if (s == st->table->end()) {
        refuse(st, "[" + std::string(section) + "]: unknown section");
        return 0;
    }
    auto k = s->second.find(key);
    if (k == s->second.end()) {
        refuse(st, std::string(name) + ": unknown key in [" + sec + "]");
        return 0;
    }
    if (!st->seen.insert(sec + "." + key).second) {
        refuse(st, std::string(name) + ": duplicate key in [" + sec + "]");
        return 0;
    }
    const std::string why = k->second(value);
    if (!why.empty()) {
        refuse(st, std::string(name) + ": " + why);
        return 0;
    }
    return 1;
}

// Line of `key` in [section] of the file (0 if absent), for errors found after parsing.
int line_of(const std::string &path, const std::string &section, const std::string &key)
{
    std::ifstream f(path);
    std::string line, sec;
    int no = 0;
    while (std::getline(f, line)) {
        no++;
        const size_t a = line.find_first_not_of(" \t");
        if (a == std::string::npos || line[a] == ';' || line[a] == '#') {
            continue;
        }
        if (line[a] == '[') {
            sec = lower(line.substr(a + 1, line.find(']') - a - 1));
            continue;
        }
        const size_t eq = line.find_first_of("=:");
        if (eq == std::string::npos) {
            continue;
        }
        std::string k = line.substr(a, eq - a);
        k.erase(k.find_last_not_of(" \t") + 1);
        if (sec == section && lower(k) == key) {
            return no;
        }
    }
    return 0;
}

// inih calls the handler for keys only: a section without keys is checked here, for
// the lines before `before` (the first other refusal; 0 = the whole file).
void check_sections(const std::string &path, const Table &table, int before)
{
    std::ifstream f(path);
    std::string line;
    int no = 0;
    while (std::getline(f, line)) {
        no++;
        if (before > 0 && no >= before) {
            return;
        }
        const size_t a = line.find_first_not_of(" \t");
        if (a == std::string::npos || line[a] != '[') {
            continue;
        }
        const size_t b = line.find(']', a);
        const std::string sec = line.substr(a + 1, b == std::string::npos ? std::string::npos : b - a - 1);
        if (b != std::string::npos && table.find(lower(sec)) == table.end()) {
            throw ConfigError(path + ":" + std::to_string(no) + ": [" + sec + "]: unknown section");
        }
    }
}

std::string base_name(const std::string &path)
{
    const size_t s = path.rfind('/');
    return s == std::string::npos ? path : path.substr(s + 1);
}

// Range check of the three config messages against the spec, naming the INI line.
void check_micro(const std::string &path, const Config &c)
{
    int bad = -1;
    std::string sec, name;
    if (navkit_micro_cfg_geometry_check(&c.micro.geometry, &bad) != NAVKIT_OK) {
        sec = "micro_cfg_geometry";
        name = navkit_micro_cfg_geometry_field_name(bad);
    } else if (navkit_micro_cfg_motion_check(&c.micro.motion, &bad) != NAVKIT_OK) {
        sec = "micro_cfg_motion";
        name = navkit_micro_cfg_motion_field_name(bad);
    } else if (navkit_micro_cfg_io_check(&c.micro.io, &bad) != NAVKIT_OK) {
        sec = "micro_cfg_io";
        name = navkit_micro_cfg_io_field_name(bad);
    } else {
        return;
    }
    throw ConfigError(path + ":" + std::to_string(line_of(path, sec, name)) + ": " + name +
                      ": outside the spec's range (docs/protocol.md, " + sec + ")");
}

}  // namespace

const std::vector<int> &supported_bauds()
{
    static const std::vector<int> b = {9600,   19200,  38400,   57600,   115200,  230400,
                                       460800, 500000, 921600, 1000000, 2000000, 3000000};
    return b;
}

void Ini::load_file(const std::string &path, Config &cfg)
{
    const std::string base = base_name(path);
    Table table;
    if (base == "NavAndControl.ini") {
        table = nav_table(cfg);
    } else if (base == "sensors.ini") {
        table = sensors_table(cfg);
    } else {
        throw ConfigError(path + ":0: file: not a file navkit-host reads");
    }
    std::FILE *f = std::fopen(path.c_str(), "r");
    if (!f) {
        throw ConfigError(path + ":0: file: " + std::strerror(errno));
    }
    ParseState st{&table, f, 0, 0, "", {}};
    const int rc = ini_parse_stream(read_line, &st, handler, &st);
    std::fclose(f);
    const int first = st.error_line && rc > 0 ? std::min(st.error_line, rc) : std::max(st.error_line, rc);
    check_sections(path, table, first);
    if (rc < 0) {
        throw ConfigError(path + ":0: file: inih could not allocate its line buffer");
    }
    // rc is inih's first bad line: one before ours (or without ours) is a malformed line
    if (rc > 0 && (st.error_line == 0 || rc < st.error_line)) {
        st.error_line = rc;
        st.error = "line: malformed (not [section], key = value or a comment)";
    }
    if (st.error_line) {
        throw ConfigError(path + ":" + std::to_string(st.error_line) + ": " + st.error);
    }
    if (base == "NavAndControl.ini") {
        check_micro(path, cfg);
    }
}

Config Ini::load(const std::string &dir)
{
    Config c;
    load_file(dir + "/NavAndControl.ini", c);
    load_file(dir + "/sensors.ini", c);
    for (int i = 0; i < 4; i++) {
        if (c.sensors.ir[i].min_mm >= c.sensors.ir[i].max_mm) {
            const std::string p = dir + "/sensors.ini", sec = "ir" + std::to_string(i);
            throw ConfigError(p + ":" + std::to_string(line_of(p, sec, "max_mm")) +
                              ": max_mm: must be above min_mm in [" + sec + "]");
        }
    }
    if (c.animation.file[0] != '/') {
        c.animation.file = dir + "/" + c.animation.file;  // read by Animation::start when on
    }
    return c;
}

}  // namespace navkit
