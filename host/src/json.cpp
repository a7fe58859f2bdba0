#include "navkit/json.hpp"

#include <cstdio>

namespace navkit {

std::string json_string(const std::string &v)
{
    std::string out = "\"";
    for (const char ch : v) {
        const unsigned char u = static_cast<unsigned char>(ch);
        if (ch == '"' || ch == '\\') {
            out += '\\';
            out += ch;
        } else if (u < 0x20) {
            char esc[8];
            std::snprintf(esc, sizeof esc, "\\u%04x", u);
            out += esc;
        } else {
            out += ch;
        }
    }
    return out + "\"";
}

} // namespace navkit
