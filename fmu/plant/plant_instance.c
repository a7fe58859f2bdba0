/* plant_instance.c: the FMI-version-neutral instance logic of the plant FMU: the state
 * table, value-reference lookup, get/set, reset/terminate bookkeeping and doStep. See
 * plant_instance.h. */
#include "plant_instance.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { ST_INSTANTIATED = 1, ST_INIT = 2, ST_STEP = 4, ST_TERMINATED = 8 };
#define ST_ANY (ST_INSTANTIATED | ST_INIT | ST_STEP | ST_TERMINATED)

/* Which states each call is legal in; name follows the "fmi2"/"fmi3" prefix in messages. */
static const struct { const char *name; unsigned states; } legal[NPI_FN_COUNT] = {
  [NPI_SET_DEBUG_LOGGING] = { "SetDebugLogging", ST_ANY },
  [NPI_SETUP_EXPERIMENT] = { "SetupExperiment", ST_INSTANTIATED },
  [NPI_ENTER_INIT] = { "EnterInitializationMode", ST_INSTANTIATED },
  [NPI_EXIT_INIT] = { "ExitInitializationMode", ST_INIT },
  [NPI_TERMINATE] = { "Terminate", ST_STEP },
  [NPI_RESET] = { "Reset", ST_ANY },
  [NPI_GET] = { "Get<Type>", ST_INIT | ST_STEP | ST_TERMINATED },
  [NPI_SET] = { "Set<Type>", ST_INSTANTIATED | ST_INIT | ST_STEP },  /* per variable: see can_set */
  [NPI_DO_STEP] = { "DoStep", ST_STEP },
  [NPI_GET_STATUS] = { "Get<Type>Status", ST_STEP | ST_TERMINATED },
};

npi_t *npi_new(size_t size, const char *name, int logging, const char *api, npi_log_fn log) {
  npi_t *c = calloc(1, size);
  if (!c) return NULL;
  snprintf(c->name, sizeof c->name, "%s", name ? name : "");
  c->logging = logging;
  c->api = api;
  c->log = log;
  np_set_start_values(&c->m);
  c->state = ST_INSTANTIATED;
  c->dirty = 1;
  return c;
}

void npi_free(npi_t *c) {
  if (!c) return;
  np_release(&c->m);
  free(c);
}

