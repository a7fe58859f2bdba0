/* fmil.h: the one FMI layer of navkit's FMUs (firmware, AVR firmware, plant).
 *
 * The layer owns everything FMI: the state machine (which call is legal when), value
 * references checked against the model's variable table, get/set of every type, the
 * communication-point check, logging through the importer's callback, and the FMI 3.0
 * (fmil_fmi3.c) and FMI 2.0 (fmil_fmi2.c) entry points, refusing what no model supports.
 * A model brings only its config header and its model code:
 *
 *   fmil_model.h (on the FMU's include path, found first) defines
 *     FMIL_INSTANTIATION_TOKEN  the token (FMI 3) / guid (FMI 2) of its modelDescription.xml
 *     FMIL_NUM_VRS              value references run 0 .. FMIL_NUM_VRS - 1 (holes allowed)
 *     fmil_model_t              the model's whole state (a type; no statics anywhere)
 *   and its model code defines the table fmil_model_vars and the fmil_model_* hooks below.
 *
 * The FMU's build (navkit_add_fmu in fmu/CMakeLists.txt) compiles this layer once per FMU
 * with FMIL_MODEL_IDENTIFIER (the modelIdentifier, a string) defined.
 *
 * States: Instantiated -> InitializationMode -> StepMode -> Terminated; Reset goes back to
 * Instantiated with every variable at its start value. Inputs may be set in the first
 * three, parameters (fixed) before StepMode only, outputs never; values may be read from
 * InitializationMode on. Every refusal is logged (logStatusError) and returns an error.
 */
#ifndef FMIL_H
#define FMIL_H

#include "fmil_types.h"
#include "fmil_model.h" /* the model's config header: includes fmil_types.h as it needs */

#ifndef FMIL_MODEL_IDENTIFIER
#error "FMIL_MODEL_IDENTIFIER (the modelIdentifier) comes from navkit_add_fmu (fmu/CMakeLists.txt)"
#endif

/* The calls whose legality depends on the state (fmil_allowed). FMIL_SETUP_EXPERIMENT and
 * FMIL_GET_STATUS are FMI 2 only. */
typedef enum {
    FMIL_SET_DEBUG_LOGGING,
    FMIL_SETUP_EXPERIMENT,
    FMIL_ENTER_INIT,
    FMIL_EXIT_INIT,
    FMIL_TERMINATE,
    FMIL_RESET,
    FMIL_GET,
    FMIL_SET,
    FMIL_DO_STEP,
    FMIL_GET_STATUS,
    FMIL_FN_COUNT
} fmil_fn_t;

typedef struct fmil_instance fmil_instance_t;

/* Hands msg, of status st and category cat, to the importer's logger (the version layer
 * knows its signature). */
typedef void (*fmil_log_fn)(const fmil_instance_t *c, fmil_status_t st, const char *cat, const char *msg);

/* One FMU instance: the layer's bookkeeping and the model. */
struct fmil_instance {
    unsigned state;         /* one FMIL_ST_* bit (fmil_instance.c) */
    int dirty;              /* parameters set since fmil_model_start last ran */
    int log_events;         /* logEvents messages on (SetDebugLogging); errors always go */
    char name[128];         /* instance name */
    const char *api;        /* "fmi2" or "fmi3": prefix of function names in messages */
    fmil_log_fn log;        /* the version layer's logger */
    void *env;              /* the importer's environment pointer */
    void (*callback)(void); /* the importer's logger (cast to the version's type) */
    char resources[1024];   /* the FMU's resources folder, a path ("" when unknown) */
    double time;            /* s: the next communication point */
    /* For the get/set of every step, per scalar type (FMIL_F64 .. FMIL_U64, index type - 1)
     * and value reference: 1 + the value's offset in model where a Get (get_at) or a Set
     * (set_at: inputs only) needs no other check, else 0 (the full check decides and
     * logs). Filled from fmil_model_vars by fmil_new. */
    uint32_t get_at[FMIL_U64][FMIL_NUM_VRS];
    uint32_t set_at[FMIL_U64][FMIL_NUM_VRS];
    fmil_model_t model;
};

/* ---------------------------------------------------------------- what a model brings */

/* The variable table: FMIL_NUM_VRS rows, indexed by value reference. */
extern const fmil_var_t fmil_model_vars[FMIL_NUM_VRS];

/* Once, after the instance is allocated (zeroed) and before fmil_model_start_values:
 * take resources (c->resources names the FMU's resources folder). FMIL_ERROR (logged)
 * fails the instantiation. */
fmil_status_t fmil_model_instantiate(fmil_instance_t *c);

/* Every variable to its start value and the model to its power-on state (instantiation
 * and Reset). */
void fmil_model_start_values(fmil_instance_t *c);

