// Ini: NavAndControl.ini and sensors.ini, read by ini_read (ini_file.hpp) against a table
// of each file's sections and keys; each key's setter parses and range-checks its value
// into the Config as the key is read, and the spec's range checks of the micro's config,
// each servo's limits and the IR ranges run afterwards, named at the lines ini_read kept.
#include "navkit/ini.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <climits>
#include <functional>
#include <grp.h>
#include <limits>
#include <map>
#include <utility>
#include <sstream>
#include <type_traits>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "navkit/ini_file.hpp"
#include "navkit/json.hpp"
#include "navkit/options.hpp"
#include "navkit/slcan.hpp"

namespace navkit {
namespace {

// A key's parser: "" on success, else the reason the value is refused.
using Setter = std::function<std::string(const std::string &)>;
// A key's value as it is now in the Config, as JSON text (--print-config).
using Getter = std::function<std::string()>;
// One key of a table: how its INI text is read into the Config and how its value is shown.
struct Key {
    Setter set;
    Getter json;
};
using Section = std::map<std::string, Key>;
using Table = std::map<std::string, Section>;

// JSON of a finite number, the fewest digits that read back as x.
std::string json_number(double x)
{
    char buf[32];
    if (x == std::floor(x) && std::fabs(x) < 1e15) {
        std::snprintf(buf, sizeof buf, "%.0f", x); // a whole number without an exponent
        return buf;
    }
    for (int prec = 1; prec <= 17; prec++) {
        std::snprintf(buf, sizeof buf, "%.*g", prec, x);
        if (std::strtod(buf, nullptr) == x) {
            break;
        }
    }
    return buf;
}

// The getter of an integer field *p.
template <class T> Getter int_json(const T *p)
{
    return [p]() { return std::to_string(static_cast<long>(*p)); };
}

// The getter of a string field *p.
Getter str_json(const std::string *p)
{
    return [p]() { return json_string(*p); };
}

// An integer key into *p, lo..hi (default: T's range); decimal, or also 0x hex for the
// bit-mask keys (hex_ok).
template <class T>
Key int_key(T *p, long lo = std::numeric_limits<T>::min(), long hi = std::numeric_limits<T>::max(), bool hex_ok = false)
{
    Setter set = [p, lo, hi, hex_ok](const std::string &v) -> std::string {
        long x;
        const std::string why = ini_parse_int(v, hex_ok, &x);
        if (!why.empty()) {
            return why;
        }
        if (x < lo || x > hi) {
            return std::to_string(x) + " is outside " + std::to_string(lo) + ".." + std::to_string(hi);
        }
        *p = static_cast<T>(x);
        return "";
    };
    return Key{set, int_json(p)};
}

// An integer key into *p that takes one of `list` (decimal); any other value is refused
// as "<value> is not <what> (<list>)".
Key listed_key(int *p, const std::vector<int> &list, const std::string &what)
{
    Setter set = [p, &list, what](const std::string &v) -> std::string {
        long x;
        const std::string why = ini_parse_int(v, false, &x);
        if (!why.empty()) {
            return why;
        }
        for (int b : list) {
            if (x == b) {
                *p = b;
                return "";
            }
        }
        std::string all;
        for (int b : list) {
            all += (all.empty() ? "" : ", ") + std::to_string(b);
        }
        return std::to_string(x) + " is not " + what + " (" + all + ")";
    };
    return Key{set, int_json(p)};
}

// A bit-mask key into *p, lo..hi: decimal or 0x hex.
template <class T> Key mask_key(T *p, long lo = std::numeric_limits<T>::min(), long hi = std::numeric_limits<T>::max())
{
    return int_key(p, lo, hi, true);
}

// A finite number into *p, lo..hi (the key's unit).
Key dbl_key(double *p, double lo, double hi)
{
    Setter set = [p, lo, hi](const std::string &v) -> std::string {
        double x;
        const std::string why = ini_parse_real(v, &x);
        if (!why.empty()) {
            return why;
        }
        if (x < lo || x > hi) {
            std::ostringstream s;
            s << x << " is outside " << lo << ".." << hi;
            return s.str();
        }
        *p = x;
        return "";
    };
    return Key{set, [p]() { return json_number(*p); }};
}

// The value into *p, once check (shm_name_error, ...) finds nothing wrong with it.
Key checked_key(std::string *p, std::string (*check)(const std::string &))
{
    Setter set = [p, check](const std::string &v) -> std::string {
        const std::string why = check(v);
        if (!why.empty()) {
            return why;
        }
        *p = v;
        return "";
    };
    return Key{set, str_json(p)};
}

// 0 or 1 into *p.
Key bool_key(bool *p)
{
    Setter set = [p](const std::string &v) -> std::string {
        if (v != "0" && v != "1") {
            return "'" + v + "' is not 0 or 1";
        }
        *p = v == "1";
        return "";
    };
    return Key{set, [p]() { return std::string(*p ? "true" : "false"); }};
}

// The value as written into *p; empty only when allow_empty.
Key str_key(std::string *p, bool allow_empty)
{
    Setter set = [p, allow_empty](const std::string &v) -> std::string {
        if (v.empty() && !allow_empty) {
            return "needs a value";
        }
        *p = v;
        return "";
    };
    return Key{set, str_json(p)};
}

// One value for all eight elements, or eight comma-separated values.
template <class T> Key array_key(T (*arr)[8])
{
    Setter set = [arr](const std::string &v) -> std::string {
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
            const std::string why = ini_parse_int(s, false, &x);
            if (!why.empty()) {
                return why;
            }
            if (x < std::numeric_limits<T>::min() || x > std::numeric_limits<T>::max()) {
                return std::to_string(x) + " does not fit the field";
            }
            tmp[i] = static_cast<T>(x);
        }
        std::memcpy(*arr, tmp, sizeof tmp);
        return "";
    };
    Getter json = [arr]() {
        std::string out = "[";
        for (size_t i = 0; i < 8; i++) {
            out += (i ? ", " : "") + std::to_string(static_cast<long>((*arr)[i]));
        }
        return out + "]";
    };
    return Key{set, json};
}

// The spec's defaults and check of a config message (for cfg_key_NONZERO's probe; unused
// for a message without NONZERO fields).
[[maybe_unused]] void cfg_defaults(navkit_micro_cfg_geometry_t *m)
{
    navkit_micro_cfg_geometry_defaults(m);
}
[[maybe_unused]] void cfg_defaults(navkit_micro_cfg_motion_t *m)
{
    navkit_micro_cfg_motion_defaults(m);
}
[[maybe_unused]] void cfg_defaults(navkit_micro_cfg_io_t *m)
{
    navkit_micro_cfg_io_defaults(m);
}
[[maybe_unused]] int cfg_check(const navkit_micro_cfg_geometry_t *m)
{
    return navkit_micro_cfg_geometry_check(m, nullptr);
}
[[maybe_unused]] int cfg_check(const navkit_micro_cfg_motion_t *m)
{
    return navkit_micro_cfg_motion_check(m, nullptr);
}
[[maybe_unused]] int cfg_check(const navkit_micro_cfg_io_t *m)
{
    return navkit_micro_cfg_io_check(m, nullptr);
}

// The key of config field msg->*f by its kind in NAVKIT_<MSG>_CONFIG_FIELDS (navkit_proto.h):
// INT any value of the field's type (decimal; an array: 1 or 8 values), MASK also 0x hex;
// the spec's ranges are checked after reading (check_micro).
template <class M, class T> Key cfg_key_INT(M *msg, T M::*f)
{
    return int_key(&(msg->*f));
}

template <class M, class T, size_t N> Key cfg_key_INT(M *msg, T (M::*f)[N])
{
    return array_key(&(msg->*f));
}

template <class M, class T> Key cfg_key_MASK(M *msg, T M::*f)
{
    return mask_key(&(msg->*f));
}

// NONZERO (the spec's signs: range -1..1, constraint nonzero): taken when the spec's check
// takes it, tried on the defaults with this value (+1 or -1), else refused at its own line.
template <class M, class T> Key cfg_key_NONZERO(M *msg, T M::*f)
{
    Setter set = [msg, f](const std::string &v) -> std::string {
        long x = 0;
        const bool fits = ini_parse_int(v, false, &x).empty() && x >= std::numeric_limits<T>::min() &&
                          x <= std::numeric_limits<T>::max();
        M probe;
        cfg_defaults(&probe);
        probe.*f = static_cast<T>(fits ? x : 0);
        if (!fits || cfg_check(&probe) != NAVKIT_OK) {
            return "'" + v + "' is not 1 or -1 (the micro refuses any other sign)";
        }
        msg->*f = probe.*f;
        return "";
    };
    return Key{set, int_json(&(msg->*f))};
}

// NavAndControl.ini's sections and keys, each writing into c.
Table nav_table(Config &c)
{
    Table t;
    ExecutiveCfg &e = c.exec;
    t["executive"] = {
        {"frame_rate_hz", dbl_key(&e.frame_rate_hz, kMinRateHz, kMaxRateHz)},
        {"planner_timeout", dbl_key(&e.planner_timeout_s, 0, 3600)},
        {"console_idle", dbl_key(&e.console_idle_s, 0, 3600)},
        {"shm_name", checked_key(&e.shm_name, shm_name_error)},
        {"shm_group", checked_key(&e.shm_group, shm_group_error)},
        {"log_dir", str_key(&e.log_dir, false)}, // log_dir_error: main, on the folder in use
        {"record", bool_key(&e.record)},
        {"dio_default", mask_key(&e.dio_default, 0, 4095)},
        {"mc_datalog",
         {[&e](const std::string &v) -> std::string {
              long x;
              std::string why = ini_parse_int(v, false, &x);
              if (why.empty()) {
                  why = mc_datalog_error(x);
              }
              if (why.empty()) {
                  e.mc_datalog = static_cast<int>(x);
              }
              return why;
          },
          int_json(&e.mc_datalog)}},
    };
    MicroCfg &m = c.micro;
    t["micro"] = {
        {"port", str_key(&m.port, false)},
        {"baud", listed_key(&m.baud, supported_bauds(), "a supported rate")},
        {"data_bits", int_key(&m.data_bits, 5, 8)},
        {"parity",
         {[&m](const std::string &v) -> std::string {
              if (v != "N" && v != "E" && v != "O") {
                  return "'" + v + "' is not N, E or O";
              }
              m.parity = v[0];
              return "";
          },
          [&m]() { return json_string(std::string(1, m.parity)); }}},
        {"stop_bits", int_key(&m.stop_bits, 1, 2)},
        {"latency_timer_ms", int_key(&m.latency_timer_ms, 0, 255)},
        {"link", checked_key(&m.link, micro_link_error)},
        {"can_bitrate", listed_key(&m.can_bitrate, Slcan::bitrates(), "a bit rate an SLCAN adapter sets")},
    };
    // [micro_cfg_*]: one key per config field of the spec, of the kind the spec gives it
#define NAVKIT_INI_CFG_KEY(name, kind) {#name, cfg_key_##kind(msg, &std::remove_pointer_t<decltype(msg)>::name)},
    {
        navkit_micro_cfg_geometry_t *msg = &m.geometry;
        t["micro_cfg_geometry"] = {NAVKIT_MICRO_CFG_GEOMETRY_CONFIG_FIELDS(NAVKIT_INI_CFG_KEY)};
    }
    {
        navkit_micro_cfg_motion_t *msg = &m.motion;
        t["micro_cfg_motion"] = {NAVKIT_MICRO_CFG_MOTION_CONFIG_FIELDS(NAVKIT_INI_CFG_KEY)};
    }
    {
        navkit_micro_cfg_io_t *msg = &m.io;
        t["micro_cfg_io"] = {NAVKIT_MICRO_CFG_IO_CONFIG_FIELDS(NAVKIT_INI_CFG_KEY)};
    }
#undef NAVKIT_INI_CFG_KEY
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
        {"file", str_key(&an.file_setting, false)},
        {"log", bool_key(&an.log)},
    };
    return t;
}

