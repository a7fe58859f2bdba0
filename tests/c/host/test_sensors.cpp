// Sensor calibrations: battery divider, GP2D12 curve and its valid range, SRF04, servo.
#include <gtest/gtest.h>

#include <cmath>

#include "navkit/sensors.hpp"

using namespace navkit;

// ADC counts of a voltage (10 bit, 5 V).
static uint16_t adc_of(double v)
{
    return static_cast<uint16_t>(std::lround(v / 5.0 * 1024.0));
}

TEST(Sensors, BatteryThroughTheDivider)
{
    Battery b{BatteryCal{}};
    b.set(adc_of(12.0 / 3.0));
    EXPECT_NEAR(b.value(), 12.0, 0.02);
    BatteryCal c;
    c.offset_v = 0.5;
    Battery b2{c};
    b2.set(1023); // full scale: 1023 counts = 5 V * 1023 / 1024 at the pin
    EXPECT_NEAR(b2.value(), 5.0 * 1023.0 / 1024.0 * 3.0 + 0.5, 1e-9);
}

TEST(Sensors, Gp2d12CurveInverted)
{
    const Gp2d12Cal c;
    // inside the valid 100..800 mm band: at its very edges one ADC count decides
    for (int d : {105, 200, 400, 795}) {
        const double v = c.a_v_mm / (d + c.b_mm) + c.c_v; // the sensor's curve
        Gp2d12 s{c};
        s.set(adc_of(v));
        EXPECT_NEAR(s.value(), d, d * 0.02 + 2) << "at " << d << " mm";
    }
}

TEST(Sensors, Gp2d12OutsideTenToEightyCmIsZero)
{
    const Gp2d12Cal c;
    Gp2d12 s{c};
    s.set(adc_of(c.a_v_mm / (50 + c.b_mm) + c.c_v)); // 5 cm: too close
    EXPECT_EQ(s.value(), 0);
    s.set(adc_of(c.a_v_mm / (1500 + c.b_mm) + c.c_v)); // 150 cm: too far
    EXPECT_EQ(s.value(), 0);
    s.set(0);
    EXPECT_EQ(s.value(), 0);
}

TEST(Sensors, Srf04EchoToMm)
{
    Srf04 s{Srf04Cal{}};
    s.set(5831); // 1 m and back at 343 m/s
    EXPECT_NEAR(s.value(), 1000, 2);
    s.set(0);
    EXPECT_EQ(s.value(), 0) << "no echo";
    s.set(60000);
    EXPECT_EQ(s.value(), 0) << "beyond max_mm";
}

TEST(Sensors, RcServoCalibration)
{
    ServoCal c;
    c.gain = 0.5;
    c.offset_deg = 2.0;
    RcServo s{c};
    EXPECT_EQ(s.value(), 20) << "before any set(): the calibration of a raw 0";
    s.set(300);
    EXPECT_EQ(s.value(), 170); // 0.5 * 30.0 deg + 2 deg = 17.0 deg
    s.set(300);
    EXPECT_EQ(s.value(), 170) << "the same raw value again";
    s.set(0);
    EXPECT_EQ(s.value(), 20);
    BatteryCal bc;
    bc.offset_v = 0.5;
    EXPECT_EQ(Battery{bc}.value(), 0.5) << "before any set(): the calibration of a raw 0";
}

TEST(Sensors, UpdateUsesTheConfiguredChannels)
{
    SensorsCfg cfg;
    cfg.battery.channel = 6;
    Sensors s{cfg};
    navkit_micro_data_t d{};
    d.adc[6] = 1023;
    d.sonar_echo[2] = 1166;
    d.servo_pos[7] = -450;
    s.update(d);
    EXPECT_NEAR(s.battery.value(), 5.0 * 1023.0 / 1024.0 * 3.0, 1e-9); // full scale of ch 6
    EXPECT_NEAR(s.sonar[2].value(), 200, 1);
    EXPECT_EQ(s.servo[7].value(), -450);
}
