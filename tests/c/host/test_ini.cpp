// Ini: the shipped files load; every refusal names file:line: key: reason.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "navkit/ini.hpp"

using namespace navkit;

static const std::string kConfig = std::string(NAVKIT_SOURCE_DIR) + "/config";

class IniFiles : public ::testing::Test {
protected:
    void SetUp() override
    {
        char tmpl[] = "/tmp/navkit-iniXXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        dir_ = tmpl;
        copy("sensors.ini");
        copy("NavAndControl.ini");
    }
    void TearDown() override
    {
        std::remove((dir_ + "/sensors.ini").c_str());
        std::remove((dir_ + "/NavAndControl.ini").c_str());
        rmdir(dir_.c_str());
    }
    void copy(const std::string &name)
    {
        std::ifstream in(kConfig + "/" + name);
        std::ofstream out(dir_ + "/" + name);
        out << in.rdbuf();
    }
    void write(const std::string &name, const std::string &text) { std::ofstream(dir_ + "/" + name) << text; }
    // The ConfigError text of loading dir_, or "" if it loads.
    std::string error()
    {
        try {
            Ini::load(dir_);
        } catch (const ConfigError &e) {
            return e.what();
        }
        return "";
    }
    std::string dir_;
};

TEST(Ini, ShippedFilesLoadWithTheSpecDefaults)
{
    const Config c = Ini::load(kConfig);
    navkit_micro_cfg_motion_t m;
    navkit_micro_cfg_motion_defaults(&m);
    EXPECT_EQ(c.micro.motion.watchdog_timeout, m.watchdog_timeout);
    EXPECT_EQ(c.micro.motion.spec_hash, NAVKIT_SPEC_HASH);
    EXPECT_DOUBLE_EQ(c.exec.frame_rate_hz, 10.0);
    EXPECT_DOUBLE_EQ(c.exec.planner_timeout_s, 1.0);
    EXPECT_EQ(c.micro.port, "auto");
    EXPECT_EQ(c.sensors.ir[3].channel, 3);
    EXPECT_EQ(c.micro.io.servo_center[7], 1500);
}

TEST_F(IniFiles, OverridesApply)
{
    write("NavAndControl.ini", "[executive]\nframe_rate_hz = 50\n[micro]\nport = /dev/ttyUSB3\nparity = E\n"
                               "[micro_cfg_io]\nservo_center = 1400, 1410, 1420, 1430, 1440, 1450, 1460, 1470\n");
    const Config c = Ini::load(dir_);
    EXPECT_DOUBLE_EQ(c.exec.frame_rate_hz, 50.0);
    EXPECT_EQ(c.micro.port, "/dev/ttyUSB3");
    EXPECT_EQ(c.micro.parity, 'E');
    EXPECT_EQ(c.micro.io.servo_center[0], 1400);
    EXPECT_EQ(c.micro.io.servo_center[7], 1470);
}

TEST_F(IniFiles, UnknownKey)
{
    write("NavAndControl.ini", "; x\n[executive]\nframe_rate = 5\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: frame_rate: unknown key in [executive]");
}

TEST_F(IniFiles, UnknownSectionEvenWithoutKeys)
{
    write("sensors.ini", "[battery]\nchannel = 4\n\n[lidar]\n");
    EXPECT_EQ(error(), dir_ + "/sensors.ini:4: [lidar]: unknown section");
}

TEST_F(IniFiles, MalformedValue)
{
    write("NavAndControl.ini", "[executive]\nrecord = yes\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: record: 'yes' is not 0 or 1");
}

TEST_F(IniFiles, OutOfRangeValue)
{
    write("NavAndControl.ini", "[executive]\n\ndio_default = 4096\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: dio_default: 4096 is outside 0..4095");
}

TEST_F(IniFiles, SpecRangeOfAConfigField)
{
    write("NavAndControl.ini", "[micro_cfg_motion]\ndefault_speed = 100\nwatchdog_timeout = 5\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: watchdog_timeout: outside the spec's range "
                              "(docs/protocol.md, micro_cfg_motion)");
}

TEST_F(IniFiles, ValueThatDoesNotFitTheField)
{
    write("NavAndControl.ini", "[micro_cfg_geometry]\ncounts_per_rev = 70000\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: counts_per_rev: 70000 is outside 0..65535");
}

TEST_F(IniFiles, ArrayNeedsOneOrEightValues)
{
    write("NavAndControl.ini", "[micro_cfg_io]\nservo_min = -900, -900\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: servo_min: needs 1 or 8 comma-separated values, got 2");
}

TEST_F(IniFiles, DuplicateKey)
{
    write("NavAndControl.ini", "[executive]\nrecord = 1\nrecord = 0\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: record: duplicate key in [executive]");
}

