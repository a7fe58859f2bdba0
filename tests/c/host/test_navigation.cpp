// Navigation: planner low-level commands -> micro commands; teleop; DIO-only changes.
#include <gtest/gtest.h>

#include <cstring>

#include "navkit/navigation.hpp"

using namespace navkit;

static navkit_lisp_cmd_t lisp()
{
    navkit_lisp_cmd_t c;
    navkit_lisp_cmd_defaults(&c);
    return c;
}

TEST(Navigation, ForwardStartModifyStopPassThrough)
{
    for (int code : {1, 3, 5}) {
        navkit_lisp_cmd_t c = lisp();
        c.fwd_cmd = code;
        c.accel = 400;
        c.speed = 250;
        c.distance = -200000000;
        navkit_micro_cmd_t m;
        ASSERT_EQ(Navigation::convert(c, 0, 0x5, &m).nav_result, NAVKIT_NAV_RESULT_OK);
        EXPECT_EQ(m.fwd_cmd, code);
        EXPECT_EQ(m.accel, 400);
        EXPECT_EQ(m.speed, 250);
        EXPECT_EQ(m.distance, -200000000);
        EXPECT_EQ(m.turn_cmd, 0);
        EXPECT_EQ(m.dio_command, 0x5);
    }
}

TEST(Navigation, TurnModesOneThreeFive)
{
    for (int code : {1, 3, 5}) {
        navkit_lisp_cmd_t c = lisp();
        c.turn_mode = code;
        c.turn_accel = 900;
        c.turn_rate = 300;
        c.turn_distance = -450;
        navkit_micro_cmd_t m;
        ASSERT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
        EXPECT_EQ(m.turn_cmd, code);
        EXPECT_EQ(m.turn_accel, 900);
        EXPECT_EQ(m.turn_rate, 300);
        EXPECT_EQ(m.turn_distance, -450);
        EXPECT_EQ(m.fwd_cmd, 0);
    }
}

TEST(Navigation, HeadingSelectPassesZeroTo3600)
{
    navkit_lisp_cmd_t c = lisp();
    c.turn_mode = 10;
    navkit_micro_cmd_t m;
    for (int h : {0, 900, 3600}) {
        c.turn_distance = h;
        ASSERT_EQ(Navigation::convert(c, 1234, 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
        EXPECT_EQ(m.turn_cmd, NAVKIT_TURN_CMD_HDG_SEL);
        EXPECT_EQ(m.turn_distance, h);
    }
    c.turn_distance = 3601;
    EXPECT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_REJECTED);
    c.turn_distance = -1;
    EXPECT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_REJECTED);
}

