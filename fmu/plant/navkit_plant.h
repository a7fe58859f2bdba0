/* navkit_plant.h: the whole contract of the plant model (the reference Leaf robot).
 *
 * One table, PLANT_VARIABLES, lists every FMU variable: name, causality, start value, unit
 * and description. The C code builds the value struct, the value references and the
 * start values from it; gen_model_description.py reads the same lines to write
 * modelDescription.xml (FMI 3.0 and FMI 2.0), so the two cannot drift apart.
 * Value reference = position in the table, starting at 0 (time).
 *
 * Frames and signs: start pose = origin, x forward, y left, yaw counter-clockwise
 * positive (unwrapped); heading clockwise positive, 0..360; duty and encoders + forward.
 * Each table line is one macro call on one line (the generator parses them).
 */
#ifndef NAVKIT_PLANT_H
#define NAVKIT_PLANT_H

#include <stddef.h>
#include <stdint.h>

/* The generator reads these lines and the table below as they stand: one macro call a line. */
/* clang-format off */
#define PLANT_MODEL_NAME "navkit_plant"
#define PLANT_MODEL_DESCRIPTION "navkit reference robot: differential drive, DC motors, encoders, gyro, compass, battery, RC servos, DIO loopback, GP2D12 IR and SRF04 sonar in a 2D world"
/* Change the token whenever the table changes (the importer checks it). */
#define PLANT_INSTANTIATION_TOKEN "{6f1c2a54-7a43-4d1e-9b1e-navkit-plant-v3}"

#define PLANT_STR_MAX 4096          /* bytes, longest String value incl. the terminator */
#define PLANT_MAX_SUBSTEP_S 0.001   /* s, internal integration step bound */
#define PLANT_MAX_WALLS 100000      /* walls a world file may hold */
#define PLANT_WALL_BYTES 32         /* bytes of one wall in the walls output: 4 float64 */

/* PLANT_VARIABLES(F64, I32, STR, BIN): each entry X(name, causality, start, "unit", "description").
 * Causalities: INDEPENDENT, PARAMETER (fixed), INPUT, OUTPUT. Unit "" = dimensionless.
 * BIN (Binary) is FMI 3.0 only: the FMI 2.0 description leaves it out (its value reference
 * stays unused there). */
