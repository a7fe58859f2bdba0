#include "navkit/sensors.hpp"

#include <cmath>

namespace navkit {

static const double kAdcFull = 1024.0; // 10-bit ADC: counts = V * 1024 / vref (AVR ADC transfer)

double Battery::calc() const
{
    return raw() * c_.vref / kAdcFull * c_.divider + c_.offset_v;
}

double Gp2d12::volts() const
{
    return raw() * c_.vref / kAdcFull;
}

int Gp2d12::calc() const
{
    const double v = volts() - c_.c_v;
    if (v <= 0) {
        return 0; // below the curve's floor: beyond any valid range
    }
    const double d = c_.a_v_mm / v - c_.b_mm;
    if (d < c_.min_mm || d > c_.max_mm) {
        return 0;
    }
    return static_cast<int>(std::lround(d));
}

int Srf04::calc() const
{
    if (raw() == 0) {
        return 0;
    }
    const double d = raw() * c_.mm_per_us + c_.offset_mm;
    if (d <= 0 || d > c_.max_mm) {
        return 0;
    }
    return static_cast<int>(std::lround(d));
}

int RcServo::calc() const
{
    return static_cast<int>(std::lround(c_.gain * raw() + c_.offset_deg * 10.0));
}

Sensors::Sensors(const SensorsCfg &c)
    : battery(c.battery), ir{Gp2d12(c.ir[0]), Gp2d12(c.ir[1]), Gp2d12(c.ir[2]), Gp2d12(c.ir[3])},
      sonar{Srf04(c.sonar[0]), Srf04(c.sonar[1]), Srf04(c.sonar[2]), Srf04(c.sonar[3])},
      servo{RcServo(c.servo[0]), RcServo(c.servo[1]), RcServo(c.servo[2]), RcServo(c.servo[3]),
            RcServo(c.servo[4]), RcServo(c.servo[5]), RcServo(c.servo[6]), RcServo(c.servo[7])},
      cfg_(c)
{
}

void Sensors::update(const navkit_micro_data_t &d)
{
    battery.set(d.adc[cfg_.battery.channel]);
    for (int i = 0; i < 4; i++) {
        ir[i].set(d.adc[cfg_.ir[i].channel]);
        sonar[i].set(d.sonar_echo[i]);
    }
    for (int i = 0; i < 8; i++) {
        servo[i].set(d.servo_pos[i]);
    }
}

} // namespace navkit