/* The parameters take effect and the model starts at time c->time (s): at
 * ExitInitializationMode, and before a Get in InitializationMode after parameters
 * changed. FMIL_ERROR (logged) when a parameter is refused. */
fmil_status_t fmil_model_start(fmil_instance_t *c);

/* After a Set of inputs: recompute what follows them at once (may do nothing). */
void fmil_model_inputs_changed(fmil_instance_t *c);

/* Advance the model from communication point t (s, == c->time) by h (s, > 0, finite).
 * The layer sets c->time = t + h after FMIL_OK or FMIL_WARNING. */
fmil_status_t fmil_model_step(fmil_instance_t *c, double t, double h);

/* Release what fmil_model_instantiate and the model took (the instance is freed after). */
void fmil_model_free(fmil_instance_t *c);

/* ---------------------------------------------------------------- what the layer offers */

/* Formats a message (printf-style) and logs it: FMIL_ERROR always (logStatusError), the
 * rest as logEvents when debug logging switched them on. Nothing when c is NULL. */
void fmil_log(const fmil_instance_t *c, fmil_status_t st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The version layers' calls (fmil_instance.c). Each takes a possibly NULL instance
 * (the call fails, nothing logged) and returns FMIL_OK or FMIL_ERROR (logged). */

/* A zeroed instance named name, resources folder resources (may be NULL), logging events
 * when logging != 0, api "fmi2"/"fmi3", logger log with the importer's env and callback;
 * then fmil_model_instantiate and fmil_model_start_values. NULL when out of memory or the
 * model refused (logged through log first). */
fmil_instance_t *fmil_new(const char *name, const char *resources, int logging, const char *api, fmil_log_fn log,
                          void *env, void (*callback)(void));
/* fmil_model_free, then the instance. */
void fmil_free(fmil_instance_t *c);
/* FMIL_OK if call fn is legal in c's state, else logs why and returns FMIL_ERROR. */
fmil_status_t fmil_allowed(const fmil_instance_t *c, fmil_fn_t fn);
/* SetDebugLogging: on != 0 switches logEvents on, for categories (n of them; none = all);
 * an unknown category is an error. */
fmil_status_t fmil_set_debug_logging(fmil_instance_t *c, int on, size_t n, const char *const categories[]);
/* EnterInitializationMode: the time becomes start_time (s); the model will start afresh. */
fmil_status_t fmil_enter_init(fmil_instance_t *c, double start_time);
/* ExitInitializationMode: fmil_model_start if parameters changed, then StepMode. */
fmil_status_t fmil_exit_init(fmil_instance_t *c);
/* Terminate: StepMode -> Terminated. */
fmil_status_t fmil_terminate(fmil_instance_t *c);
/* Reset: fmil_model_start_values, time 0 s, Instantiated. */
fmil_status_t fmil_reset(fmil_instance_t *c);
/* Get/Set of nvr scalars of type (not FMIL_STR/FMIL_BIN): values is an array of that
 * type's C type with nvals (== nvr) elements; fn names the API function in messages. */
fmil_status_t fmil_get(fmil_instance_t *c, const uint32_t vr[], size_t nvr, void *values, size_t nvals,
                       fmil_type_t type, const char *fn);
/* Set: as Get the other way; each variable must be settable now (inputs until Terminated,
 * parameters before StepMode), then fmil_model_inputs_changed runs. */
fmil_status_t fmil_set(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const void *values, size_t nvals,
                       fmil_type_t type, const char *fn);
/* Get of String variables: points values[i] at the value (valid until it is set again). */
fmil_status_t fmil_get_strings(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const char *values[], size_t nvals,
                               const char *fn);
/* Set of String variables: copies values[i] (NULL = "", shorter than FMIL_STR_MAX). */
fmil_status_t fmil_set_strings(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const char *const values[],
                               size_t nvals, const char *fn);
/* Get of Binary variables: points values[i] at the bytes (valid until the next step or
 * set) and sets sizes[i] (bytes). */
fmil_status_t fmil_get_binaries(fmil_instance_t *c, const uint32_t vr[], size_t nvr, size_t sizes[],
                                const uint8_t *values[], size_t nvals, const char *fn);
/* Set of Binary variables: copies sizes[i] bytes (at most the variable's cap) of values[i]. */
fmil_status_t fmil_set_binaries(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const size_t sizes[],
                                const uint8_t *const values[], size_t nvals, const char *fn);
/* Get/Set of a type the model has no variable of: FMIL_OK for nvr = 0, else an error. */
fmil_status_t fmil_no_values(const fmil_instance_t *c, size_t nvr, const char *fn);
/* DoStep from communication point t (s) by h (s). */
fmil_status_t fmil_do_step(fmil_instance_t *c, double t, double h);
/* Logs that fn is not supported by this FMU and returns FMIL_ERROR. */
fmil_status_t fmil_unsupported(const fmil_instance_t *c, const char *fn);

#endif /* FMIL_H */
