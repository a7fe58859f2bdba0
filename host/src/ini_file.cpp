// IniFile: inih's ini_parse_stream fed one whole, counted line at a time, so every key and
// section header is kept with its line and every refusal names it. Parsing stops after the
// first refusal of the reader or the caller's check; inih's own first malformed line (its
// return value) wins when it comes earlier.
#include "navkit/ini_file.hpp"

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include <ini.h>

namespace navkit {
namespace {

// What inih's reader and handler share while one file is read.
struct Reader {
    IniFile *file;
    const IniCheck *check;
    std::FILE *f;
    int line = 0;       // lines handed to inih so far (inih asks for one line per call)
    long bytes = 0;     // bytes read from the file so far (at most kMaxIniBytes)
    int read_errno = 0; // errno of a failed read (0 = none)
    int error_line = 0; // line of `error`, 0 = none yet
    std::string error;  // "key: reason" of the first refused line
};

// An INI file larger than this is refused (bytes): a shipped one is a few kB; the bound
// keeps a link to an endless file (/dev/zero, a pipe) from being read for ever.
const long kMaxIniBytes = 1L << 20;

void refuse(Reader *r, const std::string &why)
{
    if (r->error_line == 0) {
        r->error_line = r->line;
        r->error = why;
    }
}

// A "[name]" line (inih calls the handler for keys only, so headers are noted here, and a
// section without keys is still known): a repeated one is refused, a new one checked.
void note_header(Reader *r, const std::string &line)
{
    const size_t bom = r->line == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0; // inih skips one
    const size_t a = line.find_first_not_of(" \t\r\n\f\v", bom);
    if (a == std::string::npos || line[a] != '[') {
        return;
    }
    const size_t b = line.find(']', a);
    if (b == std::string::npos) {
        return; // inih refuses it as malformed
    }
    const std::string written = line.substr(a + 1, b - a - 1);
    const std::string name = ini_lower(written);
    if (r->file->find(name)) {
        refuse(r, "[" + written + "]: duplicate section");
        return;
    }
    r->file->sections.push_back(IniSection{name, written, r->line, {}});
    if (*r->check) {
        const std::string why = (*r->check)(r->file->sections.back(), nullptr);
        if (!why.empty()) {
            refuse(r, why);
        }
    }
}

// inih's reader: one whole line per call (at most num - 1 characters with its newline),
// counted; a longer line is refused here as soon as it is longer (inih would cut it and
// parse the pieces; reading on would hold an endless line in memory), and so are a NUL
// byte (C strings would end the value there), a carriage return that is not part of a
// CR LF (CR-only line ends: the file would be one long line), a file over kMaxIniBytes,
// and an indented key or header (inih would add it to the previous key's value: its
// multi-line continuation, compiled into the system's libinih). After the first refusal
// it ends the input: only the first is reported.
char *read_line(char *str, int num, void *stream)
{
    Reader *r = static_cast<Reader *>(stream);
    if (r->error_line) {
        return nullptr;
    }
    std::string line;
    std::string bad; // why this line is refused while it is read, "" = not
    int ch;
    while ((ch = std::fgetc(r->f)) != EOF) {
        if (++r->bytes > kMaxIniBytes) {
            bad = "file: longer than " + std::to_string(kMaxIniBytes) + " bytes (not an INI file)";
            break;
        }
        if (ch == '\0') {
            bad = "line: a NUL byte at column " + std::to_string(line.size() + 1) + " (not a text file)";
            break;
        }
        if (ch == '\r') {
            const int next = std::fgetc(r->f);
            if (next != EOF) {
                std::ungetc(next, r->f);
            }
            if (next != '\n' && next != EOF) {
                bad = "line: a carriage return not followed by a line feed at column " +
                      std::to_string(line.size() + 1) + " (CR-only line ends: save the file with LF or CR LF)";
                break;
            }
        }
        line.push_back(static_cast<char>(ch));
        if (line.size() > static_cast<size_t>(num) - 1) {
            bad = "line: longer than " + std::to_string(num - 2) + " characters";
            break;
        }
        if (ch == '\n') {
            break;
        }
    }
    if (bad.empty() && ch == EOF && std::ferror(r->f)) {
        r->read_errno = errno;
        return nullptr;
    }
    if (line.empty() && bad.empty()) {
        return nullptr;
    }
    r->line++;
    const size_t text = line.find_first_not_of(" \t\r\n\f\v");
    if (!bad.empty()) {
        refuse(r, bad);
        line = "\n"; // parsed as an empty line
    } else if (text > 0 && text != std::string::npos && line[text] != ';' && line[text] != '#') {
        // inih would take it as a continuation of the previous key's value
        refuse(r, "line: indented (keys and [sections] start at the beginning of the line; "
                  "continuation lines are not supported)");
        line = "\n";
    } else {
        note_header(r, line);
    }
    std::memcpy(str, line.c_str(), line.size() + 1);
    return str;
}

// inih's handler: one key of the line just read; a nonzero return accepts it.
int on_key(void *user, const char *section, const char *name, const char *value)
{
    Reader *r = static_cast<Reader *>(user);
    if (*section == '\0' || r->file->sections.empty()) {
        refuse(r, std::string(name) + ": outside any [section]");
        return 0;
    }
    IniSection &sec = r->file->sections.back();
    const std::string key = ini_lower(name);
    if (sec.keys.count(key)) {
        refuse(r, std::string(name) + ": duplicate key in [" + sec.name + "]");
        return 0;
    }
    const IniKey &k = sec.keys[key] = IniKey{name, value, r->line};
    if (*r->check) {
        const std::string why = (*r->check)(sec, &k);
        if (!why.empty()) {
            refuse(r, why);
            return 0;
        }
    }
    return 1;
}

} // namespace

std::string ini_lower(std::string s)
{
    for (char &ch : s) {
        ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    }
    return s;
}

const IniSection *IniFile::find(const std::string &name) const
{
    for (const IniSection &s : sections) {
        if (s.name == name) {
            return &s;
        }
    }
    return nullptr;
}

int IniFile::line(const std::string &section, const std::string &key) const
{
    const IniSection *s = find(section);
    if (!s) {
        return 0;
    }
    const auto k = s->keys.find(key);
    return k == s->keys.end() ? s->line : k->second.line;
}

void IniFile::fail(int at, const std::string &what) const
{
    throw ConfigError(path + ":" + std::to_string(at) + ": " + what);
}

IniFile ini_read(const std::string &path, const IniCheck &check)
{
    IniFile file;
    file.path = path;
    std::unique_ptr<std::FILE, int (*)(std::FILE *)> f(std::fopen(path.c_str(), "r"), std::fclose);
    if (!f) {
        file.fail(0, std::string("file: ") + std::strerror(errno));
    }
    Reader r{&file, &check, f.get(), 0, 0, 0, 0, ""};
    const int rc = ini_parse_stream(read_line, &r, on_key, &r);
    if (rc < 0) {
        file.fail(0, "file: inih could not allocate its line buffer");
    }
    if (r.read_errno) {
        file.fail(0, std::string("file: ") + std::strerror(r.read_errno));
    }
    // rc is inih's first bad line: one before ours (or without ours) is a malformed line
    if (rc > 0 && (r.error_line == 0 || rc < r.error_line)) {
        file.fail(rc, "line: malformed (not [section], key = value or a comment)");
    }
    if (r.error_line) {
        file.fail(r.error_line, r.error);
    }
    return file;
}

} // namespace navkit