// sensors.ini's sections and keys, each writing into c.sensors.
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
            {"channel", int_key(&g.channel, 0, 7)},    {"vref", dbl_key(&g.vref, 0.1, 10)},
            {"a_v_mm", dbl_key(&g.a_v_mm, 1, 100000)}, {"b_mm", dbl_key(&g.b_mm, -1000, 1000)},
            {"c_v", dbl_key(&g.c_v, -5, 5)},           {"min_mm", int_key(&g.min_mm, 0, 10000)},
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

// The file name of path (after its last '/').
std::string base_name(const std::string &path)
{
    const size_t s = path.rfind('/');
    return s == std::string::npos ? path : path.substr(s + 1);
}

// The path of the face file `setting` ([animation] file) of config folder dir: an
// absolute setting as it is, else relative to the folder.
std::string face_path(const std::string &dir, const std::string &setting)
{
    return setting[0] == '/' ? setting : dir + "/" + setting;
}

// Range check of the three config messages against the spec, naming the INI line (a
// message's constraints are checked after its ranges: check_constraints reports those).
void check_micro(const IniFile &ini, const Config &c)
{
    int bad = -1;
    std::string sec, name;
    if (navkit_micro_cfg_geometry_check(&c.micro.geometry, &bad) == NAVKIT_ERR_RANGE) {
        sec = "micro_cfg_geometry";
        name = navkit_micro_cfg_geometry_field_name(bad);
    } else if (navkit_micro_cfg_motion_check(&c.micro.motion, &bad) == NAVKIT_ERR_RANGE) {
        sec = "micro_cfg_motion";
        name = navkit_micro_cfg_motion_field_name(bad);
    } else if (navkit_micro_cfg_io_check(&c.micro.io, &bad) == NAVKIT_ERR_RANGE) {
        sec = "micro_cfg_io";
        name = navkit_micro_cfg_io_field_name(bad);
    } else {
        return;
    }
    ini.fail(ini.line(sec, name), name + ": outside the spec's range (docs/protocol.md, " + sec + ")");
}

