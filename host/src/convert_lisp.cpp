#include "navkit/convert_lisp.hpp"

#include <cctype>
#include <cstdint>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "navkit/json.hpp"
#include "navkit/navigation.hpp"

namespace navkit {

namespace {

// A member of an input line: name, raw value and the byte offset of its name.
struct Member {
    std::string name;
    int64_t value;
    size_t at;
};

// One input line, read as a flat JSON object of integers: {"name": -12, ...}.
class LineReader {
public:
    explicit LineReader(const std::string &s) : s_(s) {}

    // The object's members in order into *members; "" or the reason, at byte offset().
    std::string read(std::vector<Member> *members)
    {
        std::set<std::string> seen;
        space();
        if (!take('{')) {
            return "expected '{' (one JSON object a line)";
        }
        space();
        if (!take('}')) {
            for (;;) {
                std::string name;
                int64_t v = 0;
                const size_t at = i_;
                std::string why = key(&name);
                if (!why.empty()) {
                    return why;
                }
                if (!seen.insert(name).second) {
                    i_ = at;
                    return "\"" + name + "\" given twice";
                }
                space();
                if (!take(':')) {
                    return "expected ':'";
                }
                space();
                why = integer(&v);
                if (!why.empty()) {
                    return "\"" + name + "\": " + why;
                }
                members->push_back(Member{name, v, at});
                space();
                if (take('}')) {
                    break;
                }
                if (!take(',')) {
                    return "expected ',' or '}'";
                }
                space();
            }
        }
        space();
        return i_ == s_.size() ? "" : "text after the object";
    }
    size_t offset() const { return i_; }

private:
    void space()
    {
        while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\r')) {
            i_++;
        }
    }
    bool take(char c)
    {
        if (i_ < s_.size() && s_[i_] == c) {
            i_++;
            return true;
        }
        return false;
    }
    // A member name: a JSON string of plain characters (field names need no escapes).
    std::string key(std::string *name)
    {
        if (!take('"')) {
            return "expected a field name in double quotes";
        }
        const size_t start = i_;
        while (i_ < s_.size() && s_[i_] != '"') {
            if (s_[i_] == '\\' || static_cast<unsigned char>(s_[i_]) < 0x20) {
                return "a field name is plain text (no escapes or control characters)";
            }
            i_++;
        }
        if (i_ == s_.size()) {
            i_ = start - 1;
            return "unterminated string";
        }
        *name = s_.substr(start, i_ - start);
        i_++;
        return "";
    }
    // A JSON integer: -?digits, at most 18 digits (no fraction or exponent: raw values).
    std::string integer(int64_t *v)
    {
        const size_t start = i_;
        const bool neg = take('-');
        const size_t digits = i_;
        int64_t x = 0;
        while (i_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[i_]))) {
            if (i_ - digits >= 18) {
                i_ = start;
                return "more than 18 digits (a raw value)";
            }
            x = x * 10 + (s_[i_++] - '0');
        }
        if (i_ == digits || (i_ < s_.size() && (s_[i_] == '.' || s_[i_] == 'e' || s_[i_] == 'E'))) {
            i_ = start;
            return "expected an integer (a raw value)";
        }
        *v = neg ? -x : x;
        return "";
    }

    const std::string &s_;
    size_t i_ = 0;
};

const char *refusal_name(Refusal r)
{
    switch (r) {
    case Refusal::none:
        return "none";
    case Refusal::code:
        return "code";
    case Refusal::range:
        return "range";
    case Refusal::heading_range:
        return "heading_range";
    case Refusal::heading_missing:
        return "heading_missing";
    }
    return "?";
}

// The verdict line of a command whose field `field` (value v) lies outside lisp_cmd's
// own spec (range, or not a code of its enum, or a broken constraint).
std::string lisp_range_line(int field, int64_t v)
{
    const int64_t lo = navkit_lisp_cmd_field_min(field), hi = navkit_lisp_cmd_field_max(field);
    const std::string text = std::to_string(v) +
                             (navkit_lisp_cmd_in_range(field, v)
                                  ? std::string(" is not a value lisp_cmd takes (its spec's codes or constraints)")
                                  : " is outside " + std::to_string(lo) + ".." + std::to_string(hi) + " (" +
                                        navkit_lisp_cmd_field_units(field) + "), lisp_cmd's own range");
    return "{\"nav_result\": \"rejected\", \"refusal\": \"lisp_range\", \"lisp_field\": " +
           json_string(navkit_lisp_cmd_field_name(field)) + ", \"value\": " + std::to_string(v) +
           ", \"min\": " + std::to_string(lo) + ", \"max\": " + std::to_string(hi) +
           ", \"text\": " + json_string(text) + "}";
}