#define PLANT_VARIABLES(F64, I32, STR, BIN) \
F64(time, INDEPENDENT, 0.0, "s", "Simulation time") \
F64(motor_left_duty, INPUT, 0.0, "", "Left motor PWM duty -1..1, + drives the wheel forward") \
F64(motor_right_duty, INPUT, 0.0, "", "Right motor PWM duty -1..1, + drives the wheel forward") \
F64(servo_pulse_0, INPUT, 0.0, "us", "RC servo 0 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_1, INPUT, 0.0, "us", "RC servo 1 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_2, INPUT, 0.0, "us", "RC servo 2 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_3, INPUT, 0.0, "us", "RC servo 3 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_4, INPUT, 0.0, "us", "RC servo 4 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_5, INPUT, 0.0, "us", "RC servo 5 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_6, INPUT, 0.0, "us", "RC servo 6 pulse width, 0 = not driven (holds)") \
F64(servo_pulse_7, INPUT, 0.0, "us", "RC servo 7 pulse width, 0 = not driven (holds)") \
I32(dio_out, INPUT, 0, "", "bitmask: levels the micro drives on its 12 DIO pins (output pins only)") \
I32(dio_dir, INPUT, 0, "", "bitmask: 1 = pin is an output") \
I32(enc_left, OUTPUT, 0, "", "counts: left quadrature-decoded encoder count (x4), + forward") \
I32(enc_right, OUTPUT, 0, "", "counts: right quadrature-decoded encoder count (x4), + forward") \
I32(gyro_raw, OUTPUT, 0, "", "LSB: yaw-rate gyro, counter-clockwise positive, saturates at the 16-bit range") \
I32(compass_raw, OUTPUT, 0, "", "deg*10: compass bearing 0..3599, clockwise from north") \
F64(ir_voltage_0, OUTPUT, 0.0, "V", "Sharp GP2D12 IR ranger 0 output (ADC ch0)") \
F64(ir_voltage_1, OUTPUT, 0.0, "V", "Sharp GP2D12 IR ranger 1 output (ADC ch1)") \
F64(ir_voltage_2, OUTPUT, 0.0, "V", "Sharp GP2D12 IR ranger 2 output (ADC ch2)") \
F64(ir_voltage_3, OUTPUT, 0.0, "V", "Sharp GP2D12 IR ranger 3 output (ADC ch3)") \
F64(battery_voltage, OUTPUT, 0.0, "V", "Battery pack terminal voltage (the board divides by 3 before ADC ch4)") \
F64(sonar_echo_0, OUTPUT, 0.0, "us", "SRF04 sonar 0 echo pulse width, 0 = no echo") \
F64(sonar_echo_1, OUTPUT, 0.0, "us", "SRF04 sonar 1 echo pulse width, 0 = no echo") \
F64(sonar_echo_2, OUTPUT, 0.0, "us", "SRF04 sonar 2 echo pulse width, 0 = no echo") \
F64(sonar_echo_3, OUTPUT, 0.0, "us", "SRF04 sonar 3 echo pulse width, 0 = no echo") \
I32(dio_in, OUTPUT, 0, "", "bitmask: output pins looped back from dio_out, input pins from dio_input_pattern") \
F64(x_mm, OUTPUT, 0.0, "mm", "Truth: x position, start pose frame (x forward)") \
F64(y_mm, OUTPUT, 0.0, "mm", "Truth: y position, start pose frame (y left)") \
F64(yaw_deg, OUTPUT, 0.0, "deg", "Truth: yaw, counter-clockwise positive, unwrapped") \
F64(heading_deg, OUTPUT, 0.0, "deg", "Truth: heading, clockwise positive from the start heading, 0..360") \
F64(distance_mm, OUTPUT, 0.0, "mm", "Truth: signed path length along the body axis") \
F64(v_mm_s, OUTPUT, 0.0, "mm/s", "Truth: forward speed") \
F64(w_deg_s, OUTPUT, 0.0, "deg/s", "Truth: yaw rate, counter-clockwise positive") \
F64(servo_deg_0, OUTPUT, 0.0, "deg", "Truth: servo 0 angle, clockwise positive") \
F64(servo_deg_1, OUTPUT, 0.0, "deg", "Truth: servo 1 angle, clockwise positive") \
F64(servo_deg_2, OUTPUT, 0.0, "deg", "Truth: servo 2 angle, clockwise positive") \
F64(servo_deg_3, OUTPUT, 0.0, "deg", "Truth: servo 3 angle, clockwise positive") \
F64(servo_deg_4, OUTPUT, 0.0, "deg", "Truth: servo 4 angle, clockwise positive") \
F64(servo_deg_5, OUTPUT, 0.0, "deg", "Truth: servo 5 angle, clockwise positive") \
F64(servo_deg_6, OUTPUT, 0.0, "deg", "Truth: servo 6 angle, clockwise positive") \
F64(servo_deg_7, OUTPUT, 0.0, "deg", "Truth: servo 7 angle, clockwise positive") \
BIN(walls, OUTPUT, "", "", "The world's walls as loaded from world_file, in the start pose frame (x forward, y left): per wall 4 IEEE 754 float64, little-endian: ax, ay, bx, by in mm (32 bytes a wall, file order; box = 4 walls, polyline = a wall per segment); empty = no walls. Set when the model starts") \
I32(seed, PARAMETER, 1, "", "Seed of every noise source (same seed, same outputs)") \
STR(world_file, PARAMETER, "", "", "Absolute path of a world file (config/worlds format); empty = no walls") \
F64(wheel_diameter_mm, PARAMETER, 100.0, "mm", "Nominal wheel diameter") \
F64(wheel_scale_left, PARAMETER, 1.0, "", "True left wheel diameter / nominal (odometry error)") \
F64(wheel_scale_right, PARAMETER, 1.0, "", "True right wheel diameter / nominal (odometry error)") \
F64(track_width_mm, PARAMETER, 300.0, "mm", "Distance between the wheel contact points") \
I32(encoder_counts_per_rev, PARAMETER, 2000, "", "counts per wheel revolution after x4 decoding") \
F64(mass_kg, PARAMETER, 12.0, "kg", "Robot mass") \
F64(yaw_inertia_kg_m2, PARAMETER, 0.36, "kg.m2", "Robot yaw moment of inertia about the wheel axle centre") \
F64(gear_ratio, PARAMETER, 33.0, "", "Motor turns per wheel turn") \
F64(motor_r_ohm, PARAMETER, 2.0, "Ohm", "Armature resistance") \
F64(motor_kt_nm_a, PARAMETER, 0.0275, "N.m/A", "Motor torque constant") \
F64(motor_ke_v_s_rad, PARAMETER, 0.0275, "V.s/rad", "Motor back-EMF constant") \
F64(motor_i_max_a, PARAMETER, 2.5, "A", "Motor driver current limit (torque limit)") \
F64(motor_rotor_inertia_kg_m2, PARAMETER, 1.0e-6, "kg.m2", "Rotor inertia (reflected through the gear)") \
F64(friction_coulomb_n, PARAMETER, 3.0, "N", "Coulomb friction of each drive train, at the wheel contact") \
F64(friction_viscous_n_s_m, PARAMETER, 2.0, "N.s/m", "Viscous friction of each drive train, at the wheel contact") \
F64(battery_ocv_v, PARAMETER, 12.0, "V", "Battery open-circuit voltage at the start") \
F64(battery_empty_v, PARAMETER, 10.5, "V", "Open-circuit voltage when battery_capacity_ah has been drawn") \
F64(battery_capacity_ah, PARAMETER, 2.0, "A.h", "Charge that takes the open-circuit voltage from battery_ocv_v to battery_empty_v") \
F64(battery_r_ohm, PARAMETER, 0.1, "Ohm", "Battery internal resistance (sag under load)") \
F64(battery_idle_a, PARAMETER, 0.5, "A", "Current drawn by the electronics besides the motors") \
F64(gyro_lsb_per_dps, PARAMETER, 131.0, "1/(deg/s)", "Gyro sensitivity, LSB per deg/s") \
F64(gyro_bias_dps, PARAMETER, 0.5, "deg/s", "Gyro bias at the start") \
F64(gyro_bias_walk_dps_rt_s, PARAMETER, 0.002, "deg/s/sqrt(s)", "Gyro bias random walk: deg/s per square root of s") \
F64(gyro_noise_dps, PARAMETER, 0.05, "deg/s", "Gyro white noise, RMS per sample") \
F64(compass_start_deg, PARAMETER, 0.0, "deg", "Compass bearing of the start heading, clockwise from north") \
F64(compass_noise_deg, PARAMETER, 1.0, "deg", "Compass noise, RMS per sample") \
F64(servo_center_us, PARAMETER, 1500.0, "us", "Servo pulse width at 0 deg") \
F64(servo_us_per_deg, PARAMETER, 10.0, "us/deg", "Servo pulse width change per degree, + = clockwise") \
F64(servo_rate_dps, PARAMETER, 300.0, "deg/s", "Servo travel rate limit") \
F64(servo_travel_deg, PARAMETER, 90.0, "deg", "Servo mechanical travel either side of 0") \
I32(dio_input_pattern, PARAMETER, 0, "", "bitmask: levels external circuits drive on the input pins") \
F64(ir_a_v_mm, PARAMETER, 331.4, "V.mm", "GP2D12 curve V = a/(d + b) + c above ir_peak_mm: a") \
F64(ir_b_mm, PARAMETER, 40.0, "mm", "GP2D12 curve offset b") \
F64(ir_c_v, PARAMETER, 0.015, "V", "GP2D12 curve offset c") \
F64(ir_peak_mm, PARAMETER, 80.0, "mm", "GP2D12 output peaks here and falls linearly to 0 V at contact") \
F64(ir_far_mm, PARAMETER, 1500.0, "mm", "No wall within this range: output as at this range") \
F64(ir_noise_v, PARAMETER, 0.01, "V", "GP2D12 output noise, RMS per reading") \
F64(ir_period_ms, PARAMETER, 38.0, "ms", "GP2D12 reading period (the output holds between readings)") \
F64(sonar_min_mm, PARAMETER, 30.0, "mm", "SRF04 minimum range (closer walls read as this)") \
F64(sonar_max_mm, PARAMETER, 3000.0, "mm", "SRF04 maximum range (farther = no echo)") \
F64(sonar_beam_deg, PARAMETER, 30.0, "deg", "SRF04 full beam width (less than 180)") \
F64(sound_speed_m_s, PARAMETER, 343.0, "m/s", "Speed of sound") \
F64(sonar_noise_us, PARAMETER, 10.0, "us", "SRF04 echo width noise, RMS per reading") \
F64(sonar_period_ms, PARAMETER, 50.0, "ms", "SRF04 ranging period (the output holds between pings)") \
F64(ir_x_mm_0, PARAMETER, 200.0, "mm", "IR 0 mount x (front)") \
F64(ir_y_mm_0, PARAMETER, 0.0, "mm", "IR 0 mount y") \
F64(ir_angle_deg_0, PARAMETER, 0.0, "deg", "IR 0 pointing angle, counter-clockwise from x") \
F64(ir_x_mm_1, PARAMETER, 0.0, "mm", "IR 1 mount x (left)") \
F64(ir_y_mm_1, PARAMETER, 180.0, "mm", "IR 1 mount y") \
F64(ir_angle_deg_1, PARAMETER, 90.0, "deg", "IR 1 pointing angle, counter-clockwise from x") \
F64(ir_x_mm_2, PARAMETER, 0.0, "mm", "IR 2 mount x (right)") \
F64(ir_y_mm_2, PARAMETER, -180.0, "mm", "IR 2 mount y") \
F64(ir_angle_deg_2, PARAMETER, -90.0, "deg", "IR 2 pointing angle, counter-clockwise from x") \
F64(ir_x_mm_3, PARAMETER, -200.0, "mm", "IR 3 mount x (back)") \
F64(ir_y_mm_3, PARAMETER, 0.0, "mm", "IR 3 mount y") \
F64(ir_angle_deg_3, PARAMETER, 180.0, "deg", "IR 3 pointing angle, counter-clockwise from x") \
F64(sonar_x_mm_0, PARAMETER, 200.0, "mm", "Sonar 0 mount x (front)") \
F64(sonar_y_mm_0, PARAMETER, 0.0, "mm", "Sonar 0 mount y") \
F64(sonar_angle_deg_0, PARAMETER, 0.0, "deg", "Sonar 0 pointing angle, counter-clockwise from x") \
F64(sonar_x_mm_1, PARAMETER, 170.0, "mm", "Sonar 1 mount x (front left)") \
F64(sonar_y_mm_1, PARAMETER, 120.0, "mm", "Sonar 1 mount y") \
F64(sonar_angle_deg_1, PARAMETER, 45.0, "deg", "Sonar 1 pointing angle, counter-clockwise from x") \
F64(sonar_x_mm_2, PARAMETER, 170.0, "mm", "Sonar 2 mount x (front right)") \
F64(sonar_y_mm_2, PARAMETER, -120.0, "mm", "Sonar 2 mount y") \
F64(sonar_angle_deg_2, PARAMETER, -45.0, "deg", "Sonar 2 pointing angle, counter-clockwise from x") \
F64(sonar_x_mm_3, PARAMETER, -200.0, "mm", "Sonar 3 mount x (back)") \
F64(sonar_y_mm_3, PARAMETER, 0.0, "mm", "Sonar 3 mount y") \
F64(sonar_angle_deg_3, PARAMETER, 180.0, "deg", "Sonar 3 pointing angle, counter-clockwise from x")
/* clang-format on */

