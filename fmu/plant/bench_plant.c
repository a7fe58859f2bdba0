/* bench_plant.c: microseconds per 1 ms fmi3DoStep of the built navkit_plant FMU.
 *
 * Usage: navkit_plant_bench [steps] [world file]
 * Loads the FMU's shared library, drives it in a slow arc through the world (default:
 * config/worlds/hallway.txt) and times two loops: fmi3DoStep alone, and a step with the
 * exchange the harness does every millisecond (set duties, servos and DIO, get every
 * firmware-side output).
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "fmi3FunctionTypes.h"
#include "navkit_plant.h"

/* Wall-clock seconds (monotonic). */
static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Resolves symbol name from lib or exits. */
static void *sym(void *lib, const char *name)
{
    void *p = dlsym(lib, name);
    if (!p) {
        fprintf(stderr, "bench: %s not found: %s\n", name, dlerror());
        exit(1);
    }
    return p;
}

/* Prints FMU log messages. */
static void log_cb(fmi3InstanceEnvironment env, fmi3Status st, fmi3String cat, fmi3String msg)
{
    (void)env;
    fprintf(stderr, "[%d %s] %s\n", (int)st, cat, msg);
}

int main(int argc, char **argv)
{
    long steps = argc > 1 ? atol(argv[1]) : 1000000;
    const char *world = argc > 2 ? argv[2] : NAVKIT_WORLDS_DIR "/hallway.txt";
    void *lib = dlopen(NAVKIT_PLANT_SO, RTLD_NOW);
    if (!lib) {
        fprintf(stderr, "bench: %s\n", dlerror());
        return 1;
    }
    fmi3InstantiateCoSimulationTYPE *inst = sym(lib, "fmi3InstantiateCoSimulation");
    fmi3EnterInitializationModeTYPE *enter = sym(lib, "fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *exit_init = sym(lib, "fmi3ExitInitializationMode");
    fmi3SetStringTYPE *set_str = sym(lib, "fmi3SetString");
    fmi3SetFloat64TYPE *set_f = sym(lib, "fmi3SetFloat64");
    fmi3GetFloat64TYPE *get_f = sym(lib, "fmi3GetFloat64");
    fmi3SetInt32TYPE *set_i = sym(lib, "fmi3SetInt32");
    fmi3GetInt32TYPE *get_i = sym(lib, "fmi3GetInt32");
    fmi3DoStepTYPE *do_step = sym(lib, "fmi3DoStep");
    fmi3FreeInstanceTYPE *free_inst = sym(lib, "fmi3FreeInstance");

    fmi3Instance c = inst("bench", PLANT_INSTANTIATION_TOKEN, NULL, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                          NULL, log_cb, NULL);
    fmi3ValueReference vr_world = PLANT_VR_world_file;
    if (!c || set_str(c, &vr_world, 1, &world, 1) || enter(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) || exit_init(c)) {
        return 1;
    }
    const fmi3ValueReference vr_in_f[] = {PLANT_VR_motor_left_duty, PLANT_VR_motor_right_duty, PLANT_VR_servo_pulse_0,
                                          PLANT_VR_servo_pulse_1,   PLANT_VR_servo_pulse_2,    PLANT_VR_servo_pulse_3,
                                          PLANT_VR_servo_pulse_4,   PLANT_VR_servo_pulse_5,    PLANT_VR_servo_pulse_6,
                                          PLANT_VR_servo_pulse_7};
    const fmi3ValueReference vr_in_i[] = {PLANT_VR_dio_out, PLANT_VR_dio_dir};
    const fmi3ValueReference vr_out_f[] = {PLANT_VR_ir_voltage_0, PLANT_VR_ir_voltage_1,    PLANT_VR_ir_voltage_2,
                                           PLANT_VR_ir_voltage_3, PLANT_VR_battery_voltage, PLANT_VR_sonar_echo_0,
                                           PLANT_VR_sonar_echo_1, PLANT_VR_sonar_echo_2,    PLANT_VR_sonar_echo_3};
    const fmi3ValueReference vr_out_i[] = {PLANT_VR_enc_left, PLANT_VR_enc_right, PLANT_VR_gyro_raw,
                                           PLANT_VR_compass_raw, PLANT_VR_dio_in};
    double in_f[10] = {0.30, 0.32, 1500, 1600, 1400, 1500, 1500, 1500, 1500, 0};
    int32_t in_i[2] = {0x0A5, 0x0FF};
    double out_f[9];
    int32_t out_i[5];
    fmi3Boolean ev, term, early;
    double t = 0.0, last;
    set_f(c, vr_in_f, 10, in_f, 10);
    set_i(c, vr_in_i, 2, in_i, 2);

    double t0 = now_s();
    for (long i = 0; i < steps; i++, t += 0.001) {
        do_step(c, t, 0.001, fmi3True, &ev, &term, &early, &last);
    }
    double dt_step = now_s() - t0;

    t0 = now_s();
    for (long i = 0; i < steps; i++, t += 0.001) {
        in_f[0] = (i & 4096) ? 0.30 : -0.20;
        set_f(c, vr_in_f, 10, in_f, 10);
        set_i(c, vr_in_i, 2, in_i, 2);
        do_step(c, t, 0.001, fmi3True, &ev, &term, &early, &last);
        get_f(c, vr_out_f, 9, out_f, 9);
        get_i(c, vr_out_i, 5, out_i, 5);
    }
    double dt_all = now_s() - t0;
    printf("navkit_plant: %ld steps of 1 ms, world %s\n", steps, world);
    printf("  doStep only:          %.3f us/step (%.0fx real time)\n", 1e6 * dt_step / steps, 1e-3 * steps / dt_step);
    printf("  doStep + set/get I/O: %.3f us/step (%.0fx real time)\n", 1e6 * dt_all / steps, 1e-3 * steps / dt_all);
    printf("  last: enc %d/%d gyro %d battery %.3f V ir0 %.3f V sonar0 %.0f us\n", out_i[0], out_i[1], out_i[2],
           out_f[4], out_f[0], out_f[5]);
    free_inst(c);
    dlclose(lib);
    return 0;
}
