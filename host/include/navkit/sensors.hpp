// Sensors: one class per sensor kind, each with set(raw) and value() in engineering
// units, calibrated from sensors.ini (the seed's battery, GP2D12, SRF04, RCservo). The
// value is worked out when a new raw value is set (at most once per micro_data) and read
// as often as the frame needs it (Calibrated).
#pragma once

#include <cstdint>

#include "navkit/ini.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

// What every sensor kind S shares: the raw value held and its calibrated value, worked
// out by S::calc() (of raw()) when set() brings a raw value other than the one held, and
// read as often as the frame needs it. Before any set(): the value of a raw 0.
template <class S, class Raw, class Value> class Calibrated {
public:
    void set(Raw raw)
    {
        if (raw_ != raw) { // value_ is of the raw value held
            raw_ = raw;
            value_ = static_cast<const S *>(this)->calc();
        }
    }
    Value value() const { return value_; } // S's engineering unit

protected:
    Calibrated() = default;
    // S's constructor, once its calibration is set: the value of the raw 0 held
    void init() { value_ = static_cast<const S *>(this)->calc(); }
    Raw raw() const { return raw_; }

private:
    Raw raw_ = 0;
    Value value_ = 0;
};

// Battery: ADC counts (10 bit) through the board divider -> volts.
class Battery : public Calibrated<Battery, uint16_t, double> {
public:
    explicit Battery(const BatteryCal &c) : c_(c) { init(); }

private:
    friend Calibrated;
    double calc() const; // V, of raw() (ADC counts)
    BatteryCal c_;
};

// Sharp GP2D12 IR ranger: ADC counts -> mm through V = a / (d + b) + c; 0 outside min..max.
class Gp2d12 : public Calibrated<Gp2d12, uint16_t, int> {
public:
    explicit Gp2d12(const Gp2d12Cal &c) : c_(c) { init(); }
    double volts() const; // V at the ADC pin

private:
    friend Calibrated;
    int calc() const; // mm (0 = out of range), of raw() (ADC counts)
    Gp2d12Cal c_;
};

// SRF04 sonar: echo time (us) -> mm; 0 = no echo (or farther than max_mm).
class Srf04 : public Calibrated<Srf04, uint16_t, int> {
public:
    explicit Srf04(const Srf04Cal &c) : c_(c) { init(); }

private:
    friend Calibrated;
    int calc() const; // mm, of raw() (echo time, us)
    Srf04Cal c_;
};

// RC servo: reported position (deg x 10) -> calibrated position (deg x 10).
class RcServo : public Calibrated<RcServo, int16_t, int> {
public:
    explicit RcServo(const ServoCal &c) : c_(c) { init(); }

private:
    friend Calibrated;
    int calc() const; // deg x 10, of raw() (deg x 10)
    ServoCal c_;
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