TEST(Navigation, HeadingHoldIsCurrentHeadingPlusWord9Wrapped)
{
    navkit_lisp_cmd_t c = lisp();
    c.turn_mode = 11;
    navkit_micro_cmd_t m;
    const int cases[][3] = {{1000, 0, 1000}, {1000, 100, 1100}, {3500, 300, 200}, {100, -1800, 1900}, {0, -3600, 0}};
    for (const auto &k : cases) {
        c.turn_distance = k[1];
        ASSERT_EQ(Navigation::convert(c, static_cast<uint16_t>(k[0]), 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
        EXPECT_EQ(m.turn_cmd, NAVKIT_TURN_CMD_HDG_SEL);
        EXPECT_EQ(m.turn_distance, k[2]) << k[0] << " + " << k[1];
    }
}

TEST(Navigation, HeadingHoldWithoutAFreshHeadingIsRejected)
{
    navkit_lisp_cmd_t c = lisp();
    c.time_tag = 77;
    c.fwd_cmd = NAVKIT_FWD_CMD_START;
    c.speed = 100;
    c.distance = 500;
    c.turn_mode = 11;
    c.turn_distance = 100;
    navkit_micro_cmd_t m;
    m.turn_distance = 4242;
    EXPECT_EQ(Navigation::convert(c, std::nullopt, 0, &m).nav_result, NAVKIT_NAV_RESULT_REJECTED);
    EXPECT_EQ(m.turn_distance, 4242) << "untouched: never a hold of heading 0";

    ConsoleCfg cc;
    Navigation n(cc);
    n.init();
    Arbitration a;
    a.planner_new = true;
    a.planner = c;
    EXPECT_FALSE(n.update(a, std::nullopt).is_new) << "nothing goes to the micro";
    EXPECT_TRUE(n.heading_missing());
    EXPECT_EQ(n.nav_result(), NAVKIT_NAV_RESULT_REJECTED);
    c.time_tag = 78;
    a.planner = c;
    const NavOutput o = n.update(a, uint16_t{900});
    EXPECT_TRUE(o.is_new);
    EXPECT_FALSE(n.heading_missing());
    EXPECT_EQ(o.cmd.turn_distance, 1000) << "with fresh data: 900 + 100";
}

TEST(Navigation, ServoGoesToItsSlotOnly)
{
    navkit_lisp_cmd_t c = lisp();
    c.rc_servo_num = 7;
    c.rc_param0 = 300;
    c.rc_param1 = 800;
    c.rc_param2 = -900;
    navkit_micro_cmd_t m;
    ASSERT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
    EXPECT_EQ(m.rc7_param0, 300);
    EXPECT_EQ(m.rc7_param1, 800);
    EXPECT_EQ(m.rc7_param2, -900);
    EXPECT_EQ(m.rc0_param0, 0);
    c.rc_servo_num = 2;
    c.rc_param2 = NAVKIT_SERVO_GOTO_GOTO_FLAG;
    ASSERT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
    EXPECT_EQ(m.rc2_param0, 300);
    EXPECT_EQ(m.rc2_param2, 9999);
    EXPECT_EQ(m.rc7_param0, 0);
}

TEST(Navigation, ServoNumberOutsideZeroToSevenOrZeroRateHasNoEffect)
{
    navkit_micro_cmd_t none = Navigation::neutral(0);
    for (int num : {-1, 8, 100}) {
        navkit_lisp_cmd_t c = lisp();
        c.rc_servo_num = num;
        c.rc_param0 = 300;
        navkit_micro_cmd_t m;
        ASSERT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
        EXPECT_EQ(std::memcmp(&m, &none, sizeof m), 0) << num;
    }
    navkit_lisp_cmd_t c = lisp();
    c.rc_servo_num = 3;
    c.rc_param0 = 0;
    c.rc_param1 = 100;
    navkit_micro_cmd_t m;
    ASSERT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_OK);
    EXPECT_EQ(m.rc3_param1, 0) << "param0 = 0: no servo command";
}

TEST(Navigation, HighLevelCodesAreNotImplemented)
{
    for (int code : {100, 101, 105}) {
        navkit_lisp_cmd_t c = lisp();
        c.fwd_cmd = code;
        c.turn_mode = 5;
        navkit_micro_cmd_t m;
        EXPECT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_NOT_IMPLEMENTED);
        EXPECT_EQ(m.fwd_cmd, 0) << "never sent to the micro";
        EXPECT_EQ(m.turn_cmd, 5) << "the rest of the message still applies";
    }
}

TEST(Navigation, ValuesThatDoNotFitTheMicroAreRejected)
{
    navkit_lisp_cmd_t c = lisp();
    c.fwd_cmd = 1;
    c.speed = 40000;
    navkit_micro_cmd_t m;
    EXPECT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_REJECTED);
    c = lisp();
    c.fwd_cmd = 2;
    EXPECT_EQ(Navigation::convert(c, 0, 0, &m).nav_result, NAVKIT_NAV_RESULT_REJECTED);
}

