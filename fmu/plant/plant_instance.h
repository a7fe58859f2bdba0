/* plant_instance.h: the part of a plant FMU instance that does not depend on the FMI
 * version, shared by the FMI 3.0 wrapper (plant_fmi3.c) and the FMI 2.0 wrapper
 * (plant_fmi2.c).
 *
 * States: Instantiated -> InitializationMode -> StepMode -> Terminated; npi_reset goes
 * back to Instantiated with start values. A table in plant_instance.c says which call is
 * legal in which state; any other call is an error with a log message. The calls return
 * a neutral npi_status_t that the wrapper maps onto its fmi2Status / fmi3Status; an
 * instance argument may be NULL (nothing is logged and the call fails, but for
 * npi_no_values with no references). Messages go to the importer through the npi_log_fn
 * the wrapper hands npi_new.
 */
#ifndef PLANT_INSTANCE_H
#define PLANT_INSTANCE_H

#include "navkit_plant.h"

/* Result of every call: NPI_OK, or NPI_ERROR (already logged where there was an instance). */
typedef enum { NPI_OK = 0, NPI_ERROR = 1 } npi_status_t;

/* The calls that depend on the state (npi_allowed). NPI_SETUP_EXPERIMENT and
 * NPI_GET_STATUS are FMI 2 only. */
typedef enum {
  NPI_SET_DEBUG_LOGGING, NPI_SETUP_EXPERIMENT, NPI_ENTER_INIT, NPI_EXIT_INIT, NPI_TERMINATE, NPI_RESET,
  NPI_GET, NPI_SET, NPI_DO_STEP, NPI_GET_STATUS, NPI_FN_COUNT
} npi_fn_t;

typedef struct npi npi_t;

/* Hands msg, of status st, to the importer's logger (the wrapper knows its signature). */
typedef void (*npi_log_fn)(const npi_t *c, npi_status_t st, const char *msg);

/* The version-neutral part of one FMU instance: the model plus the state bookkeeping.
 * A wrapper's instance struct starts with it, so its fmi2Component / fmi3Instance is
 * also an npi_t pointer. */
struct npi {
  np_model_t m;
  unsigned state;          /* one state bit, see plant_instance.c */
  int dirty;               /* parameters changed since the model was started */
  int logging;             /* SetDebugLogging: log more than errors */
  char name[128];          /* instance name */
  const char *api;         /* "fmi2" or "fmi3": prefix of the function names in messages */
  npi_log_fn log;          /* the wrapper's logger */
};

/* Allocates a zeroed instance of size bytes (the wrapper's struct, which starts with an
 * npi_t) named name, with the model at its start values, in Instantiated. logging: log
 * more than errors; api: "fmi2" or "fmi3"; log: the wrapper's logger. NULL when out of
 * memory. */
npi_t *npi_new(size_t size, const char *name, int logging, const char *api, npi_log_fn log);

/* Frees the model's world and the instance (c may be NULL). */
void npi_free(npi_t *c);

/* Formats a message (printf-style) and sends it through c's logger: errors always, the
 * rest when logging is on. Nothing when c is NULL. */
void npi_log(const npi_t *c, npi_status_t st, const char *fmt, ...);

/* NPI_OK if call fn is legal in c's state, else logs and returns NPI_ERROR. */
npi_status_t npi_allowed(const npi_t *c, npi_fn_t fn);

/* SetDebugLogging: logging on (non-zero) or off. */
npi_status_t npi_set_debug_logging(npi_t *c, int on);

/* EnterInitializationMode: model time = start_time (s), the model will start afresh. */
npi_status_t npi_enter_init(npi_t *c, double start_time);

/* ExitInitializationMode: starts the model if the parameters changed, goes to StepMode. */
npi_status_t npi_exit_init(npi_t *c);

/* Terminate: StepMode -> Terminated. */
npi_status_t npi_terminate(npi_t *c);

/* Reset: every variable back to its start value, model time 0 s, Instantiated. */
npi_status_t npi_reset(npi_t *c);

/* Get<Type> for type NP_F64 (vals is double[]) or NP_I32 (int32_t[]): copies the values
 * of the nvr variables vr into vals, which holds nvals (must equal nvr). fn names the
 * FMI function in messages. */
npi_status_t npi_get(npi_t *c, const uint32_t vr[], size_t nvr, void *vals, size_t nvals, np_type_t type,
                     const char *fn);

/* Set<Type> for type NP_F64 or NP_I32: copies the nvals (must equal nvr) values vals into
 * the variables vr, then updates the outputs that follow the inputs. fn as in npi_get. */
npi_status_t npi_set(npi_t *c, const uint32_t vr[], size_t nvr, const void *vals, size_t nvals, np_type_t type,
                     const char *fn);

/* GetString: points vals[i] at the value of String variable vr[i] (valid until it is set
 * again); nvals must equal nvr. fn as in npi_get. */
npi_status_t npi_get_strings(npi_t *c, const uint32_t vr[], size_t nvr, const char *vals[], size_t nvals,
                             const char *fn);

/* SetString: copies vals[i] (NULL = "", at most NP_STR_MAX - 1 bytes) into String
 * variable vr[i]; nvals must equal nvr. fn as in npi_get. */
npi_status_t npi_set_strings(npi_t *c, const uint32_t vr[], size_t nvr, const char *const vals[], size_t nvals,
                             const char *fn);

/* Get/Set of a type the model has no variable of: NPI_OK for nvr = 0 references, else
 * logs msg and returns NPI_ERROR. */
npi_status_t npi_no_values(const npi_t *c, size_t nvr, const char *msg);

/* DoStep: advances the model from communication point t (s, must be the model time) by
 * h (s, > 0); the model time becomes exactly t + h (the importer's clock). */
npi_status_t npi_do_step(npi_t *c, double t, double h);

#endif /* PLANT_INSTANCE_H */
