// Animation: Animation.ini errors name file:line: key; the emotion matrix's targets at
// the extremes; one version per update toward the target; the beacon steps only while
// the micro is active; talking toggles the mouth; the console draws the face above the
// status line on a terminal.
#include <gtest/gtest.h>

#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <poll.h>
#include <pty.h>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "navkit/animation.hpp"
#include "navkit/console.hpp"
#include "tmp_file.hpp"

using namespace navkit;

static const std::string kShipped = std::string(NAVKIT_SOURCE_DIR) + "/config/Animation.ini";

// A small valid file: one 5-character head line, feature m (happiness, 3 versions).
static const char *kMini = "[face]\n"             // 1
                           "width = 5\n"          // 2
                           "features = m\n"       // 3
                           "head.0 = \"|...|\"\n" // 4
                           "[m]\n"                // 5
                           "input = happiness\n"  // 6
                           "row = 0\n"            // 7
                           "col = 1\n"            // 8
                           "version.0 = \"a\"\n"  // 9
                           "version.1 = \"b\"\n"  // 10
                           "version.2 = \"c\"\n"; // 11

class AnimationFile : public ::testing::Test {
protected:
    // The ConfigError text of starting on `text`, or "" if it starts.
    std::string error(const std::string &text)
    {
        tmp_.write(text);
        Animation a;
        try {
            a.start(path_);
        } catch (const ConfigError &e) {
            return e.what();
        }
        return "";
    }
    // kMini with line `no` (1-based) replaced by `line` ("" drops it; "\n..." adds after).
    static std::string mini_with(int no, const std::string &line)
    {
        std::string out, l;
        std::istringstream in(kMini);
        for (int i = 1; std::getline(in, l); i++) {
            out += i == no ? line : l + "\n";
        }
        return out;
    }
    TmpFile tmp_{"navkit-anim", "Animation.ini"};
    const std::string &dir_ = tmp_.dir, &path_ = tmp_.path;
};

TEST_F(AnimationFile, MiniStarts)
{
    EXPECT_EQ(error(kMini), "");
}

TEST_F(AnimationFile, MissingFileNamesThePath)
{
    Animation a;
    try {
        a.start(dir_ + "/nope.ini");
        FAIL() << "started without a file";
    } catch (const ConfigError &e) {
        EXPECT_EQ(std::string(e.what()), dir_ + "/nope.ini:0: file: No such file or directory");
    }
}

TEST_F(AnimationFile, ErrorsNameFileLineKeyReason)
{
    const std::string p = path_ + ":";
    struct Case {
        std::string text, want;
    };
    const std::vector<Case> cases = {
        {mini_with(2, "width = 5\ncolour = red\n"), p + "3: colour: unknown key in [face]"},
        {mini_with(2, "width = five\n"), p + "2: width: 'five' is not a decimal integer"},
        {mini_with(2, "width = 500\n"), p + "2: width: 500 is outside 1..120"},
        {mini_with(4, "head.0 = \"|..|\"\n"), p + "4: head.0: 4 characters, width is 5"},
        {mini_with(4, "head.0 = |...|\n"),
         p + "4: head.0: '|...|' is not a quoted strip (\"...\", at least one character)"},
        {mini_with(4, "head.0 = \"|...|\"\nhead.2 = \"|...|\"\n"), p + "5: head.2: head.1 is missing"},
        {mini_with(3, "features = m, n\n"), p + "3: features: no [n] section"},
        {std::string(kMini) + "[nose]\nrow = 1\n", p + "12: [nose]: unknown section (not in [face] features)"},
        {mini_with(6, "input = anger\n"), p + "6: input: 'anger' is not happiness, arousal, surprise or beacon"},
        {mini_with(6, ""), p + "5: input: missing in [m]"},
        {mini_with(7, "row = 1\n"), p + "7: row: 1 is outside 0..0"},
        {mini_with(7, "row = 0\nrow = 0\n"), p + "8: row: duplicate key in [m]"},
        {mini_with(10, "version.1 = \"bb\"\n"), p + "10: version.1: 2 characters, version.0 has 1"},
        {mini_with(10, ""), p + "10: version.2: version.1 is missing"},
        {mini_with(11, "from = 10\nto = 10\n"), p + "12: to: from and to are equal (10)"},
        {mini_with(11, "from = -200\n"), p + "11: from: -200 is outside -100..100"},
        {mini_with(6, "input = beacon\n") + "to = 5\n", p + "12: to: not used with input = beacon"},
        {mini_with(11, "gaze_cols = 2\n"), p + "11: gaze_cols: 1-character versions at col 1 +- 2 do not fit width 5"},
        {mini_with(11, "talk = \"xy\"\n"), p + "11: talk: 2 characters, version.0 has 1"},
        {mini_with(8, "col = 1\nthis is not a key\n"),
         p + "9: line: malformed (not [section], key = value or a comment)"},
        {"width = 5\n" + std::string(kMini), p + "1: width: outside any [section]"},
        {"[m]\ninput = happiness\n", p + "0: [face]: missing section"},
    };
    for (const Case &c : cases) {
        EXPECT_EQ(error(c.text), c.want) << c.text;
    }
}

