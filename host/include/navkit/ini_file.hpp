// IniFile: one INI file read with inih (ini_parse_stream) through a line-counting reader,
// kept whole: every section in file order with its header line and its keys with theirs.
// The one reader of NavAndControl.ini, sensors.ini (Ini) and Animation.ini (Animation).
// It refuses, with ConfigError "path:line: key: reason" for the earliest bad line only:
// a missing or unreadable file (line 0), a line longer than inih's buffer, an indented
// key or section line (no multi-line values), a malformed line (inih's own error), a key outside any section, a duplicate key in a section and a
// repeated section header (no shipped file or test repeats one). Section and key names
// are matched without regard to case.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "navkit/ini.hpp"

namespace navkit {

struct IniKey {
    std::string name;  // as written in the file
    std::string value; // as inih hands it over (trimmed, inline comment removed)
    int line = 0;      // 1-based line of the key in the file
};

struct IniSection {
    std::string name;                   // lower-case
    std::string written;                // as written between the brackets
    int line = 0;                       // 1-based line of its [header]
    std::map<std::string, IniKey> keys; // lower-case key name -> key
};

struct IniFile {
    std::string path;                 // as given to ini_read
    std::vector<IniSection> sections; // in file order, each once

    // The section of lower-case `name`, nullptr if the file has none.
    const IniSection *find(const std::string &name) const;
    // Line of lower-case `key` in [section] (lower-case), else of the section's header,
    // else 0 (neither is in the file): where an error found after reading is reported.
    int line(const std::string &section, const std::string &key) const;
    // Throws ConfigError "path:line: what" (what = "key: reason").
    [[noreturn]] void fail(int line, const std::string &what) const;
};

// A caller's check of one section header (key == nullptr, sec has no keys yet) or one key
// (sec holds it and the keys before it), called in file order while the file is read: "" accepts
// it, any other text ("key: reason") refuses it at that line. Refusals of the reader and of
// the check are one stream: the earliest line's is reported.
using IniCheck = std::function<std::string(const IniSection &sec, const IniKey *key)>;

// Reads `path` whole; `check` (may be empty) sees every header and key as it is read.
// Throws ConfigError "path:line: key: reason" for the first refused line (see above).
IniFile ini_read(const std::string &path, const IniCheck &check = nullptr);

// `s` in lower case (ASCII).
std::string ini_lower(std::string s);

} // namespace navkit
