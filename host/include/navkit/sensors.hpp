// Sensors: one class per sensor kind, each with set(raw) and value() in engineering
// units, calibrated from sensors.ini (the seed's battery, GP2D12, SRF04, RCservo). The
// value is worked out when a new raw value is set (at most once per micro_data) and read
// as often as the frame needs it.
#pragma once

#include <cstdint>

#include "navkit/ini.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

// Battery: ADC counts (10 bit) through the board divider -> volts.
class Battery {
public:
    explicit Battery(const BatteryCal &c) : c_(c), value_(calc()) {}
    void set(uint16_t adc)
    {
        if (adc_ != adc) { // value_ is of the raw value held
            adc_ = adc;
            value_ = calc();
        }
    }
    double value() const { return value_; } // V
private:
    double calc() const; // V, of adc_
    BatteryCal c_;
    uint16_t adc_ = 0;
    double value_ = 0;
};

// Sharp GP2D12 IR ranger: ADC counts -> mm through V = a / (d + b) + c; 0 outside min..max.
class Gp2d12 {
public:
    explicit Gp2d12(const Gp2d12Cal &c) : c_(c), value_(calc()) {}
    void set(uint16_t adc)
    {
        if (adc_ != adc) { // value_ is of the raw value held
            adc_ = adc;
            value_ = calc();
        }
    }
    int value() const { return value_; } // mm, 0 = out of range
    double volts() const;                // V at the ADC pin
private:
    int calc() const; // mm, of adc_
    Gp2d12Cal c_;
    uint16_t adc_ = 0;
    int value_ = 0;
};

// SRF04 sonar: echo time (us) -> mm; 0 = no echo (or farther than max_mm).
class Srf04 {
public:
    explicit Srf04(const Srf04Cal &c) : c_(c), value_(calc()) {}
    void set(uint16_t echo_us)
    {
        if (us_ != echo_us) { // value_ is of the raw value held
            us_ = echo_us;
            value_ = calc();
        }
    }
    int value() const { return value_; } // mm
private:
    int calc() const; // mm, of us_
    Srf04Cal c_;
    uint16_t us_ = 0;
    int value_ = 0;
};

// RC servo: reported position (deg x 10) -> calibrated position (deg x 10).
class RcServo {
public:
    explicit RcServo(const ServoCal &c) : c_(c), value_(calc()) {}
    void set(int16_t pos)
    {
        if (pos_ != pos) { // value_ is of the raw value held
            pos_ = pos;
            value_ = calc();
        }
    }
    int value() const { return value_; } // deg x 10
private:
    int calc() const; // deg x 10, of pos_
    ServoCal c_;
    int16_t pos_ = 0;
    int value_ = 0;
};

class Sensors {
public:
    explicit Sensors(const SensorsCfg &c);
    void update(const navkit_micro_data_t &d);
    Battery battery;
    Gp2d12 ir[4];
    Srf04 sonar[4];
    RcServo servo[8];

private:
    SensorsCfg cfg_; // ADC channels
};

} // namespace navkit