TEST_F(IniFiles, MalformedLine)
{
    write("NavAndControl.ini", "[executive]\njust words\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: line: malformed (not [section], key = value or a comment)");
}

TEST_F(IniFiles, MissingFile)
{
    std::remove((dir_ + "/sensors.ini").c_str());
    EXPECT_EQ(error(), dir_ + "/sensors.ini:0: file: No such file or directory");
}

TEST_F(IniFiles, IrRangeOrder)
{
    write("sensors.ini", "[ir2]\nmin_mm = 500\nmax_mm = 400\n");
    EXPECT_EQ(error(), dir_ + "/sensors.ini:3: max_mm: must be above min_mm in [ir2]");
}

TEST_F(IniFiles, TwoBadLinesReportTheFirst)
{
    // inih goes on after the first refusal; the message is still the first line's
    write("NavAndControl.ini", "[executive]\nrecord = yes\nframe_rate = 5\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: record: 'yes' is not 0 or 1");
}

TEST_F(IniFiles, MalformedLineBeforeABadKeyIsTheFirst)
{
    write("NavAndControl.ini", "[executive]\njust words\nframe_rate = 5\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: line: malformed (not [section], key = value or a comment)");
    write("NavAndControl.ini", "[executive]\nframe_rate = 5\njust words\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: frame_rate: unknown key in [executive]");
}

TEST_F(IniFiles, EmptyUnknownSectionAfterABadKeyIsNotTheFirst)
{
    write("sensors.ini", "[battery]\nchannel = 9\n[lidar]\n");
    EXPECT_EQ(error(), dir_ + "/sensors.ini:2: channel: 9 is outside 0..7");
}

TEST_F(IniFiles, OverlongLineIsRefusedNotCut)
{
    write("NavAndControl.ini", "[executive]\nlog_dir = /" + std::string(300, 'x') + "\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: line: longer than 198 characters");
}

TEST_F(IniFiles, BaudMustBeASupportedRate)
{
    write("NavAndControl.ini", "[micro]\n\nbaud = 250000\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: baud: 250000 is not a supported rate (9600, 19200, 38400, "
                              "57600, 115200, 230400, 460800, 500000, 921600, 1000000, 2000000, 3000000)");
    write("NavAndControl.ini", "[micro]\nbaud = 921600\n");
    EXPECT_EQ(Ini::load(dir_).micro.baud, 921600);
}

TEST_F(IniFiles, FrameRateRangeIsTheCommandLines)
{
    write("NavAndControl.ini", "[executive]\nframe_rate_hz = 0.05\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: frame_rate_hz: 0.05 is outside 0.1..1000");
}

TEST_F(IniFiles, WatchdogMustOutlastTwoFrames)
{
    // 5 Hz: 200 ms frames, two of them 400 ms, the default watchdog 300 ms (navkit-host's
    // main refuses it with the real-time clock, at the later of the two keys)
    EXPECT_EQ(frame_watchdog_error(5.0, 300),
              "a frame of 200 ms at 5 Hz needs [micro_cfg_motion] watchdog_timeout "
              "above two frames (400 ms), not 300 ms: one lost frame would stop the robot");
    EXPECT_EQ(frame_watchdog_error(10.0, 200).substr(0, 31), "a frame of 100 ms at 10 Hz need");
    EXPECT_EQ(frame_watchdog_error(10.0, 201), "");
    write("NavAndControl.ini", "[executive]\nframe_rate_hz = 5\n[micro_cfg_motion]\n\nwatchdog_timeout = 400\n");
    const auto rate_watchdog_at = [](const Config &c) {
        return later_key_at(c, "executive", "frame_rate_hz", "micro_cfg_motion", "watchdog_timeout");
    };
    EXPECT_EQ(rate_watchdog_at(Ini::load(dir_)), dir_ + "/NavAndControl.ini:5: watchdog_timeout");
    write("NavAndControl.ini", "[micro_cfg_motion]\nwatchdog_timeout = 400\n[executive]\nframe_rate_hz = 5\n");
    EXPECT_EQ(rate_watchdog_at(Ini::load(dir_)), dir_ + "/NavAndControl.ini:4: frame_rate_hz");
    write("NavAndControl.ini", "[micro_cfg_motion]\nwatchdog_timeout = 400\n");
    EXPECT_EQ(rate_watchdog_at(Ini::load(dir_)), dir_ + "/NavAndControl.ini:2: watchdog_timeout")
        << "frame_rate_hz not written: the watchdog's line";
    write("NavAndControl.ini", "[executive]\nframe_rate_hz = 5\n");
    EXPECT_EQ(rate_watchdog_at(Ini::load(dir_)), dir_ + "/NavAndControl.ini:2: frame_rate_hz");
}

