// The robot controller (the seed's NavAndControl.cpp): the objects of every part and
// the three functions a user edits, RobotInit(), RobotMain() and RobotShutdown()
// (host/src/robot.cpp). The executive (main.cpp) loads the config, builds a Robot,
// calls RobotInit, RobotMain once per frame of its clock, and RobotShutdown.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "navkit/animation.hpp"
#include "navkit/clock.hpp"
#include "navkit/comm.hpp"
#include "navkit/console.hpp"
#include "navkit/datalog.hpp"
#include "navkit/ini.hpp"
#include "navkit/micro_usb.hpp"
#include "navkit/navigation.hpp"
#include "navkit/process_commands.hpp"
#include "navkit/sensors.hpp"

namespace navkit {

struct Robot {
    explicit Robot(const Config &c);

    Config cfg;
    Console console;
    MicroUsb micro;
    Comm comm;
    ProcessCommands process;
    Navigation nav;
    Sensors sensors;
    Datalog datalog;
    Animation animation; // the face, when [animation] on
    Clock *clock = nullptr;

    FrameTick tick;             // the frame being run
    navkit_micro_data_t data{}; // the newest micro_data
    bool have_data = false;
    navkit_lisp_cmd_t lisp_cmd{};   // the planner's current command
    navkit_lisp_data_t lisp_data{}; // published every frame
    navkit_emotion_t emotion{};     // the planner's emotion (the face's targets)
    bool quit = false;              // 'Q': this frame sends the stop and the executive ends
    Owner owner = Owner::none;      // who commanded the robot last (status line, datalog)
    int64_t key_ignored_us = -1;    // frame time (us) of the last "key ignored" line
    uint32_t frames = 0;
};

void RobotInit(Robot &r);
void RobotMain(Robot &r);
void RobotShutdown(Robot &r);

} // namespace navkit
