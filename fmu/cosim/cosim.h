/* navkit_cosim: native coupler of the firmware FMU and the plant FMU (FMI 3.0).
 *
 * The harness (Python, fmpy) instantiates and initialises both FMUs, then hands this
 * library the instance handles, the addresses of the FMI functions it needs from each
 * FMU's shared library, and the value references to connect. cosim_run() then does
 * n fixed steps (1 ms at the firmware's 1 kHz control rate) in native code:
 *
 *   per step:  plant outputs -> firmware inputs; firmware doStep; collect serial_tx;
 *              firmware outputs -> plant inputs; plant doStep; every `record_every`
 *              steps append one truth row (simulated time s, then each recorded value).
 *
 * The firmware steps on the plant's outputs at the start of the step and the plant steps
 * on the duties the firmware computed in it (Gauss-Seidel order, firmware first).
 * Time is kept as an integer step count, so it never drifts.
 */
#ifndef NAVKIT_COSIM_H
#define NAVKIT_COSIM_H

#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#define COSIM_API __attribute__((visibility("default")))
#else
#define COSIM_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Which FMU: the firmware (index 0) or the plant (index 1). */
enum { COSIM_FIRMWARE = 0, COSIM_PLANT = 1 };
/* Variable types the coupler moves. */
enum { COSIM_FLOAT64 = 0, COSIM_INT32 = 1 };
/* Result codes; cosim_error() says more. */
enum { COSIM_OK = 0, COSIM_ERR_ARG = -1, COSIM_ERR_FULL = -2, COSIM_ERR_FMU = -3, COSIM_ERR_TERMINATED = -4 };

/* One FMU as the coupler sees it: its fmi3Instance and the addresses of its fmi3
 * functions (fmi3GetFloat64, fmi3SetFloat64, fmi3GetInt32, fmi3SetInt32, fmi3GetBinary,
 * fmi3SetBinary, fmi3DoStep), as void pointers so ctypes can pass plain integers. The
 * binary accessors may be NULL for the plant. */
typedef struct {
    void *instance;
    void *get_float64;
    void *set_float64;
    void *get_int32;
    void *set_int32;
    void *get_binary;
    void *set_binary;
    void *do_step;
} cosim_fmu_t;

typedef struct cosim cosim_t;

/* A new coupler of `firmware` and `plant` (both copied) stepping `step_s` seconds per
 * step (> 0), starting at simulated time `start_s`. NULL if out of memory or bad args. */
COSIM_API cosim_t *cosim_new(const cosim_fmu_t *firmware, const cosim_fmu_t *plant, double step_s, double start_s);

/* Frees the coupler (never the FMU instances, which the harness owns). NULL is fine. */
COSIM_API void cosim_free(cosim_t *c);

/* Connects output `src_vr` of FMU `src` (COSIM_FIRMWARE or COSIM_PLANT) to input `dst_vr`
 * of the other FMU, both of `type` (COSIM_FLOAT64 or COSIM_INT32). COSIM_OK or an error. */
COSIM_API int cosim_connect(cosim_t *c, int src, int type, uint32_t src_vr, uint32_t dst_vr);

/* The firmware's Binary serial variables: `rx_vr` (input, bytes arriving during the next
 * step) and `tx_vr` (output, bytes sent during the last step). COSIM_OK or an error. */
COSIM_API int cosim_serial(cosim_t *c, uint32_t rx_vr, uint32_t tx_vr);

/* Adds a truth column: variable `vr` of `type` of FMU `fmu`, read as a double (Int32
 * converted exactly). Column 0 of every row is the simulated time in s. Returns the
 * column index (>= 1) or an error code. */
COSIM_API int cosim_record(cosim_t *c, int fmu, int type, uint32_t vr);

/* Records a row every `every` steps (>= 1; 20 = 50 Hz at 1 kHz). COSIM_OK or an error. */
COSIM_API int cosim_record_every(cosim_t *c, uint32_t every);

/* Number of doubles per truth row: 1 (time) + the number of recorded columns. */
COSIM_API size_t cosim_row_width(const cosim_t *c);

/* Fills `row` (cosim_row_width() doubles) with the current time and recorded values,
 * without stepping (the row at start, or after a reset). COSIM_OK or an error. */
COSIM_API int cosim_sample(cosim_t *c, double *row);

/* Copies every plant output connected to the firmware into the firmware's inputs and
 * vice versa without stepping (after initialisation or a firmware reset). During
 * cosim_run() an input whose value did not change (bit for bit) since it was last set is
 * not set again (an FMU keeps its inputs): each step makes one set call per type with
 * only the changed inputs, or none; this call sets all of them. */
COSIM_API int cosim_exchange(cosim_t *c);

/* Does `n_steps` steps. `rx` (`rx_len` bytes, may be NULL/0) is set as serial_rx before
 * the first step; serial_rx is empty for the later ones. Bytes the firmware sends are
 * appended to `tx` (capacity `tx_cap`), their count stored in *tx_len; truth rows are
 * appended to `rows` (room for `rows_cap` rows), their count stored in *n_rows.
 * Returns COSIM_OK, or an error after the step that failed (outputs up to it are kept;
 * COSIM_ERR_FULL if tx or rows had no room: the excess is dropped, the error says how much). */
COSIM_API int cosim_run(cosim_t *c, uint32_t n_steps, const uint8_t *rx, size_t rx_len, uint8_t *tx, size_t tx_cap,
                        size_t *tx_len, double *rows, size_t rows_cap, size_t *n_rows);

/* Current simulated time in s (start + steps * step). */
COSIM_API double cosim_time(const cosim_t *c);

/* Steps done since cosim_new(). */
COSIM_API uint64_t cosim_steps(const cosim_t *c);

/* Sets the time at which the firmware FMU's next doStep starts, in s, for a firmware
 * that was reset and re-initialised with its own start time (firmware time = this +
 * steps since the call). */
COSIM_API void cosim_firmware_restart(cosim_t *c, double firmware_start_s);

/* Nanoseconds spent inside each FMU's doStep and data exchange since cosim_new(), for
 * the benchmark: `which` = COSIM_FIRMWARE or COSIM_PLANT. 0 unless timing is on. An
 * estimate: one step in COSIM_TIMING_EVERY is timed and counts that many times (three
 * clock reads in every step cost about 15 % of the FMUs' time; a prime stride does not
 * lock onto the phase of the firmware's periodic tasks). */
COSIM_API uint64_t cosim_fmu_ns(const cosim_t *c, int which);

/* Steps per timed step when timing is on (see cosim_fmu_ns). */
#define COSIM_TIMING_EVERY 17u

/* Turns timing of each FMU's calls on (1) or off (0, the default: no clock reads). */
COSIM_API void cosim_timing(cosim_t *c, int on);

/* The text of the last error ("" if none). Valid until the next call. */
COSIM_API const char *cosim_error(const cosim_t *c);

#ifdef __cplusplus
}
#endif
#endif