/* ---------------------------------------------------------------- variables */

/* A Binary value: len bytes at data (malloc'd by the model, NULL before it starts), cap
 * the bytes allocated. The same layout as the FMI layer's fmil_binary_t (plant_fmu.c
 * checks it), so the layer reads it in place. */
typedef struct {
    uint8_t *data;
    size_t len, cap; /* bytes */
} plant_binary_t;

#define PLANT_VR_ENTRY(name, caus, start, unit, desc) PLANT_VR_##name,
/* Value references: PLANT_VR_<name>, in table order. */
typedef enum {
    PLANT_VARIABLES(PLANT_VR_ENTRY, PLANT_VR_ENTRY, PLANT_VR_ENTRY, PLANT_VR_ENTRY) PLANT_NUM_VARS
} plant_vr_t;
#undef PLANT_VR_ENTRY

#define PLANT_FIELD_F64(name, caus, start, unit, desc) double name;
#define PLANT_FIELD_I32(name, caus, start, unit, desc) int32_t name;
#define PLANT_FIELD_STR(name, caus, start, unit, desc) char name[PLANT_STR_MAX];
#define PLANT_FIELD_BIN(name, caus, start, unit, desc) plant_binary_t name;
/* Every variable's current value, one field per table entry. */
typedef struct {
    PLANT_VARIABLES(PLANT_FIELD_F64, PLANT_FIELD_I32, PLANT_FIELD_STR, PLANT_FIELD_BIN)
} plant_values_t;
#undef PLANT_FIELD_F64
#undef PLANT_FIELD_I32
#undef PLANT_FIELD_STR
#undef PLANT_FIELD_BIN