std::string verdict_line(const Conversion &c, const navkit_micro_cmd_t &m)
{
    if (c.nav_result != NAVKIT_NAV_RESULT_REJECTED) {
        std::string o = std::string("{\"nav_result\": ") + json_string(navkit_nav_result_name(c.nav_result)) +
                        ", \"micro_cmd\": {";
        for (int i = 0; i < NAVKIT_MICRO_CMD_FIELD_COUNT; i++) {
            o += (i ? ", " : "") + json_string(navkit_micro_cmd_field_name(i)) + ": ";
            const int n = navkit_micro_cmd_field_elements(i);
            if (n == 1) {
                o += std::to_string(navkit_micro_cmd_get(&m, i, 0));
                continue;
            }
            o += "[";
            for (int e = 0; e < n; e++) {
                o += (e ? ", " : "") + std::to_string(navkit_micro_cmd_get(&m, i, e));
            }
            o += "]";
        }
        return o + "}}";
    }
    std::string o = std::string("{\"nav_result\": \"rejected\", \"refusal\": ") + json_string(refusal_name(c.refusal)) +
                    ", \"lisp_field\": " + json_string(navkit_lisp_cmd_field_name(c.lisp_field)) +
                    ", \"value\": " + std::to_string(c.value);
    if (c.refusal == Refusal::range) {
        o += ", \"micro_field\": " + json_string(navkit_micro_cmd_field_name(c.micro_field)) +
             ", \"min\": " + std::to_string(navkit_micro_cmd_field_min(c.micro_field)) +
             ", \"max\": " + std::to_string(navkit_micro_cmd_field_max(c.micro_field));
    }
    return o + ", \"text\": " + json_string(c.text()) + "}";
}

} // namespace

int convert_lisp_lines(std::istream &in, std::ostream &out, std::string *error)
{
    std::string line;
    for (long n = 1; std::getline(in, line); n++) {
        std::vector<Member> members;
        LineReader r(line);
        std::string why = r.read(&members);
        size_t at = r.offset(); // of the reason
        navkit_lisp_cmd_t cmd;
        navkit_lisp_cmd_defaults(&cmd);
        std::optional<uint16_t> heading;
        int bad = -1; // the first field outside lisp_cmd's own range
        int64_t bad_value = 0;
        for (const auto &[name, v, member_at] : members) {
            if (!why.empty()) {
                break;
            }
            at = member_at;
            if (name == "heading") {
                if (v < 0 || v >= Navigation::kFullTurn) {
                    why = "\"heading\": " + std::to_string(v) + " is outside 0.." +
                          std::to_string(Navigation::kFullTurn - 1) + " (deg x 0.1, the micro's heading)";
                }
                heading = static_cast<uint16_t>(v);
                continue;
            }
            const int f = navkit_lisp_cmd_field_index(name.c_str());
            if (f < 0) {
                why = "\"" + name + "\": not a lisp_cmd field (docs/protocol.md) or \"heading\"";
            } else if (!navkit_lisp_cmd_in_range(f, v)) {
                if (bad < 0) {
                    bad = f;
                    bad_value = v;
                }
            } else {
                navkit_lisp_cmd_set(&cmd, f, 0, v);
            }
        }
        if (!why.empty()) {
            *error = "stdin:" + std::to_string(n) + ": byte " + std::to_string(at) + ": " + why;
            return 1;
        }
        // as ProcessCommands: a command outside lisp_cmd's own spec never reaches navigation
        if (bad < 0 && navkit_lisp_cmd_check(&cmd, &bad) != NAVKIT_OK) {
            bad_value = navkit_lisp_cmd_get(&cmd, bad, 0);
        }
        if (bad >= 0) {
            out << lisp_range_line(bad, bad_value) << "\n" << std::flush;
            continue;
        }
        navkit_micro_cmd_t m;
        navkit_micro_cmd_defaults(&m);
        const Conversion c = Navigation::convert(cmd, heading, 0, &m);
        out << verdict_line(c, m) << "\n" << std::flush;
    }
    return 0;
}

} // namespace navkit