// The first broken spec constraint of config message *m of INI section sec (the generated
// navkit_<msg>_constraint_check, _constraint_field and _field_name), named at the later of
// its keys' lines: an le of arrays such as servo_min <= servo_max as "servo 3's servo_min
// 100 is above its servo_max -100", element i named by the fields' common prefix.
template <class M>
void check_constraints_of(const IniFile &ini, const Config &c, const std::string &sec, const M *m,
                          int (*broken)(const M *, int *, int32_t *), int (*field)(int, int), const char *(*name)(int))
{
    int element = 0;
    int32_t value[2] = {0, 0};
    const int k = broken(m, &element, value);
    if (k < 0) {
        return;
    }
    const std::string a = name(field(k, 0));
    if (field(k, 1) < 0) { // nonzero
        ini.fail(ini.line(sec, a), a + ": 0 breaks the spec's constraint " + a + " != 0 (the micro refuses it)");
    }
    const std::string b = name(field(k, 1));
    const std::string noun = a.substr(0, a.find('_'));
    const std::string whose = b.compare(0, noun.size() + 1, noun + "_") == 0
                                  ? noun + " " + std::to_string(element) + "'s "
                                  : "";
    throw ConfigError(later_key_at(c, sec, a, sec, b) + ": " + whose + a + " " + std::to_string(value[0]) +
                      " is above " + (whose.empty() ? "" : "its ") + b + " " + std::to_string(value[1]) +
                      " (the micro refuses it)");
}

