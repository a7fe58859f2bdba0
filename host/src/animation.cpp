// Animation: Animation.ini -> a head and its features; update() ramps the features
// toward the emotion's targets one version per call. The file is read whole by ini_read
// (ini_file.hpp: inih through a line-counting reader), so every error names the exact
// line; the keys are checked afterwards (a feature's section is only known once [face]
// features is read, wherever it is in the file).
#include "navkit/animation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "navkit/ini_file.hpp"

namespace navkit {
namespace {

constexpr int kMaxWidth = 120;   // characters per face line
constexpr int kMaxLines = 40;    // head lines
constexpr int kMaxVersions = 64; // versions per feature

// Checks of one parsed file; every failure throws "path:line: key: reason".
class Checker {
public:
    explicit Checker(const IniFile &ini) : ini_(ini) {}

    // Throws ConfigError "path:line: key: why".
    [[noreturn]] void fail(int line, const std::string &key, const std::string &why) const
    {
        ini_.fail(line, key + ": " + why);
    }

    // The key's value as a decimal integer in lo..hi.
    int integer(const std::string &key, const IniKey &e, long lo, long hi) const
    {
        long x;
        const std::string why = ini_parse_int(e.value, false, &x);
        if (!why.empty()) {
            fail(e.line, key, why);
        }
        if (x < lo || x > hi) {
            fail(e.line, key, std::to_string(x) + " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
        }
        return static_cast<int>(x);
    }

    // A strip: the characters between double quotes (printable ASCII, one column each).
    std::string strip(const std::string &key, const IniKey &e) const
    {
        const std::string &v = e.value;
        if (v.size() < 3 || v.front() != '"' || v.back() != '"') {
            fail(e.line, key, "'" + v + "' is not a quoted strip (\"...\", at least one character)");
        }
        const std::string s = v.substr(1, v.size() - 2);
        for (size_t i = 0; i < s.size(); i++) {
            const unsigned char ch = static_cast<unsigned char>(s[i]);
            if (ch < 0x20 || ch > 0x7e) {
                fail(e.line, key, "character " + std::to_string(i) + " is not printable ASCII");
            }
        }
        return s;
    }

    // "name.N" keys of a section into a list 0..N-1 (each a strip); refuses gaps.
    std::vector<std::string> numbered(const IniSection &s, const std::string &stem, int max_count) const
    {
        std::map<int, std::pair<std::string, int>> got; // N -> strip, line
        for (const auto &kv : s.keys) {
            if (kv.first.compare(0, stem.size() + 1, stem + ".") != 0) {
                continue;
            }
            const IniKey n{kv.first, kv.first.substr(stem.size() + 1), kv.second.line};
            const int i = integer(kv.first, n, 0, max_count - 1);
            if (std::to_string(i) != n.value) {
                fail(n.line, kv.first, "write the number as " + std::to_string(i));
            }
            got[i] = {strip(kv.first, kv.second), kv.second.line};
        }
        std::vector<std::string> out;
        for (const auto &kv : got) {
            if (kv.first != static_cast<int>(out.size())) {
                fail(kv.second.second, stem + "." + std::to_string(kv.first),
                     stem + "." + std::to_string(out.size()) + " is missing");
            }
            out.push_back(kv.second.first);
        }
        return out;
    }

    // Keys of a section in file order; refuses those that are not `known` (or stem.N).
    std::vector<std::pair<std::string, IniKey>> keys(const std::string &sec, const IniSection &s,
                                                     const std::vector<std::string> &known,
                                                     const std::string &stem) const
    {
        std::vector<std::pair<std::string, IniKey>> v(s.keys.begin(), s.keys.end());
        std::sort(v.begin(), v.end(), [](const auto &a, const auto &b) { return a.second.line < b.second.line; });
        for (const auto &kv : v) {
            const bool numbered_key = kv.first.compare(0, stem.size() + 1, stem + ".") == 0;
            if (!numbered_key && std::find(known.begin(), known.end(), kv.first) == known.end()) {
                fail(kv.second.line, kv.first, "unknown key in [" + sec + "]");
            }
        }
        return v;
    }

private:
    const IniFile &ini_;
};

// s without its leading and trailing blanks.
std::string trim(const std::string &s)
{
    const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
    return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// The input's range in emotion units (the spec's).
void input_range(FaceInput in, int *lo, int *hi)
{
    *lo = in == FaceInput::happiness ? -100 : 0;
    *hi = 100;
}

// The emotion's value of input `in` (emotion units; 0 for the beacon).
int input_value(FaceInput in, const navkit_emotion_t &e)
{
    switch (in) {
    case FaceInput::happiness:
        return e.happiness;
    case FaceInput::arousal:
        return e.arousal;
    case FaceInput::surprise:
        return e.surprise;
    case FaceInput::beacon:
        break;
    }
    return 0;
}

// now moved one step (1) toward target.
int step_toward(int now, int target)
{
    return now + (target > now) - (target < now);
}

} // namespace

void Animation::start(const std::string &path)
{
    const IniFile ini = ini_read(path);
    const Checker ck(ini);

    // [face]: width, head.N, features
    const IniSection *fs = ini.find("face");
    if (!fs) {
        ck.fail(0, "[face]", "missing section");
    }
    const IniSection &face = *fs;
    int width = 0;
    std::vector<std::string> names;
    const IniKey *features_entry = nullptr;
    for (const auto &kv : ck.keys("face", face, {"width", "features"}, "head")) {
        if (kv.first == "width") {
            width = ck.integer(kv.first, kv.second, 1, kMaxWidth);
        } else if (kv.first == "features") {
            features_entry = &face.keys.at("features");
            std::stringstream ss(kv.second.value);
            std::string item;
            while (std::getline(ss, item, ',')) {
                item = ini_lower(trim(item));
                if (item.empty() || item == "face") {
                    ck.fail(kv.second.line, "features", "'" + item + "' is not a feature name");
                }
                if (std::find(names.begin(), names.end(), item) != names.end()) {
                    ck.fail(kv.second.line, "features", item + " is listed twice");
                }
                names.push_back(item);
            }
        }
    }
    if (width == 0) {
        ck.fail(face.line, "width", "missing in [face]");
    }
    if (!features_entry || names.empty()) {
        ck.fail(face.line, "features", "missing in [face] (comma-separated feature sections)");
    }
    std::vector<std::string> head = ck.numbered(face, "head", kMaxLines);
    if (head.empty()) {
        ck.fail(face.line, "head.0", "missing in [face]");
    }
    for (size_t i = 0; i < head.size(); i++) {
        if (static_cast<int>(head[i].size()) != width) {
            const std::string k = "head." + std::to_string(i);
            ck.fail(face.keys.at(k).line, k,
                    std::to_string(head[i].size()) + " characters, width is " + std::to_string(width));
        }
    }
    for (const std::string &n : names) {
        if (!ini.find(n)) {
            ck.fail(features_entry->line, "features", "no [" + n + "] section");
        }
    }
    const int nlines = static_cast<int>(head.size());

    // Feature sections, in file order.
    std::map<std::string, FaceFeature> built;
    for (const IniSection &s : ini.sections) {
        const std::string &sec = s.name;
        if (sec == "face") {
            continue;
        }
        if (std::find(names.begin(), names.end(), sec) == names.end()) {
            ck.fail(s.line, "[" + sec + "]", "unknown section (not in [face] features)");
        }
        FaceFeature ft;
        ft.name = sec;
        const IniKey *row = nullptr, *col = nullptr, *input = nullptr, *from = nullptr, *to = nullptr;
        const IniKey *talk = nullptr, *gx = nullptr, *gy = nullptr;
        const auto kvs = ck.keys(sec, s, {"row", "col", "input", "from", "to", "talk", "gaze_cols", "gaze_rows"},
                                 "version");
        for (const auto &kv : kvs) {
            const IniKey *e = &s.keys.at(kv.first);
            const std::string &k = kv.first;
            if (k == "row") {
                row = e;
                ft.row = ck.integer(k, *e, 0, nlines - 1);
            } else if (k == "col") {
                col = e;
                ft.col = ck.integer(k, *e, 0, width - 1);
            } else if (k == "input") {
                input = e;
                const std::string v = ini_lower(e->value);
                if (v == "happiness") {
                    ft.input = FaceInput::happiness;
                } else if (v == "arousal") {
                    ft.input = FaceInput::arousal;
                } else if (v == "surprise") {
                    ft.input = FaceInput::surprise;
                } else if (v == "beacon") {
                    ft.input = FaceInput::beacon;
                } else {
                    ck.fail(e->line, k, "'" + e->value + "' is not happiness, arousal, surprise or beacon");
                }
            } else if (k == "from") {
                from = e;
            } else if (k == "to") {
                to = e;
            } else if (k == "talk") {
                talk = e;
                ft.talk = ck.strip(k, *e);
            } else if (k == "gaze_cols") {
                gx = e;
                ft.gaze_cols = ck.integer(k, *e, 0, width);
            } else if (k == "gaze_rows") {
                gy = e;
                ft.gaze_rows = ck.integer(k, *e, 0, nlines);
            }
        }
        if (!input) {
            ck.fail(s.line, "input", "missing in [" + sec + "]");
        }
        if (!row) {
            ck.fail(s.line, "row", "missing in [" + sec + "]");
        }
        if (!col) {
            ck.fail(s.line, "col", "missing in [" + sec + "]");
        }
        ft.versions = ck.numbered(s, "version", kMaxVersions);
        if (ft.versions.size() < 2) {
            ck.fail(s.line, "version." + std::to_string(ft.versions.size()),
                    "missing in [" + sec + "] (at least version.0 and version.1)");
        }
        const size_t len = ft.versions[0].size();
        for (size_t i = 1; i < ft.versions.size(); i++) {
            if (ft.versions[i].size() != len) {
                const std::string k = "version." + std::to_string(i);
                ck.fail(s.keys.at(k).line, k,
                        std::to_string(ft.versions[i].size()) + " characters, version.0 has " + std::to_string(len));
            }
        }
        if (talk && ft.talk.size() != len) {
            ck.fail(talk->line, "talk",
                    std::to_string(ft.talk.size()) + " characters, version.0 has " + std::to_string(len));
        }
        if (ft.input == FaceInput::beacon) {
            for (const IniKey *e : {from, to, talk}) {
                if (e) {
                    const std::string k = e == from ? "from" : e == to ? "to" : "talk";
                    ck.fail(e->line, k, "not used with input = beacon");
                }
            }
        } else {
            int lo, hi;
            input_range(ft.input, &lo, &hi);
            ft.from = from ? ck.integer("from", *from, lo, hi) : lo;
            ft.to = to ? ck.integer("to", *to, lo, hi) : hi;
            if (ft.from == ft.to) {
                const IniKey *e = to ? to : from;
                ck.fail(e->line, e == to ? "to" : "from", "from and to are equal (" + std::to_string(ft.from) + ")");
            }
        }
        const int l = static_cast<int>(len);
        if (ft.col - ft.gaze_cols < 0 || ft.col + l + ft.gaze_cols > width) {
            const IniKey *e = gx ? gx : col;
            ck.fail(e->line, e == gx ? "gaze_cols" : "col",
                    std::to_string(l) + "-character versions at col " + std::to_string(ft.col) + " +- " +
                        std::to_string(ft.gaze_cols) + " do not fit width " + std::to_string(width));
        }
        if (ft.row - ft.gaze_rows < 0 || ft.row + ft.gaze_rows >= nlines) {
            const IniKey *e = gy ? gy : row;
            ck.fail(e->line, e == gy ? "gaze_rows" : "row",
                    "row " + std::to_string(ft.row) + " +- " + std::to_string(ft.gaze_rows) + " is outside the " +
                        std::to_string(nlines) + " head lines");
        }
        built[sec] = ft;
    }

    end();
    width_ = width;
    head_ = head;
    for (const std::string &n : names) {
        features_.push_back(built.at(n));
    }
    navkit_emotion_defaults(&good_);
    render();
}

FaceUpdate Animation::update(const navkit_emotion_t &emotion, bool micro_active)
{
    FaceUpdate u;
    if (!started()) {
        return u;
    }
    int bad = -1;
    if (navkit_emotion_check(&emotion, &bad) == NAVKIT_OK) {
        good_ = emotion;
    } else if (!refused_any_ || emotion.time_tag != refused_tag_) {
        u.rejected = true;
        u.rejected_field = bad;
        refused_any_ = true;
        refused_tag_ = emotion.time_tag;
    }
    const navkit_emotion_t &e = good_;
    for (FaceFeature &f : features_) {
        const int n = static_cast<int>(f.versions.size());
        if (f.input == FaceInput::beacon) {
            if (micro_active) {
                f.version = (f.version + 1) % n;
            }
            f.target = f.version;
        } else {
            const int x = input_value(f.input, e);
            double t = static_cast<double>(x - f.from) / static_cast<double>(f.to - f.from);
            t = std::min(1.0, std::max(0.0, t));
            f.target = static_cast<int>(std::lround(t * (n - 1)));
            f.version = step_toward(f.version, f.target);
        }
        const int tx = static_cast<int>(std::lround(e.gaze_x * f.gaze_cols / 100.0));
        const int ty = static_cast<int>(std::lround(-e.gaze_y * f.gaze_rows / 100.0));
        f.dx = step_toward(f.dx, tx);
        f.dy = step_toward(f.dy, ty);
        f.talk_open = !f.talk.empty() && e.talking == 1 && !f.talk_open;
    }
    const std::vector<std::string> before = lines_;
    render();
    u.changed = !drawn_ || lines_ != before;
    drawn_ = true;
    return u;
}

void Animation::render()
{
    lines_ = head_;
    for (const FaceFeature &f : features_) {
        const std::string &s = f.talk_open ? f.talk : f.versions[static_cast<size_t>(f.version)];
        std::string &line = lines_[static_cast<size_t>(f.row + f.dy)];
        for (size_t i = 0; i < s.size(); i++) {
            if (s[i] != ' ') {
                line[static_cast<size_t>(f.col + f.dx) + i] = s[i];
            }
        }
    }
}

void Animation::end()
{
    width_ = 0;
    head_.clear();
    features_.clear();
    lines_.clear();
    good_ = navkit_emotion_t{};
    refused_any_ = false;
    refused_tag_ = 0;
    drawn_ = false;
}

std::string Animation::state() const
{
    std::string s;
    char b[64];
    for (const FaceFeature &f : features_) {
        std::snprintf(b, sizeof b, "%s%s=%d%s", s.empty() ? "" : " ", f.name.c_str(), f.version,
                      f.talk_open ? ":talk" : "");
        s += b;
        if (f.gaze_cols || f.gaze_rows) {
            std::snprintf(b, sizeof b, "@%+d,%+d", f.dx, f.dy);
            s += b;
        }
    }
    return s;
}

} // namespace navkit
