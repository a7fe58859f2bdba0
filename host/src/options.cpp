#include "navkit/options.hpp"

#include <cstring>
#include <set>

#include "navkit/ini.hpp"

namespace navkit {

const char *usage()
{
    return "usage: navkit-host [options]\n"
           "  --config DIR       folder of NavAndControl.ini and sensors.ini (default: config)\n"
           "  --port PATH        serial port of the micro, or 'auto' (overrides [micro] port)\n"
           "  --link serial|slcan  frames on the line, or CAN frames through an SLCAN adapter\n"
           "                     (overrides [micro] link)\n"
           "  --rate HZ          frame rate (overrides [executive] frame_rate_hz)\n"
           "  --frame-ms MS      the frame as a period, 1..10000 ms (instead of --rate)\n"
           "  --clock real|lockstep  real time (default) or one frame per lockstep tick\n"
           "  --lockstep-fd N    the lockstep socket (with --clock lockstep)\n"
           "  --shm NAME         rcomm shared-memory name (overrides [executive] shm_name)\n"
           "  --record           start the datalog at start-up\n"
           "  --log-dir DIR      folder of the datalog files (overrides [executive] log_dir)\n"
           "  --timing-log FILE  real time: one line per frame (scheduled, start, end ns)\n"
           "  --print-config     print the effective configuration (JSON: every key's value and\n"
           "                     the file:line, option or default it came from) and exit; --config\n"
           "                     may then name one INI file\n"
           "  --convert-lisp     read planner commands (lisp_cmd fields as JSON, one object a\n"
           "                     line) on stdin, print the micro command made of each or why it is\n"
           "                     refused (JSON, one a line), and exit; takes no other option\n"
           "  --list-ports       print the USB ttys port = auto chooses from (JSON: with --link, the\n"
           "                     ports of that link's kind, then the others) and exit; takes only\n"
           "                     --link and --dev-root DIR (dev/ and sys/ under DIR instead of /)\n"
           "  --help             this text\n"
           "keys: R record, S stop recording, Q quit; w/x forward/reverse, a/d turn, space stop,\n"
           "      0-9 - = toggle DIO bits 0-11 (console levels)\n";
}

std::string parse_options(int argc, char **argv, Options *o)
{
    std::set<std::string> seen; // each option at most once: a second one is refused, not "the last wins"
    for (int i = 1; i < argc; i++) {
        const std::string a = argv[i] == std::string("-h") ? "--help" : argv[i];
        if (a.compare(0, 2, "--") == 0 && !seen.insert(a).second) {
            return a + ": given twice";
        }
        // the next argument; one that looks like an option is not taken as a value
        auto value = [&](std::string *out) -> bool {
            if (i + 1 >= argc || std::strncmp(argv[i + 1], "--", 2) == 0) {
                return false;
            }
            *out = argv[++i];
            return true;
        };
        std::string v;
        if (a == "--help" || a == "-h") {
            o->help = true;
        } else if (a == "--record") {
            o->record = true;
        } else if (a == "--print-config") {
            o->print_config = true;
        } else if (a == "--convert-lisp") {
            o->convert_lisp = true;
        } else if (a == "--list-ports") {
            o->list_ports = true;
        } else if (a == "--config" || a == "--port" || a == "--link" || a == "--rate" || a == "--frame-ms" ||
                   a == "--clock" || a == "--lockstep-fd" || a == "--shm" || a == "--log-dir" || a == "--timing-log" ||
                   a == "--dev-root") {
            if (!value(&v)) {
                return a + ": needs a value" +
                       (i + 1 < argc ? std::string(" (got the option ") + argv[i + 1] + ")" : std::string());
            }
            if (v.empty()) {
                return a + ": needs a value (got an empty one)";
            }
            if (a == "--config") {
                o->config_dir = v;
            } else if (a == "--port") {
                o->port = v;
            } else if (a == "--link") {
                const std::string why = micro_link_error(v); // as [micro] link: one rule
                if (!why.empty()) {
                    return a + ": " + why;
                }
                o->link = v;
            } else if (a == "--rate") {
                // decimal as the INI's numbers (no hex, inf or nan)
                if (!ini_parse_real(v, &o->rate_hz).empty() ||
                    !(o->rate_hz >= kMinRateHz && o->rate_hz <= kMaxRateHz)) {
                    return a + ": " + v + ": not a rate in 0.1..1000 Hz (the range of [executive] frame_rate_hz)";
                }
            } else if (a == "--frame-ms") {
                // the periods of the rates --rate takes
                if (!ini_parse_real(v, &o->frame_ms).empty() ||
                    !(o->frame_ms >= 1000.0 / kMaxRateHz && o->frame_ms <= 1000.0 / kMinRateHz)) {
                    return a + ": " + v + ": not a frame of 1..10000 ms (the periods of [executive] frame_rate_hz)";
                }
            } else if (a == "--clock") {
                if (v != "real" && v != "lockstep") {
                    return a + ": " + v + ": choose real or lockstep";
                }
                o->lockstep = v == "lockstep";
            } else if (a == "--lockstep-fd") {
                long fd = -1;
                if (!ini_parse_int(v, false, &fd).empty() || fd < 0 || fd > 65535) {
                    return a + ": " + v + ": not a file descriptor";
                }
                o->lockstep_fd = static_cast<int>(fd);
            } else if (a == "--shm") {
                o->shm = v; // as [executive] shm_name: one rule, so "navkit" is refused here too
                const std::string why = shm_name_error(o->shm);
                if (!why.empty()) {
                    return a + ": " + why;
                }
            } else if (a == "--dev-root") {
                o->dev_root = v;
            } else if (a == "--log-dir") {
                o->log_dir = v;
                const std::string why = log_dir_error(v);
                if (!why.empty()) {
                    return a + ": " + why;
                }
            } else {
                o->timing_log = v;
            }
        } else {
            return a + ": unknown option (see --help)";
        }
    }
    // The options that answer and exit (no config, no run): any option beside them but
    // those they take would be ignored, so it is refused.
    struct Alone {
        bool given;
        const char *name;
        std::set<std::string> takes;
        const char *does;
    };
    const Alone alone[] = {
        {o->convert_lisp, "--convert-lisp", {"--convert-lisp", "--help"}, "it reads stdin only"},
        {o->list_ports,
         "--list-ports",
         {"--list-ports", "--link", "--dev-root", "--help"},
         "it only lists the USB ttys"},
    };
    for (const Alone &x : alone) {
        for (const std::string &other : seen) {
            if (x.given && !x.takes.count(other)) {
                return other + " has no effect with " + x.name + " (" + x.does + ")";
            }
        }
    }
    if (!o->dev_root.empty() && !o->list_ports) {
        return "--dev-root needs --list-ports";
    }
    if (o->lockstep && o->lockstep_fd < 0) {
        return "--clock lockstep needs --lockstep-fd N";
    }
    if (!o->lockstep && o->lockstep_fd >= 0) {
        return "--lockstep-fd needs --clock lockstep";
    }
    if (o->rate_hz > 0 && o->frame_ms > 0) {
        return "--rate and --frame-ms both set the frame: give one";
    }
    // options the lockstep clock would ignore are refused, never dropped silently
    if (o->lockstep && o->rate_hz > 0) {
        return "--rate has no effect with --clock lockstep (the driver's ticks start the frames)";
    }
    if (o->lockstep && o->frame_ms > 0) {
        return "--frame-ms has no effect with --clock lockstep (the driver's ticks start the frames)";
    }
    if (o->print_config && (seen.count("--clock") || !o->timing_log.empty())) {
        return std::string(seen.count("--clock") ? "--clock" : "--timing-log") +
               " has no effect with --print-config (nothing runs)";
    }
    if (o->lockstep && !o->timing_log.empty()) {
        return "--timing-log has no effect with --clock lockstep (it times the real-time schedule)";
    }
    return "";
}

} // namespace navkit