// The spec's constraints of the three config messages (protocol/navkit.toml).
void check_constraints(const IniFile &ini, const Config &c)
{
    check_constraints_of(ini, c, "micro_cfg_geometry", &c.micro.geometry, navkit_micro_cfg_geometry_constraint_check,
                         navkit_micro_cfg_geometry_constraint_field, navkit_micro_cfg_geometry_field_name);
    check_constraints_of(ini, c, "micro_cfg_io", &c.micro.io, navkit_micro_cfg_io_constraint_check,
                         navkit_micro_cfg_io_constraint_field, navkit_micro_cfg_io_field_name);
}

// Each GP2D12's valid range must be non-empty, named at its max_mm line.
void check_ir(const IniFile &ini, const Config &c)
{
    for (int i = 0; i < 4; i++) {
        if (c.sensors.ir[i].min_mm >= c.sensors.ir[i].max_mm) {
            const std::string sec = "ir" + std::to_string(i);
            ini.fail(ini.line(sec, "max_mm"), "max_mm: must be above min_mm in [" + sec + "]");
        }
    }
}

// The frame-vs-watchdog rule on a frame of frame_ms (ms), naming rate_hz (Hz) too when
// the frame was given as a rate (else 0).
std::string frame_check(double frame_ms, unsigned watchdog_timeout_ms, double rate_hz)
{
    if (2.0 * frame_ms < static_cast<double>(watchdog_timeout_ms)) {
        return "";
    }
    char rate[40] = "";
    if (rate_hz > 0) {
        std::snprintf(rate, sizeof rate, " at %g Hz", rate_hz);
    }
    char why[240];
    std::snprintf(why, sizeof why,
                  "a frame of %g ms%s needs [micro_cfg_motion] watchdog_timeout above two frames "
                  "(%g ms), not %u ms: one lost frame would stop the robot",
                  frame_ms, rate, 2.0 * frame_ms, watchdog_timeout_ms);
    return why;
}

} // namespace