/* ---------------------------------------------------------------- model state */

#define PLANT_N_IR 4
#define PLANT_N_SONAR 4
#define PLANT_N_SERVO 8

/* A wall: a line segment in the start pose frame, m. */
typedef struct {
    double ax, ay, bx, by;
} plant_wall_t;

/* A sensor mount in the body frame: m, and the unit pointing vector. */
typedef struct {
    double x, y, ux, uy;
} plant_mount_t;

/* Constants derived from the parameters when the simulation starts (SI units). */
typedef struct {
    double r[2];                           /* m, true wheel radius left/right */
    double g[2];                           /* rad/m, motor shaft angle per metre of wheel travel */
    double kt[2], ke[2];                   /* N/A, V/(m/s): motor constants at the wheel */
    double damp_emf[2];                    /* N.s/m: back-EMF damping (kt ke / R) + viscous friction */
    double track;                          /* m */
    double mass[2][2];                     /* kg, mass matrix in wheel-speed coordinates (body + rotors) */
    double counts_per_m[2];                /* counts per metre of wheel travel */
    double ir_period, sonar_period;        /* s */
    double sonar_cos_half, sonar_sin_half; /* half beam */
    double us_per_m;                       /* us of echo per metre of range (there and back) */
    plant_mount_t ir[PLANT_N_IR], sonar[PLANT_N_SONAR];
} plant_derived_t;