TEST(Navigation, EveryNewCommandIsAcknowledgedWithItsVerdict)
{
    // lisp_data.ack_time_tag + nav_result: the verdict on each new command, obeyed or not
    ConsoleCfg cc;
    Navigation n(cc);
    n.init();
    Arbitration a;
    a.planner_new = true;
    a.planner = lisp();
    a.planner.time_tag = 100;
    a.planner.fwd_cmd = 1;
    EXPECT_TRUE(n.update(a, 0).is_new);
    EXPECT_EQ(n.ack_time_tag(), 100);
    EXPECT_EQ(n.nav_result(), NAVKIT_NAV_RESULT_OK);
    a.planner.time_tag = 200;
    a.planner.speed = 40000; // does not fit micro_cmd.speed
    EXPECT_FALSE(n.update(a, 0).is_new);
    EXPECT_EQ(n.ack_time_tag(), 200);
    EXPECT_EQ(n.nav_result(), NAVKIT_NAV_RESULT_REJECTED);
    Arbitration r; // out of lisp_cmd's own range: refused by ProcessCommands
    r.planner_rejected = true;
    r.rejected_time_tag = 300;
    EXPECT_FALSE(n.update(r, 0).is_new);
    EXPECT_EQ(n.ack_time_tag(), 300);
    EXPECT_EQ(n.nav_result(), NAVKIT_NAV_RESULT_REJECTED);
    Arbitration d; // dropped by a console or safety stop
    d.planner_dropped = true;
    d.rejected_time_tag = 400;
    d.stop = true;
    EXPECT_TRUE(n.update(d, 0).is_new) << "the stop goes out";
    EXPECT_EQ(n.ack_time_tag(), 400);
    EXPECT_EQ(n.nav_result(), NAVKIT_NAV_RESULT_REJECTED);
}

TEST(Navigation, UpdateDioOnlyChangeIsANeutralNewCommand)
{
    ConsoleCfg cc;
    Navigation n(cc);
    n.init();
    Arbitration a;
    a.dio = 0x3;
    NavOutput o = n.update(a, 0);
    ASSERT_TRUE(o.is_new);
    EXPECT_EQ(o.cmd.fwd_cmd, 0);
    EXPECT_EQ(o.cmd.dio_command, 0x3);
    EXPECT_FALSE(n.update(a, 0).is_new) << "nothing changed: repeat";
}

TEST(Navigation, UpdateStopAndTeleop)
{
    ConsoleCfg cc;
    cc.teleop_speed = 123;
    Navigation n(cc);
    n.init();
    Arbitration a;
    a.teleop_new = true;
    a.teleop = Teleop::reverse;
    NavOutput o = n.update(a, 0);
    EXPECT_EQ(o.cmd.fwd_cmd, 1);
    EXPECT_EQ(o.cmd.speed, 123);
    EXPECT_LT(o.cmd.distance, 0);
    Arbitration s;
    s.stop = true;
    s.timeout_started = true;
    o = n.update(s, 0);
    EXPECT_EQ(o.cmd.fwd_cmd, 5);
    EXPECT_EQ(o.cmd.turn_cmd, 5);
    EXPECT_EQ(n.nav_result(), NAVKIT_NAV_RESULT_PLANNER_TIMEOUT);
}

// ---- the reason of a refusal (Conversion): what the console and --convert-lisp say

