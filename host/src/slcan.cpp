#include "navkit/slcan.hpp"

#include <algorithm>
#include <cstdio>
#include <iterator>

namespace navkit {

// SLCAN "Sn": n = index in this table (bit/s); 9 (83 300) is an extension some adapters lack.
static const int kRates[] = {10000, 20000, 50000, 100000, 125000, 250000, 500000, 800000, 1000000};
// A line longer than any frame line ("T" + 8 + 1 + 16 + 4 time stamp digits) is noise.
static const size_t kMaxLine = 40;

const std::vector<int> &Slcan::bitrates()
{
    static const std::vector<int> v(std::begin(kRates), std::end(kRates));
    return v;
}

std::string Slcan::bitrate_command(int bitrate)
{
    for (size_t i = 0; i < sizeof kRates / sizeof kRates[0]; i++) {
        if (kRates[i] == bitrate) {
            return "S" + std::to_string(i);
        }
    }
    return "";
}

std::string Slcan::open_commands(int bitrate)
{
    const std::string s = bitrate_command(bitrate);
    return s.empty() ? "" : "C\r" + s + "\rO\r";
}

std::string Slcan::frame_command(uint16_t id, const uint8_t data[8])
{
    char buf[32];
    int n = std::snprintf(buf, sizeof buf, "t%03X8", static_cast<unsigned>(id & 0x7FFu));
    for (int i = 0; i < 8; i++) {
        n += std::snprintf(buf + n, sizeof buf - static_cast<size_t>(n), "%02X", data[i]);
    }
    return std::string(buf, static_cast<size_t>(n)) + "\r";
}

static int hex_digit(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

// n hex digits of s from `at` into *v; false if any is not hex.
static bool hex_value(const std::string &s, size_t at, size_t n, uint32_t *v)
{
    *v = 0;
    for (size_t i = at; i < at + n; i++) {
        const int d = i < s.size() ? hex_digit(s[i]) : -1;
        if (d < 0) {
            return false;
        }
        *v = (*v << 4) | static_cast<uint32_t>(d);
    }
    return true;
}

bool Slcan::parse(const std::string &line, SlcanFrame *f) const
{
    const char c = line[0];
    if (c != 't' && c != 'T' && c != 'r' && c != 'R') {
        return false;
    }
    f->extended = (c == 'T' || c == 'R');
    f->remote = (c == 'r' || c == 'R');
    const size_t nid = f->extended ? 8 : 3;
    uint32_t v;
    if (!hex_value(line, 1, nid, &f->id) || f->id >= (f->extended ? (1u << 29) : (1u << 11)) ||
        !hex_value(line, 1 + nid, 1, &v) || v > 8) {
        return false;
    }
    f->dlc = static_cast<uint8_t>(v);
    const size_t data_at = 2 + nid;
    const size_t data_len = f->remote ? 0 : 2u * f->dlc;
    // after the data: nothing, or a 4-digit time stamp
    const size_t rest = line.size() - std::min(line.size(), data_at + data_len);
    if (line.size() < data_at + data_len || (rest != 0 && rest != 4)) {
        return false;
    }
    for (size_t i = 0; i < data_len / 2; i++) {
        if (!hex_value(line, data_at + 2 * i, 2, &v)) {
            return false;
        }
        f->data[i] = static_cast<uint8_t>(v);
    }
    return rest == 0 || hex_value(line, data_at + data_len, 4, &v);
}

void Slcan::feed(const uint8_t *buf, size_t len, std::vector<SlcanFrame> *out)
{
    for (size_t i = 0; i < len; i++) {
        const char c = static_cast<char>(buf[i]);
        if (c == '\a') {
            refused_++;
            line_.clear();
            continue;
        }
        if (c != '\r') {
            if (line_.size() <= kMaxLine) {
                line_.push_back(c);
            }
            continue;
        }
        if (line_.empty() || line_ == "z" || line_ == "Z") {
            line_.clear(); // an answer: done, frame queued
            continue;
        }
        SlcanFrame f;
        if (line_.size() <= kMaxLine && parse(line_, &f)) {
            out->push_back(f);
        } else {
            bad_lines_++;
        }
        line_.clear();
    }
}

} // namespace navkit
