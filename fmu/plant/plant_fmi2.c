/* plant_fmi2.c: FMI 2.0 co-simulation wrapper of the plant model (modelIdentifier
 * navkit_plant_fmi2), for importers that only know FMI 2. Same model, names and value
 * references as the FMI 3 FMU (Float64 -> Real, Int32 -> Integer).
 *
 * States: Instantiated -> InitializationMode -> StepMode -> Terminated; fmi2Reset goes back
 * to Instantiated with start values. legal[] says which call is allowed in which state;
 * any other call returns fmi2Error. Model exchange, FMU state and derivatives: none.
 */
#include "navkit_plant.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"   /* exports the fmi2 functions (visibility default) */

enum { ST_INSTANTIATED = 1, ST_INIT = 2, ST_STEP = 4, ST_TERMINATED = 8 };
#define ST_ANY (ST_INSTANTIATED | ST_INIT | ST_STEP | ST_TERMINATED)

/* The calls that depend on the state. */
typedef enum {
  FN_SET_DEBUG_LOGGING, FN_SETUP_EXPERIMENT, FN_ENTER_INIT, FN_EXIT_INIT, FN_TERMINATE, FN_RESET,
  FN_GET, FN_SET, FN_DO_STEP, FN_GET_STATUS, FN_COUNT
} fn_t;

/* Which states each call is legal in. */
static const struct { const char *name; unsigned states; } legal[FN_COUNT] = {
  [FN_SET_DEBUG_LOGGING] = { "fmi2SetDebugLogging", ST_ANY },
  [FN_SETUP_EXPERIMENT] = { "fmi2SetupExperiment", ST_INSTANTIATED },
  [FN_ENTER_INIT] = { "fmi2EnterInitializationMode", ST_INSTANTIATED },
  [FN_EXIT_INIT] = { "fmi2ExitInitializationMode", ST_INIT },
  [FN_TERMINATE] = { "fmi2Terminate", ST_STEP },
  [FN_RESET] = { "fmi2Reset", ST_ANY },
  [FN_GET] = { "fmi2Get<Type>", ST_INIT | ST_STEP | ST_TERMINATED },
  [FN_SET] = { "fmi2Set<Type>", ST_INSTANTIATED | ST_INIT | ST_STEP },  /* per variable: see can_set */
  [FN_DO_STEP] = { "fmi2DoStep", ST_STEP },
  [FN_GET_STATUS] = { "fmi2Get<Type>Status", ST_STEP | ST_TERMINATED },
};

/* One FMU instance: the model plus the wrapper's bookkeeping. */
typedef struct {
  np_model_t m;
  unsigned state;
  int dirty;                       /* parameters changed since the model was started */
  int logging;
  char name[128];
  double start_time;               /* s, from fmi2SetupExperiment */
  fmi2CallbackFunctions cb;
} inst_t;

/* Sends a message to the importer's logger (errors always, the rest when logging is on). */
static void logf2(inst_t *c, fmi2Status st, const char *fmt, ...) {
  if (!c->cb.logger || (st == fmi2OK && !c->logging)) return;
  char buf[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  c->cb.logger(c->cb.componentEnvironment, c->name, st, st >= fmi2Error ? "logStatusError" : "logEvents", "%s", buf);
}

/* fmi2OK if call fn is legal in c's state, else logs and returns fmi2Error. */
static fmi2Status allowed(inst_t *c, fn_t fn) {
  if (!c) return fmi2Error;
  if (legal[fn].states & c->state) return fmi2OK;
  logf2(c, fmi2Error, "%s is not allowed in state %u", legal[fn].name, c->state);
  return fmi2Error;
}

/* Starts the model from the current parameters when they changed (Initialization Mode). */
static fmi2Status ensure_started(inst_t *c) {
  if (!c->dirty) return fmi2OK;
  char err[1024];
  if (np_start(&c->m, c->start_time, err, sizeof err)) {
    logf2(c, fmi2Error, "%s", err);
    return fmi2Error;
  }
  c->dirty = 0;
  return fmi2OK;
}

/* ---------------------------------------------------------------- common */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  inst_t *c = comp;
  (void)nCategories; (void)categories;
  if (allowed(c, FN_SET_DEBUG_LOGGING)) return fmi2Error;
  c->logging = loggingOn;
  return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)fmuResourceLocation; (void)visible;
  const char *why = NULL;
  if (fmuType != fmi2CoSimulation)
    why = "navkit_plant_fmi2 is co-simulation only";
  else if (!fmuGUID || strcmp(fmuGUID, NP_INSTANTIATION_TOKEN) != 0)
    why = "guid does not match modelDescription.xml";
  if (why) {
    if (functions && functions->logger)
      functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError", "%s", why);
    return NULL;
  }
  inst_t *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "");
  if (functions) c->cb = *functions;
  c->logging = loggingOn;
  np_set_start_values(&c->m);
  c->state = ST_INSTANTIATED;
  c->dirty = 1;
  return c;
}