TEST(Navigation, RangeRefusalNamesTheFieldsTheRangeAndTheCause)
{
    navkit_lisp_cmd_t c = lisp();
    c.fwd_cmd = NAVKIT_FWD_CMD_MODIFY;
    c.speed = 40000;
    navkit_micro_cmd_t m;
    const Conversion v = Navigation::convert(c, 0, 0, &m);
    EXPECT_EQ(v.nav_result, NAVKIT_NAV_RESULT_REJECTED);
    EXPECT_EQ(v.refusal, Refusal::range);
    EXPECT_EQ(v.lisp_field, NAVKIT_LISP_CMD_FIELD_SPEED);
    EXPECT_EQ(v.micro_field, NAVKIT_MICRO_CMD_FIELD_SPEED);
    EXPECT_EQ(v.value, 40000);
    EXPECT_EQ(v.text(), "40000 is outside -32768..32767 (mm/s), the range of micro_cmd.speed it is copied to for "
                        "fwd_cmd 3 (modify)");

    c = lisp();
    c.turn_mode = NAVKIT_TURN_MODE_HEADING_HOLD;
    c.turn_accel = 40000;
    EXPECT_EQ(Navigation::convert(c, 0, 0, &m).text(),
              "40000 is outside -32768..32767 (deg/s^2 x 0.1), the range of micro_cmd.turn_accel it is copied to for "
              "turn_mode 11 (heading_hold)");
}

TEST(Navigation, ServoRefusalNamesTheSlotOfTheServoNumber)
{
    // rc7's fields follow mc_datalog_cmd in the spec: the slot comes from the spec's names
    for (int num : {0, 5, 7}) {
        navkit_lisp_cmd_t c = lisp();
        c.rc_servo_num = num;
        c.rc_param0 = 100;
        c.rc_param2 = -40000;
        navkit_micro_cmd_t m;
        const Conversion v = Navigation::convert(c, 0, 0, &m);
        EXPECT_EQ(v.refusal, Refusal::range);
        EXPECT_EQ(v.lisp_field, NAVKIT_LISP_CMD_FIELD_RC_PARAM2);
        const std::string slot = "rc" + std::to_string(num) + "_param2";
        EXPECT_EQ(v.micro_field, navkit_micro_cmd_field_index(slot.c_str()));
        EXPECT_NE(v.text().find("micro_cmd." + slot + " it is copied to for rc_servo_num " + std::to_string(num)),
                  std::string::npos)
            << v.text();
    }
}

TEST(Navigation, HeadingRefusalsSayWhy)
{
    navkit_lisp_cmd_t c = lisp();
    c.turn_mode = NAVKIT_TURN_MODE_HEADING_SELECT;
    c.turn_distance = Navigation::kFullTurn + 1;
    navkit_micro_cmd_t m;
    Conversion v = Navigation::convert(c, 0, 0, &m);
    EXPECT_EQ(v.refusal, Refusal::heading_range);
    EXPECT_EQ(v.lisp_field, NAVKIT_LISP_CMD_FIELD_TURN_DISTANCE);
    EXPECT_EQ(v.text(), "3601 is outside 0..3600 (deg x 0.1), the headings of turn_mode 10 (heading_select)");

    c.turn_mode = NAVKIT_TURN_MODE_HEADING_HOLD;
    v = Navigation::convert(c, std::nullopt, 0, &m);
    EXPECT_EQ(v.refusal, Refusal::heading_missing);
    EXPECT_EQ(v.lisp_field, NAVKIT_LISP_CMD_FIELD_TURN_MODE);
    EXPECT_NE(v.text().find("heading hold (turn mode 11) needs the micro's current heading"), std::string::npos);
}

TEST(Navigation, UnknownCodeAndConvertedCommandsSayNothing)
{
    navkit_lisp_cmd_t c = lisp();
    c.fwd_cmd = 2;
    navkit_micro_cmd_t m;
    const Conversion v = Navigation::convert(c, 0, 0, &m);
    EXPECT_EQ(v.refusal, Refusal::code);
    EXPECT_EQ(v.text(), "2 is no fwd_cmd code the host converts");
    c.fwd_cmd = NAVKIT_FWD_CMD_EXPLORE;
    const Conversion hi = Navigation::convert(c, 0, 0, &m);
    EXPECT_EQ(hi.nav_result, NAVKIT_NAV_RESULT_NOT_IMPLEMENTED);
    EXPECT_EQ(hi.refusal, Refusal::none);
    EXPECT_EQ(hi.text(), "");
}