void npi_log(const npi_t *c, npi_status_t st, const char *fmt, ...) {
  if (!c || (st == NPI_OK && !c->logging)) return;
  char buf[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  c->log(c, st, buf);
}

npi_status_t npi_allowed(const npi_t *c, npi_fn_t fn) {
  if (!c) return NPI_ERROR;
  if (legal[fn].states & c->state) return NPI_OK;
  npi_log(c, NPI_ERROR, "%s%s is not allowed in state %u", c->api, legal[fn].name, c->state);
  return NPI_ERROR;
}

/* Starts the model from the current parameters when they changed (InitializationMode,
 * where the model time is the start time). */
static npi_status_t ensure_started(npi_t *c) {
  if (!c->dirty) return NPI_OK;
  char err[1024];
  if (np_start(&c->m, c->m.t, err, sizeof err)) {
    npi_log(c, NPI_ERROR, "%s", err);
    return NPI_ERROR;
  }
  c->dirty = 0;
  return NPI_OK;
}

npi_status_t npi_set_debug_logging(npi_t *c, int on) {
  if (npi_allowed(c, NPI_SET_DEBUG_LOGGING)) return NPI_ERROR;
  c->logging = on;
  return NPI_OK;
}

npi_status_t npi_enter_init(npi_t *c, double start_time) {
  if (npi_allowed(c, NPI_ENTER_INIT)) return NPI_ERROR;
  c->m.t = start_time;
  c->m.v.time = start_time;
  c->dirty = 1;
  c->state = ST_INIT;
  return NPI_OK;
}

npi_status_t npi_exit_init(npi_t *c) {
  if (npi_allowed(c, NPI_EXIT_INIT) || ensure_started(c)) return NPI_ERROR;
  c->state = ST_STEP;
  return NPI_OK;
}

npi_status_t npi_terminate(npi_t *c) {
  if (npi_allowed(c, NPI_TERMINATE)) return NPI_ERROR;
  c->state = ST_TERMINATED;
  return NPI_OK;
}

npi_status_t npi_reset(npi_t *c) {
  if (npi_allowed(c, NPI_RESET)) return NPI_ERROR;
  np_set_start_values(&c->m);
  c->m.t = 0.0;
  c->state = ST_INSTANTIATED;
  c->dirty = 1;
  return NPI_OK;
}

/* ---------------------------------------------------------------- get / set */

/* Checks vr against the table and type; logs and returns NULL when it does not fit. */
static const np_var_info_t *lookup(const npi_t *c, uint32_t vr, np_type_t type, const char *fn) {
  if (vr >= NP_NUM_VARS) {
    npi_log(c, NPI_ERROR, "%s: unknown value reference %u", fn, vr);
    return NULL;
  }
  if (np_vars[vr].type != type) {
    npi_log(c, NPI_ERROR, "%s: variable %s (vr %u) has another type", fn, np_vars[vr].name, vr);
    return NULL;
  }
  return &np_vars[vr];
}

/* Checks that variable vi may be set in c's state: parameters before StepMode, inputs
 * always; setting a parameter marks the model for a restart. */
static int can_set(npi_t *c, const np_var_info_t *vi) {
  if (vi->causality == NP_INPUT) return 1;
  if (vi->causality == NP_PARAMETER && (c->state & (ST_INSTANTIATED | ST_INIT))) {
    c->dirty = 1;
    return 1;
  }
  npi_log(c, NPI_ERROR, "variable %s cannot be set in state %u", vi->name, c->state);
  return 0;
}

/* Copies nvr values of type (NP_F64 or NP_I32) between vals and the model (get != 0:
 * model -> vals); npi_get and npi_set. The state is checked once per call; per value
 * the reference is checked against the table (vr in range, type) and, for a set, its
 * causality (inputs always settable, the rest through can_set). One loop per type so a
 * value is one fixed-size copy (these calls run several times per 1 ms co-simulation
 * step). On an error the values before the bad reference have been copied. */
static npi_status_t copy_values(npi_t *c, const uint32_t vr[], size_t nvr, void *vals, size_t nvals, np_type_t type,
                                int get, const char *fn) {
  if (npi_allowed(c, get ? NPI_GET : NPI_SET)) return NPI_ERROR;
  if (nvals != nvr) {
    npi_log(c, NPI_ERROR, "%s: nValues %zu != nValueReferences %zu (all variables are scalars)", fn, nvals, nvr);
    return NPI_ERROR;
  }
  if (get && c->state == ST_INIT && ensure_started(c)) return NPI_ERROR;
  char *base = (char *)&c->m.v;
#define NPI_COPY_LOOP(CT, NPT, GET)                                                             \
  for (size_t i = 0; i < nvr; i++) {                                                         \
    const uint32_t r = vr[i];                                                                \
    if (r >= NP_NUM_VARS || np_vars[r].type != (NPT)) {                                      \
      (void)lookup(c, r, type, fn); /* logs why */                                           \
      return NPI_ERROR;                                                                      \
    }                                                                                        \
    char *field = base + np_vars[r].offset;                                                  \
    if (GET) {                                                                               \
      memcpy((char *)vals + i * sizeof(CT), field, sizeof(CT));                              \
    } else {                                                                                 \
      if (np_vars[r].causality != NP_INPUT && !can_set(c, &np_vars[r])) return NPI_ERROR;    \
      memcpy(field, (const char *)vals + i * sizeof(CT), sizeof(CT));                        \
    }                                                                                        \
  }
  /* GET a constant in each loop: four loops without a branch on the direction */
  if (type == NP_F64) {
    if (get) {
      NPI_COPY_LOOP(double, NP_F64, 1)
    } else {
      NPI_COPY_LOOP(double, NP_F64, 0)
    }
  } else if (get) { /* NP_I32 (the header's contract) */
    NPI_COPY_LOOP(int32_t, type, 1)
  } else {
    NPI_COPY_LOOP(int32_t, type, 0)
  }
#undef NPI_COPY_LOOP
  if (!get) np_inputs_changed(&c->m);
  return NPI_OK;
}

npi_status_t npi_get(npi_t *c, const uint32_t vr[], size_t nvr, void *vals, size_t nvals, np_type_t type,
                     const char *fn) {
  return copy_values(c, vr, nvr, vals, nvals, type, 1, fn);
}

npi_status_t npi_set(npi_t *c, const uint32_t vr[], size_t nvr, const void *vals, size_t nvals, np_type_t type,
                     const char *fn) {
  return copy_values(c, vr, nvr, (void *)vals, nvals, type, 0, fn);
}

npi_status_t npi_get_strings(npi_t *c, const uint32_t vr[], size_t nvr, const char *vals[], size_t nvals,
                             const char *fn) {
  if (npi_allowed(c, NPI_GET) || nvals != nvr) return NPI_ERROR;
  for (size_t i = 0; i < nvr; i++) {
    const np_var_info_t *vi = lookup(c, vr[i], NP_STR, fn);
    if (!vi) return NPI_ERROR;
    vals[i] = (const char *)&c->m.v + vi->offset;
  }
  return NPI_OK;
}

npi_status_t npi_set_strings(npi_t *c, const uint32_t vr[], size_t nvr, const char *const vals[], size_t nvals,
                             const char *fn) {
  if (npi_allowed(c, NPI_SET) || nvals != nvr) return NPI_ERROR;
  for (size_t i = 0; i < nvr; i++) {
    const np_var_info_t *vi = lookup(c, vr[i], NP_STR, fn);
    if (!vi || !can_set(c, vi)) return NPI_ERROR;
    const char *s = vals[i] ? vals[i] : "";
    if (strlen(s) >= NP_STR_MAX) {
      npi_log(c, NPI_ERROR, "%s: %s is longer than %d bytes", fn, vi->name, NP_STR_MAX - 1);
      return NPI_ERROR;
    }
    memcpy((char *)&c->m.v + vi->offset, s, strlen(s) + 1);
  }
  return NPI_OK;
}

npi_status_t npi_no_values(const npi_t *c, size_t nvr, const char *msg) {
  if (nvr == 0) return NPI_OK;
  npi_log(c, NPI_ERROR, "%s", msg);
  return NPI_ERROR;
}

/* ---------------------------------------------------------------- co-simulation */

npi_status_t npi_do_step(npi_t *c, double t, double h) {
  if (npi_allowed(c, NPI_DO_STEP)) return NPI_ERROR;
  if (!(h > 0.0) || !isfinite(h)) {
    npi_log(c, NPI_ERROR, "%sDoStep: communicationStepSize %g must be > 0", c->api, h);
    return NPI_ERROR;
  }
  if (fabs(t - c->m.t) > 1e-9 * (1.0 + fabs(c->m.t))) {
    npi_log(c, NPI_ERROR, "%sDoStep: currentCommunicationPoint %.9f != model time %.9f", c->api, t, c->m.t);
    return NPI_ERROR;
  }
  np_step(&c->m, h);
  c->m.t = t + h;   /* the importer's clock: no drift */
  c->m.v.time = c->m.t;
  return NPI_OK;
}