std::string frame_watchdog_error(double frame_rate_hz, unsigned watchdog_timeout_ms)
{
    return frame_check(1000.0 / frame_rate_hz, watchdog_timeout_ms, frame_rate_hz);
}

std::string frame_ms_watchdog_error(double frame_ms, unsigned watchdog_timeout_ms)
{
    return frame_check(frame_ms, watchdog_timeout_ms, 0.0);
}

std::string ini_parse_int(const std::string &v, bool hex_ok, long *out)
{
    const size_t sign = !v.empty() && (v[0] == '+' || v[0] == '-') ? 1 : 0;
    const bool hex = v.size() > 2 && v[0] == '0' && (v[1] == 'x' || v[1] == 'X');
    if (hex && !hex_ok) {
        return "'" + v + "' is hex: 0x is taken by the bit masks only, this key is decimal";
    }
    const size_t from = hex ? 2 : sign;
    const char *digits = hex ? "0123456789abcdefABCDEF" : "0123456789";
    if (v.size() <= from || v.find_first_not_of(digits, from) != std::string::npos) {
        return "'" + v + "' is not a " + (hex_ok ? "decimal or 0x hex" : "decimal") + " integer";
    }
    errno = 0;
    const long x = std::strtol(v.c_str() + (hex ? 2 : 0), nullptr, hex ? 16 : 10); // base 10: never octal
    if (errno) {
        return "'" + v + "' is out of range";
    }
    *out = x;
    return "";
}