void fmi2FreeInstance(fmi2Component comp) {
  inst_t *c = comp;
  if (!c) return;
  np_release(&c->m);
  free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  inst_t *c = comp;
  (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
  if (allowed(c, FN_SETUP_EXPERIMENT)) return fmi2Error;
  c->start_time = startTime;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
  inst_t *c = comp;
  if (allowed(c, FN_ENTER_INIT)) return fmi2Error;
  c->m.t = c->start_time;
  c->m.v.time = c->start_time;
  c->dirty = 1;
  c->state = ST_INIT;
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {
  inst_t *c = comp;
  if (allowed(c, FN_EXIT_INIT) || ensure_started(c)) return fmi2Error;
  c->state = ST_STEP;
  return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp) {
  inst_t *c = comp;
  if (allowed(c, FN_TERMINATE)) return fmi2Error;
  c->state = ST_TERMINATED;
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp) {
  inst_t *c = comp;
  if (allowed(c, FN_RESET)) return fmi2Error;
  np_set_start_values(&c->m);
  c->m.t = 0.0;
  c->start_time = 0.0;
  c->state = ST_INSTANTIATED;
  c->dirty = 1;
  return fmi2OK;
}

/* ---------------------------------------------------------------- get / set */

/* Checks vr against the table and type; logs and returns NULL when it does not fit. */
static const np_var_info_t *lookup(inst_t *c, fmi2ValueReference vr, np_type_t type, const char *fn) {
  if (vr >= NP_NUM_VARS) {
    logf2(c, fmi2Error, "%s: unknown value reference %u", fn, vr);
    return NULL;
  }
  if (np_vars[vr].type != type) {
    logf2(c, fmi2Error, "%s: variable %s (vr %u) has another type", fn, np_vars[vr].name, vr);
    return NULL;
  }
  return &np_vars[vr];
}

/* Checks that variable vi may be set in c's state: parameters before StepMode, inputs always. */
static int can_set(inst_t *c, const np_var_info_t *vi) {
  if (vi->causality == NP_INPUT) return 1;
  if (vi->causality == NP_PARAMETER && (c->state & (ST_INSTANTIATED | ST_INIT))) {
    c->dirty = 1;
    return 1;
  }
  logf2(c, fmi2Error, "variable %s cannot be set in state %u", vi->name, c->state);
  return 0;
}

/* Copies nvr values of size sz between vals and the model (get != 0: model -> vals). */
static fmi2Status copy_values(inst_t *c, const fmi2ValueReference vr[], size_t nvr, void *vals, np_type_t type,
                              size_t sz, int get, const char *fn) {
  if (allowed(c, get ? FN_GET : FN_SET)) return fmi2Error;
  if (get && c->state == ST_INIT && ensure_started(c)) return fmi2Error;
  for (size_t i = 0; i < nvr; i++) {
    const np_var_info_t *vi = lookup(c, vr[i], type, fn);
    if (!vi || (!get && !can_set(c, vi))) return fmi2Error;
    char *field = (char *)&c->m.v + vi->offset;
    if (get)
      memcpy((char *)vals + i * sz, field, sz);
    else
      memcpy(field, (const char *)vals + i * sz, sz);
  }
  if (!get) np_inputs_changed(&c->m);
  return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  return copy_values(comp, vr, nvr, value, NP_F64, sizeof(double), 1, "fmi2GetReal");
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  return copy_values(comp, vr, nvr, (void *)value, NP_F64, sizeof(double), 0, "fmi2SetReal");
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  return copy_values(comp, vr, nvr, value, NP_I32, sizeof(int32_t), 1, "fmi2GetInteger");
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  return copy_values(comp, vr, nvr, (void *)value, NP_I32, sizeof(int32_t), 0, "fmi2SetInteger");
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  inst_t *c = comp;
  if (allowed(c, FN_GET)) return fmi2Error;
  for (size_t i = 0; i < nvr; i++) {
    const np_var_info_t *vi = lookup(c, vr[i], NP_STR, "fmi2GetString");
    if (!vi) return fmi2Error;
    value[i] = (const char *)&c->m.v + vi->offset;
  }
  return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  inst_t *c = comp;
  if (allowed(c, FN_SET)) return fmi2Error;
  for (size_t i = 0; i < nvr; i++) {
    const np_var_info_t *vi = lookup(c, vr[i], NP_STR, "fmi2SetString");
    if (!vi || !can_set(c, vi)) return fmi2Error;
    const char *s = value[i] ? value[i] : "";
    if (strlen(s) >= NP_STR_MAX) {
      logf2(c, fmi2Error, "fmi2SetString: %s is longer than %d bytes", vi->name, NP_STR_MAX - 1);
      return fmi2Error;
    }
    memcpy((char *)&c->m.v + vi->offset, s, strlen(s) + 1);
  }
  return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  (void)vr; (void)value;
  if (nvr == 0) return fmi2OK;
  if (comp) logf2(comp, fmi2Error, "fmi2GetBoolean: the model has no Boolean variable");
  return fmi2Error;
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  (void)vr; (void)value;
  if (nvr == 0) return fmi2OK;
  if (comp) logf2(comp, fmi2Error, "fmi2SetBoolean: the model has no Boolean variable");
  return fmi2Error;
}

/* ---------------------------------------------------------------- co-simulation */

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  inst_t *c = comp;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (allowed(c, FN_DO_STEP)) return fmi2Error;
  double h = communicationStepSize;
  if (!(h > 0.0) || !isfinite(h)) {
    logf2(c, fmi2Error, "fmi2DoStep: communicationStepSize %g must be > 0", h);
    return fmi2Error;
  }
  if (fabs(currentCommunicationPoint - c->m.t) > 1e-9 * (1.0 + fabs(c->m.t))) {
    logf2(c, fmi2Error, "fmi2DoStep: currentCommunicationPoint %.9f != model time %.9f", currentCommunicationPoint, c->m.t);
    return fmi2Error;
  }
  np_step(&c->m, h);
  c->m.t = currentCommunicationPoint + h;   /* the importer's clock: no drift */
  c->m.v.time = c->m.t;
  return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
  if (comp) logf2(comp, fmi2Error, "fmi2CancelStep: doStep never runs asynchronously");
  return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value) {
  inst_t *c = comp;
  if (allowed(c, FN_GET_STATUS) || s != fmi2DoStepStatus) return fmi2Error;
  *value = fmi2OK;
  return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value) {
  inst_t *c = comp;
  if (allowed(c, FN_GET_STATUS) || s != fmi2LastSuccessfulTime) return fmi2Error;
  *value = c->m.t;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value) {
  (void)s; (void)value;
  if (comp) logf2(comp, fmi2Error, "fmi2GetIntegerStatus: no integer status");
  return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value) {
  inst_t *c = comp;
  if (allowed(c, FN_GET_STATUS) || s != fmi2Terminated) return fmi2Error;
  *value = fmi2False;
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value) {
  (void)s; (void)value;
  if (comp) logf2(comp, fmi2Error, "fmi2GetStringStatus: no string status");
  return fmi2Error;
}

/* ---------------------------------------------------------------- not supported */

/* Logs that fn is not supported and returns fmi2Error. */
static fmi2Status unsupported(fmi2Component comp, const char *fn) {
  if (comp) logf2(comp, fmi2Error, "%s is not supported by navkit_plant_fmi2", fn);
  return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate) {
  (void)FMUstate;
  return unsupported(comp, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate) {
  (void)FMUstate;
  return unsupported(comp, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate) {
  (void)FMUstate;
  return unsupported(comp, "fmi2FreeFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t *size) {
  (void)FMUstate; (void)size;
  return unsupported(comp, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
  (void)FMUstate; (void)serializedState; (void)size;
  return unsupported(comp, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
  (void)serializedState; (void)size; (void)FMUstate;
  return unsupported(comp, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
  return unsupported(comp, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr; (void)nvr; (void)order; (void)value;
  return unsupported(comp, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr; (void)nvr; (void)order; (void)value;
  return unsupported(comp, "fmi2GetRealOutputDerivatives");
}