TEST(Animation, ShippedFileStartsAtVersionZero)
{
    Animation a;
    a.start(kShipped);
    ASSERT_EQ(a.features().size(), 4u);
    EXPECT_EQ(a.features()[0].name, "beacon");
    EXPECT_EQ(a.features()[3].name, "mouth");
    for (const FaceFeature &f : a.features()) {
        EXPECT_EQ(f.version, 0) << f.name;
    }
    ASSERT_EQ(a.lines().size(), 10u);
    for (const std::string &l : a.lines()) {
        EXPECT_EQ(static_cast<int>(l.size()), a.width());
    }
    EXPECT_EQ(a.lines()[7].substr(7, 7), " /---\\ ") << "version 0 of the mouth is drawn before any update";
    EXPECT_EQ(a.state(), "beacon=0 brows=0 eyes=0@+0,+0 mouth=0");
}

static navkit_emotion_t emotion(int happiness, int arousal, int surprise)
{
    navkit_emotion_t e;
    navkit_emotion_defaults(&e);
    e.happiness = happiness;
    e.arousal = arousal;
    e.surprise = surprise;
    return e;
}

static const FaceFeature &feature(const Animation &a, const std::string &name)
{
    for (const FaceFeature &f : a.features()) {
        if (f.name == name) {
            return f;
        }
    }
    throw std::runtime_error("no feature " + name);
}

TEST(Animation, RampsOneVersionPerUpdateTowardTheTarget)
{
    Animation a;
    a.start(kShipped);
    const navkit_emotion_t smile = emotion(100, 0, 0);
    std::vector<int> seen;
    for (int i = 0; i < 6; i++) {
        a.update(smile, false);
        seen.push_back(feature(a, "mouth").version);
        EXPECT_EQ(feature(a, "mouth").target, 4);
    }
    EXPECT_EQ(seen, (std::vector<int>{1, 2, 3, 4, 4, 4}));
    EXPECT_EQ(a.lines()[7].substr(7, 7), " \\___/ ");
    seen.clear();
    for (int i = 0; i < 3; i++) {
        a.update(emotion(0, 0, 0), false);
        seen.push_back(feature(a, "mouth").version);
    }
    EXPECT_EQ(seen, (std::vector<int>{3, 2, 2})) << "happiness 0 targets the middle version";
}