std::string ini_parse_real(const std::string &v, double *out)
{
    // [+-] digits [. digits] [e [+-] digits], at least one digit before the exponent
    size_t i = !v.empty() && (v[0] == '+' || v[0] == '-') ? 1 : 0;
    auto digits = [&v, &i]() {
        const size_t a = i;
        while (i < v.size() && v[i] >= '0' && v[i] <= '9') {
            i++;
        }
        return i - a;
    };
    size_t n = digits();
    if (i < v.size() && v[i] == '.') {
        i++;
        n += digits();
    }
    bool ok = n > 0;
    if (ok && i < v.size() && (v[i] == 'e' || v[i] == 'E')) {
        i++;
        if (i < v.size() && (v[i] == '+' || v[i] == '-')) {
            i++;
        }
        ok = digits() > 0;
    }
    if (!ok || i != v.size()) {
        return "'" + v + "' is not a decimal number";
    }
    const double x = std::strtod(v.c_str(), nullptr);
    if (!std::isfinite(x)) {
        return "'" + v + "' is out of range";
    }
    *out = x;
    return "";
}

std::string micro_link_error(const std::string &v)
{
    return (v == "serial" || v == "slcan") ? "" : "'" + v + "' is not serial or slcan";
}

std::string shm_name_error(const std::string &v)
{
    if (v.size() < 2 || v[0] != '/' || v.find('/', 1) != std::string::npos || v.size() - 1 > NAME_MAX || v == "/." ||
        v == "/..") {
        return "'" + v + "' is not a POSIX shared-memory name ('/' then 1.." + std::to_string(NAME_MAX) +
               " characters, no other '/', not . or ..)";
    }
    return "";
}

std::string shm_group_error(const std::string &v)
{
    if (!v.empty() && !getgrnam(v.c_str())) {
        return "'" + v + "' is not a group of this system (getgrnam)";
    }
    return "";
}

std::string log_dir_error(const std::string &v)
{
    struct stat st;
    if (v.empty()) {
        return "needs a value";
    }
    if (stat(v.c_str(), &st) != 0) {
        return v + ": " + std::strerror(errno);
    }
    if (!S_ISDIR(st.st_mode)) {
        return v + ": not a directory";
    }
    if (access(v.c_str(), W_OK | X_OK) != 0) {
        return v + ": cannot create files in it (" + std::strerror(errno) + ")";
    }
    return "";
}

std::string mc_datalog_error(long v)
{
    navkit_micro_cmd_t probe; // the spec's check of the field, on a command that passes it otherwise
    navkit_micro_cmd_defaults(&probe);
    probe.mc_datalog_cmd = static_cast<uint16_t>(v);
    if (v < 0 || v > 0xFFFF || navkit_micro_cmd_check(&probe, nullptr) != NAVKIT_OK) {
        return std::to_string(v) + " is not a micro datalog selection (spec enum mc_datalog: docs/protocol.md)";
    }
    return "";
}

