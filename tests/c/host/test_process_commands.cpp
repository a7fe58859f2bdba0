// ProcessCommands: planner priority, timeout, console idle, safety, and the seed's DIO masks.
#include <gtest/gtest.h>

#include "navkit/process_commands.hpp"

using namespace navkit;

static const int64_t kS = 1000000; // us per s

static PlannerInput planner(int32_t tag, int32_t active = 0, int32_t dio = 0, uint32_t hb = 1)
{
    PlannerInput p;
    p.have = true;
    navkit_lisp_cmd_defaults(&p.cmd);
    p.cmd.time_tag = tag;
    p.cmd.dio_active = active;
    p.cmd.dio_command = dio;
    p.heartbeat = hb;
    return p;
}

static ExecutiveCfg exec_cfg(double timeout_s = 1.0, int dio_default = 0)
{
    ExecutiveCfg e;
    e.planner_timeout_s = timeout_s;
    e.dio_default = dio_default;
    return e;
}

TEST(ProcessCommands, NewCommandOnlyWhenTheTimeTagChanges)
{
    ProcessCommands pc(exec_cfg());
    EXPECT_TRUE(pc.update(planner(7), {}, {}, 0).planner_new);
    EXPECT_FALSE(pc.update(planner(7), {}, {}, 100000).planner_new);
    EXPECT_TRUE(pc.update(planner(8), {}, {}, 200000).planner_new);
    EXPECT_FALSE(pc.update(PlannerInput{}, {}, {}, 300000).planner_new) << "no message";
}

TEST(ProcessCommands, DioPlannerKeepsABitOnlyWhileActiveInEveryMessage)
{
    ProcessCommands pc(exec_cfg(0, 0xF00));
    // the seed's example: Lisp takes bits 0 and 3, sets them to 1 and 0
    Arbitration a = pc.update(planner(1, 0b1001, 0b0001), {}, {}, 0);
    EXPECT_EQ(a.dio, 0xF00 | 0b0001);
    a = pc.update(planner(1, 0b1001, 0b0001), {}, {}, 100000);
    EXPECT_EQ(a.dio, 0xF01) << "the same message keeps them";
    a = pc.update(planner(2, 0b0001, 0b0000), {}, {}, 200000);
    EXPECT_EQ(a.dio, 0xF00) << "bit 3 released (console level 0), bit 0 driven to 0";
    a = pc.update(planner(3, 0xF00, 0x000), {}, {}, 300000);
    EXPECT_EQ(a.dio, 0x000) << "the planner can drive bits low over the console's levels";
    a = pc.update(planner(4, 0, 0xFFF), {}, {}, 400000);
    EXPECT_EQ(a.dio, 0xF00) << "dio_command without dio_active has no effect";
}

TEST(ProcessCommands, ConsoleTogglesOnlyTheBitsItOwns)
{
    ProcessCommands pc(exec_cfg(0));
    ConsoleInput c;
    c.dio_toggle = 0b0110;
    Arbitration a = pc.update(planner(1, 0b0100, 0b0000), c, {}, 0);
    EXPECT_EQ(a.dio, 0b0010) << "bit 2 is the planner's";
    a = pc.update(planner(2, 0, 0), {}, {}, 100000);
    EXPECT_EQ(a.dio, 0b0110) << "released: the console's level shows";
}

TEST(ProcessCommands, PlannerTimeoutStopsOnceThenObeysTheNextNewCommand)
{
    ProcessCommands pc(exec_cfg(1.0));
    pc.update(planner(1, 0b1, 0b1, 1), {}, {}, 0);
    Arbitration a = pc.update(planner(1, 0b1, 0b1, 1), {}, {}, kS - 1);
    EXPECT_FALSE(a.stop);
    a = pc.update(planner(1, 0b1, 0b1, 1), {}, {}, kS);
    EXPECT_TRUE(a.stop && a.timeout_started);
    EXPECT_EQ(a.dio, 0) << "a silent planner loses its DIO bits";
    EXPECT_TRUE(pc.planner_timed_out());
    a = pc.update(planner(1, 0b1, 0b1, 2), {}, {}, 2 * kS);
    EXPECT_FALSE(a.stop || a.planner_new) << "a heartbeat alone does not re-run the old command";
    a = pc.update(planner(2, 0b1, 0b1, 3), {}, {}, 3 * kS);
    EXPECT_TRUE(a.planner_new);
    EXPECT_FALSE(pc.planner_timed_out());
}

TEST(ProcessCommands, HeartbeatKeepsThePlannerAlive)
{
    ProcessCommands pc(exec_cfg(1.0));
    pc.update(planner(1), {}, {}, 0);
    for (uint32_t k = 1; k < 50; k++) {
        EXPECT_FALSE(pc.update(planner(1, 0, 0, k + 1), {}, {}, k * 100000).stop);
    }
}

TEST(ProcessCommands, TimeoutZeroKeepsTheSeedBehaviour)
{
    ProcessCommands pc(exec_cfg(0));
    pc.update(planner(1), {}, {}, 0);
    EXPECT_FALSE(pc.update(planner(1), {}, {}, 3600 * kS).stop);
}