TEST_F(IniFiles, SignsMustBePlusOrMinusOne)
{
    // the spec's range is -1..1, but the micro refuses 0 (firmware/core/config.c)
    for (const char *key : {"enc_left_sign", "enc_right_sign", "motor_left_sign", "motor_right_sign", "gyro_sign"}) {
        write("NavAndControl.ini", std::string("[micro_cfg_geometry]\n\n") + key + " = 0\n");
        EXPECT_EQ(error(),
                  dir_ + "/NavAndControl.ini:3: " + key + ": '0' is not 1 or -1 (the micro refuses any other sign)");
    }
    write("NavAndControl.ini", "[micro_cfg_geometry]\nenc_left_sign = -1\ngyro_sign = 1\n");
    const Config c = Ini::load(dir_);
    EXPECT_EQ(c.micro.geometry.enc_left_sign, -1);
    EXPECT_EQ(c.micro.geometry.gyro_sign, 1);
}

TEST_F(IniFiles, ServoMinAboveServoMaxIsRefused)
{
    write("NavAndControl.ini", "[micro_cfg_io]\nservo_min = 1000\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: servo_min: servo 0's servo_min 1000 is above its servo_max 900 "
                              "(the micro refuses it)");
    write("NavAndControl.ini",
          "[micro_cfg_io]\nservo_min = -900\n\nservo_max = 900, 900, 900, -1000, 900, 900, 900, 900\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:4: servo_max: servo 3's servo_min -900 is above its servo_max -1000 "
                              "(the micro refuses it)");
    write("NavAndControl.ini", "[micro_cfg_io]\nservo_min = 100\nservo_max = 100\n");
    EXPECT_EQ(error(), "") << "equal limits are taken";
}

TEST(IniNumbers, IntegersAreDecimalHexOnlyWhereAllowed)
{
    long x = -1;
    EXPECT_EQ(ini_parse_int("0400", false, &x), "");
    EXPECT_EQ(x, 400) << "a leading zero is not octal";
    EXPECT_EQ(ini_parse_int("-012", false, &x), "");
    EXPECT_EQ(x, -12);
    EXPECT_EQ(ini_parse_int("+7", false, &x), "");
    EXPECT_EQ(x, 7);
    EXPECT_EQ(ini_parse_int("0800", false, &x), "") << "no octal digit rule either";
    EXPECT_EQ(x, 800);
    EXPECT_EQ(ini_parse_int("0x10", false, &x),
              "'0x10' is hex: 0x is taken by the bit masks only, this key is decimal");
    EXPECT_EQ(ini_parse_int("0x0F0", true, &x), "");
    EXPECT_EQ(x, 0xF0);
    EXPECT_EQ(ini_parse_int("0XaB", true, &x), "");
    EXPECT_EQ(x, 0xAB);
    for (const char *bad : {"", "-", "1.5", "1e3", "12abc", " 5", "0x", "-0x10", "0xg"}) {
        EXPECT_EQ(ini_parse_int(bad, true, &x), "'" + std::string(bad) + "' is not a decimal or 0x hex integer") << bad;
    }
    EXPECT_EQ(ini_parse_int("99999999999999999999", false, &x), "'99999999999999999999' is out of range");
    EXPECT_EQ(ini_parse_int("-99999999999999999999", false, &x), "'-99999999999999999999' is out of range");
}

TEST(IniNumbers, RealsAreDecimalAndFinite)
{
    double x = -1;
    EXPECT_EQ(ini_parse_real("0.015", &x), "");
    EXPECT_DOUBLE_EQ(x, 0.015);
    EXPECT_EQ(ini_parse_real("-.5", &x), "");
    EXPECT_DOUBLE_EQ(x, -0.5);
    EXPECT_EQ(ini_parse_real("10", &x), "");
    EXPECT_DOUBLE_EQ(x, 10.0);
    EXPECT_EQ(ini_parse_real("2.5e-3", &x), "");
    EXPECT_DOUBLE_EQ(x, 0.0025);
    EXPECT_EQ(ini_parse_real("007.5", &x), "");
    EXPECT_DOUBLE_EQ(x, 7.5);
    for (const char *bad : {"", ".", "0x10", "0x1p3", "inf", "-infinity", "nan", "1e", "1.2.3", "5 Hz", "e5"}) {
        EXPECT_EQ(ini_parse_real(bad, &x), "'" + std::string(bad) + "' is not a decimal number") << bad;
    }
    EXPECT_EQ(ini_parse_real("1e999", &x), "'1e999' is out of range");
    EXPECT_EQ(ini_parse_real("-1e999", &x), "'-1e999' is out of range");
}