const std::vector<int> &supported_bauds()
{
    static const std::vector<int> b = {9600,   19200,  38400,  57600,   115200,  230400,
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
    // the table's checks run as each header and key is read, so the first refusal of the
    // file (the reader's or the table's) is the one reported
    const IniFile ini = ini_read(path, [&table](const IniSection &sec, const IniKey *key) -> std::string {
        const auto s = table.find(sec.name);
        if (s == table.end()) {
            return "[" + sec.written + "]: unknown section";
        }
        if (!key) {
            return "";
        }
        const auto k = s->second.find(ini_lower(key->name));
        if (k == s->second.end()) {
            return key->name + ": unknown key in [" + sec.name + "]";
        }
        const std::string why = k->second.set(key->value);
        return why.empty() ? "" : key->name + ": " + why;
    });
    bool any_key = false;
    for (const IniSection &sec : ini.sections) {
        any_key = any_key || !sec.keys.empty();
    }
    cfg.files.push_back(path);
    for (const IniSection &sec : ini.sections) {
        cfg.origin[sec.name] = path + ":" + std::to_string(sec.line);
        for (const auto &k : sec.keys) {
            cfg.origin[sec.name + "." + k.first] = path + ":" + std::to_string(k.second.line);
        }
    }
    if (!any_key) {
        cfg.notes.push_back(path + ": no keys (empty, or only comments and sections): every value is its default");
    }
    if (base == "NavAndControl.ini") {
        check_micro(ini, cfg);
        check_constraints(ini, cfg);
    } else {
        check_ir(ini, cfg);
    }
}

// The file and line where [sec] key was written, from c.origin (see key_at).
static std::pair<std::string, long> origin_of(const Config &c, const std::string &sec, const std::string &key)
{
    for (const std::string &k : {sec + "." + key, sec}) {
        const auto o = c.origin.find(k);
        const size_t colon = o == c.origin.end() ? std::string::npos : o->second.rfind(':');
        long line = 0;
        if (colon != std::string::npos && ini_parse_int(o->second.substr(colon + 1), false, &line).empty()) {
            return {o->second.substr(0, colon), line};
        }
    }
    return {c.files.empty() ? std::string() : c.files[0], 0};
}

std::string key_at(const Config &c, const std::string &sec, const std::string &key)
{
    const auto at = origin_of(c, sec, key);
    return at.first + ":" + std::to_string(at.second) + ": " + key;
}

std::string later_key_at(const Config &c, const std::string &sec_a, const std::string &key_a, const std::string &sec_b,
                         const std::string &key_b)
{
    return origin_of(c, sec_a, key_a).second > origin_of(c, sec_b, key_b).second ? key_at(c, sec_a, key_a)
                                                                                 : key_at(c, sec_b, key_b);
}

Config Ini::load(const std::string &dir)
{
    Config c;
    load_file(dir + "/NavAndControl.ini", c);
    load_file(dir + "/sensors.ini", c);
    c.animation.file = face_path(dir, c.animation.file_setting);
    return c;
}

Config Ini::load_path(const std::string &path)
{
    struct stat st;
    if (stat(path.c_str(), &st) != 0 || S_ISDIR(st.st_mode)) {
        return load(path); // a missing folder: load names the file it lacks
    }
    Config c;
    load_file(path, c);
    const size_t slash = path.rfind('/');
    c.animation.file = face_path(slash == std::string::npos ? "." : path.substr(0, slash), c.animation.file_setting);
    return c;
}

std::string Ini::json(const Config &c)
{
    Config shown = c; // the tables' getters read the copy they are built on
    std::string out = "{\n  \"files\": [";
    std::vector<Table> tables;
    for (size_t i = 0; i < c.files.size(); i++) {
        out += (i ? ", " : "") + json_string(c.files[i]);
        tables.push_back(base_name(c.files[i]) == "NavAndControl.ini" ? nav_table(shown) : sensors_table(shown));
    }
    out += "],\n  \"sections\": {";
    bool first_sec = true;
    for (const Table &t : tables) {
        for (const auto &sec : t) {
            out += std::string(first_sec ? "" : ",") + "\n    " + json_string(sec.first) + ": {";
            first_sec = false;
            bool first_key = true;
            for (const auto &key : sec.second) {
                const auto o = c.origin.find(sec.first + "." + key.first);
                out += std::string(first_key ? "" : ",") + "\n      " + json_string(key.first) +
                       ": {\"value\": " + key.second.json() +
                       ", \"from\": " + json_string(o == c.origin.end() ? "default" : o->second) + "}";
                first_key = false;
            }
            out += "\n    }";
        }
    }
    out += "\n  },\n  \"headers\": {";
    bool first_header = true;
    for (const Table &t : tables) {
        for (const auto &sec : t) {
            const auto o = c.origin.find(sec.first);
            if (o != c.origin.end()) {
                out += std::string(first_header ? "" : ",") + "\n    " + json_string(sec.first) + ": " +
                       json_string(o->second);
                first_header = false;
            }
        }
    }
    return out + "\n  }\n}\n";
}

} // namespace navkit