TEST(ProcessCommands, ConsoleTeleopOnlyWhenThePlannerIsQuiet)
{
    ExecutiveCfg e = exec_cfg(0);
    e.console_idle_s = 2.0;
    ProcessCommands pc(e);
    ConsoleInput fwd;
    fwd.teleop = Teleop::forward;
    EXPECT_TRUE(pc.update(PlannerInput{}, fwd, {}, 0).teleop_new) << "no planner yet";
    pc.update(planner(1), {}, {}, kS);
    EXPECT_FALSE(pc.update(planner(1), fwd, {}, 2 * kS).teleop_new) << "planner has priority";
    Arbitration a = pc.update(planner(1), fwd, {}, 3 * kS);
    EXPECT_TRUE(a.teleop_new) << "2 s after its last command";
    EXPECT_EQ(a.owner, Owner::console);
    EXPECT_EQ(pc.update(planner(2), fwd, {}, 3 * kS + 1).owner, Owner::planner);
}

TEST(ProcessCommands, SafetyStopsAndIgnoresMotionWhileItHolds)
{
    ProcessCommands pc(exec_cfg(0));
    SafetyInput bad;
    bad.stop = true;
    Arbitration a = pc.update(planner(1), {}, bad, 0);
    EXPECT_TRUE(a.stop && a.safety_started);
    EXPECT_FALSE(a.planner_new);
    a = pc.update(planner(2, 0b1, 0b1), {}, bad, 100000);
    EXPECT_FALSE(a.stop || a.planner_new) << "one stop, motion ignored";
    EXPECT_EQ(a.dio, 0b1) << "DIO still follows the planner";
    a = pc.update(planner(3), {}, {}, 200000);
    EXPECT_TRUE(a.planner_new) << "cleared: the next new command is obeyed";
}

TEST(ProcessCommands, OutOfRangeCommandIsRejectedAndChangesNothing)
{
    ProcessCommands pc(exec_cfg(0));
    pc.update(planner(1, 0b1, 0b1), {}, {}, 0);
    PlannerInput p = planner(2, 0b11, 0b10);
    p.cmd.turn_mode = 12;
    Arbitration a = pc.update(p, {}, {}, 100000);
    EXPECT_TRUE(a.planner_rejected);
    EXPECT_FALSE(a.planner_new);
    EXPECT_EQ(a.rejected_field, NAVKIT_LISP_CMD_FIELD_TURN_MODE);
    EXPECT_EQ(a.rejected_time_tag, p.cmd.time_tag);
    EXPECT_EQ(a.dio, 0b1);
}

TEST(ProcessCommands, ConsoleStopAlwaysWinsThenThePlannersNextNewCommand)
{
    ProcessCommands pc(exec_cfg(0));
    ConsoleInput stop, fwd;
    stop.teleop = Teleop::stop;
    fwd.teleop = Teleop::forward;
    EXPECT_TRUE(pc.update(planner(1), {}, {}, 0).planner_new);
    Arbitration a = pc.update(planner(1), stop, {}, 100000);
    EXPECT_TRUE(a.teleop_new && a.teleop == Teleop::stop) << "the stop key while the planner drives";
    EXPECT_EQ(a.owner, Owner::console);
    a = pc.update(planner(1), {}, {}, 200000);
    EXPECT_FALSE(a.planner_new || a.teleop_new) << "the planner's old command is not run again";
    a = pc.update(planner(1), fwd, {}, 300000);
    EXPECT_FALSE(a.teleop_new) << "other keys: the planner still has priority";
    EXPECT_EQ(a.teleop_ignored, TeleopIgnored::planner);
    a = pc.update(planner(2), stop, {}, 400000);
    EXPECT_TRUE(a.teleop_new && a.teleop == Teleop::stop && !a.planner_new)
        << "a new planner command in the stop's frame is dropped";
    EXPECT_TRUE(a.planner_dropped && a.rejected_time_tag == 2) << "and acknowledged as not obeyed";
    a = pc.update(planner(3), {}, {}, 500000);
    EXPECT_TRUE(a.planner_new) << "its next new command is obeyed";
    EXPECT_EQ(a.owner, Owner::planner);
    EXPECT_EQ(a.teleop_ignored, TeleopIgnored::no);
}

TEST(ProcessCommands, TeleopKeysIgnoredDuringSafetySayWhy)
{
    ProcessCommands pc(exec_cfg(0));
    SafetyInput bad;
    bad.stop = true;
    ConsoleInput fwd, stop;
    fwd.teleop = Teleop::forward;
    stop.teleop = Teleop::stop;
    pc.update(PlannerInput{}, {}, bad, 0);
    Arbitration a = pc.update(PlannerInput{}, fwd, bad, 100000);
    EXPECT_FALSE(a.teleop_new);
    EXPECT_EQ(a.teleop_ignored, TeleopIgnored::safety);
    EXPECT_TRUE(pc.update(PlannerInput{}, stop, bad, 200000).teleop_new) << "a stop is always taken";
    a = pc.update(planner(7), {}, bad, 300000);
    EXPECT_FALSE(a.planner_new) << "not obeyed while safety holds";
    EXPECT_TRUE(a.planner_dropped && a.rejected_time_tag == 7) << "but acknowledged as not obeyed";
}