TEST_F(IniFiles, NumbersInTheFiles)
{
    write("NavAndControl.ini", "[executive]\ndio_default = 0x0F0\n[micro_cfg_motion]\nwheel_kp = 0400\n"
                               "[micro_cfg_io]\nsensor_enable = 0x3FF\nservo_min = -0900\n");
    const Config c = Ini::load(dir_);
    EXPECT_EQ(c.exec.dio_default, 0xF0);
    EXPECT_EQ(c.micro.motion.wheel_kp, 400) << "decimal, not octal 256";
    EXPECT_EQ(c.micro.io.sensor_enable, 0x3FF);
    EXPECT_EQ(c.micro.io.servo_min[5], -900);
    write("NavAndControl.ini", "[executive]\nframe_rate_hz = 0x10\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: frame_rate_hz: '0x10' is not a decimal number");
    write("NavAndControl.ini", "[executive]\nplanner_timeout = nan\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: planner_timeout: 'nan' is not a decimal number");
    write("NavAndControl.ini", "[micro_cfg_motion]\n\nwheel_kp = 0x10\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: wheel_kp: '0x10' is hex: 0x is taken by the bit masks only, "
                              "this key is decimal");
    write("NavAndControl.ini", "[micro_cfg_io]\nservo_max = 900, 0x10, 900, 900, 900, 900, 900, 900\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:2: servo_max: '0x10' is hex: 0x is taken by the bit masks only, "
                              "this key is decimal");
    copy("NavAndControl.ini");
    write("sensors.ini", "[sonar1]\nmm_per_us = inf\n");
    EXPECT_EQ(error(), dir_ + "/sensors.ini:2: mm_per_us: 'inf' is not a decimal number");
}

TEST_F(IniFiles, IndentedKeyIsReportedAtItsLineNotAsThePreviousKey)
{
    write("NavAndControl.ini", "[executive]\nframe_rate_hz = 10\n    planner_timeout = 5\n");
    EXPECT_EQ(error(), dir_ + "/NavAndControl.ini:3: line: indented (keys and [sections] start at the beginning "
                              "of the line; continuation lines are not supported)");
}

TEST_F(IniFiles, ShmNameGroupAndLogDirAreCheckedAtTheirLines)
{
    const std::string nav = dir_ + "/NavAndControl.ini:";
    const std::string bad_name = " is not a POSIX shared-memory name ('/' then 1..255 characters, no other '/', "
                                 "not . or ..)";
    for (const std::string &v : std::vector<std::string>{"/a/b", "navkit", "/", "/.."}) {
        write("NavAndControl.ini", "[executive]\n\nshm_name = " + v + "\n");
        EXPECT_EQ(error(), nav + "3: shm_name: '" + v + "'" + bad_name) << v;
    }
    // longer than an INI line may be: --shm's path
    EXPECT_EQ(shm_name_error("/" + std::string(255, 'n')), "");
    EXPECT_EQ(shm_name_error("/" + std::string(256, 'n')), "'/" + std::string(256, 'n') + "'" + bad_name);
    write("NavAndControl.ini", "[executive]\nshm_name = /nk\nshm_group = nosuchgroup-nk\n");
    EXPECT_EQ(error(), nav + "3: shm_group: 'nosuchgroup-nk' is not a group of this system (getgrnam)");
    // log_dir's folder is checked by main, only when --log-dir does not replace it: here
    // its place is kept for that message
    write("NavAndControl.ini", "[executive]\n\nlog_dir = " + dir_ + "/nope\n");
    EXPECT_EQ(key_at(Ini::load(dir_), "executive", "log_dir"), nav + "3: log_dir");
    write("NavAndControl.ini", "[micro]\n[executive]\n");
    EXPECT_EQ(key_at(Ini::load(dir_), "executive", "log_dir"), nav + "2: log_dir") << "not written: its section's line";
    EXPECT_EQ(log_dir_error(dir_ + "/nope"), dir_ + "/nope: No such file or directory");
    EXPECT_EQ(log_dir_error(dir_ + "/sensors.ini"), dir_ + "/sensors.ini: not a directory");
    write("NavAndControl.ini", "[executive]\nlog_dir =\n");
    EXPECT_EQ(error(), nav + "2: log_dir: needs a value");
    write("NavAndControl.ini", "[executive]\nshm_name = /nk.test-1\nshm_group = root\nlog_dir = " + dir_ + "\n");
    const Config c = Ini::load(dir_);
    EXPECT_EQ(c.exec.shm_name, "/nk.test-1");
    EXPECT_EQ(c.exec.shm_group, "root");
    EXPECT_EQ(c.exec.log_dir, dir_);
}