/* The model: values, derived constants, world and every piece of state. No statics. */
typedef struct {
    plant_values_t v;
    plant_derived_t k;
    plant_wall_t *walls; /* malloc'd, n_walls entries, NULL when none */
    size_t n_walls;
    double t;                   /* s, model time */
    double xm, ym, yaw;         /* m, m, rad: pose in the start frame */
    double vw[2];               /* m/s, wheel contact speeds left/right */
    double sw[2];               /* m, wheel travel left/right */
    double fc[2];               /* N, Coulomb friction of the last sub-step (warm start) */
    double vbat;                /* V, battery terminal voltage */
    double charge_ah;           /* A.h drawn from the battery so far */
    double gyro_bias;           /* deg/s */
    double next_ir, next_sonar; /* s, time of the next IR reading / sonar ping */
    uint64_t rng[4];            /* splitmix64 states: gyro, compass, IR, sonar */
    double spare[4];            /* cached second Box-Muller normal per stream */
    int have_spare[4];
    double step_h;      /* s: the step size plant_step last saw (0 = none yet); for it: */
    int step_n;         /* sub-steps per step */
    double step_hs;     /* s: sub-step, step_h / step_n */
    double step_sqrt_h; /* s^0.5: sqrt(step_h), the gyro bias walk's scale */
    /* the drive train's W = h (M + h D)^-1 (s/kg) of the last sub-step and the h (s) and
     * damping D (N.s/m) it was computed for (w_h = 0: none yet; a sub-step is > 0) */
    double w_h, w_damp[2], w00, w01, w11;
} plant_model_t;

/* Sets every variable to its start value and frees the world (values only; call
 * plant_start before stepping). */
void plant_set_start_values(plant_model_t *m);

/* Checks the parameters, loads world_file and puts the robot at the start pose with
 * outputs computed, time = t0 (s). Returns 0, or -1 with a message in err[errlen]
 * (world file errors read "file:line: message"). */
int plant_start(plant_model_t *m, double t0, char *err, size_t errlen);

/* Advances the model by h seconds (h > 0) in sub-steps of at most PLANT_MAX_SUBSTEP_S. */
void plant_step(plant_model_t *m, double h);

/* Recomputes outputs that follow inputs at once (dio_in); call after setting inputs. */
void plant_inputs_changed(plant_model_t *m);

/* Frees the world. The model can be started again. */
void plant_release(plant_model_t *m);

#endif /* NAVKIT_PLANT_H */