TEST(Animation, EmotionMatrixTargetsAtTheExtremes)
{
    Animation a;
    a.start(kShipped);
    for (int i = 0; i < 8; i++) {
        a.update(emotion(-100, 100, 100), false);
    }
    EXPECT_EQ(feature(a, "mouth").version, 0);
    EXPECT_EQ(feature(a, "eyes").version, 3);
    EXPECT_EQ(feature(a, "brows").version, 3);
    for (int i = 0; i < 8; i++) {
        a.update(emotion(100, 0, 0), false);
    }
    EXPECT_EQ(feature(a, "mouth").version, 4);
    EXPECT_EQ(feature(a, "eyes").version, 0);
    EXPECT_EQ(feature(a, "brows").version, 0);
    EXPECT_EQ(a.lines()[4].substr(6, 9), "(-)   (-)");
}

TEST_F(AnimationFile, FromAboveToReversesTheVersions)
{
    std::ofstream(path_) << mini_with(11, "version.2 = \"c\"\nfrom = 100\nto = -100\n");
    Animation a;
    a.start(path_);
    a.update(emotion(100, 0, 0), false);
    EXPECT_EQ(a.features()[0].target, 0);
    a.update(emotion(-100, 0, 0), false);
    EXPECT_EQ(a.features()[0].target, 2);
    EXPECT_EQ(a.lines()[0], "|b..|") << "one step from 0, spaces of the head stay";
}

TEST(Animation, BeaconStepsOnlyWhileTheMicroIsActive)
{
    Animation a;
    a.start(kShipped);
    const navkit_emotion_t e = emotion(0, 0, 0);
    std::vector<int> seen;
    for (bool active : {false, false, true, true, true, true, true, false, false, true}) {
        a.update(e, active);
        seen.push_back(feature(a, "beacon").version);
    }
    EXPECT_EQ(seen, (std::vector<int>{0, 0, 1, 2, 3, 0, 1, 1, 1, 2}));
    EXPECT_EQ(a.lines()[0].substr(9, 3), "(|)");
}

TEST(Animation, TalkingTogglesTheMouthEveryUpdate)
{
    Animation a;
    a.start(kShipped);
    navkit_emotion_t e = emotion(100, 50, 0);
    e.talking = 1;
    std::vector<bool> open;
    for (int i = 0; i < 4; i++) {
        a.update(e, false);
        open.push_back(feature(a, "mouth").talk_open);
        EXPECT_EQ(a.lines()[7].substr(7, 7) == " ( o ) ", open.back());
        EXPECT_FALSE(feature(a, "eyes").talk_open) << "eyes have no talk strip";
    }
    EXPECT_EQ(open, (std::vector<bool>{true, false, true, false}));
    EXPECT_EQ(feature(a, "mouth").version, 4) << "the ramp goes on under the talking";
    e.talking = 0;
    a.update(e, false);
    a.update(e, false);
    EXPECT_FALSE(feature(a, "mouth").talk_open);
    EXPECT_EQ(a.lines()[7].substr(7, 7), " \\___/ ");
}

TEST(Animation, GazeMovesTheEyesOneStepPerUpdate)
{
    Animation a;
    a.start(kShipped);
    navkit_emotion_t e = emotion(0, 100, 0);
    e.gaze_x = 100;
    e.gaze_y = 100;
    a.update(e, false);
    EXPECT_EQ(feature(a, "eyes").dx, 1);
    EXPECT_EQ(feature(a, "eyes").dy, -1);
    a.update(e, false);
    a.update(e, false);
    EXPECT_EQ(feature(a, "eyes").dx, 2);
    EXPECT_EQ(feature(a, "eyes").dy, -1);
    EXPECT_EQ(a.lines()[3].substr(8, 9), "(O)   (O)") << "up one line, right two columns";
    EXPECT_EQ(a.lines()[4], "   |             |   ");
    EXPECT_EQ(feature(a, "mouth").dx, 0) << "the mouth does not follow the gaze";
}

TEST(Animation, OutOfRangeEmotionIsRefusedOncePerTimeTag)
{
    Animation a;
    a.start(kShipped);
    a.update(emotion(100, 0, 0), false);
    navkit_emotion_t bad = emotion(-100, 0, 0);
    bad.time_tag = 7;
    bad.arousal = 101;
    FaceUpdate u = a.update(bad, false);
    EXPECT_TRUE(u.rejected);
    EXPECT_EQ(u.rejected_field, NAVKIT_EMOTION_FIELD_AROUSAL);
    EXPECT_EQ(feature(a, "mouth").target, 4) << "the last valid emotion is kept";
    u = a.update(bad, false);
    EXPECT_FALSE(u.rejected) << "said once per time tag";
    bad.time_tag = 8;
    EXPECT_TRUE(a.update(bad, false).rejected);
}

TEST(Animation, ChangedOnlyWhenTheDrawingChanges)
{
    Animation a;
    a.start(kShipped);
    const navkit_emotion_t e = emotion(-100, 0, 0); // every target is version 0
    EXPECT_TRUE(a.update(e, false).changed) << "the first update draws";
    EXPECT_FALSE(a.update(e, false).changed);
    EXPECT_TRUE(a.update(e, true).changed) << "the beacon stepped";
    a.end();
    EXPECT_FALSE(a.started());
    EXPECT_TRUE(a.lines().empty());
    EXPECT_FALSE(a.update(e, true).changed) << "nothing after end()";
}

// What the console wrote to the pty's other end so far.
static std::string drain(int master)
{
    std::string out;
    char b[4096];
    pollfd p{master, POLLIN, 0};
    while (poll(&p, 1, 50) > 0) {
        const ssize_t n = read(master, b, sizeof b);
        if (n <= 0) {
            break;
        }
        out.append(b, static_cast<size_t>(n));
    }
    return out;
}

TEST(ConsoleFace, DrawnAboveTheStatusLineOnATerminal)
{
    int master = -1, slave = -1;
    ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    std::FILE *out = fdopen(slave, "w");
    ASSERT_NE(out, nullptr);
    {
        Console c(out, -1, 1.0);
        c.init();
        ASSERT_TRUE(c.out_tty());
        c.set_face({"<o o>", " --- "});
        c.status("s1");
        EXPECT_EQ(drain(master), "\033[?7l<o o>\r\n --- \r\ns1\033[?7h") << "autowrap off while drawn";
        c.set_face({"<o o>", " --- "});
        c.status("s2");
        EXPECT_EQ(drain(master), "\033[?7l\r\033[Ks2\033[?7h") << "an unchanged face is not redrawn";
        c.set_face({"<- ->", " --- "});
        c.status("s3");
        EXPECT_EQ(drain(master), "\r\033[2A\033[J\033[?7l<- ->\r\n --- \r\ns3\033[?7h")
            << "a changed face is redrawn in place";
        c.set_time_us(1500000);
        c.print("hello");
        EXPECT_EQ(drain(master), "\r\033[2A\033[J[    1.500] hello\r\n") << "a message scrolls above the face";
        c.status("s4");
        EXPECT_EQ(drain(master), "\033[?7l<- ->\r\n --- \r\ns4\033[?7h");
        c.set_face({});
        c.print("bye");
        EXPECT_EQ(drain(master), "\r\033[2A\033[J[    1.500] bye\r\n");
        c.status("s5");
        EXPECT_EQ(drain(master), "\033[?7ls5\033[?7h") << "no face after an empty set_face";
    }
    std::fclose(out);
    close(master);
}

TEST(ConsoleFace, NothingWhenStdoutIsNotATerminal)
{
    std::FILE *out = std::tmpfile();
    ASSERT_NE(out, nullptr);
    {
        Console c(out, -1, 1.0);
        c.init();
        EXPECT_FALSE(c.out_tty());
        c.set_face({"<o o>"});
        c.status("s1");
    }
    std::rewind(out);
    char b[256] = {0};
    const size_t n = std::fread(b, 1, sizeof b - 1, out);
    EXPECT_EQ(std::string(b, n), "[    0.000] status: s1\n");
    std::fclose(out);
}
